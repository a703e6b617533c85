# SPDX-License-Identifier: Apache-2.0
"""The UsdPreviewSurface → Phong conversion against an independent reference of the spec's BRDF
(tests/support/preview_reference.py): a lit sphere's specular energy and highlight peak."""

from __future__ import annotations

import math

import numpy as np
import pytest

from support import preview_reference as ref

# The conversion's fidelity (Phong / reference), as measured by ``python tests/support/preview_reference.py``
# and quoted in docs/validation/accuracy.md; a change of the mapping that leaves these bands fails here.
SPECULAR_ENERGY_BAND = (0.9, 1.3)  # every roughness 0.05…1, metallic 0 and 1
PEAK_BAND = (0.9, 1.1)  # roughness <= 0.6 (α < ½, where the peak is matched)
# The polar grid integrates a lobe to this accuracy (checked on GGX's own normalisation).
GRID_RELATIVE = 2e-3


@pytest.mark.parametrize("roughness", [0.05, 0.2, 1.0])
def test_the_grid_integrates_ggx_normalisation(roughness):
    # ∫ D(n·h) (n·h) dω_n = 1 over the hemisphere around h, for the narrowest lobe too.
    n, weight = ref._normals()
    h = (ref.LIGHT + ref.VIEW) / np.linalg.norm(ref.LIGHT + ref.VIEW)
    a2 = roughness**4
    nh = n @ h
    d = a2 / (math.pi * (nh * nh * (a2 - 1) + 1) ** 2)
    assert (d * np.maximum(nh, 0)) @ weight == pytest.approx(1.0, rel=GRID_RELATIVE)


@pytest.mark.slow
@pytest.mark.parametrize("metallic", ref.METALLICS)
@pytest.mark.parametrize("roughness", ref.ROUGHNESSES)
def test_converted_material_keeps_the_highlights_energy_and_peak(roughness, metallic):
    r = ref.fidelity(roughness, metallic)
    assert SPECULAR_ENERGY_BAND[0] <= r["specular"] <= SPECULAR_ENERGY_BAND[1], r
    if roughness <= 0.6:
        assert PEAK_BAND[0] <= r["peak"] <= PEAK_BAND[1], r
