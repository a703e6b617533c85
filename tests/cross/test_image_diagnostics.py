# SPDX-License-Identifier: Apache-2.0
"""Images that explain themselves (phongscene/diagnostics.py, issue 26.3): each black or empty
case a new user met gets a warning that names its cause, from ``render``, the CLI's render,
compile and diff, and --frames; a lit scene gets none."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import phongscene as ps
from phongscene.cli import main
from phongscene.diagnostics import BLACK_RADIANCE, DARK_RADIANCE, ImageChecks, explain_image

WIDTH = 40  # small images: the statistics need no more

CAMERA = """def Camera "Camera"
{
    double3 xformOp:translate = %(eye)s
%(rotate)s    uniform token[] xformOpOrder = [%(order)s]
}
"""
# A first scene in UsdLux units: a 10 cm sphere light 4.9 units from a ball on a floor.
SCENE = """#usda 1.0
(
    upAxis = "Y"
    metersPerUnit = %(mpu)s
)

%(camera)s
def SphereLight "Light"
{
    float inputs:%(intensity_name)s = %(intensity)s
    float inputs:radius = %(radius)s
    bool inputs:normalize = %(normalize)s
    double3 xformOp:translate = %(light)s
    uniform token[] xformOpOrder = ["xformOp:translate"]
}

def Sphere "Ball"
{
    double radius = %(size)s
    double3 xformOp:translate = (0, %(size)s, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}

def Mesh "Floor"
{
    uniform token subdivisionScheme = "none"
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(-%(floor)s, 0, -%(floor)s), (-%(floor)s, 0, %(floor)s), (%(floor)s, 0, %(floor)s), (%(floor)s, 0, -%(floor)s)]
}
"""
LIT = dict(
    mpu=1,
    eye="(0, 2, 14)",
    rotate="",
    intensity_name="intensity",
    intensity=2000,
    radius=0.1,
    normalize=0,
    light="(2, 4, 2)",
    size=1,
    floor=5,
)


def scene_file(tmp_path, name="scene", **changes) -> str:
    values = {**LIT, **changes}
    rotate = values.pop("rotate")
    camera = CAMERA % {
        "eye": values.pop("eye"),
        "rotate": f"    float xformOp:rotateY = {rotate}\n" if rotate else "",
        "order": '"xformOp:translate", "xformOp:rotateY"' if rotate else '"xformOp:translate"',
    }
    path = tmp_path / f"{name}.usda"
    path.write_text(SCENE % {**values, "camera": camera})
    return str(path)


def image_warnings(path) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ps.render(path, width=WIDTH)
    return [str(w.message) for w in caught if issubclass(w.category, ps.ImageWarning)]


def one_warning(path) -> str:
    found = image_warnings(path)
    assert len(found) == 1, found
    return found[0]


def test_a_lit_scene_gets_no_warning(tmp_path):
    assert image_warnings(scene_file(tmp_path)) == []


def test_a_camera_facing_away_is_named(tmp_path):
    text = one_warning(scene_file(tmp_path, rotate=180))
    assert "nothing in view" in text and "camera faces away from every object" in text and "/Camera" in text


def test_a_scene_far_outside_the_view_is_named(tmp_path):
    text = one_warning(scene_file(tmp_path, eye="(8000, 2, 14)"))
    assert "nothing in view" in text and "every object is outside the view" in text


def test_a_scene_too_far_away_is_named_with_a_framing_distance(tmp_path):
    text = one_warning(scene_file(tmp_path, eye="(0, 2, 8000)"))
    assert "too far from the camera" in text and "units from its centre would frame it" in text


def test_a_light_below_every_surface_is_named(tmp_path):
    text = one_warning(scene_file(tmp_path, light="(2, -1, 2)"))
    assert text.split(": ", 1)[1].startswith("no light reaches what the camera sees: 100 % of the image is black")
    assert "/Light is below every surface" in text


def test_a_tiny_intensity_is_named_with_the_exposure_that_fits(tmp_path):
    text = one_warning(scene_file(tmp_path, intensity=0.01))
    assert "what the camera sees is black" in text
    assert "/Light lights a white surface to radiance" in text and "inputs:exposure +" in text


def test_a_misspelt_intensity_is_connected_to_the_dark_image(tmp_path):
    path = scene_file(tmp_path, intensity_name="intensty")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ps.render(path, width=WIDTH)
    texts = [str(w.message) for w in caught]
    assert any("inputs:intensty: not an input" in t for t in texts)  # the reader's own warning
    (dark,) = [t for t in texts if "too dark" in t]
    assert "% of it is black" in dark
    assert (
        "/Light has no inputs:intensity (/Light.inputs:intensty is not an input: did you mean inputs:intensity?)"
        in dark
    )


def test_a_metre_light_in_a_centimetre_scene_is_named(tmp_path):
    # Ball and floor in centimetres; the light's radius a metre (100 units), normalized: its
    # intensity spread over 100² times the area.
    path = scene_file(
        tmp_path,
        mpu=0.01,
        eye="(0, 20, 140)",
        light="(20, 40, 20)",
        radius=100,
        normalize=1,
        intensity=100,
        size=10,
        floor=50,
    )
    text = one_warning(path)
    assert "too dark" in text and "/Light has a radius (100) larger than the whole scene" in text


def test_the_exposure_hint_brings_the_brightest_to_white(tmp_path):
    path = scene_file(tmp_path, intensity=2000 * 2.0**-8)  # 8 stops under the lit scene
    scene = ps.load_usd(path)
    settings = ps.RenderOverrides(width=WIDTH).settings(scene)
    image = ps.render(scene, settings=settings, explain=False)
    (text,) = explain_image(scene, image, settings)
    stops = float(text.split("inputs:exposure ")[1].split(" on every light")[0])
    brighter = image * 2.0**stops
    shows = np.any(image != 0, axis=2)
    assert np.percentile(brighter.max(axis=2)[shows], 99) == pytest.approx(1.0, rel=0.05)  # nearest-rank vs linear


def test_thresholds_are_what_their_comments_say():
    # BLACK: half a code step of 8-bit sRGB, on the curve's linear segment.
    assert round(255 * 12.92 * BLACK_RADIANCE, 6) == 0.5
    assert DARK_RADIANCE == 1 / 16


def test_a_scene_built_in_python_without_lights_or_with_black_materials():
    sphere = ps.Sphere.at((0, 0, -5), 1, ps.PhongMaterial(ka=0, kd=0, ks=0))
    scene = ps.Scene(
        spheres=(sphere,),
        lights=(ps.PointLight((0, 5, 0), (3, 3, 3)),),
        settings=ps.RenderSettings(width=WIDTH, height=30),
    )
    image = ps.render(scene, explain=False)
    (text,) = explain_image(scene, image)
    assert "every material is black" in text
    lit = ps.Scene(spheres=(ps.Sphere.at((0, 0, -5), 1),), settings=scene.settings)
    with pytest.warns(ps.ImageWarning, match="the scene has no lights"):
        ps.render(lit)


def test_the_camera_inside_a_sphere_is_named():
    scene = ps.Scene(
        spheres=(ps.Sphere.at((0, 0, 0), 10),),
        lights=(ps.PointLight((0, 50, 0), (3, 3, 3)),),
        settings=ps.RenderSettings(width=WIDTH, height=30),
    )
    (text,) = explain_image(scene, ps.render(scene, explain=False))
    assert "the camera is inside a sphere" in text and "/Light" not in text


def test_a_rect_light_facing_away_is_named():
    light = ps.RectAreaLight(
        (0, 5, -5), (1, 0, 0), (0, 0, 1), (50, 50, 50), samples=3, falloff="inverse-square", source="/Panel"
    )  # emits along -(u x v) = +y: up, away from the ball
    scene = ps.Scene(
        spheres=(ps.Sphere.at((0, 0, -5), 1),), lights=(light,), settings=ps.RenderSettings(width=WIDTH, height=30)
    )
    (text,) = explain_image(scene, ps.render(scene, explain=False))
    assert "/Panel faces away from every object" in text


def test_checks_keep_nothing_of_the_scene_but_what_they_found(tmp_path):
    scene = ps.load_usd(scene_file(tmp_path, light="(2, -1, 2)"))
    checks = ImageChecks.of(scene)
    assert all(isinstance(c, str) for c in checks.causes) and not checks.nothing_in_view


def test_cli_render_compile_and_frames_warn(tmp_path, capsys):
    away = scene_file(tmp_path, "away", rotate=180)
    assert main(["render", away, "-o", str(tmp_path / "a.png"), "--width", str(WIDTH)]) == 0
    assert "warning: nothing in view: the camera faces away" in capsys.readouterr().err
    assert main(["compile", away, "-o", str(tmp_path / "a.pov")]) == 0
    assert "warning: nothing in view: the camera faces away" in capsys.readouterr().err
    below = scene_file(tmp_path, "below", light="(2, -1, 2)")
    assert main(["render", below, "-o", str(tmp_path / "b.####.png"), "--width", str(WIDTH), "--frames", "1:1"]) == 0
    assert "warning: frames 1: no light reaches what the camera sees" in capsys.readouterr().err


@pytest.mark.povray
def test_cli_render_with_povray_and_diff_warn(tmp_path, capsys):
    typo = scene_file(tmp_path, "typo", intensity_name="intensty")
    assert main(["render", typo, "-o", str(tmp_path / "t.exr"), "--width", str(WIDTH), "--backend", "povray"]) == 0
    assert "did you mean inputs:intensity?)" in capsys.readouterr().err.split("too dark")[1]
    assert main(["diff", typo, "-o", str(tmp_path / "report"), "--width", str(WIDTH)]) == 0
    out = capsys.readouterr()
    assert "warning: the image is too dark" in out.err
    import json

    meta = json.loads((tmp_path / "report" / "metrics.json").read_text())
    (dark,) = meta["image_warnings"]
    assert dark.startswith("the image is too dark")


def test_instanced_copies_count_as_geometry():
    from phongscene.scene import Prototype

    tri = ps.TriangleMesh(np.array([[-1.0, -1, 0], [1, -1, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    copies = np.stack([np.eye(4)] * 2)
    copies[:, 2, 3] = -5.0
    copies[1, 0, 3] = 2.0
    group = ps.Instances(Prototype((tri,)), copies)
    settings = ps.RenderSettings(width=WIDTH, height=30)
    lit = ps.Scene(instances=(group,), lights=(ps.PointLight((0, 0, 0), (3, 3, 3)),), settings=settings)
    assert ImageChecks.of(lit).nothing_in_view == ""
    assert explain_image(lit, ps.render(lit, explain=False)) == []
    behind_copies = copies.copy()
    behind_copies[:, 2, 3] = 5.0  # behind the default camera, which looks down -Z from the origin
    behind = ps.Scene(instances=(ps.Instances(Prototype((tri,)), behind_copies),), lights=lit.lights, settings=settings)
    assert ImageChecks.of(behind).nothing_in_view.startswith("the camera faces away from every object")


def test_sphere_samples_are_every_strided_row_of_centres_and_tops_made_row_by_row():
    # _Spheres.sample_points makes only the rows it takes (memory per point, issue 23.3): they
    # must be exactly the strided rows of the whole centres-then-tops array.
    from phongscene.diagnostics import _Spheres

    rng = np.random.default_rng(3)
    matrices = np.tile(np.eye(4), (7, 1, 1))
    matrices[:, :3, 3] = rng.random((7, 3))
    matrices[:, :3, 1] *= rng.random((7, 1))
    sets = (
        ps.Points(rng.random((1000, 3)), rng.random(1000) + 0.1, source="/A"),
        ps.Points(rng.random((13, 3)), rng.random(13) + 0.1, source="/B"),
    )
    for spheres_matrices in (matrices, np.zeros((0, 4, 4))):
        for points in (sets, (), sets[1:]):
            spheres = _Spheres(spheres_matrices, ("s",) * len(spheres_matrices), points)
            whole = [spheres_matrices[:, :3, 3], spheres_matrices[:, :3, 3] + spheres_matrices[:, :3, 1]]
            for p in points:
                whole += [p.centers, p.centers + p.radii[:, None] * (0.0, 1.0, 0.0)]
            whole = np.concatenate(whole)
            for about in (1, 3, 10, 1024, 5000):
                assert np.array_equal(spheres.sample_points(about), whole[:: max(1, len(whole) // about)])


def test_a_dim_light_on_grey_surfaces_is_named_together():
    """Neither cause alone (the light makes a white surface 0.23 bright, the floor reflects 30 %):
    together, the floor lit at 45° stays under DARK_RADIANCE, and the warning says so, naming both
    numbers, instead of finding no cause (an Isaac Sim scene's sun of intensity 3000 over 1°)."""
    grey = ps.PhongMaterial(ka=0.1, kd=0.6, ks=0.0, diffuse_color=(0.5, 0.5, 0.5))
    floor = ps.TriangleMesh(
        points=np.array([[-5.0, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]),
        triangles=np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int32),
        material=grey,
    )
    sun = ps.DirectionalLight(direction=(-(0.5**0.5), -(0.5**0.5), 0.0), color=(0.7177, 0.7177, 0.7177))
    scene = ps.Scene(
        camera=ps.look_at((0.0, 6.0, 9.0), (0.0, 0.0, 0.0), 50.0),
        lights=(sun,),
        meshes=(floor,),
        settings=ps.RenderSettings(width=WIDTH, height=30),
    )
    image = ps.render(scene, explain=False)
    (text,) = explain_image(scene, image)
    assert "the image is too dark" in text
    assert "a dim light on grey surfaces" in text and "30 % of that" in text and "kd 0.6" in text
    assert "radiance 0.23" in text and "0.069 at most" in text
    assert "no cause found" not in text
    brighter = ps.Scene(
        camera=scene.camera,
        lights=(ps.DirectionalLight(direction=sun.direction, color=(4.0, 4.0, 4.0)),),
        meshes=(floor,),
        settings=scene.settings,
    )
    assert explain_image(brighter, ps.render(brighter, explain=False)) == []
