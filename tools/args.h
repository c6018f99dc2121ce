// SPDX-License-Identifier: Apache-2.0
#pragma once
// A small command-line parser: options are asked for by name, then finish() rejects whatever
// was not asked for, so every subcommand states exactly what it accepts.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace vfit::cli {

class Args {
public:
  /// `tokens`: the arguments after the subcommand name; `command`: for messages.
  Args(std::vector<std::string> tokens, std::string command);

  /// True if `--name` is present (consumed).
  bool flag(std::string_view name);
  /// The value of `--name VALUE` or `--name=VALUE` (last one wins); nullopt when absent.
  std::optional<std::string> value(std::string_view name);
  /// Every value of a repeatable `--name VALUE`.
  std::vector<std::string> values(std::string_view name);
  /// The arguments that are not options, after every option has been asked for; throws
  /// vfit::Error (a usage error) for an unknown option or a wrong number of positionals.
  std::vector<std::string> positionals(std::size_t min_count, std::size_t max_count);

  /// Parses an integer option value, with a usage error naming the option.
  static int to_int(const std::string& option, const std::string& value, int min_value, int max_value);

private:
  std::vector<std::string> m_tokens;
  std::vector<bool> m_used;
  std::string m_command;
};

/// Refuses, before any work is done, an output `path` (given with `option`, e.g. "--out") whose
/// folder does not exist, or that names one of `inputs` (an input is never overwritten; inputs
/// that are not files, such as "mannequin", never match): throws vfit::Error naming the path.
void check_output_path(const std::string& path, std::string_view option, const std::vector<std::string>& inputs);

/// `path`'s extension in lower case, with its dot (".glb"); empty when it has none.
std::string lower_extension(const std::string& path);

/// The command line's `--threads N` (every command takes it: the whole process runs on at most N
/// worker threads), or 0 when it was not given (every core). Set by main() before a command runs.
int thread_limit();
void set_thread_limit(int threads);

} // namespace vfit::cli
