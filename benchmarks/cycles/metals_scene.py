# SPDX-License-Identifier: Apache-2.0
"""Chrome and gold spheres at roughness 0, 0.1, 0.3 on a floor, built in Blender: exported to USD
(OUT/metals.usda) and rendered by Cycles (OUT/cycles.exr, 160x90, 64 samples). Run with Blender's
Python module (pip install bpy, in its own venv):  python metals_scene.py -- OUT
Then, from the repository:  .venv/bin/python benchmarks/cycles/metals_compare.py OUT
(docs/reflection.md quotes the result)."""

import math
import sys

import bpy

out = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene


def material(name, color, metallic, roughness, transmission=0.0, ior=1.5):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    b = m.node_tree.nodes["Principled BSDF"]
    b.inputs["Base Color"].default_value = (*color, 1)
    b.inputs["Metallic"].default_value = metallic
    b.inputs["Roughness"].default_value = roughness
    b.inputs["IOR"].default_value = ior
    if transmission:
        b.inputs["Transmission Weight"].default_value = transmission
    return m


spheres = [
    ("Chrome0", (0.9, 0.9, 0.9), 1, 0.0),
    ("Chrome01", (0.9, 0.9, 0.9), 1, 0.1),
    ("Chrome03", (0.9, 0.9, 0.9), 1, 0.3),
    ("Gold0", (1.0, 0.77, 0.34), 1, 0.0),
    ("Gold01", (1.0, 0.77, 0.34), 1, 0.1),
    ("Gold03", (1.0, 0.77, 0.34), 1, 0.3),
]
for i, (name, c, met, rough) in enumerate(spheres):
    x = (i % 3 - 1) * 2.4
    y = 0 if i < 3 else 2.6
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1, location=(x, y, 1), segments=64, ring_count=32)
    o = bpy.context.object
    o.name = name
    bpy.ops.object.shade_smooth()
    o.data.materials.append(material(name, c, met, rough))
bpy.ops.mesh.primitive_plane_add(size=30, location=(0, 1, 0))
floor = bpy.context.object
floor.name = "Floor"
checker = material("Floor", (0.6, 0.3, 0.2), 0, 0.8)
floor.data.materials.append(checker)
# coloured neighbours for the mirrors to show
for j, (name, c) in enumerate((("Red", (0.8, 0.1, 0.05)), ("Blue", (0.05, 0.2, 0.8)))):
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(-4.5 + 9 * j, 1.3, 0.7), segments=48, ring_count=24)
    o = bpy.context.object
    o.name = name
    bpy.ops.object.shade_smooth()
    o.data.materials.append(material(name, c, 0, 0.5))
bpy.ops.object.light_add(type="POINT", location=(3, -4, 7))
light = bpy.context.object
light.data.energy = 3000
light.data.shadow_soft_size = 0
bpy.ops.object.camera_add(location=(0, -9.5, 5.0), rotation=(math.radians(65), 0, 0))
scene.camera = bpy.context.object
scene.world = bpy.data.worlds.new("World")
scene.world.use_nodes = True
scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.05, 0.06, 0.08, 1)
scene.render.engine = "CYCLES"
scene.cycles.samples = 64
scene.cycles.device = "CPU"
scene.render.resolution_x, scene.render.resolution_y = 160, 90
scene.cycles.max_bounces = 6
scene.cycles.glossy_bounces = 6
scene.view_settings.view_transform = "Standard"
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.filepath = out + "/cycles.exr"
bpy.ops.wm.usd_export(filepath=out + "/metals.usda")
bpy.ops.render.render(write_still=True)
print("done")
