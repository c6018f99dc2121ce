#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The tree's habits, checked in CI (.ci/run) and before a commit:
#   1. every C++ source is clang-format clean (.clang-format);
#   2. includes point downward only: tools → engine → geometry → kernels, and name the library's
#      headers as a consumer does, "vfit/<layer>/…" (cmake/vfit_library.cmake);
#   3. no words about how the work was organised ("stop N", "issue N", "item N");
#   4. every source, script and CMake file names its licence (an SPDX-License-Identifier line);
#   5. clang-tidy's naming rules (.clang-tidy, readability-identifier-naming) on every source
#      file of the build, with `tidy` as the first argument (needs build/<preset>/compile_commands.json).
# Usage: tools/check_style.sh [tidy [preset]]
set -euo pipefail
cd "$(dirname "$0")/.."

status=0
mapfile -t sources < <(git ls-files '*.cpp' '*.h')

if ! clang-format --dry-run -Werror "${sources[@]}"; then
  echo "check_style: run clang-format -i on the files above" >&2
  status=1
fi

# Layer → the layers above it, which it must not include.
declare -A above=([kernels]="geometry engine tools bindings" [geometry]="engine tools bindings" [engine]="tools bindings")
for layer in kernels geometry engine; do
  for up in ${above[$layer]}; do
    if git grep -nE "^#include \"(vfit/)?$up/" -- "$layer/" >/dev/null; then
      git grep -nE "^#include \"(vfit/)?$up/" -- "$layer/" >&2
      echo "check_style: $layer/ includes $up/ (includes point downward only)" >&2
      status=1
    fi
  done
done

if git grep -nE '^#include "(kernels|geometry|engine)/' -- '*.h' '*.cpp' >/dev/null; then
  git grep -nE '^#include "(kernels|geometry|engine)/' -- '*.h' '*.cpp' >&2
  echo 'check_style: include the library as "vfit/<layer>/…" (above)' >&2
  status=1
fi

if git grep -nIiE "(stop|issue|item) #?[0-9]+" -- . ':!*.json' ':!*.npz' >/dev/null; then
  git grep -nIiE "(stop|issue|item) #?[0-9]+" -- . ':!*.json' ':!*.npz' >&2
  echo "check_style: words about how the work was organised (above)" >&2
  status=1
fi

unlicensed=$(git ls-files '*.h' '*.c' '*.cpp' '*.cl' '*.cjs' '*.py' '*.sh' '*.cmake' '*CMakeLists.txt' '.ci/run' |
  xargs grep -L "SPDX-License-Identifier: Apache-2.0" || true)
if [ -n "$unlicensed" ]; then
  echo "$unlicensed" >&2
  echo "check_style: files without an SPDX-License-Identifier line (above)" >&2
  status=1
fi

if [ "${1:-}" = tidy ]; then
  preset=${2:-release}
  db="build/$preset"
  [ -f "$db/compile_commands.json" ] || { echo "check_style: no $db/compile_commands.json (configure first)" >&2; exit 2; }
  # Every translation unit of the build under the source folders (regexes on the paths).
  # Headers of the source tree only (not the build's generated ones), also as reached through
  # the build's include/vfit/ links.
  run-clang-tidy -quiet -p "$db" -j "$(nproc)" -checks='-*,readability-identifier-naming' \
    -header-filter="^$PWD/((kernels|geometry|engine|tools|bindings)/|$db/include/vfit/)" \
    "$PWD/(kernels|geometry|engine|tools|bindings|tests|bench)/.*\.cpp$" >"$db/clang-tidy.log" 2>&1 || true
  if grep -qE "warning: .*\[readability-identifier-naming\]|error: " "$db/clang-tidy.log"; then
    grep -E "warning: .*\[readability-identifier-naming\]|error: " "$db/clang-tidy.log" | sort -u >&2
    echo "check_style: clang-tidy naming rules failed (full log: $db/clang-tidy.log)" >&2
    status=1
  fi
fi
exit $status
