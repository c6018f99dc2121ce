// SPDX-License-Identifier: Apache-2.0
#include "error.h"

namespace vfit {
namespace {
std::string compose(const std::string& source, std::int64_t line, const std::string& what) {
  if (source.empty()) return what;
  if (line > 0) return source + ":" + std::to_string(line) + ": " + what;
  return source + ": " + what;
}
} // namespace

Error::Error(const std::string& source, std::int64_t line, const std::string& what)
    : std::runtime_error(compose(source, line, what)), m_source(source), m_line(line) {}

Error::Error(const std::string& message) : std::runtime_error(message) {}

} // namespace vfit
