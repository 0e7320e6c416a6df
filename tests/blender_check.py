# Run by Blender itself (tests/blender_test.sh):
#   blender -b --factory-startup --python-exit-code 1 --python tests/blender_check.py -- BUNDLE NAME
# Imports reefgen's Blender bundle the two ways its README gives and checks
# what Blender made of it against the EXR Blender reads: the GLB's size and
# heights at every vertex, its two textures; the displacement script's heights
# at every vertex. Heights must match within 0.1 % of the range, and the sea
# floor (negative heights) must survive. Prints one line per check.
import json
import os
import sys

import bpy
import numpy as np

bundle, name = sys.argv[sys.argv.index("--") + 1:][:2]
exr = os.path.join(bundle, name + ".height.exr")


def fail(why):
    print("FAIL:", why)
    sys.exit(1)


img = bpy.data.images.load(exr)
n = img.size[0]
px = np.array(img.pixels[:], dtype=np.float32).reshape(n, n, img.channels)[:, :, 0]
heights = px[::-1]  # Blender's rows run from the bottom; row 0 = north as in the file
lo, hi = float(heights.min()), float(heights.max())
tol = 1e-3 * (hi - lo)
if lo >= 0:
    fail("the test island has no sea floor (min %.2f m)" % lo)
print("EXR as Blender reads it: %dx%d, %.2f ... %.2f m" % (n, n, lo, hi))


def check_heights(what, co, spacing):
    # Vertex (x, y) -> pixel (row, col): centred, north = +y.
    col = co[:, 0] / spacing + (n - 1) / 2
    row = (n - 1) / 2 - co[:, 1] / spacing
    # Between pixels (a GLB coarser than the EXR): bilinear, as reefgen resamples.
    r0 = np.clip(np.floor(row + 1e-4).astype(int), 0, n - 2)
    c0 = np.clip(np.floor(col + 1e-4).astype(int), 0, n - 2)
    fr, fc = np.clip(row - r0, 0, 1), np.clip(col - c0, 0, 1)
    top = heights[r0, c0] + fc * (heights[r0, c0 + 1] - heights[r0, c0])
    bot = heights[r0 + 1, c0] + fc * (heights[r0 + 1, c0 + 1] - heights[r0 + 1, c0])
    want = top + fr * (bot - top)
    err = float(np.abs(co[:, 2] - want).max())
    print("%s: %d vertices, max |z - EXR| = %.4f m (bar %.4f m), min z %.2f m" % (what, len(co), err, tol, co[:, 2].min()))
    if err > tol:
        fail(what + ": heights differ from the EXR by %.4f m" % err)
    if co[:, 2].min() > lo + tol:
        fail(what + ": the sea floor did not survive (min z %.2f m, EXR %.2f m)" % (co[:, 2].min(), lo))


info = json.load(open(os.path.join(bundle, "..", name + ".json")))["bundles"]["blender"]
span = info["span_m"]
spacing = span / (n - 1)

# A. The GLB. Debian 12's Blender 3.4 importer still uses numpy.bool, which
# numpy 1.24 removed: the one-line fix the bundle's README gives users.
if not hasattr(np, "bool"):
    np.bool = bool
bpy.ops.import_scene.gltf(filepath=os.path.join(bundle, name + ".glb"))
ob = [o for o in bpy.context.scene.objects if o.type == "MESH" and o.name.startswith(name)][0]
co = np.zeros(len(ob.data.vertices) * 3, dtype=np.float32)
ob.data.vertices.foreach_get("co", co)
co = co.reshape(-1, 3) @ np.array(ob.matrix_world)[:3, :3].T + np.array(ob.matrix_world)[:3, 3]
dims = co.max(0) - co.min(0)
print("GLB: %.3f x %.3f m across (want %.3f)" % (dims[0], dims[1], span))
if abs(dims[0] - span) > 1e-3 * span or abs(dims[1] - span) > 1e-3 * span:
    fail("GLB size %.3f x %.3f m, want %.3f m" % (dims[0], dims[1], span))
check_heights("GLB (%d² vertices)" % info["mesh_side_px"], co, spacing)
mat = ob.data.materials[0]
images = sorted(nd.image.size[0] for nd in mat.node_tree.nodes if nd.type == "TEX_IMAGE" and nd.image)
normal_maps = [nd for nd in mat.node_tree.nodes if nd.type == "NORMAL_MAP"]
print("GLB material: %d image textures %s, %d normal map node(s)" % (len(images), images, len(normal_maps)))
if len(images) != 2 or not normal_maps:
    fail("the GLB's material lacks its base colour or normal texture")

# B. The displacement script, as a user runs it.
sys.argv = [os.path.join(bundle, name + ".displace.py")]
exec(compile(open(sys.argv[0]).read(), sys.argv[0], "exec"), {"__file__": sys.argv[0], "__name__": "__main__"})
ob = bpy.data.objects[name + ".displaced"]
deps = bpy.context.evaluated_depsgraph_get()
me = ob.evaluated_get(deps).to_mesh()
co = np.zeros(len(me.vertices) * 3, dtype=np.float32)
me.vertices.foreach_get("co", co)
check_heights("displace.py", co.reshape(-1, 3), spacing)
print("PASS")
