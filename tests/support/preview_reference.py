# SPDX-License-Identifier: Apache-2.0
"""An independent reference of the UsdPreviewSurface BRDF for direct light, and how far
phongscene's Phong conversion (``phongscene.usd.preview_to_phong``) is from it.

Reference (UsdPreviewSurface spec, metallic workflow): Lambert diffuse diffuseColor·(1 − metallic)/π
plus Cook-Torrance specular D·G·F / (4 (n·l)(n·v)) with α = roughness², GGX D = α²/(π((n·h)²(α² − 1) + 1)²),
Smith's height-uncorrelated GGX G = G1(l)·G1(v), G1(x) = 2(n·x)/((n·x) + sqrt(α² + (1 − α²)(n·x)²)),
Schlick's F = F0 + (1 − F0)(1 − v·h)⁵ with F0 = ((1 − ior)/(1 + ior))² mixed toward diffuseColor by
metallic. (No (1 − F) on the diffuse lobe: the converted Phong material has none either.)

The measure is a sphere seen by an orthographic camera along v and lit by a distant light from l
of irradiance 1: its image's luminance integrated over the disc (the light it reflects to the
camera) and at the highlight's centre (the peak), with n·l and n·v weights, split into specular
and total. The specular lobe is integrated on a polar grid of normals around the half vector,
dense near it, so that roughness 0.05 (α = 0.0025) is resolved.

``python tests/support/preview_reference.py`` prints the table docs/validation/accuracy.md quotes.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from phongscene.usd import preview_to_phong

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
VIEW = np.array([0.0, 0.0, 1.0])
LIGHT = np.array([0.3, 0.4, 1.0]) / np.linalg.norm([0.3, 0.4, 1.0])  # 23° off the view direction
BASE_COLOR = (0.8, 0.8, 0.8)
ROUGHNESSES = (0.05, 0.1, 0.2, 0.4, 0.6, 0.8, 1.0)
METALLICS = (0.0, 1.0)
# Normals on a polar grid around the half vector: θ = (π/2)·u³ for u uniform (dense near θ = 0,
# where the narrowest lobe lives), φ uniform.
GRID_U, GRID_PHI = 6000, 360


def _normals():
    h = (LIGHT + VIEW) / np.linalg.norm(LIGHT + VIEW)
    helper = np.array([1.0, 0.0, 0.0])
    t1 = np.cross(h, helper)
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(h, t1)
    u = (np.arange(GRID_U) + 0.5) / GRID_U
    theta = 0.5 * math.pi * u**3
    dtheta = 1.5 * math.pi * u**2 / GRID_U
    phi = (np.arange(GRID_PHI) + 0.5) / GRID_PHI * 2 * math.pi
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    n = (
        ct[..., None] * h + st[..., None] * (np.cos(phi)[None, :, None] * t1 + np.sin(phi)[None, :, None] * t2)
    ).reshape(-1, 3)
    weight = (np.sin(theta) * dtheta)[:, None] * np.full(GRID_PHI, 2 * math.pi / GRID_PHI)
    return n, weight.reshape(-1)


def reference_specular(n: np.ndarray, f0: np.ndarray, roughness: float) -> np.ndarray:
    """The spec's specular BRDF · (n·l), RGB, for unit normals n (rows)."""
    alpha = roughness**2
    a2 = alpha * alpha
    nl, nv = n @ LIGHT, n @ VIEW
    h = (LIGHT + VIEW) / np.linalg.norm(LIGHT + VIEW)
    nh, vh = n @ h, VIEW @ h
    d = a2 / (math.pi * (nh * nh * (a2 - 1) + 1) ** 2)

    def g1(x):
        return 2 * x / (x + np.sqrt(a2 + (1 - a2) * x * x))

    f = f0[None, :] + (1 - f0[None, :]) * (1 - vh) ** 5
    with np.errstate(divide="ignore", invalid="ignore"):
        brdf = (d * g1(nl) * g1(nv))[:, None] * f / (4 * nl * nv)[:, None]
    return np.where(((nl > 0) & (nv > 0))[:, None], brdf * nl[:, None], 0.0)


def phong_specular(n: np.ndarray, material) -> np.ndarray:
    """The seed's specular term ks·cs·max(0, r·wo)^e · (n·l), RGB."""
    nl = n @ LIGHT
    r = 2 * nl[:, None] * n - LIGHT
    rv = r @ VIEW
    lobe = np.where(rv > 0, np.power(np.maximum(rv, 0.0), material.exponent), 0.0)
    value = material.ks * np.asarray(material.specular_color)[None, :] * lobe[:, None] * nl[:, None]
    return np.where(((nl > 0) & ((n @ VIEW) > 0))[:, None], value, 0.0)


def fidelity(roughness: float, metallic: float, base=BASE_COLOR) -> dict[str, float]:
    """Phong / reference ratios of the sphere image's luminance: specular integrated over the disc,
    specular peak (at the half vector), and total (diffuse + specular) integrated."""
    material = preview_to_phong(base, roughness, metallic)
    base = np.asarray(base, dtype=np.float64)
    f0 = (1 - metallic) * 0.04 + metallic * base
    n, weight = _normals()
    # The disc's area element is (n·v) dω_n for an orthographic view along v.
    area = weight * np.maximum(n @ VIEW, 0.0)
    spec_ref = (reference_specular(n, f0, roughness) @ LUMINANCE) @ area
    spec_phong = (phong_specular(n, material) @ LUMINANCE) @ area
    h = ((LIGHT + VIEW) / np.linalg.norm(LIGHT + VIEW))[None, :]
    peak_ref = float((reference_specular(h, f0, roughness) @ LUMINANCE)[0])
    peak_phong = float((phong_specular(h, material) @ LUMINANCE)[0])
    # Diffuse over the lit, visible part of the disc (closed form not needed: same grid).
    nl = np.maximum(n @ LIGHT, 0.0)
    diffuse_ref = (((1 - metallic) * base / math.pi) @ LUMINANCE) * (nl @ area)
    diffuse_phong = ((material.kd * np.asarray(material.diffuse_color) / math.pi) @ LUMINANCE) * (nl @ area)
    return {
        "specular": spec_phong / spec_ref,
        "peak": peak_phong / peak_ref,
        "total": (spec_phong + diffuse_phong) / (spec_ref + diffuse_ref),
    }


def table() -> str:
    rows = ["| roughness | metallic | specular energy | highlight peak | total |", "|---|---|---|---|---|"]
    for metallic in METALLICS:
        for roughness in ROUGHNESSES:
            r = fidelity(roughness, metallic)
            rows.append(f"| {roughness:g} | {metallic:g} | {r['specular']:.3f} | {r['peak']:.3f} | {r['total']:.3f} |")
    return "\n".join(rows)


if __name__ == "__main__":
    print("Phong conversion / UsdPreviewSurface reference, sphere luminance (tests/support/preview_reference.py)")
    print(table())
