# Imports an fskin glTF animation into Blender and checks what a user sees:
# one mesh, one shape key per frame (plus Basis) with the mesh's vertex count,
# keyed over time. Not part of `make test` (Blender is a large install):
#   blender -b --python tools/gltf-check/blender_check.py -- FILE.glb [FRAMES]
# Prints one line starting with BLENDER_RESULT; exits 1 on any problem.
import sys

import bpy
import numpy

# Debian 12's Blender 3.4 glTF importer still uses numpy.bool, which numpy
# 1.24 removed; the alias restores the builtin it stood for.
if not hasattr(numpy, "bool"):
    numpy.bool = bool

args = sys.argv[sys.argv.index("--") + 1:]
path = args[0]
expected_frames = int(args[1]) if len(args) > 1 else None

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=path)
meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
problems = []
if len(meshes) != 1:
    problems.append(f"{len(meshes)} meshes, expected 1")
mesh = meshes[0].data
keys = mesh.shape_keys.key_blocks if mesh.shape_keys else []
frames = max(len(keys), 1)  # Basis = frame 0, then one key per later frame
for key in keys:
    if len(key.data) != len(mesh.vertices):
        problems.append(f"shape key {key.name}: {len(key.data)} vertices, mesh {len(mesh.vertices)}")
animated = bool(mesh.shape_keys and mesh.shape_keys.animation_data and mesh.shape_keys.animation_data.action)
if len(keys) > 1 and not animated:
    problems.append("shape keys are not animated")
if expected_frames is not None and frames != expected_frames:
    problems.append(f"{frames} frames, expected {expected_frames}")
print("BLENDER_RESULT", f"blender {bpy.app.version_string}", f"vertices {len(mesh.vertices)}",
      f"faces {len(mesh.polygons)}", f"frames {frames}", f"animated {animated}",
      f"colour attributes {[a.name for a in mesh.color_attributes]}",
      "ok" if not problems else f"problems {problems}")
sys.exit(1 if problems else 0)
