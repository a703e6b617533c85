# SPDX-License-Identifier: Apache-2.0
"""A clear glass sphere (Principled BSDF, transmission 1, roughness 0, IOR 1.5) and a frosted-free
glass slab in front of coloured spheres on a floor, built in Blender: exported to USD
(OUT/glass.usda) and rendered by Cycles (OUT/cycles.exr, 160x90, 256 samples). Run with
Blender's Python module (pip install bpy, in its own venv):  python glass_scene.py -- OUT
Then, from the repository:  .venv/bin/python benchmarks/cycles/glass_compare.py OUT
(docs/reflection.md quotes the result)."""

import math
import sys

import bpy

out = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene


def material(name, color, roughness, transmission=0.0, ior=1.5):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    b = m.node_tree.nodes["Principled BSDF"]
    b.inputs["Base Color"].default_value = (*color, 1)
    b.inputs["Roughness"].default_value = roughness
    b.inputs["IOR"].default_value = ior
    b.inputs["Transmission Weight"].default_value = transmission
    return m


def sphere(name, location, radius, mat):
    bpy.ops.mesh.primitive_uv_sphere_add(radius=radius, location=location, segments=96, ring_count=48)
    o = bpy.context.object
    o.name = name
    bpy.ops.object.shade_smooth()
    o.data.materials.append(mat)
    return o


sphere("Glass", (-1.3, 0, 1), 1.0, material("Glass", (1, 1, 1), 0.0, transmission=1.0))
bpy.ops.mesh.primitive_cube_add(size=1, location=(1.6, 0, 0.9))
slab = bpy.context.object
slab.name = "Slab"
slab.scale = (1.4, 0.3, 1.8)
slab.data.materials.append(material("SlabGlass", (1, 1, 1), 0.0, transmission=1.0))
# coloured spheres behind, for the glass to show (upside down through the ball, shifted through the slab)
for j, (name, c) in enumerate((("Red", (0.8, 0.1, 0.05)), ("Green", (0.1, 0.7, 0.1)), ("Blue", (0.05, 0.2, 0.8)))):
    sphere(name, (-2.6 + 2.6 * j, 3.2, 0.7), 0.7, material(name, c, 0.5))
bpy.ops.mesh.primitive_plane_add(size=30, location=(0, 1, 0))
floor = bpy.context.object
floor.name = "Floor"
floor.data.materials.append(material("Floor", (0.6, 0.55, 0.5), 0.8))
bpy.ops.object.light_add(type="POINT", location=(3, -4, 7))
light = bpy.context.object
light.data.energy = 3000
light.data.shadow_soft_size = 0
bpy.ops.object.camera_add(location=(0, -9.5, 4.0), rotation=(math.radians(72), 0, 0))
scene.camera = bpy.context.object
scene.world = bpy.data.worlds.new("World")
scene.world.use_nodes = True
scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.05, 0.06, 0.08, 1)
scene.render.engine = "CYCLES"
scene.cycles.samples = 256
scene.cycles.device = "CPU"
scene.render.resolution_x, scene.render.resolution_y = 160, 90
scene.cycles.max_bounces = 8
scene.cycles.transmission_bounces = 8
scene.cycles.glossy_bounces = 8
scene.cycles.caustics_reflective = False  # Whitted has no caustics; Cycles' noise there is not the comparison
scene.cycles.caustics_refractive = False
scene.view_settings.view_transform = "Standard"
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.filepath = out + "/cycles.exr"
# MaterialX networks carry the Principled BSDF's transmission (its UsdPreviewSurface does not: opacity 1)
bpy.ops.wm.usd_export(filepath=out + "/glass.usda", generate_materialx_network=True)
bpy.ops.render.render(write_still=True)
print("done")
