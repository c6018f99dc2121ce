#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# README's two set-up commands:
#   tools/setup.sh demo   installs the Debian packages, builds (release) and runs `vfit demo`
#   tools/setup.sh test   installs the Debian packages, builds (release) and runs every test
# An optional second argument picks another CMake preset (debug, asan, no-opencl).
set -euo pipefail
cd "$(dirname "$0")/.."

job=${1:-}
preset=${2:-release}
case "$job" in
  demo|test) ;;
  *) echo "usage: tools/setup.sh demo|test [preset]" >&2; exit 2 ;;
esac

./tools/install_deps.sh
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset"

if [ "$job" = demo ]; then
  exec "./build/$preset/tools/vfit" demo --out vfit_demo
fi
# Every suite: unit, integration, opencl and corpus (corpus tests skip, saying why, when
# ../shared/corpus is absent).
exec ctest --preset "$preset"
