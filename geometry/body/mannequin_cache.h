// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// make_mannequin() through a cache on disk, so that a command asking for a mannequin it has
/// built before starts at once (building the default one takes over a second).
///
/// The cache folder is $VFIT_CACHE_DIR, else $XDG_CACHE_HOME/vfit, else $HOME/.cache/vfit;
/// VFIT_CACHE_DIR=off turns the cache off. An entry is keyed by every MannequinOptions field
/// and by the build (vfit version, git commit, compiler and build type: kernels/version.h), and
/// holds the body's exact floats and doubles, so a body read from the cache is bit-identical to
/// the one make_mannequin() returns in the same build. Builds from a tree with uncommitted
/// changes ("-dirty") or outside git never use it, since their code may differ under one key.
/// Entries are written atomically (a temporary file renamed); a cache that cannot be read or
/// written, or an entry that is truncated or holds another key, is ignored and the body built.
#include <filesystem>
#include <optional>

#include "body.h"
#include "mannequin.h"

namespace vfit {

/// The body make_mannequin(options) returns, from the cache when it holds it (then stored
/// there when it did not). Throws as make_mannequin() does. O(file size) on a hit.
Body cached_mannequin(const MannequinOptions& options);

/// The cache folder in use, or nullopt when the cache is off (VFIT_CACHE_DIR=off, a build
/// without a clean commit, or no folder named by the environment).
std::optional<std::filesystem::path> mannequin_cache_dir();

} // namespace vfit
