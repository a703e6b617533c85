# SPDX-License-Identifier: Apache-2.0
"""A glass of water (Principled BSDF, transmission 1, roughness 0: a tumbler of IOR 1.5 and, in it,
water of IOR 1.33 whose side and bottom overlap the glass by 5 mm, the usual way to model it for
a renderer without nested media: no two surfaces coincide) in front of coloured spheres on a floor, built in Blender: exported
to USD (OUT/water.usda) and rendered by Cycles (OUT/cycles.exr, 160x120, 256 samples, caustics
off). Run with Blender's Python module (pip install bpy, in its own venv):
python water_scene.py -- OUT; then, from the repository:
.venv/bin/python benchmarks/cycles/water_compare.py OUT  (docs/reflection.md quotes the result)."""

import math
import sys

import bpy

out = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene

# The tumbler's profile (radius, height) in metres, and the water's
OUTER_R, INNER_R, HEIGHT, BOTTOM = 0.8, 0.72, 2.0, 0.15
OVERLAP = 0.005
WATER_R, WATER_BOTTOM, WATER_TOP = INNER_R + OVERLAP, BOTTOM - OVERLAP, 1.4
SEGMENTS = 96
# The tumbler stands 1 mm above the floor: a base in the floor's plane would make the two surfaces
# coincide, where each renderer takes its own of the two equal hits (POV-Ray and phongscene differ
# there, and neither is wrong).
LIFT = 0.001


def material(name, color, roughness, transmission=0.0, ior=1.5):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    b = m.node_tree.nodes["Principled BSDF"]
    b.inputs["Base Color"].default_value = (*color, 1)
    b.inputs["Roughness"].default_value = roughness
    b.inputs["IOR"].default_value = ior
    b.inputs["Transmission Weight"].default_value = transmission
    return m


def lathe(name, profile, mat):
    """A closed solid of revolution about z from a closed (radius, height) profile."""
    import bmesh  # importable once bpy is

    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    rings = []
    for k in range(SEGMENTS):
        a = 2 * math.pi * k / SEGMENTS
        rings.append([bm.verts.new((r * math.cos(a), r * math.sin(a), z)) for r, z in profile])
    n = len(profile)
    for k in range(SEGMENTS):
        ring, following = rings[k], rings[(k + 1) % SEGMENTS]
        for j in range(n):
            quad = (ring[j], ring[(j + 1) % n], following[(j + 1) % n], following[j])
            if len(set(quad)) == 4:
                bm.faces.new(quad)
    bmesh.ops.remove_doubles(bm, verts=bm.verts, dist=1e-9)
    bmesh.ops.recalc_face_normals(bm, faces=bm.faces)
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new(name, mesh)
    obj.location = (0, 0, LIFT)
    scene.collection.objects.link(obj)
    obj.data.materials.append(mat)
    return obj


# The profiles start and end on the axis with a tiny radius (a closed fan there would need triangles).
AXIS = 1e-4
lathe(
    "Glass",
    [(AXIS, 0.0), (OUTER_R, 0.0), (OUTER_R, HEIGHT), (INNER_R, HEIGHT), (INNER_R, BOTTOM), (AXIS, BOTTOM)],
    material("Glass", (1, 1, 1), 0.0, transmission=1.0, ior=1.5),
)
lathe(
    "Water",
    [(AXIS, WATER_BOTTOM), (WATER_R, WATER_BOTTOM), (WATER_R, WATER_TOP), (AXIS, WATER_TOP)],
    material("Water", (1, 1, 1), 0.0, transmission=1.0, ior=1.33),
)


def sphere(name, location, radius, mat):
    bpy.ops.mesh.primitive_uv_sphere_add(radius=radius, location=location, segments=64, ring_count=32)
    o = bpy.context.object
    o.name = name
    bpy.ops.object.shade_smooth()
    o.data.materials.append(mat)


# coloured spheres behind, for the glass and the water to show
for j, (name, c) in enumerate((("Red", (0.8, 0.1, 0.05)), ("Green", (0.1, 0.7, 0.1)), ("Blue", (0.05, 0.2, 0.8)))):
    sphere(name, (-1.5 + 1.5 * j, 2.6, 0.6 + 0.4 * j), 0.6, material(name, c, 0.5))
bpy.ops.mesh.primitive_plane_add(size=30, location=(0, 1, 0))
bpy.context.object.name = "Floor"
bpy.context.object.data.materials.append(material("Floor", (0.6, 0.55, 0.5), 0.8))
bpy.ops.object.light_add(type="POINT", location=(3, -4, 7))
light = bpy.context.object
light.data.energy = 3000
light.data.shadow_soft_size = 0
bpy.ops.object.camera_add(location=(0, -6.0, 2.6), rotation=(math.radians(80), 0, 0))
scene.camera = bpy.context.object
scene.world = bpy.data.worlds.new("World")
scene.world.use_nodes = True
scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.05, 0.06, 0.08, 1)
scene.render.engine = "CYCLES"
scene.cycles.samples = 256
scene.cycles.device = "CPU"
scene.render.resolution_x, scene.render.resolution_y = 160, 120
scene.cycles.max_bounces = 12
scene.cycles.transmission_bounces = 12
scene.cycles.glossy_bounces = 12
scene.cycles.caustics_reflective = False  # Whitted has no caustics; Cycles' noise there is not the comparison
scene.cycles.caustics_refractive = False
scene.view_settings.view_transform = "Standard"
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.filepath = out + "/cycles.exr"
# MaterialX networks carry the Principled BSDF's transmission (its UsdPreviewSurface does not: opacity 1)
bpy.ops.wm.usd_export(filepath=out + "/water.usda", generate_materialx_network=True)
bpy.ops.render.render(write_still=True)
print("done")
