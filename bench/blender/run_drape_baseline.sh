#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The drape bar against Blender on this host, in one run: for each round, Blender 3.4's
# cloth on the drape's meshes (bench/blender/drape_baseline.py), then vfit's
# BM_drape_tee_to_rest/2 with blender_x and wall_s_at_reference_speed (the wall time scaled to
# a host where Blender takes the reference 1.6 s per frame) from that round's Blender time.
#   bench/blender/run_drape_baseline.sh [BUILD_DIR (build/release)] [FRAMES (24)] [ROUNDS (2)]
# Needs `blender` on the PATH (Debian 12: apt-get install blender, 3.4.1).
set -euo pipefail
build=${1:-build/release}
frames=${2:-24}
rounds=${3:-2}
here=$(cd "$(dirname "$0")" && pwd)
bench="$build/bench/vfit_cloth_bench"
[[ -x "$bench" ]] || { echo "$bench: not built (cmake --build --preset release --target vfit_cloth_bench)" >&2; exit 2; }
command -v blender >/dev/null || { echo "blender: not found (apt-get install blender)" >&2; exit 2; }
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
# The meshes: the benchmark's own fixture, written once.
VFIT_DRAPE_OBJ_DIR="$dir" "$bench" --benchmark_filter='BM_drape_tee_to_rest/1/' >/dev/null 2>&1
for r in $(seq "$rounds"); do
  line=$(blender -b --factory-startup --python "$here/drape_baseline.py" -- "$dir" "$frames" 2>&1 | grep 'blender_s_per_frame=')
  echo "round $r: $line"
  s=$(sed 's/.*blender_s_per_frame=\([0-9.]*\).*/\1/' <<<"$line")
  VFIT_BLENDER_S_PER_FRAME="$s" "$bench" --benchmark_filter='BM_drape_tee_to_rest/2/' 2>/dev/null |
    grep '^BM_' | grep -o 'blender_x=[0-9.]*\|cpu_s_to_rest=[0-9.]*\|sim_s_per_wall_s=[0-9.]*\|simulated_s=[0-9.]*\|wall_s_to_rest=[0-9.]*\|wall_s_at_reference_speed=[0-9.]*' |
    paste -sd' ' | sed "s/^/round $r: vfit /"
done
