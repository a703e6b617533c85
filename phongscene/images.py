# SPDX-License-Identifier: Apache-2.0
"""Images through OpenImageIO. The image convention everywhere: linear float32 (H, W, 3),
row 0 at the top. EXR keeps the data (float, or half as POV-Ray writes it); PNG is sRGB for eyes.
Writes are atomic (``phongscene.files``)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .errors import PhongSceneError
from .files import atomic_path

if TYPE_CHECKING:
    from OpenImageIO import ImageBuf

# Extensions we write, and how: EXR stays linear float; PNG is sRGB-encoded 8-bit.
WRITABLE = (".exr", ".png")
# EXR compression: none, chosen for speed. A 1280x720 float render (benchmarks S1) took, written
# and read back, 17 ms uncompressed (11.1 MB), 30 ms rle (no smaller on float data), 49 ms
# zips level 1 (7.6 MB) and 105 ms zip, OpenImageIO's default (6.0 MB): zip is most of a small
# render's write time. Every lossless choice reads back bit-identical; readers handle them all.
EXR_COMPRESSION = "none"


class Image(np.ndarray):
    """A rendered image: a numpy array in the image convention (linear float32 (H, W, 3), row 0
    at the top) that Jupyter displays (``_repr_png_``: sRGB 8-bit, clipped to [0, 1], as
    ``write_image`` writes a PNG). Any numpy operation works on it; ``np.asarray`` gives the plain
    array."""

    def __array_wrap__(self, obj, context=None, return_scalar=False):
        # numpy ufuncs and reductions: what is still (H, W, 3) stays an Image; a reduction
        # (image.max(), image.mean(axis=2)) is a plain array or scalar, as for any ndarray.
        if obj.ndim == 3 and obj.shape[2] == 3:
            return (
                super().__array_wrap__(obj, context, return_scalar)
                if return_scalar
                else super().__array_wrap__(obj, context)
            )
        out = np.asarray(obj)
        return out[()] if return_scalar else out

    def _repr_png_(self) -> bytes | None:
        if self.ndim != 3 or self.shape[2] != 3 or self.dtype != np.float32:
            return None  # a slice or a derived array is no longer an image
        import tempfile

        with tempfile.TemporaryDirectory(prefix="phongscene-") as folder:
            path = write_image(Path(folder) / "image.png", np.asarray(self))
            return path.read_bytes()


def as_image(pixels) -> np.ndarray:
    """Check and convert to the image convention: float32, (H, W, 3), C-contiguous."""
    a = np.ascontiguousarray(pixels, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"expected an image of shape (H, W, 3), got {a.shape}")
    return a


def read_image(path: str | os.PathLike) -> np.ndarray:
    """Read any image OpenImageIO decodes as linear float32 (H, W, 3). 8-bit sRGB files
    (PNG, JPEG) are decoded to linear; alpha is dropped; grey is repeated to RGB."""
    import OpenImageIO as oiio  # here: only commands that read or write images pay its import
    from OpenImageIO import ImageBuf, ImageBufAlgo

    path = str(path)
    buf = ImageBuf(path)
    if buf.has_error:
        raise PhongSceneError(f"{path}: cannot read image: {buf.geterror()}")
    spec = buf.spec()
    space = spec.get_string_attribute("oiio:ColorSpace").lower()
    if "srgb" in space:
        # Decoded into float first: colorconvert keeps the buffer's pixel type, and linear values
        # stored back in 8 bits lose most of the dark codes (codes 51 and 52 both became ~8/255).
        if not buf.read(0, 0, True, oiio.TypeFloat):
            raise PhongSceneError(f"{path}: cannot decode image: {buf.geterror()}")
        buf = ImageBufAlgo.colorconvert(buf, "sRGB", "linear")
    pixels = buf.get_pixels(oiio.TypeFloat)
    if pixels is None or buf.has_error:
        raise PhongSceneError(f"{path}: cannot decode image: {buf.geterror()}")
    pixels = np.asarray(pixels, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)
    if spec.nchannels == 1:
        pixels = np.repeat(pixels, 3, axis=2)
    elif spec.nchannels < 3:
        raise PhongSceneError(f"{path}: expected RGB, got {spec.nchannels} channels")
    return np.ascontiguousarray(pixels[:, :, :3])


def write_image(path: str | os.PathLike, pixels, *, half: bool = False, display: str = "srgb") -> Path:
    """Write ``pixels`` (linear float32 H×W×3) atomically. ``.exr``: float (or half) linear;
    ``.png``: 8-bit by ``display`` (``phongscene.display``): "srgb", values clipped to [0, 1] and
    sRGB-encoded, or the book's "book" / "book-gamut" codes (max_to_one or out-of-gamut red,
    gamma 1, truncation)."""
    from OpenImageIO import ImageBuf, ImageBufAlgo

    from .display import book_codes, check_display

    path = Path(path)
    ext = path.suffix.lower()
    if ext not in WRITABLE:
        raise PhongSceneError(f"{path}: cannot write '{ext}' images; use one of {', '.join(WRITABLE)}")
    img = as_image(pixels)
    if ext == ".png" and check_display(display) != "srgb":
        return write_imagebuf(path, ImageBuf(book_codes(img, out_of_gamut_red=display == "book-gamut")), "uint8")
    buf = ImageBuf(img)
    if ext == ".png":
        buf = ImageBufAlgo.colorconvert(buf, "linear", "sRGB")
        fmt = "uint8"
    else:
        fmt = "half" if half else "float"
        buf.specmod().attribute("compression", EXR_COMPRESSION)
    write_imagebuf(path, buf, fmt)
    return path


def write_imagebuf(path: str | os.PathLike, buf: ImageBuf, fmt: str) -> Path:
    """Write an OpenImageIO ``buf`` as it is (no colour conversion) in pixel format ``fmt``,
    atomically."""
    path = Path(path)
    with atomic_path(path) as tmp:
        if not buf.write(str(tmp), fmt) or buf.has_error:
            raise PhongSceneError(f"{path}: cannot write image: {buf.geterror()}")
        _check_written(path, tmp, buf.spec())
    return path


def _check_written(path: Path, tmp: Path, spec) -> None:
    """Read the written file back whole before it replaces ``path``: OpenImageIO's PNG writer
    does not report a full disk, and a truncated file must not be renamed into place."""
    from OpenImageIO import ImageBuf

    back = ImageBuf(str(tmp))
    ok = back.read(force=True) and not back.has_error
    error = back.geterror()  # retrieved either way, so OpenImageIO does not print it
    if ok:
        got = back.spec()
        ok = (got.width, got.height, got.nchannels) == (spec.width, spec.height, spec.nchannels)
    back.clear()
    if not ok:
        detail = f": {error.strip().splitlines()[0]}" if error.strip() else ""
        raise PhongSceneError(f"{path}: the written image does not read back whole (is the disk full?){detail}")
