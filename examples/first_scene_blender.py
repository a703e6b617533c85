"""The first-scene tutorial's scene, built in Blender and exported to USD
(docs/tutorial/first-scene.md, "The same scene from Blender").

Run with Blender's Python module (`pip install bpy` in a virtual environment of its own; bpy
5.0.1 wrote examples/first_scene_blender.usda):

    /path/to/bpy-venv/bin/python examples/first_scene_blender.py [--cycles] [OUT.usda]

With --cycles it also renders the scene with Cycles, direct light only (no bounces: phongscene's
light transport), to OUT_cycles.exr (linear float) beside OUT.usda, for a comparison.

or paste it into Blender's Python console. It builds what examples/first_scene.usda writes by
hand, in Blender's terms: Z up, the camera at (0, -6, 1) looking along +Y, a 10 cm point light
4 m up and 1 m in front of the camera, a smooth sphere of radius 1 on a 10 m ground. Blender's
materials are Principled BSDFs (exported as UsdPreviewSurface, which phongscene maps to Phong):
the base colour is the hand-written file's kd·cd, so the diffuse light is the same.
"""

import math
import os
import sys

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = sys.argv[-1] if sys.argv[-1].endswith(".usda") else os.path.join(HERE, "first_scene_blender.usda")
CYCLES = "--cycles" in sys.argv[1:]
CYCLES_SAMPLES = 256  # per pixel: the noise of a lit pixel's median stays far below 1 %

# A Blender point light of power P watts has the radiant intensity P/(4π) W/sr: Blender's
# exporter writes it as a SphereLight of intensity P/π with inputs:normalize = 1, which UsdLux
# reads as I = intensity/4. The hand-written scene's light has I = 30π W/sr: P = 4π · 30π = 120π² W.
POWER_W = 120 * math.pi**2
LIGHT_RADIUS = 0.1

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.resolution_x, scene.render.resolution_y = 320, 213


def principled(name, base_color, roughness, specular_ior_level):
    material = bpy.data.materials.new(name)
    material.use_nodes = True  # Blender 5.0 still needs it for a node tree (deprecated for 6.0)
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*base_color, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Specular IOR Level"].default_value = specular_ior_level
    return material


bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=1.0, location=(0, 0, 1))
ball = bpy.context.active_object
ball.name = "Ball"
bpy.ops.object.shade_smooth()
ball.data.materials.append(principled("Red", (0.64, 0.16, 0.08), roughness=0.4, specular_ior_level=0.5))

bpy.ops.mesh.primitive_plane_add(size=10, location=(0, 0, 0))
ground = bpy.context.active_object
ground.name = "Ground"
ground.data.materials.append(principled("Grey", (0.4, 0.4, 0.4), roughness=1.0, specular_ior_level=0.0))

light_data = bpy.data.lights.new("Key", "POINT")
light_data.energy = POWER_W
light_data.shadow_soft_size = LIGHT_RADIUS
light = bpy.data.objects.new("Key", light_data)
light.location = (0, -5, 4)
scene.collection.objects.link(light)

camera_data = bpy.data.cameras.new("Camera")
camera_data.lens = 35.0
camera_data.sensor_fit = "HORIZONTAL"
camera_data.sensor_width = 36.0
camera = bpy.data.objects.new("Camera", camera_data)
camera.location = (0, -6, 1)
camera.rotation_euler = (math.radians(90), 0, 0)  # a Blender camera looks along its local -Z: now +Y
scene.collection.objects.link(camera)
scene.camera = camera

bpy.ops.wm.usd_export(
    filepath=OUT,
    export_materials=True,
    generate_preview_surface=True,
    export_lights=True,
    export_cameras=True,
    export_normals=True,
    convert_orientation=False,  # keep Blender's Z up (phongscene reads Z-up stages)
    convert_scene_units="METERS",
    relative_paths=True,
)
print("wrote", OUT)

if CYCLES:
    cycles = scene.cycles
    scene.render.engine = "CYCLES"
    cycles.device = "CPU"
    cycles.samples = CYCLES_SAMPLES
    cycles.use_denoising = False
    cycles.max_bounces = 0  # direct light only
    cycles.caustics_reflective = cycles.caustics_refractive = False
    scene.view_settings.view_transform = "Standard"  # no tone mapping: the EXR holds linear radiance
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = OUT[: -len(".usda")] + "_cycles.exr"
    bpy.ops.render.render(write_still=True)
    print("wrote", scene.render.filepath)
