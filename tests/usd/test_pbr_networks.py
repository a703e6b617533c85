# SPDX-License-Identifier: Apache-2.0
"""MaterialX Standard Surface / OpenPBR and OmniPBR materials (phongscene/usd/pbr_networks.py):
read from the USD shader prims, mapped as the equivalent UsdPreviewSurface is, the surface
context preferred over a viewer's stand-in, and warnings grouped."""

from __future__ import annotations

import numpy as np
import pytest
from usda import FLOAT32, read

from phongscene.usd import pbr_networks

CAMERA_AND_LIGHT = """
def Camera "Cam" { double3 xformOp:translate = (0, 0, 5)
    uniform token[] xformOpOrder = ["xformOp:translate"] }
def DistantLight "Sun" { float inputs:intensity = 1 }
"""


def _material(name: str, context: str, shader_body: str, output: str = "out", info: str = "") -> str:
    return f"""
def Material "{name}" {{
    token outputs:{context}surface.connect = </{name}/S.outputs:{output}>
    def Shader "S" {{
        {info}
        {shader_body}
        token outputs:{output}
    }}
}}
"""


def _sphere(name: str, material: str) -> str:
    return f"""
def Sphere "{name}" (prepend apiSchemas = ["MaterialBindingAPI"]) {{
    rel material:binding = </{material}>
}}
"""


def _materials_of(result) -> dict[str, object]:
    return {s.material.source: s.material for s in result.scene.spheres}


def _same_look(a, b) -> None:
    for field in ("ka", "kd", "ks", "exponent"):
        assert getattr(a, field) == pytest.approx(getattr(b, field), rel=FLOAT32, abs=FLOAT32), field
    for field in ("diffuse_color", "specular_color"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), rtol=FLOAT32, atol=FLOAT32, err_msg=field)


@pytest.mark.parametrize("metal", [0.0, 0.35, 1.0])
def test_standard_surface_reads_as_the_equivalent_preview_surface(tmp_path, metal):
    # base 0.5 × base_color = the preview's diffuseColor; specular 1 and IOR 1.5 are the preview's
    # F0 = 0.04 (its Blender specular level 0.5); the lobes are the same GGX, so the looks agree.
    mtlx = _material(
        "X",
        "mtlx:",
        f"""uniform token info:id = "ND_standard_surface_surfaceshader"
        float inputs:base = 0.5
        color3f inputs:base_color = (0.8, 0.4, 0.2)
        float inputs:metalness = {metal}
        float inputs:specular_roughness = 0.3""",
    )
    preview = _material(
        "P",
        "",
        f"""uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor = (0.4, 0.2, 0.1)
        float inputs:metallic = {metal}
        float inputs:roughness = 0.3""",
        output="surface",
    )
    result = read(tmp_path, CAMERA_AND_LIGHT + mtlx + preview + _sphere("A", "X") + _sphere("B", "P"))
    looks = _materials_of(result)
    _same_look(looks["/X/S"], looks["/P/S"])
    assert not [w for w in result.warnings if "unknown surface shaders" in w or "registered" in w]


def test_open_pbr_defaults_are_the_networks_own(tmp_path):
    # Nothing authored: OpenPBR's base 0.8 grey, roughness 0.3, F0 0.04.
    mtlx = _material("O", "mtlx:", 'uniform token info:id = "ND_open_pbr_surface_surfaceshader"')
    preview = _material(
        "P",
        "",
        """uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor = (0.8, 0.8, 0.8)
        float inputs:roughness = 0.3""",
        output="surface",
    )
    looks = _materials_of(read(tmp_path, CAMERA_AND_LIGHT + mtlx + preview + _sphere("A", "O") + _sphere("B", "P")))
    _same_look(looks["/O/S"], looks["/P/S"])


def test_omni_pbr_reads_its_constants(tmp_path):
    # OmniPBR: diffuse_color_constant × diffuse_tint; specular_level 0.25 is F0 = 0.02, which is
    # the preview surface's Blender specular level 0.25 at ior 1.5.
    omni = _material(
        "Om",
        "mdl:",
        """color3f inputs:diffuse_color_constant = (0.5, 0.5, 0.25)
        color3f inputs:diffuse_tint = (1, 0.5, 1)
        float inputs:reflection_roughness_constant = 0.2
        float inputs:metallic_constant = 0.5
        float inputs:specular_level = 0.25""",
        info="""uniform token info:implementationSource = "sourceAsset"
        uniform asset info:mdl:sourceAsset = @OmniPBR.mdl@
        uniform token info:mdl:sourceAsset:subIdentifier = "OmniPBR\"""",
    )
    preview = _material(
        "P",
        "",
        """uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor = (0.5, 0.25, 0.25)
        float inputs:metallic = 0.5
        float inputs:roughness = 0.2
        float inputs:specular = 0.25""",
        output="surface",
    )
    looks = _materials_of(read(tmp_path, CAMERA_AND_LIGHT + omni + preview + _sphere("A", "Om") + _sphere("B", "P")))
    _same_look(looks["/Om/S"], looks["/P/S"])


def test_the_materialx_surface_wins_over_the_viewers_stand_in(tmp_path):
    # A file with a green UsdPreviewSurface for viewers and the real (red) MaterialX surface.
    material = """
def Material "M" {
    token outputs:surface.connect = </M/Preview.outputs:surface>
    token outputs:mtlx:surface.connect = </M/X.outputs:out>
    def Shader "Preview" { uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor = (0, 1, 0)
        token outputs:surface }
    def Shader "X" { uniform token info:id = "ND_standard_surface_surfaceshader"
        color3f inputs:base_color = (1, 0, 0)
        token outputs:out }
}
"""
    result = read(tmp_path, CAMERA_AND_LIGHT + material + _sphere("A", "M"))
    (sphere,) = result.scene.spheres
    assert sphere.material.source == "/M/X"
    assert sphere.material.diffuse_color[0] > 0 and sphere.material.diffuse_color[1] == 0


def test_unmodelled_lobes_are_one_warning_listing_the_materials(tmp_path):
    body = CAMERA_AND_LIGHT
    for i in range(3):
        body += _material(
            f"C{i}",
            "mtlx:",
            'uniform token info:id = "ND_standard_surface_surfaceshader"\n        float inputs:coat = 1',
        )
        body += _sphere(f"S{i}", f"C{i}")
    warnings = [w for w in read(tmp_path, body).warnings if "inputs:coat" in w]
    assert len(warnings) == 1
    assert all(f"/C{i}/S" in warnings[0] for i in range(3))


def test_an_unregistered_shader_id_used_many_times_is_one_warning(tmp_path):
    body = CAMERA_AND_LIGHT
    for i in range(40):
        body += _material(f"U{i}", "", 'uniform token info:id = "ND_made_up_surface"') + _sphere(f"S{i}", f"U{i}")
    warnings = read(tmp_path, body).warnings
    registered = [w for w in warnings if "no shader is registered" in w or "is registered" in w]
    assert len(registered) == 1
    assert "40 shaders" in registered[0] and "'ND_made_up_surface'" in registered[0]
    grey = [w for w in warnings if "unknown surface shaders" in w]
    assert len(grey) == 1 and "(40)" in grey[0]


def test_an_unknown_mdl_material_names_its_asset(tmp_path):
    mdl = _material(
        "D",
        "mdl:",
        "",
        info="""uniform token info:implementationSource = "sourceAsset"
        uniform asset info:mdl:sourceAsset = @Custom.mdl@
        uniform token info:mdl:sourceAsset:subIdentifier = "Glass\"""",
    )
    warnings = read(tmp_path, CAMERA_AND_LIGHT + mdl + _sphere("A", "D")).warnings
    assert any("unknown surface shaders" in w and "Custom.mdl" in w and "Glass" in w for w in warnings)


def test_a_wrong_typed_input_is_a_problem_naming_it(tmp_path):
    from phongscene.errors import SceneError

    mtlx = _material(
        "X", "mtlx:", 'uniform token info:id = "ND_standard_surface_surfaceshader"\n        string inputs:base = "much"'
    )
    with pytest.raises(SceneError, match=r"/X/S.*inputs:base"):
        read(tmp_path, CAMERA_AND_LIGHT + mtlx + _sphere("A", "X"))


@pytest.mark.parametrize(
    "network, nodedef",
    [
        (pbr_networks.STANDARD_SURFACE, "ND_standard_surface_surfaceshader"),
        (pbr_networks.OPEN_PBR, "ND_open_pbr_surface_surfaceshader"),
    ],
)
def test_defaults_match_the_materialx_data_libraries(network, nodedef):
    mx = pytest.importorskip("MaterialX")
    library = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), library)
    definition = library.getNodeDef(nodedef)
    assert definition is not None
    for name, default in {**pbr_networks.inputs(network), **network.unmodelled}.items():
        found = definition.getActiveInput(name)
        assert found is not None, name
        expected = [float(v) for v in found.getValueString().split(",")]
        assert np.ravel(default).tolist() == pytest.approx(expected), name


@pytest.mark.parametrize("weight", [1.0, 0.6])
def test_standard_surface_transmission_is_the_preview_surfaces_glass(tmp_path, weight):
    """transmission t is the UsdPreviewSurface's opacity 1 − t: the same dielectric (kt, ior,
    Fresnel mirror); a tinted transmission colour is named as not modelled."""
    mtlx = _material(
        "X",
        "mtlx:",
        f"""uniform token info:id = "ND_standard_surface_surfaceshader"
        float inputs:base = 0.5
        color3f inputs:base_color = (1, 1, 1)
        float inputs:specular_roughness = 0.1
        float inputs:specular_IOR = 1.45
        float inputs:transmission = {weight}
        color3f inputs:transmission_color = (1, 0.9, 0.8)""",
    )
    preview = _material(
        "P",
        "",
        f"""uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor = (0.5, 0.5, 0.5)
        float inputs:roughness = 0.1
        float inputs:ior = 1.45
        float inputs:opacity = {1.0 - weight}""",
        output="surface",
    )
    result = read(tmp_path, CAMERA_AND_LIGHT + mtlx + preview + _sphere("A", "X") + _sphere("B", "P"))
    looks = _materials_of(result)
    x, p = looks["/X/S"], looks["/P/S"]
    _same_look(x, p)
    assert x.kt == pytest.approx(weight) and x.kt == pytest.approx(p.kt)
    assert (x.ior, x.kr, x.fresnel) == pytest.approx((p.ior, p.kr, p.fresnel))
    assert any("tinted transmission" in w and "/X/S" in w for w in result.warnings)
    assert not [w for w in result.warnings if "inputs:transmission " in w]


def test_one_shaders_many_unmodelled_lobes_are_one_line(tmp_path):
    body = CAMERA_AND_LIGHT + _material(
        "C",
        "mtlx:",
        'uniform token info:id = "ND_standard_surface_surfaceshader"\n'
        "        float inputs:coat = 1\n        float inputs:sheen = 0.5\n        float inputs:subsurface = 0.2",
    )
    warnings = [w for w in read(tmp_path, body + _sphere("S", "C")).warnings if "not in the Phong model" in w]
    assert len(warnings) == 1
    assert all(f"/C/S.inputs:{name}" in warnings[0] for name in ("coat", "sheen", "subsurface"))
