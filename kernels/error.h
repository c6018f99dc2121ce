// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The error type every vfit layer throws for bad input (seen by the CLI as exit code 2).

#include <cstdint>
#include <stdexcept>
#include <string>

namespace vfit {

/// Bad input or an impossible request at a library boundary. The message names the input and
/// the element: "<source>:<line>: <what>" when a line is known, "<source>: <what>" otherwise.
/// The CLI prints it as `vfit: error: <message>` and exits with code 2.
class Error : public std::runtime_error {
public:
  /// `source` is a file path or a name such as "garment"; `line` ≤ 0 means "no line".
  Error(const std::string& source, std::int64_t line, const std::string& what);
  /// A message that already names its input.
  explicit Error(const std::string& message);

  const std::string& source() const { return m_source; }
  std::int64_t line() const { return m_line; }

private:
  std::string m_source;
  std::int64_t m_line = 0;
};

} // namespace vfit
