# Renders a reefgen Blender bundle in Blender itself (Cycles, CPU, headless)
# for the docs: the GLB as Blender imports it, textured by its own material
# layers (base colour + normal texture), a sea plane at 0 m, a sun.
#   blender -b --factory-startup --python scripts/render_bundle.py -- BUNDLE NAME OUT.png [WIDTH HEIGHT SAMPLES]
import math
import os
import sys

import bpy
import numpy as np

args = sys.argv[sys.argv.index("--") + 1:]
bundle, name, out = args[:3]
width, height, samples = (int(a) for a in (args[3:6] if len(args) >= 6 else (1400, 800, 24)))

# Debian 12's Blender 3.4 glTF importer still uses numpy.bool (gone in numpy 1.24).
if not hasattr(np, "bool"):
    np.bool = bool
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=os.path.join(bundle, name + ".glb"))
island = [o for o in bpy.context.scene.objects if o.type == "MESH"][0]
span = max(island.dimensions[0], island.dimensions[1])
# Relief shown twice as high, as terrain previews usually are.
island.scale[2] *= 2.0

# The sea floor beyond the island's square: a plane at its deepest point, in
# the deep-sea-floor material's colour, so the mesh's edge does not show.
bpy.context.view_layer.update()
floor_z = min((island.matrix_world @ v.co).z for v in island.data.vertices) - 0.5
bpy.ops.mesh.primitive_plane_add(size=span * 40, location=(0, 0, floor_z))
floor = bpy.context.active_object
floor_mat = bpy.data.materials.new("floor")
floor_mat.use_nodes = True
floor_mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.014, 0.034, 0.105, 1)
floor.data.materials.append(floor_mat)

# The sea: a plane at 0 m, blue and partly transparent over the reef and lagoon.
bpy.ops.mesh.primitive_plane_add(size=span * 40, location=(0, 0, 0))
sea = bpy.context.active_object
mat = bpy.data.materials.new("sea")
mat.use_nodes = True
bsdf = mat.node_tree.nodes["Principled BSDF"]
bsdf.inputs["Base Color"].default_value = (0.02, 0.18, 0.32, 1)
bsdf.inputs["Roughness"].default_value = 0.15
bsdf.inputs["Alpha"].default_value = 0.55
mat.blend_method = "BLEND"
sea.data.materials.append(mat)

world = bpy.data.worlds.new("sky")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.55, 0.72, 0.9, 1)
world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.6
bpy.context.scene.world = world

bpy.ops.object.light_add(type="SUN", rotation=(math.radians(50), 0, math.radians(-40)))
bpy.context.active_object.data.energy = 4.0

# Camera from the south-south-west, 30 degrees down, the whole island in view.
bpy.ops.object.camera_add()
cam = bpy.context.active_object
bpy.context.scene.camera = cam
dist = span * 0.95
az, el = math.radians(200), math.radians(32)
cam.location = (dist * math.sin(az), dist * math.cos(az), dist * math.sin(el))
direction = -np.array(cam.location)
cam.rotation_euler = (math.atan2(math.hypot(direction[0], direction[1]), -direction[2]), 0,
                      math.atan2(direction[1], direction[0]) - math.pi / 2)
cam.data.lens = 40
cam.data.clip_end = span * 60

scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = samples
scene.cycles.use_denoising = False
scene.render.resolution_x, scene.render.resolution_y = width, height
scene.render.filepath = out
bpy.ops.render.render(write_still=True)
print("rendered", out)
