# SPDX-License-Identifier: Apache-2.0
# Blender's view of a fitted .glb (`vfit fit --out fitted.glb`): imports it, turns one bone of
# the armature the importer built (or several, comma-separated), and measures whether each garment moved with the body, then
# exports the posed scene to a second .glb.
#
#   blender -b --factory-startup --python tests/package/blender_pose.py -- FITTED.glb BONE[,BONE] OUT.glb
#
# Prints one JSON line: per mesh the largest vertex displacement (m) and, for each garment, over
# its vertices that moved more than 1 cm, the median of |d_garment − d_body| / |d_garment|, where
# d_body is the displacement of the body vertex nearest to the garment vertex before posing (0:
# the garment moves exactly as the body under it; 1: as if not attached to it).
import json
import statistics
import sys

import bpy
import numpy
from mathutils.kdtree import KDTree

# Debian 12's Blender 3.4 glTF importer still calls numpy.bool, which Debian's numpy 1.24 no
# longer has (an alias of bool, removed): give it back before importing.
if "bool" not in numpy.__dict__:
    numpy.bool = bool

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if len(args) != 3:
    sys.exit("usage: blender -b --factory-startup --python blender_pose.py -- FITTED.glb BONE OUT.glb")
fitted, bone_names, posed_out = args

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=fitted)
scene = bpy.context.scene
armatures = [o for o in scene.objects if o.type == "ARMATURE"]
if len(armatures) != 1:
    sys.exit(f"blender_pose: expected one armature, found {len(armatures)}")
armature = armatures[0]
meshes = {o.name: o for o in scene.objects if o.type == "MESH"}
if "body" not in meshes or len(meshes) < 2:
    sys.exit(f"blender_pose: expected a body and garments, found {sorted(meshes)}")


def positions(obj):
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = evaluated.to_mesh()
    points = [evaluated.matrix_world @ v.co for v in mesh.vertices]
    evaluated.to_mesh_clear()
    return points


before = {name: positions(o) for name, o in meshes.items()}
for bone_name in bone_names.split(","):
    if bone_name not in armature.pose.bones:
        sys.exit(f"blender_pose: no bone {bone_name!r} in {sorted(b.name for b in armature.pose.bones)}")
    bone = armature.pose.bones[bone_name]
    bone.rotation_mode = "XYZ"
    bone.rotation_euler = (0.5, 0.3, 0.6)
bpy.context.view_layer.update()
after = {name: positions(o) for name, o in meshes.items()}

body_before, body_after = before["body"], after["body"]
tree = KDTree(len(body_before))
for i, p in enumerate(body_before):
    tree.insert(p, i)
tree.balance()

result = {"meshes": {}}
for name in meshes:
    moves = [(a - b) for a, b in zip(after[name], before[name])]
    entry = {"max_move_m": max(m.length for m in moves)}
    if name != "body":
        ratios = []
        for p, d in zip(before[name], moves):
            if d.length > 0.01:
                _, nearest, _ = tree.find(p)
                ratios.append((d - (body_after[nearest] - body_before[nearest])).length / d.length)
        entry["moved_vertices"] = len(ratios)
        entry["median_mismatch"] = statistics.median(ratios) if ratios else None
    result["meshes"][name] = entry

bpy.ops.export_scene.gltf(filepath=posed_out, export_format="GLB")
print("blender_pose: " + json.dumps(result))
