#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The fitted .glb posed in Blender: `vfit fit` dresses the mannequin in the demo pose in a tee
# and trousers and writes fitted.glb; Blender (Debian's `blender`, run headless) imports it,
# turns the left shoulder and the left hip and exports the posed scene (blender_pose.py). Passes when both
# garments moved (some vertex more than 5 cm) and moved with the body under them (median
# mismatch under 0.25), and the exported scene reads back in vfit. Exits 77 (CTest: skipped)
# when Blender is not installed.
# Usage: blender_pose_test.sh VFIT SOURCE_DIR WORK_DIR
set -euo pipefail
vfit=$1 src=$2 work=$3
command -v blender >/dev/null 2>&1 || { echo "blender_pose_test: skipped: no blender on the PATH (apt-get install blender)"; exit 77; }
rm -rf "$work"
mkdir -p "$work"
"$vfit" garment tee --out "$work/tee.obj" --vertices 2000 >/dev/null
"$vfit" garment trousers --out "$work/trousers.obj" --vertices 2000 >/dev/null
"$vfit" fit --body mannequin --vertices 4000 --pose demo --garment "$work/tee.obj" --garment "$work/trousers.obj" \
  --no-simulation --out "$work/fitted.glb" --quiet
blender -b --factory-startup --python "$src/tests/package/blender_pose.py" -- "$work/fitted.glb" left_shoulder,left_hip \
  "$work/posed.glb" >"$work/blender.log" 2>&1 || { cat "$work/blender.log"; exit 1; }
line=$(grep '^blender_pose: {' "$work/blender.log" | sed 's/^blender_pose: //')
[ -n "$line" ] || { cat "$work/blender.log"; exit 1; }
echo "$line"
python3 - "$line" <<'PY'
import json, sys
r = json.loads(sys.argv[1])["meshes"]
garments = [n for n in r if n != "body"]
assert len(garments) == 2, r
for n in garments:
    assert r[n]["max_move_m"] > 0.05, f"{n} did not move with the arm: {r[n]}"
    assert r[n]["median_mismatch"] is not None and r[n]["median_mismatch"] < 0.25, f"{n} moved unlike the body: {r[n]}"
PY
"$vfit" info "$work/posed.glb" >/dev/null
