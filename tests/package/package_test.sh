#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The installed package, as a project outside vfit sees it: installs BUILD into a fresh prefix,
# checks that every installed header's own includes are installed too, then builds and runs
# consumer/ three ways — find_package from the prefix, find_package from the build tree, and
# pkg-config's flags — each fitting a catalogue tee onto the mannequin, through the C++ engine
# and (with find_package) through the C API.
# Usage: package_test.sh BUILD_DIR SOURCE_DIR WORK_DIR GENERATOR BUILD_TYPE
set -euo pipefail
build=$1 src=$2 work=$3 generator=$4 build_type=${5:-Release}
consumer="$src/tests/package/consumer"
rm -rf "$work"
mkdir -p "$work"

cmake --install "$build" --prefix "$work/prefix" >"$work/install.log"
include="$work/prefix/include"
[ -f "$include/vfit/engine/engine.h" ] || { echo "package_test: vfit/engine/engine.h was not installed" >&2; exit 1; }

# Every quoted include of an installed header resolves inside the prefix: beside the header, or
# from the include folder (the "vfit/<layer>/…" form).
missing=0
while IFS= read -r header; do
  dir=$(dirname "$header")
  while IFS= read -r name; do
    [ -f "$dir/$name" ] || [ -f "$include/$name" ] || { echo "package_test: $header includes \"$name\", which is not installed" >&2; missing=1; }
  done < <(sed -nE 's/^#include "([^"]+)".*/\1/p' "$header")
done < <(find "$include/vfit" -name '*.h')
[ $missing = 0 ] || exit 1

for how in prefix tree; do
  if [ $how = prefix ]; then where=(-DCMAKE_PREFIX_PATH="$work/prefix"); else where=(-Dvfit_DIR="$build"); fi
  cmake -S "$consumer" -B "$work/$how" -G "$generator" -DCMAKE_BUILD_TYPE="$build_type" "${where[@]}" >"$work/$how.log"
  cmake --build "$work/$how" >>"$work/$how.log"
  "$work/$how/consumer"
  "$work/$how/c_consumer"
done

export PKG_CONFIG_PATH="$work/prefix/lib/pkgconfig:$work/prefix/lib/x86_64-linux-gnu/pkgconfig"
read -r -a flags < <(pkg-config --define-prefix --cflags --libs --static vfit)
mkdir -p "$work/pkg-config"
c++ -std=c++20 -O1 "$consumer/main.cpp" -o "$work/pkg-config/consumer" "${flags[@]}"
"$work/pkg-config/consumer"
