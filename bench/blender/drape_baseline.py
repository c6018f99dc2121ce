# SPDX-License-Identifier: Apache-2.0
# Blender baseline of the drape bar: times Blender's own cloth simulation on the drape of
# vfit_cloth_bench's BM_drape_tee_to_rest (the 6,000-vertex catalogue tee on the posed
# 7,000-vertex mannequin), so that `blender_x` compares with Blender on the same host and load.
#
#   blender -b --factory-startup --python bench/blender/drape_baseline.py -- DIR [FRAMES]
#
# DIR holds drape_body.obj and drape_tee.obj, written by the benchmark when run with
# VFIT_DRAPE_OBJ_DIR=DIR (bench/blender/run_drape_baseline.sh does both). The settings are
# Blender 3.4's defaults, as a user would start: the tee gets a Cloth modifier (quality 5 steps
# per frame, collisions on, self-collision off), the body a Collision modifier, 24 frames per
# second. Frames 2..FRAMES (default 24) are stepped in order and timed one by one; the first frame
# only initialises the cache. Prints one line per frame and a summary line:
#   blender_s_per_frame=... simulated_s_per_wall_s=... moved_m=...
# moved_m is the tee's mean vertex displacement at the last frame, evidence that the cloth ran.
import sys
import time

import bpy

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if not args:
    sys.exit("usage: blender -b --factory-startup --python drape_baseline.py -- DIR [FRAMES]")
folder = args[0]
frames = int(args[1]) if len(args) > 1 else 24

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene


def load(name):
    before = set(bpy.data.objects)
    # Our OBJ files are Y up, -Z forward (as Blender's importer assumes by default).
    bpy.ops.wm.obj_import(filepath=f"{folder}/{name}.obj", forward_axis="NEGATIVE_Z", up_axis="Y")
    added = [o for o in bpy.data.objects if o not in before]
    if len(added) != 1:
        sys.exit(f"{folder}/{name}.obj: expected one object, got {len(added)}")
    return added[0]


body = load("drape_body")
tee = load("drape_tee")
body.modifiers.new("Collision", "COLLISION")
cloth = tee.modifiers.new("Cloth", "CLOTH")
scene.frame_start = 1
scene.frame_end = frames
cloth.point_cache.frame_start = 1
cloth.point_cache.frame_end = frames
fps = scene.render.fps / scene.render.fps_base

start = [v.co.copy() for v in tee.data.vertices]
scene.frame_set(1)
times = []
for f in range(2, frames + 1):
    t0 = time.perf_counter()
    scene.frame_set(f)
    # Force the evaluation now (frame_set evaluates the depsgraph; this reads its result).
    evaluated = tee.evaluated_get(bpy.context.evaluated_depsgraph_get())
    times.append(time.perf_counter() - t0)
    print(f"frame {f}: {times[-1]:.3f} s", flush=True)

mesh = evaluated.to_mesh()
world = tee.matrix_world
moved = sum(((world @ v.co) - (world @ s)).length for v, s in zip(mesh.vertices, start)) / len(start)
evaluated.to_mesh_clear()
per_frame = sum(times) / len(times)
print(f"blender {bpy.app.version_string}: vertices tee={len(tee.data.vertices)} body={len(body.data.vertices)} "
      f"quality={cloth.settings.quality} fps={fps:g} frames={len(times)} "
      f"blender_s_per_frame={per_frame:.4f} simulated_s_per_wall_s={(1.0 / fps) / per_frame:.5f} moved_m={moved:.4f}",
      flush=True)
