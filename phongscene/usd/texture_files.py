# SPDX-License-Identifier: Apache-2.0
"""Texture image files, opened as layers are (``layers.py``): checked before they are read.

A texture file is untrusted input like a layer, and costs what its header says, not what the
file weighs (a 65 KB PNG of one grey value at 8192² decodes to 0.8 GB of float32 RGB). So:

1. the file must be a regular file (a FIFO or ``/proc/self/fd/0`` would block the reader
   forever, deaf to Ctrl-C): otherwise ``TextureRefused`` (the caller warns and uses the
   fallback);
2. the header is read alone (``ImageInput.open`` → ``spec``) and its size checked against
   ``MAX_TEXTURE_SIDE`` and the scene's texel budget (``TexelBudget``) before any pixel is decoded;
3. the pixels are decoded in the file's own precision (8 and 16 bits stay integers: a grey 8-bit
   PNG costs one byte a texel) and turned into the model's float32 texels a block of rows at a
   time (``texels``), never as a whole float64 image.

Before each allocation the reader announces its size (``phongscene.memory_model.announce``): the
sandboxed reader grows its memory limit by it, so a scene the in-process reader can read is not
refused sandboxed.
"""

from __future__ import annotations

import functools
import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
from pxr import Ar

from .. import limits
from ..limits import MAX_TEXTURE_SIDE
from ..memory_model import announce, texture_decode_bytes, texture_model_bytes
from .layers import not_regular

# The wrap modes an image file may carry (OpenImageIO's "wrapmodes" attribute, "s,t") → ours.
FILE_WRAPS = {"periodic": "repeat", "clamp": "clamp", "mirror": "mirror", "black": "black"}
# Channels a texture uses: RGB or grey, and alpha (the rest of a many-channel EXR is not decoded).
MAX_USED_CHANNELS = 4
# Texels converted to float at a time: the temporaries of one block stay a few tens of MB whatever
# the texture's size (memory_model.TEXTURE_BLOCK_BYTES; 2^18 texels of RGB in float64 = 6 MiB).
BLOCK_TEXELS = 1 << 18


class TextureRefused(Exception):
    """The file cannot be a texture (not a regular file, no image OpenImageIO can read): the
    caller warns and uses the texture's fallback."""


class TextureTooBig(Exception):
    """The header's size is beyond the bounds (a side, or the scene's texel budget): an error
    naming the texture's prim and ``inputs:file``."""


@dataclass(frozen=True)
class ImageHeader:
    """What an image file's header says, read before any pixel is decoded."""

    path: str  # the file OpenImageIO reads (a temporary copy for a .usdz-packaged image)
    width: int
    height: int
    channels: int  # channels decoded: the file's, at most MAX_USED_CHANNELS
    eight_bit: bool  # 8-bit integers (sRGB-encoded under sourceColorSpace "auto")
    wraps: tuple[str, ...]  # the file's wrap modes (s, t), or () without (valid) ones
    stored: str  # the precision pixels are decoded in: "uint8", "uint16", "half" or "float"

    @property
    def texels(self) -> int:
        return self.width * self.height


class TexelBudget:
    """Texels the model's textures of one scene hold, at most ``limit``: each texture image
    is charged before it is built, so the one over the budget is named and none is decoded."""

    def __init__(self, limit: int | None = None):
        self.limit = limits.MAX_SCENE_TEXELS if limit is None else limit
        self.used = 0

    def fits(self, texels: int) -> bool:
        return self.used + texels <= self.limit

    def charge(self, texels: int, what: str) -> None:
        if not self.fits(texels):
            raise TextureTooBig(
                f"{what} would bring the scene's textures to {self.used + texels} texels, more than the "
                f"{self.limit} (2^{self.limit.bit_length() - 1}) a scene may hold (each texture is kept as float32 RGB)"
            )
        self.used += texels


@contextmanager
def local_file(resolved: str) -> Iterator[str]:
    """A path OpenImageIO can open for the resolved asset path ``resolved``: itself, or, for an
    image packaged in a .usdz (``pkg.usdz[tex.png]``), a temporary copy read through USD's resolver
    (the package itself was checked as a layer)."""
    if not (resolved.endswith("]") and Ar.IsPackageRelativePath(resolved)):
        why = not_regular(resolved)
        if why is not None:
            raise TextureRefused(f"{resolved} {why}")
        yield resolved
        return
    asset = Ar.GetResolver().OpenAsset(Ar.ResolvedPath(resolved))
    if asset is None:
        raise TextureRefused(f"cannot read {resolved}: USD cannot open it")
    suffix = os.path.splitext(resolved[resolved.rindex("[") + 1 : -1])[1]
    with tempfile.TemporaryDirectory(prefix="phongscene-texture-") as tmp:
        local = os.path.join(tmp, "image" + suffix)
        with open(local, "wb") as f:
            f.write(memoryview(asset.GetBuffer()))
        yield local


def read_header(path: str, shown: str) -> ImageHeader:
    """The header of the image at ``path`` (``shown`` names it in messages), checked against
    the bounds; no pixel is decoded.

    Raises:
        TextureRefused: OpenImageIO cannot open it, or it is not a 2D image.
        TextureTooBig: a side is beyond MAX_TEXTURE_SIDE.
    """
    import OpenImageIO as oiio  # only for a scene with a texture (start-up cost, issue 15)

    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise TextureRefused(f"cannot read {shown}: {_error(oiio.geterror) or 'OpenImageIO cannot open it'}")
    try:
        spec = inp.spec()
    finally:
        inp.close()
    if spec.depth > 1:
        raise TextureRefused(f"cannot read {shown}: a volume image (depth {spec.depth}), not a 2D texture")
    if spec.width < 1 or spec.height < 1 or spec.nchannels < 1:
        raise TextureRefused(f"cannot read {shown}: its header says {spec.width} x {spec.height} x {spec.nchannels}")
    if max(spec.width, spec.height) > MAX_TEXTURE_SIDE:
        raise TextureTooBig(
            f"{shown} is {spec.width} x {spec.height} texels (its header); a texture's sides must be at most "
            f"{MAX_TEXTURE_SIDE}"
        )
    stored = {oiio.UINT8: "uint8", oiio.UINT16: "uint16", oiio.HALF: "half"}.get(spec.format.basetype, "float")
    wraps = spec.get_string_attribute("wrapmodes", "")
    parts = [FILE_WRAPS.get(w) for w in wraps.split(",")] if wraps else []
    return ImageHeader(
        path,
        spec.width,
        spec.height,
        min(spec.nchannels, MAX_USED_CHANNELS),
        stored == "uint8",
        tuple(parts) if len(parts) == 2 and None not in parts else (),
        stored,
    )


def decode(header: ImageHeader, shown: str) -> np.ndarray:
    """The pixels (H, W, C) of ``header``'s image as stored: uint8 or uint16 for integer files
    (``texels`` converts them as OpenImageIO does), half or float32 otherwise (other types:
    float32).

    Raises:
        TextureRefused: OpenImageIO cannot decode it.
    """
    import OpenImageIO as oiio

    native = oiio.TypeDesc(header.stored)
    announce(texture_decode_bytes(header.texels, header.channels, native.size()), shown)
    inp = oiio.ImageInput.open(header.path)
    if inp is None:
        raise TextureRefused(f"cannot read {shown}: {_error(oiio.geterror) or 'OpenImageIO cannot open it'}")
    try:
        pixels = inp.read_image(0, 0, 0, header.channels, native)
        error = _error(inp.geterror)
    finally:
        inp.close()
    if pixels is None or error:
        raise TextureRefused(f"cannot decode {shown}: {error or 'OpenImageIO cannot decode its pixels'}")
    return np.asarray(pixels).reshape(header.height, header.width, header.channels)


def texels(
    pixels: np.ndarray,
    srgb: bool,
    channel: int | None,
    scale: np.ndarray,
    bias: np.ndarray,
    factor: float,
    shown: str,
    signed: bool = False,
) -> tuple[np.ndarray, bool, int]:
    """The model's (H, W, 3) float32 texels of the selected output of ``pixels`` (``decode``):
    RGB (grey repeated), or one channel repeated (a missing alpha is 1, a missing colour channel
    of a grey image is the grey); sRGB-decoded when ``srgb`` (OpenImageIO's colour conversion, on
    colour only), then ``(texel · scale + bias) · factor`` in float64, clipped at 0 (unless
    ``signed``: a normal map's tangent-space vectors keep their sign). Built a
    block of rows at a time into a read-only float32 array (the model takes it without a copy).
    Returns (texels, whether any was negative before clipping, the count of non-finite values
    among the channels used)."""
    height, width, n = pixels.shape
    announce(texture_model_bytes(height * width), shown)
    out = np.empty((height, width, 3), dtype=np.float32)
    sel = slice(0, 3) if channel is None else slice(channel, channel + 1)
    scale, bias = np.asarray(scale, dtype=np.float64)[sel], np.asarray(bias, dtype=np.float64)[sel]
    rows = max(1, BLOCK_TEXELS // width)
    negative, nonfinite = False, 0
    for top in range(0, height, rows):
        stored = pixels[top : top + rows]
        block = _as_float(stored)
        nonfinite += int(np.count_nonzero(~np.isfinite(block)))
        colour = slice(0, 1) if n in (1, 2) else slice(0, 3)
        rgb = _srgb_to_linear(stored[:, :, colour]) if srgb else block[:, :, colour]
        if n in (1, 2):
            rgb = np.repeat(rgb, 3, axis=2)
        if channel == 3:
            values = block[:, :, n - 1 : n] if n in (2, 4) else np.ones_like(block[:, :, :1])
        elif channel is not None:
            values = rgb[:, :, channel : channel + 1]
        else:
            values = rgb
        values = (values.astype(np.float64) * scale + bias) * factor
        if not signed and values.min() < 0:  # NaN compares False: non-finite texels are counted above
            negative = True
            np.clip(values, 0.0, None, out=values)
        out[top : top + rows] = values  # broadcast: one channel repeated into RGB
    out.setflags(write=False)
    return out, negative, nonfinite


def _as_float(block: np.ndarray) -> np.ndarray:
    """float32 values of stored pixels, as OpenImageIO converts them (integers through its own
    conversion of every code: the result is what decoding the file to float gives)."""
    if block.dtype == np.uint8 or block.dtype == np.uint16:
        return _integer_lut(block.dtype.str, False)[block]
    return block.astype(np.float32)


def _srgb_to_linear(stored: np.ndarray) -> np.ndarray:
    """Linear float32 values of sRGB-encoded stored colour channels: OpenImageIO's sRGB → linear
    conversion of their float values (a per-value transfer function: integers through a table of
    every code, floats a block at a time)."""
    if stored.dtype == np.uint8 or stored.dtype == np.uint16:
        return _integer_lut(stored.dtype.str, True)[stored]
    return _colorconvert(stored.astype(np.float32))


@functools.cache
def _integer_lut(dtype: str, srgb: bool) -> np.ndarray:
    """OpenImageIO's float value of each code of an unsigned integer type (256 or 65536 codes),
    sRGB-decoded to linear when ``srgb``."""
    import OpenImageIO as oiio

    kind = np.dtype(dtype)
    codes = np.arange(np.iinfo(kind).max + 1, dtype=kind)
    buf = oiio.ImageBuf(oiio.ImageSpec(len(codes), 1, 1, oiio.UINT8 if kind == np.uint8 else oiio.UINT16))
    buf.set_pixels(oiio.ROI(), codes.reshape(1, -1, 1))
    lut = np.asarray(buf.get_pixels(oiio.TypeFloat), dtype=np.float32).reshape(1, -1, 1)
    if srgb:  # as three channels: the conversion is applied to colour
        lut = _colorconvert(np.repeat(lut, 3, axis=2))[:, :, :1]
    lut = np.ascontiguousarray(lut.ravel())
    lut.setflags(write=False)
    return lut


def _colorconvert(rgb: np.ndarray) -> np.ndarray:
    """OpenImageIO's sRGB → linear conversion of float32 values (H, W, C)."""
    import OpenImageIO as oiio

    converted = oiio.ImageBufAlgo.colorconvert(oiio.ImageBuf(np.ascontiguousarray(rgb)), "sRGB", "linear")
    values = converted.get_pixels(oiio.TypeFloat)
    return np.asarray(values, dtype=np.float32).reshape(rgb.shape)


def _error(get) -> str:
    """The first line of OpenImageIO's pending error message (``get()``): a corrupt file's message
    may quote its bytes, which the binding fails to decode as UTF-8 (found by the fuzzer)."""
    try:
        return _first_line(get())
    except UnicodeDecodeError:
        return "(OpenImageIO's message could not be decoded)"


def _first_line(text: str) -> str:
    text = (text or "").strip()
    return text.splitlines()[0] if text else ""
