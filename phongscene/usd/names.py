# SPDX-License-Identifier: Apache-2.0
"""The one table between the scene model's field names and USD's attribute names.

The model (``phongscene.scene``, ``phongscene.validate``) and the backends name model fields
(``ks``, ``samples``); USD files name attributes (``inputs:ks``, ``phong:samples``). The reader,
the writer and the shader definition use this table, and ``in_usd_terms`` translates a problem
found in the model into the attribute a user sees in the file.
"""

from __future__ import annotations

from dataclasses import replace

from ..errors import Problem, SceneError

# -- the Phong shader ---------------------------------------------------------------------------

PHONG_SHADER_ID = "phongscene_PhongSurface"  # Sdr identifier = the definition prim's name
PHONG_RENDER_CONTEXT = "phong"  # materials connect our shader to outputs:phong:surface

# Shader input (without "inputs:") -> (PhongMaterial field, Sdf value type name).
PHONG_INPUTS: dict[str, tuple[str, str]] = {
    "ka": ("ka", "float"),
    "kd": ("kd", "float"),
    "ks": ("ks", "float"),
    "exponent": ("exponent", "float"),
    "diffuseColor": ("diffuse_color", "color3f"),
    "specularColor": ("specular_color", "color3f"),
    "emissiveColor": ("emission", "color3f"),
    # Beyond the Phong chapter (Suffern ch. 24, 27, 28): written only where they differ from their
    # defaults, which trace no secondary ray.
    "kr": ("kr", "float"),
    "reflectiveColor": ("reflective_color", "color3f"),
    "kt": ("kt", "float"),
    "ior": ("ior", "float"),
    "fresnel": ("fresnel", "bool"),
    "interiorFilter": ("interior_filter", "color3f"),
    # The book's Checker3D (its color1 is diffuseColor): written only where checkerSize > 0.
    "checkerColor": ("checker_color", "color3f"),
    "checkerSize": ("checker_size", "float"),
    # The book's PlaneChecker instead (x–z cells, an outline): written only where checkerPlane is on.
    "checkerPlane": ("checker_plane", "bool"),
    "checkerOutlineWidth": ("checker_outline_width", "float"),
    "checkerOutlineColor": ("checker_outline_color", "color3f"),
    # A texture-only input: connected to a UsdUVTexture (its scale and bias decode the tangent-space
    # normal), its value unused; unconnected, the surface's own normal.
    "normal": ("normal_texture", "normal3f"),
    # A cut-out mask: opacity connected to a UsdUVTexture (its first channel), thresholded.
    "opacity": ("opacity_texture", "float"),
    "opacityThreshold": ("opacity_threshold", "float"),
}
# The inputs that only a connected texture gives a value (no constant in PhongMaterial).
PHONG_MAP_INPUTS = ("normal", "opacity")
# The inputs every authored Phong shader carries (the seed's); the others only when not default.
PHONG_SEED_INPUTS = ("ka", "kd", "ks", "exponent", "diffuseColor", "specularColor")

# -- our own attributes (the `phong:` namespace) -------------------------------------------------

INT_TYPES = ("int", "uint", "int64", "uint64")
FLOAT_TYPES = ("float", "double", "half")
STRING_TYPES = ("token", "string")
COLOR_TYPES = ("color3f", "color3d", "color3h", "float3", "double3", "half3")

SHADOW_SAMPLES = "phong:shadowSamples"
SHADOW_ADAPTIVE = "phong:shadowAdaptive"
SHADOW_CELL_SAMPLES = "phong:shadowCellSamples"
FADE_DISTANCE = "phong:fadeDistance"
FADE_POWER = "phong:fadePower"
SAMPLES = "phong:samples"
SAMPLE_PATTERN = "phong:samplePattern"
AA_THRESHOLD = "phong:aaThreshold"
SPECULAR_CONVENTION = "phong:specularConvention"
BACKGROUND = "phong:background"
# The deepest secondary ray (RenderSettings.max_depth) and the radiance of refracted rays
# (RenderSettings.transmission: "book" or "povray").
MAX_DEPTH = "phong:maxDepth"
TRANSMISSION_CONVENTION = "phong:transmissionConvention"
# A light's model: "usdlux" (the default: UsdLux's units, normalize and falloff) or "seed" (the
# seed's constant light ls·cl = intensity · 2^exposure · color, no falloff; our examples use it).
LIGHT_MODEL = "phong:lightModel"
LIGHT_MODEL_USDLUX, LIGHT_MODEL_SEED = "usdlux", "seed"
LIGHT_MODELS = (LIGHT_MODEL_USDLUX, LIGHT_MODEL_SEED)

# Intrinsic prims (Cube, Cylinder, Cone, Capsule, Plane) are traced as their exact surfaces;
# phong:tessellate = true asks for the triangle mesh instead (SEGMENTS around the axis, as
# before analytic intrinsics). phong:infinite = true on a Plane makes it the whole plane
# (POV-Ray's plane), whose extent does not enter the scene's bounds.
TESSELLATE = "phong:tessellate"
# A subdivision surface's refinement level (usd/subdivision.py: 0 is the control cage).
SUBDIVISION_LEVEL = "phong:subdivisionLevel"
INFINITE = "phong:infinite"
BOOL_TYPES = ("bool",)

# Our attributes, by the prim types that may carry them, with the value types accepted.
# Anything else in `phong:` is an error (a typo must not be ignored).
PHONG_ATTRIBUTES: dict[str, dict[str, tuple[str, ...]]] = {
    "SphereLight": {
        SHADOW_SAMPLES: INT_TYPES,
        SHADOW_ADAPTIVE: INT_TYPES,
        SHADOW_CELL_SAMPLES: INT_TYPES,
        FADE_DISTANCE: FLOAT_TYPES,
        FADE_POWER: FLOAT_TYPES,
        LIGHT_MODEL: STRING_TYPES,
    },
    "RectLight": {
        SHADOW_SAMPLES: INT_TYPES,
        SHADOW_ADAPTIVE: INT_TYPES,
        SHADOW_CELL_SAMPLES: INT_TYPES,
        LIGHT_MODEL: STRING_TYPES,
    },
    "DiskLight": {
        SHADOW_SAMPLES: INT_TYPES,
        SHADOW_ADAPTIVE: INT_TYPES,
        SHADOW_CELL_SAMPLES: INT_TYPES,
        LIGHT_MODEL: STRING_TYPES,
    },
    "DistantLight": {LIGHT_MODEL: STRING_TYPES},
    "CylinderLight": {LIGHT_MODEL: STRING_TYPES},
    "DomeLight": {LIGHT_MODEL: STRING_TYPES},
    "Cube": {TESSELLATE: BOOL_TYPES},
    "Cylinder": {TESSELLATE: BOOL_TYPES},
    "Cylinder_1": {TESSELLATE: BOOL_TYPES},
    "Cone": {TESSELLATE: BOOL_TYPES},
    "Capsule": {TESSELLATE: BOOL_TYPES},
    "Capsule_1": {TESSELLATE: BOOL_TYPES},
    "Plane": {TESSELLATE: BOOL_TYPES, INFINITE: BOOL_TYPES},
    "Mesh": {SUBDIVISION_LEVEL: INT_TYPES},
    "RenderSettings": {
        SAMPLES: INT_TYPES,
        SAMPLE_PATTERN: STRING_TYPES,
        AA_THRESHOLD: FLOAT_TYPES,
        SPECULAR_CONVENTION: STRING_TYPES,
        BACKGROUND: COLOR_TYPES,
        MAX_DEPTH: INT_TYPES,
        TRANSMISSION_CONVENTION: STRING_TYPES,
    },
}

# -- USD conventions ------------------------------------------------------------------------------

# Camera apertures are in tenths of a scene unit (UsdGeom.Camera): an orthographic camera's
# view width is horizontalAperture · APERTURE_UNIT.
APERTURE_UNIT = 0.1

# -- model field -> USD attribute, by model node type --------------------------------------------

# Transforms come from the prim's xformOps; a sphere's size from its radius (its transform is
# world · diag(radius)); a camera's FOV and orthographic width from its horizontal aperture.
USD_ATTRIBUTES: dict[str, dict[str, str]] = {
    "PhongMaterial": {field: f"inputs:{name}" for name, (field, _) in PHONG_INPUTS.items()},
    "Camera": {
        "position": "xformOp",
        "forward": "xformOp",
        "up": "xformOp",
        "projection": "projection",
        "horizontal_fov_deg": "horizontalAperture",
        "ortho_width": "horizontalAperture",
    },
    "AmbientLight": {"color": "inputs:color"},
    "PointLight": {
        "position": "xformOp",
        "color": "inputs:color",
        "fade_distance": FADE_DISTANCE,
        "fade_power": FADE_POWER,
        "falloff": LIGHT_MODEL,
        "diffuse": "inputs:diffuse",
        "specular": "inputs:specular",
    },
    "DirectionalLight": {
        "direction": "xformOp",
        "color": "inputs:color",
        "diffuse": "inputs:diffuse",
        "specular": "inputs:specular",
    },
    "RectAreaLight": {
        "center": "xformOp",
        "axis_u": "inputs:width",
        "axis_v": "inputs:height",
        "color": "inputs:color",
        "samples": SHADOW_SAMPLES,
        "adaptive": SHADOW_ADAPTIVE,
        "cell_samples": SHADOW_CELL_SAMPLES,
        "falloff": LIGHT_MODEL,
        "diffuse": "inputs:diffuse",
        "specular": "inputs:specular",
    },
    "SphereAreaLight": {
        "center": "xformOp",
        "radius": "inputs:radius",
        "color": "inputs:color",
        "samples": SHADOW_SAMPLES,
        "adaptive": SHADOW_ADAPTIVE,
        "cell_samples": SHADOW_CELL_SAMPLES,
        "falloff": LIGHT_MODEL,
        "diffuse": "inputs:diffuse",
        "specular": "inputs:specular",
    },
    "Sphere": {"world_from_object": "radius"},
    "TriangleMesh": {
        "points": "points",
        "triangles": "faceVertexIndices",
        "normals": "normals",
        "normal_indices": "normals",
        "uvs": "primvars:st",
        "uv_indices": "primvars:st",
    },
    # A texture's source is its UsdUVTexture; its texels come from the file (after scale, bias).
    "Texture": {"image": "inputs:file", "wrap_s": "inputs:wrapS", "wrap_t": "inputs:wrapT"},
    "RenderSettings": {
        "width": "resolution",
        "height": "resolution",
        "samples": SAMPLES,
        "sample_pattern": SAMPLE_PATTERN,
        "aa_threshold": AA_THRESHOLD,
        "specular": SPECULAR_CONVENTION,
        "background": BACKGROUND,
        "max_depth": MAX_DEPTH,
        "transmission": TRANSMISSION_CONVENTION,
    },
}


def usd_attribute(node: str, field: str) -> str:
    """The USD attribute that holds model field ``field`` of a node of type ``node``
    (``field`` itself when it has no USD counterpart, e.g. ``threads``)."""
    return USD_ATTRIBUTES.get(node, {}).get(field, field)


def in_usd_terms(problem: Problem) -> Problem:
    """``problem`` naming the USD attribute instead of the model field, when it is about a node
    read from USD (its prim is a USD path); otherwise unchanged."""
    if not problem.node or not problem.prim.startswith("/"):
        return problem
    return replace(problem, attribute=usd_attribute(problem.node, problem.attribute), node="")


def error_in_usd_terms(error: SceneError) -> SceneError:
    """The same error with every problem ``in_usd_terms``."""
    problems = [in_usd_terms(p) for p in error.problems]
    return error if problems == error.problems else SceneError(problems)
