// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Atomic file output: an output file either appears whole or not at all.

#include <filesystem>
#include <string_view>

namespace vfit {

/// Writes `bytes` to a temporary file in `path`'s folder, flushes it to disk and renames it
/// over `path`. On any failure the temporary file is removed and vfit::Error names `path`.
void write_file_atomically(const std::filesystem::path& path, std::string_view bytes);

/// Reads a whole file. Throws vfit::Error "<path>: cannot open: <reason>" when it can't.
std::string read_file_bytes(const std::filesystem::path& path);

} // namespace vfit
