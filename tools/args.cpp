// SPDX-License-Identifier: Apache-2.0
#include "args.h"

#include <cctype>
#include <charconv>
#include <filesystem>
#include <system_error>

#include "vfit/kernels/error.h"

namespace vfit::cli {

Args::Args(std::vector<std::string> tokens, std::string command)
    : m_tokens(std::move(tokens)), m_used(m_tokens.size(), false), m_command(std::move(command)) {}

bool Args::flag(std::string_view name) {
  bool found = false;
  for (std::size_t i = 0; i < m_tokens.size(); ++i)
    if (!m_used[i] && m_tokens[i].size() == name.size() + 2 && m_tokens[i].compare(0, 2, "--") == 0 &&
        m_tokens[i].compare(2, std::string::npos, name) == 0) {
      m_used[i] = true;
      found = true;
    }
  return found;
}

std::vector<std::string> Args::values(std::string_view name) {
  std::vector<std::string> out;
  const std::string opt = "--" + std::string(name);
  for (std::size_t i = 0; i < m_tokens.size(); ++i) {
    if (m_used[i]) continue;
    const std::string& t = m_tokens[i];
    if (t == opt) {
      if (i + 1 >= m_tokens.size()) throw Error("vfit " + m_command, 0, opt + " needs a value");
      m_used[i] = m_used[i + 1] = true;
      out.push_back(m_tokens[i + 1]);
      ++i;
    } else if (t.compare(0, opt.size() + 1, opt + "=") == 0) {
      m_used[i] = true;
      out.push_back(t.substr(opt.size() + 1));
    }
  }
  return out;
}

std::optional<std::string> Args::value(std::string_view name) {
  auto all = values(name);
  if (all.empty()) return std::nullopt;
  return all.back();
}

std::vector<std::string> Args::positionals(std::size_t min_count, std::size_t max_count) {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < m_tokens.size(); ++i) {
    if (m_used[i]) continue;
    const std::string& t = m_tokens[i];
    if (t.size() > 1 && t[0] == '-' && t != "-")
      throw Error("vfit " + m_command, 0, "unknown option '" + t + "' (see vfit " + m_command + " --help)");
    out.push_back(t);
  }
  if (out.size() < min_count)
    throw Error("vfit " + m_command, 0, "missing argument (see vfit " + m_command + " --help)");
  if (out.size() > max_count)
    throw Error("vfit " + m_command, 0,
                "unexpected argument '" + out[max_count] + "' (see vfit " + m_command + " --help)");
  return out;
}

int Args::to_int(const std::string& option, const std::string& value, int min_value, int max_value) {
  int x = 0;
  auto r = std::from_chars(value.data(), value.data() + value.size(), x);
  if (r.ec != std::errc() || r.ptr != value.data() + value.size() || x < min_value || x > max_value)
    throw Error(option, 0,
                "expected an integer in [" + std::to_string(min_value) + ", " + std::to_string(max_value) + "], got '" +
                    value + "'");
  return x;
}

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

void check_output_path(const std::string& path, std::string_view option, const std::vector<std::string>& inputs) {
  const std::filesystem::path p(path);
  const std::filesystem::path dir = p.has_parent_path() ? p.parent_path() : std::filesystem::path(".");
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec))
    throw Error(path, 0, std::string(option) + ": the folder " + dir.string() + " does not exist");
  for (const std::string& input : inputs)
    if (input == path || std::filesystem::equivalent(input, path, ec))
      throw Error(path, 0, std::string(option) + " would overwrite an input file; choose another output path");
}

namespace {
int g_thread_limit = 0;
} // namespace

int thread_limit() { return g_thread_limit; }
void set_thread_limit(int threads) { g_thread_limit = threads; }

} // namespace vfit::cli
