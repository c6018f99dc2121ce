// SPDX-License-Identifier: Apache-2.0
#pragma once
// Private to geometry/mesh: splitting a line of a text mesh format (OFF, PLY headers and
// bodies) into whitespace-separated words without copying.

#include <string_view>

namespace vfit::text {

inline bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

/// Whitespace-separated words of one line.
class Words {
public:
  explicit Words(std::string_view line = {}) : m_rest(line) {}
  bool next(std::string_view& word) {
    std::size_t i = 0;
    while (i < m_rest.size() && is_space(m_rest[i]))
      ++i;
    std::size_t j = i;
    while (j < m_rest.size() && !is_space(m_rest[j]))
      ++j;
    word = m_rest.substr(i, j - i);
    m_rest.remove_prefix(j);
    return !word.empty();
  }

private:
  std::string_view m_rest;
};

} // namespace vfit::text
