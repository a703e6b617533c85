"""Build the phongscene Blender reference scenes with headless bpy 5.0.1.

Usage:  venv/bin/python build_scenes.py [scene ...] [--samples N] [--fullgi]

For each scene NAME this writes, in this folder:
  NAME.blend            the scene as built
  NAME.usda             bpy.ops.wm.usd_export (ASCII, see USD_EXPORT_OPTS)
  NAME_cycles.exr       Cycles CPU render, direct lighting only (max_bounces=0),
                        32-bit float linear OpenEXR (RGBA, ZIP)
  NAME_cycles_notes.json  Blender light / camera / render settings

--fullgi additionally renders NAME_cycles_fullgi.exr with default bounce
limits (to check that max_bounces=0 really removes indirect light).
"""

import json
import math
import os
import sys

import bpy
from mathutils import Vector

HERE = os.path.dirname(os.path.abspath(__file__))

USD_EXPORT_OPTS = dict(
    selected_objects_only=False,
    export_animation=False,
    export_materials=True,
    generate_preview_surface=True,
    generate_materialx_network=False,
    export_textures_mode="NEW",
    export_lights=True,
    export_cameras=True,
    export_meshes=True,
    export_normals=True,
    export_uvmaps=True,
    convert_world_material=True,
    # Tessellate so that the USD mesh is the subdivided surface Cycles renders
    # (the default BEST_MATCH would write the cage + subdivisionScheme).
    export_subdivision="TESSELLATE",
    evaluation_mode="RENDER",
    convert_orientation=False,  # keep Blender's Z-up
    convert_scene_units="METERS",  # metersPerUnit = 1
    xform_op_mode="TRS",
    root_prim_path="/root",
    triangulate_meshes=False,
    use_instancing=False,
    export_custom_properties=True,
    author_blender_name=True,
    relative_paths=True,
)


# --------------------------------------------------------------------------- helpers
def reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    world = bpy.data.worlds.new("World")
    if hasattr(world, "use_nodes"):
        world.use_nodes = True
    bg = world.node_tree.nodes.get("Background")
    if bg is None:
        nt = world.node_tree
        bg = nt.nodes.new("ShaderNodeBackground")
        out = nt.nodes.get("World Output") or nt.nodes.new("ShaderNodeOutputWorld")
        nt.links.new(bg.outputs[0], out.inputs[0])
    bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bg.inputs["Strength"].default_value = 0.0
    world.color = (0.0, 0.0, 0.0)
    scene.world = world
    return scene


def setup_render(scene, res_x, res_y, samples):
    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x = res_x
    r.resolution_y = res_y
    r.resolution_percentage = 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.film_transparent = False
    r.use_compositing = False
    r.use_sequencer = False
    c = scene.cycles
    c.device = "CPU"
    c.samples = samples
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.seed = 0
    # direct lighting only
    c.max_bounces = 0
    c.diffuse_bounces = 0
    c.glossy_bounces = 0
    c.transmission_bounces = 0
    c.volume_bounces = 0
    c.transparent_max_bounces = 0
    c.caustics_reflective = False
    c.caustics_refractive = False
    c.blur_glossy = 0.0  # no filter-glossy regularisation
    c.sample_clamp_direct = 0.0  # no clamping
    c.sample_clamp_indirect = 0.0
    c.film_exposure = 1.0  # Cycles film exposure is a multiplier: 1 = none
    c.pixel_filter_type = "BLACKMAN_HARRIS"
    c.filter_width = 1.5
    vs = scene.view_settings
    vs.view_transform = "Standard"
    vs.look = "None"
    vs.exposure = 0.0
    vs.gamma = 1.0
    scene.display_settings.display_device = "sRGB"
    ims = r.image_settings
    ims.file_format = "OPEN_EXR"
    ims.color_mode = "RGBA"
    ims.color_depth = "32"
    ims.exr_codec = "ZIP"


def set_fullgi(scene):
    c = scene.cycles
    c.max_bounces = 12
    c.diffuse_bounces = 4
    c.glossy_bounces = 4
    c.transmission_bounces = 12
    c.volume_bounces = 0
    c.transparent_max_bounces = 8


def principled(name, base=(1, 1, 1), roughness=0.5, metallic=0.0, spec_level=None, ior=None):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    bsdf = nt.nodes.get("Principled BSDF")
    bsdf.inputs["Base Color"].default_value = (*base, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Metallic"].default_value = metallic
    if spec_level is not None:
        bsdf.inputs["Specular IOR Level"].default_value = spec_level
    if ior is not None:
        bsdf.inputs["IOR"].default_value = ior
    return mat


def material_notes(mat):
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    d = {"name": mat.name, "node": "Principled BSDF"}
    for k in (
        "Base Color",
        "Metallic",
        "Roughness",
        "IOR",
        "Specular IOR Level",
        "Diffuse Roughness",
        "Coat Weight",
        "Sheen Weight",
        "Transmission Weight",
        "Emission Strength",
        "Alpha",
    ):
        if k in bsdf.inputs:
            v = bsdf.inputs[k].default_value
            d[k] = list(v) if hasattr(v, "__len__") else float(v)
    d["distribution"] = bsdf.distribution
    d["subsurface_method"] = bsdf.subsurface_method
    return d


def add_plane(name, size, mat, z=0.0):
    bpy.ops.mesh.primitive_plane_add(size=size, location=(0, 0, z))
    ob = bpy.context.active_object
    ob.name = name
    ob.data.name = name + "Mesh"
    ob.data.materials.append(mat)
    return ob


def add_sphere(name, radius, loc, mat, segments=64, rings=32):
    bpy.ops.mesh.primitive_uv_sphere_add(radius=radius, location=loc, segments=segments, ring_count=rings)
    ob = bpy.context.active_object
    ob.name = name
    ob.data.name = name + "Mesh"
    bpy.ops.object.shade_smooth()
    ob.data.materials.append(mat)
    return ob


def look_at(ob, target):
    d = Vector(target) - ob.location
    ob.rotation_mode = "XYZ"
    ob.rotation_euler = d.to_track_quat("-Z", "Y").to_euler("XYZ")


def add_camera(scene, loc, target=None, rot=None, lens=35.0, sensor=36.0, fit="AUTO"):
    cam = bpy.data.cameras.new("Camera")
    cam.lens = lens
    cam.sensor_width = sensor
    cam.sensor_height = 24.0
    cam.sensor_fit = fit
    cam.clip_start = 0.1
    cam.clip_end = 1000.0
    ob = bpy.data.objects.new("Camera", cam)
    scene.collection.objects.link(ob)
    ob.location = loc
    if target is not None:
        look_at(ob, target)
    elif rot is not None:
        ob.rotation_euler = rot
    scene.camera = ob
    return ob


def add_light(scene, name, ltype, loc, energy, target=None, rot=None, **kw):
    ld = bpy.data.lights.new(name, ltype)
    ld.energy = energy
    ld.color = (1.0, 1.0, 1.0)
    for k, v in kw.items():
        setattr(ld, k, v)
    ob = bpy.data.objects.new(name, ld)
    scene.collection.objects.link(ob)
    ob.location = loc
    if target is not None:
        look_at(ob, target)
    elif rot is not None:
        ob.rotation_euler = rot
    return ob


def light_notes(ob):
    ld = ob.data
    d = {
        "object": ob.name,
        "type": ld.type,
        "energy": ld.energy,
        "energy_meaning": ("irradiance W/m^2 (strength)" if ld.type == "SUN" else "radiant power W"),
        "color": list(ld.color),
        "exposure": ld.exposure,
        "normalize": ld.normalize,
        "specular_factor": ld.specular_factor,
        "diffuse_factor": ld.diffuse_factor,
        "use_shadow": ld.use_shadow,
        "use_temperature": ld.use_temperature,
        "location": list(ob.matrix_world.translation),
        "rotation_euler_xyz_rad": list(ob.rotation_euler),
        "emit_direction_world(-Z)": list((ob.matrix_world.to_3x3() @ Vector((0, 0, -1))).normalized()),
        "matrix_world": [list(r) for r in ob.matrix_world],
    }
    if ld.type in ("POINT", "SPOT"):
        d["shadow_soft_size(radius)"] = ld.shadow_soft_size
        d["use_soft_falloff"] = ld.use_soft_falloff
    if ld.type == "SPOT":
        d["spot_size_rad"] = ld.spot_size
        d["spot_size_deg(full cone)"] = math.degrees(ld.spot_size)
        d["spot_blend"] = ld.spot_blend
        d["use_square"] = ld.use_square
    if ld.type == "SUN":
        d["angle_rad"] = ld.angle
        d["angle_deg"] = math.degrees(ld.angle)
    if ld.type == "AREA":
        d["shape"] = ld.shape
        d["size"] = ld.size
        d["size_y"] = ld.size_y
        d["spread_rad"] = ld.spread
    cy = getattr(ld, "cycles", None)
    if cy is not None:
        d["cycles"] = {
            p.identifier: getattr(cy, p.identifier) for p in cy.bl_rna.properties if p.identifier != "rna_type"
        }
    return d


def camera_notes(scene):
    ob = scene.camera
    cam = ob.data
    rx, ry = scene.render.resolution_x, scene.render.resolution_y
    # effective sensor fit
    fit = cam.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if rx >= ry else "VERTICAL"
        sensor = cam.sensor_width
    else:
        sensor = cam.sensor_width if fit == "HORIZONTAL" else cam.sensor_height
    if fit == "HORIZONTAL":
        fw = sensor
        fh = sensor * ry / rx
    else:
        fh = sensor
        fw = sensor * rx / ry
    return {
        "object": ob.name,
        "type": cam.type,
        "lens_mm": cam.lens,
        "sensor_width_mm": cam.sensor_width,
        "sensor_height_mm": cam.sensor_height,
        "sensor_fit": cam.sensor_fit,
        "effective_fit": fit,
        "film_width_mm": fw,
        "film_height_mm": fh,
        "fov_x_deg": math.degrees(2 * math.atan(fw / 2 / cam.lens)),
        "fov_y_deg": math.degrees(2 * math.atan(fh / 2 / cam.lens)),
        "blender_angle_x_deg": math.degrees(cam.angle_x),
        "blender_angle_y_deg": math.degrees(cam.angle_y),
        "shift_x": cam.shift_x,
        "shift_y": cam.shift_y,
        "clip_start": cam.clip_start,
        "clip_end": cam.clip_end,
        "dof": cam.dof.use_dof,
        "location": list(ob.matrix_world.translation),
        "rotation_euler_xyz_rad": list(ob.rotation_euler),
        "view_direction_world(-Z)": list((ob.matrix_world.to_3x3() @ Vector((0, 0, -1))).normalized()),
        "matrix_world": [list(r) for r in ob.matrix_world],
        "resolution": [rx, ry],
    }


def render_notes(scene):
    c = scene.cycles
    return {
        "blender": bpy.app.version_string,
        "engine": scene.render.engine,
        "device": c.device,
        "samples": c.samples,
        "adaptive_sampling": c.use_adaptive_sampling,
        "denoising": c.use_denoising,
        "seed": c.seed,
        "max_bounces": c.max_bounces,
        "diffuse_bounces": c.diffuse_bounces,
        "glossy_bounces": c.glossy_bounces,
        "transmission_bounces": c.transmission_bounces,
        "transparent_max_bounces": c.transparent_max_bounces,
        "caustics_reflective": c.caustics_reflective,
        "caustics_refractive": c.caustics_refractive,
        "blur_glossy": c.blur_glossy,
        "sample_clamp_direct": c.sample_clamp_direct,
        "sample_clamp_indirect": c.sample_clamp_indirect,
        "film_exposure(multiplier)": c.film_exposure,
        "pixel_filter": c.pixel_filter_type,
        "filter_width_px": c.filter_width,
        "view_transform": scene.view_settings.view_transform,
        "view_exposure_stops": scene.view_settings.exposure,
        "look": scene.view_settings.look,
        "output": "OPEN_EXR 32-bit float RGBA ZIP, scene-linear (Linear Rec.709), no view transform baked",
        "world": "Background color (0,0,0) strength 0",
    }


# --------------------------------------------------------------------------- scenes
def white_plane():
    # Pure Lambert: base colour 1, roughness 1, Specular IOR Level 0 (no specular lobe).
    mat = principled("WhiteDiffuse", base=(1, 1, 1), roughness=1.0, spec_level=0.0)
    return mat


def top_camera(scene):
    # 8 m above the origin looking straight down (-Z); 35 mm lens, 36 mm sensor.
    add_camera(scene, (0, 0, 8), rot=(0, 0, 0), lens=35.0)


def lit_plane(samples, name, kind, location, power, **light):
    """The 10 m white Lambert plane under one light, seen from straight above."""
    scene = reset()
    setup_render(scene, 320, 240, samples)
    mat = white_plane()
    add_plane("Plane", 10.0, mat)
    add_light(scene, name, kind, location, power, **light)
    top_camera(scene)
    return scene, [mat]


def scene_plane_point(samples):
    return lit_plane(samples, "PointLight", "POINT", (0, 0, 3), 1000.0, shadow_soft_size=0.0)


def scene_plane_sun(samples):
    # rotation about X by 45 deg: light travels along (0, +0.707, -0.707) -> 45 deg elevation
    return lit_plane(samples, "SunLight", "SUN", (0, -3, 3), 3.0, rot=(math.radians(45), 0, 0), angle=0.0)


def scene_plane_area(samples):
    return lit_plane(samples, "AreaLight", "AREA", (0, 0, 2), 500.0, rot=(0, 0, 0), shape="SQUARE", size=1.0)


def scene_spheres_roughness(samples):
    scene = reset()
    setup_render(scene, 320, 180, samples)
    floor = principled("FloorDiffuse", base=(0.5, 0.5, 0.5), roughness=1.0, spec_level=0.0)
    add_plane("Floor", 20.0, floor)
    mats = [floor]
    for i, rough in enumerate((0.05, 0.2, 0.4, 0.6, 0.8)):
        m = principled(f"Sphere_r{rough:.2f}".replace(".", "_"), base=(0.8, 0.8, 0.8), roughness=rough)
        mats.append(m)
        add_sphere(f"Sphere{i}", 0.5, ((i - 2) * 1.25, 0, 0.5), m)
    add_light(scene, "PointLight", "POINT", (-3.0, -3.0, 4.0), 500.0, shadow_soft_size=0.0)
    add_light(
        scene,
        "SpotLight",
        "SPOT",
        (2.5, -2.5, 5.0),
        1000.0,
        target=(0, 0, 0.5),
        spot_size=math.radians(45.0),
        spot_blend=0.15,
        shadow_soft_size=0.0,
    )
    add_camera(scene, (0, -8.0, 3.0), target=(0, 0, 0.5), lens=40.0, fit="AUTO")
    return scene, mats


def scene_suzanne_glossy(samples):
    scene = reset()
    setup_render(scene, 320, 240, samples)
    floor = principled("FloorDiffuse", base=(0.6, 0.6, 0.6), roughness=1.0, spec_level=0.0)
    add_plane("Floor", 20.0, floor)
    suz_mat = principled("SuzanneGlossy", base=(0.8, 0.15, 0.1), roughness=0.2)
    bpy.ops.mesh.primitive_monkey_add(size=2.0, location=(-1.2, 0, 1.0))
    suz = bpy.context.active_object
    suz.name = "Suzanne"
    suz.data.name = "SuzanneMesh"
    suz.rotation_euler = (0, 0, math.radians(20))
    mod = suz.modifiers.new("Subdivision", "SUBSURF")
    mod.levels = 1
    mod.render_levels = 1
    bpy.ops.object.shade_smooth()
    suz.data.materials.append(suz_mat)
    gold = principled("Gold", base=(1.0, 0.766, 0.336), roughness=0.3, metallic=1.0)
    add_sphere("GoldSphere", 0.7, (1.3, 0, 0.7), gold)
    add_light(scene, "SunLight", "SUN", (0, 0, 6), 2.0, rot=(math.radians(40), 0, math.radians(-30)), angle=0.0)
    add_light(scene, "AreaLight", "AREA", (2.5, -3.5, 4.0), 200.0, target=(0, 0, 0.8), shape="SQUARE", size=2.0)
    add_camera(scene, (0, -7.0, 2.5), target=(0, 0, 0.8), lens=40.0)
    return scene, [floor, suz_mat, gold]


def textured(name, image, roughness):
    """A Principled BSDF whose Base Color is an Image Texture node (the active UV map)."""
    mat = principled(name, roughness=roughness)
    nt = mat.node_tree
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = image
    tex.interpolation = "Linear"
    tex.extension = "REPEAT"
    nt.links.new(tex.outputs["Color"], nt.nodes.get("Principled BSDF").inputs["Base Color"])
    return mat


def scene_textured_glossy(samples):
    # An image texture on a glossy material: Blender's generated colour grid (saved as an 8-bit
    # sRGB PNG, exported beside the USD) on a floor plane (UVs tiled 2x) and a UV sphere.
    scene = reset()
    setup_render(scene, 320, 240, samples)
    image = bpy.data.images.new("ColorGrid", 64, 64)
    image.generated_type = "COLOR_GRID"
    image.filepath_raw = os.path.join(HERE, "textured_glossy_grid.png")
    image.file_format = "PNG"
    image.save()
    floor = textured("FloorTextured", image, roughness=0.6)
    plane = add_plane("Floor", 8.0, floor)
    for loop in plane.data.uv_layers.active.data:
        loop.uv = (loop.uv[0] * 2.0, loop.uv[1] * 2.0)  # repeat wrap: the grid tiles twice
    glossy = textured("SphereGlossy", image, roughness=0.25)
    add_sphere("Sphere", 1.0, (0, 0, 1.0), glossy, segments=48, rings=24)
    add_light(scene, "PointLight", "POINT", (-2.5, -3.0, 4.0), 800.0, shadow_soft_size=0.0)
    add_light(scene, "SunLight", "SUN", (0, 0, 6), 1.5, rot=(math.radians(35), 0, math.radians(40)), angle=0.0)
    add_camera(scene, (0, -6.5, 3.0), target=(0, 0, 0.7), lens=40.0)
    return scene, [floor, glossy]


SCENES = {
    "plane_point": scene_plane_point,
    "plane_sun": scene_plane_sun,
    "plane_area": scene_plane_area,
    "spheres_roughness": scene_spheres_roughness,
    "suzanne_glossy": scene_suzanne_glossy,
    "textured_glossy": scene_textured_glossy,
}


def build(name, samples, fullgi):
    scene, mats = SCENES[name](samples)
    bpy.context.view_layer.update()
    blend = os.path.join(HERE, name + ".blend")
    usda = os.path.join(HERE, name + ".usda")
    exr = os.path.join(HERE, name + "_cycles.exr")
    bpy.ops.wm.save_as_mainfile(filepath=blend, check_existing=False)
    res = bpy.ops.wm.usd_export(filepath=usda, check_existing=False, **USD_EXPORT_OPTS)
    print(name, "usd_export ->", res)
    scene.render.filepath = exr
    scene.render.use_file_extension = False
    bpy.ops.render.render(write_still=True)
    print(name, "rendered", exr)
    notes = {
        "scene": name,
        "lights": [light_notes(o) for o in scene.objects if o.type == "LIGHT"],
        "camera": camera_notes(scene),
        "materials": [material_notes(m) for m in mats],
        "objects": [
            {
                "name": o.name,
                "type": o.type,
                "location": list(o.location),
                "dimensions": list(o.dimensions),
                "modifiers": [(m.type, getattr(m, "render_levels", None)) for m in o.modifiers],
            }
            for o in scene.objects
            if o.type == "MESH"
        ],
        "render": render_notes(scene),
        "usd_export_options": USD_EXPORT_OPTS,
        "files": {"blend": os.path.basename(blend), "usda": os.path.basename(usda), "exr": os.path.basename(exr)},
    }
    if fullgi:
        set_fullgi(scene)
        scene.render.filepath = os.path.join(HERE, name + "_cycles_fullgi.exr")
        bpy.ops.render.render(write_still=True)
        notes["files"]["exr_fullgi"] = name + "_cycles_fullgi.exr"
        notes["fullgi_bounces"] = dict(max=12, diffuse=4, glossy=4)
    with open(os.path.join(HERE, name + "_cycles_notes.json"), "w") as f:
        json.dump(notes, f, indent=2, default=str)


def main(argv):
    samples = 128
    fullgi = False
    names = []
    it = iter(argv)
    for a in it:
        if a == "--samples":
            samples = int(next(it))
        elif a == "--fullgi":
            fullgi = True
        else:
            names.append(a)
    for n in names or list(SCENES):
        build(n, samples, fullgi)


if __name__ == "__main__":
    main(sys.argv[1:])
