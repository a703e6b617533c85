# SPDX-License-Identifier: Apache-2.0
"""Every tolerance of the Python side in one place, each with the reason for its size.

The native tracer's ray tolerances live in ``backends/native/src/math.hpp``; the image
comparison thresholds in ``phongscene.comparison`` (they are a user-facing setting, not a
numerical tolerance).
"""

from __future__ import annotations

import numpy as np

# -- unit vectors ------------------------------------------------------------------------------

# A unit vector the model accepts (camera axes, light directions, mesh normals) may be off unit
# length, or two of them off orthogonality, by this much: USD stores normals as float32, whose
# rounding leaves |n| within a few 1e-8 of 1; 1e-6 admits that with margin and still catches
# unnormalized input (>= 1e-3).
UNIT_TOLERANCE = 1e-6

# A unit vector read in double precision is kept bit for bit when its length is within this of
# 1 (a few ulps), so that reading what the writer wrote is exactly idempotent; otherwise it is
# divided by its length.
KEEP_UNIT = 1e-14

# A camera's |forward·up| below this counts as orthogonal (a few ulps of the unit vectors'
# rounding): only then is up left untouched, so a camera the writer wrote reads back bit for bit;
# above it, up is re-orthogonalised (Gram-Schmidt).
CAMERA_ORTHOGONAL_TOLERANCE = 1e-12

# -- transforms ---------------------------------------------------------------------------------

# A 3×3 linear map is singular when |det| is below this fraction of the product of its column
# norms (its axes are (nearly) linearly dependent, or one is zero): scale-invariant, and far
# above double rounding (~1e-16) while far below any transform a scene means (a 1e-4 : 1
# squash is still 1e-4).
SINGULAR_RELATIVE_DET = 1e-12


def is_singular(linear) -> bool:
    """Whether a 3x3 linear map is singular to ``SINGULAR_RELATIVE_DET`` (scale-invariant)."""
    scale = float(np.prod(np.linalg.norm(linear, axis=0)))
    return scale == 0 or abs(float(np.linalg.det(linear))) <= SINGULAR_RELATIVE_DET * scale
