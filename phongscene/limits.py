# SPDX-License-Identifier: Apache-2.0
"""The upper bounds of every size, count and sample knob, in validation and the CLI (which
imports this module before anything heavy: no numpy here)."""

MAX_SAMPLES = 9  # anti-aliasing grid per axis (RenderSettings.samples): POV-Ray's +R limit
# The native stratified estimator's budget is samples² points: up to 256 (its stages 4, 16, 64, 256);
# the native adaptive one's finest cell is 1/samples of a pixel (a power of 2).
MAX_STRATIFIED_SAMPLES = 16
# Positions the tracer can represent: every coordinate within ±1e150, so that differences stay
# finite and squared distances (inverse-square falloff, sphere tests, box areas) stay below
# 1e300 < the largest double; beyond that, bounds and extents overflow to inf.
MAX_COORDINATE = 1e150
# An image side: 16384 px (a 16K render); the pixel count: 2^28 (16384², 3.2 GB of float32 RGB):
# beyond these a render would not fit this machine's memory (and C++ takes int sizes).
MAX_IMAGE_SIDE = 16384
# An orthographic camera's view window (Camera.ortho_width, USD: horizontalAperture / 10), world
# units. The upper bound keeps the file's own float32 camera arithmetic finite: USD stores
# apertures as float32 tenths of a unit, and the product of two apertures (the window's area, an
# aspect conversion) overflows float32 beyond sqrt(FLT_MAX) ~ 1.8e19 tenths; 1e18 units is the
# round bound below that (a window 1e18 times a metre scene's size is a typo, not a camera). The
# lower bound is the reciprocal of MAX_COORDINATE: a pixel's step (width / MAX_IMAGE_SIDE) and its
# square stay normal doubles.
MAX_ORTHO_WIDTH = 1e18
MIN_ORTHO_WIDTH = 1e-150
MAX_PIXELS = 2**28
MAX_THREADS = 1024  # worker threads (C++ int; far more than any machine here has cores)
# A texture's side: as an image side (OpenImageIO reads bigger ones, but one 16K texture is
# already 3.2 GB of float32 RGB here).
MAX_TEXTURE_SIDE = 16384
# The texels all textures of a scene may hold: as many as a render's pixels (MAX_PIXELS; one 16K
# texture, or sixteen 4K ones: 3.2 GB as the model's float32 RGB). Checked from the files' headers,
# before decoding (phongscene.usd.texture_files.TexelBudget).
MAX_SCENE_TEXELS = 2**28
# The largest texel POV-Ray can hold: it stores an EXR image map as half floats (ref §16).
MAX_TEXEL = 65504.0
# An area light's shadow grid per axis: 257 = 2^8 + 1 (66 049 shadow rays per light and point).
MAX_SHADOW_SAMPLES = 257
# An area light's `adaptive` level: POV-Ray's default, 100, is the deepest anyone writes (a grid of
# MAX_SHADOW_SAMPLES is fully subdivided from level 8 on).
MAX_ADAPTIVE = 100
# The cells estimator's points per partial cell per axis (256 per cell at most, as stratified's budget).
MAX_CELL_SAMPLES = 16

# A light's radiance (each channel of its model colour): the renderers shade in float32 (largest
# 3.4e38 = 2^128); 2^96 (7.9e28) leaves 2^32 for the shading's sums and products (billions of lights,
# colours, specular peaks) below it, and is far beyond any real light (the sun's luminance: 1.6e9).
MAX_RADIANCE = 2.0**96

# The deepest secondary ray (RenderSettings.max_depth): POV-Ray caps max_trace_level (= max_depth + 1)
# at 256; the native tracer's recursion is as deep (a few hundred stack frames).
MAX_DEPTH = 255

# The deepest uniform refinement of a subdivision surface (phong:subdivisionLevel,
# --subdivision-level): 4^level triangles per cage quad, level 8 already 131,072 (usd/subdivision.py).
MAX_SUBDIVISION_LEVEL = 8
