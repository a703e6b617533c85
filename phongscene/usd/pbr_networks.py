# SPDX-License-Identifier: Apache-2.0
"""Physically based surface shaders that files ship besides UsdPreviewSurface — MaterialX's
Standard Surface and OpenPBR (``outputs:mtlx:surface``) and Omniverse's OmniPBR MDL material
(``outputs:mdl:surface``) — read from their USD shader prims and mapped onto the Phong model
the way a UsdPreviewSurface is (``materials.preview_to_phong``).

Each of these is, under direct light, a Lambert base plus a GGX lobe (α = roughness²) whose
normal-incidence reflectance F0 is the dielectric ((ior − 1)/(ior + 1))² scaled by a specular
weight and colour, blended toward the base colour by metalness. That is exactly what
``preview_to_phong`` matches in its specular workflow (F0 given, diffuse given), so each network
is reduced to (diffuse colour, roughness, F0) here and shares the one mapping. Lobes the model
has no term for (coat, sheen, transmission, subsurface, emission, opacity, thin film) are named
in one warning per kind, listing the materials, when they are not at their neutral value.

The inputs' defaults are the networks' own (MaterialX 1.39 data libraries, checked against the
``MaterialX`` package in tests/usd/test_pbr_networks.py; OmniPBR from its MDL source's
documented defaults), so an input a file leaves unauthored reads as the renderer that wrote it
reads it. usd-core needs no MaterialX or MDL plug-in for this: the values are the prims' own.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Network:
    """One shader network's inputs: the names it calls the base, specular and metal terms, their
    defaults, and the inputs (with their neutral values) of lobes the Phong model lacks."""

    label: str
    base_color: tuple[str, tuple[float, float, float]]
    metalness: tuple[str, float]
    specular_weight: tuple[str, float]
    roughness: tuple[str, float]
    # Inputs a network may not have (None): OmniPBR has a tint instead of a base weight, and
    # neither a specular colour nor an ior.
    base_weight: tuple[str, float] | None
    base_tint: tuple[str, tuple[float, float, float]] | None
    specular_color: tuple[str, tuple[float, float, float]] | None
    ior: tuple[str, float] | None
    # F0 of a dielectric as a function of (ior, specular weight): the networks disagree here.
    dielectric_f0: str  # "ior" (F0 from the ior, times the weight) or "level" (OmniPBR: 0.08·level)
    unmodelled: dict[str, object] = field(default_factory=dict)
    # The transmission weight and its colour (None: the network has none the model reads): the
    # weight makes the surface the book's dielectric (materials.preview_glass), as a UsdPreviewSurface's
    # opacity below 1 does; a tinted transmission colour is not modelled (a warning says so).
    transmission: tuple[str, float] | None = None
    transmission_color: tuple[str, tuple[float, float, float]] | None = None


STANDARD_SURFACE = Network(
    label="MaterialX standard_surface",
    base_weight=("base", 1.0),
    base_color=("base_color", (0.8, 0.8, 0.8)),
    metalness=("metalness", 0.0),
    specular_weight=("specular", 1.0),
    specular_color=("specular_color", (1.0, 1.0, 1.0)),
    base_tint=None,
    roughness=("specular_roughness", 0.2),
    ior=("specular_IOR", 1.5),
    dielectric_f0="ior",
    transmission=("transmission", 0.0),
    transmission_color=("transmission_color", (1.0, 1.0, 1.0)),
    unmodelled={
        "coat": 0.0,
        "sheen": 0.0,
        "subsurface": 0.0,
        "emission": 0.0,
        "thin_film_thickness": 0.0,
        "opacity": (1.0, 1.0, 1.0),
    },
)

OPEN_PBR = Network(
    label="MaterialX OpenPBR",
    base_weight=("base_weight", 1.0),
    base_color=("base_color", (0.8, 0.8, 0.8)),
    metalness=("base_metalness", 0.0),
    specular_weight=("specular_weight", 1.0),
    specular_color=("specular_color", (1.0, 1.0, 1.0)),
    base_tint=None,
    roughness=("specular_roughness", 0.3),
    ior=("specular_ior", 1.5),
    dielectric_f0="ior",
    transmission=("transmission_weight", 0.0),
    transmission_color=("transmission_color", (1.0, 1.0, 1.0)),
    unmodelled={
        "coat_weight": 0.0,
        "fuzz_weight": 0.0,
        "subsurface_weight": 0.0,
        "emission_luminance": 0.0,
        "thin_film_weight": 0.0,
        "geometry_opacity": 1.0,
    },
)

# OmniPBR.mdl (Omniverse's MDL library): diffuse_color_constant × diffuse_tint, perceptual
# reflection roughness (α = r²), metallic, and specular_level where 0.5 is F0 = 0.04 (F0 = 0.08·level).
OMNI_PBR = Network(
    label="OmniPBR (MDL)",
    base_weight=None,
    base_tint=("diffuse_tint", (1.0, 1.0, 1.0)),
    base_color=("diffuse_color_constant", (0.2, 0.2, 0.2)),
    metalness=("metallic_constant", 0.0),
    specular_weight=("specular_level", 0.5),
    specular_color=None,
    roughness=("reflection_roughness_constant", 0.5),
    ior=None,
    dielectric_f0="level",
    unmodelled={"enable_emission": False, "enable_opacity": False, "enable_clearcoat": False},
)

# The ids MaterialX writes into info:id for these surface shaders.
MTLX_NETWORKS = {
    "ND_standard_surface_surfaceshader": STANDARD_SURFACE,
    "ND_open_pbr_surface_surfaceshader": OPEN_PBR,
}
# OmniPBR is an MDL source asset (info:implementationSource = sourceAsset), named by its
# sub-identifier; OmniPBR_ClearCoat is the same material plus a coat (its coat is unmodelled).
MDL_NETWORKS = {"OmniPBR": OMNI_PBR, "OmniPBR_ClearCoat": OMNI_PBR}
# F0 per unit of OmniPBR's specular_level (0.5 → 0.04, a dielectric of ior 1.5).
OMNI_F0_PER_LEVEL = 0.08


def dielectric_f0(ior: float) -> float:
    """Normal-incidence Fresnel reflectance of a dielectric of index ``ior`` in air."""
    return ((ior - 1.0) / (ior + 1.0)) ** 2


def reduce(network: Network, values: dict[str, object]) -> tuple[np.ndarray, float, np.ndarray]:
    """(diffuse colour, roughness, F0) of a network's input values (each input's name → value,
    as ``inputs(network)`` lists them, at its default where unauthored)."""

    def colour(pair):
        return np.ones(3) if pair is None else np.clip(np.asarray(values[pair[0]], dtype=np.float64), 0.0, None)

    def number(pair):
        return 1.0 if pair is None else float(values[pair[0]])

    base = max(number(network.base_weight), 0.0) * colour(network.base_color) * colour(network.base_tint)
    metal = float(np.clip(number(network.metalness), 0.0, 1.0))
    weight = max(number(network.specular_weight), 0.0)
    if network.dielectric_f0 == "ior":
        f0_dielectric = dielectric_f0(number(network.ior)) * weight * colour(network.specular_color)
    else:
        f0_dielectric = OMNI_F0_PER_LEVEL * weight * colour(network.specular_color)
    f0 = (1.0 - metal) * f0_dielectric + metal * base
    return base * (1.0 - metal), number(network.roughness), f0


def inputs(network: Network) -> dict[str, object]:
    """Every input the mapping reads, with the network's default."""
    pairs = (
        network.base_weight,
        network.base_color,
        network.base_tint,
        network.metalness,
        network.specular_weight,
        network.specular_color,
        network.roughness,
        network.ior,
        network.transmission,
        network.transmission_color,
    )
    return dict(pair for pair in pairs if pair is not None)
