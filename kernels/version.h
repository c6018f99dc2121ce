// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Which vfit this is: the project's version (major.minor.patch, CMake's PROJECT_VERSION) and
/// the git commit the library was built from ("unknown" outside a git checkout; a "-dirty"
/// suffix when the working tree had changes), and what else decides the bits a build computes
/// (compiler, build type). Written into every report; keys the caches of built bodies.
namespace vfit {

/// "0.1.0".
const char* version();
/// The abbreviated commit hash, e.g. "5b6c6f2" or "5b6c6f2-dirty"; "unknown" when not built from git.
const char* git_commit();
/// The compiler and build type of this build, e.g. "GNU 12.2.0 Release".
const char* build_flavour();

} // namespace vfit
