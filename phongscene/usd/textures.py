# SPDX-License-Identifier: Apache-2.0
"""USD textures → ``Texture``: a ``UsdUVTexture`` connected (directly, or through node graphs
and material interface inputs) to a surface input, its ``st`` from a
``UsdPrimvarReader_float2`` (optionally through a ``UsdTransform2d``), and a mesh's st primvar
as per-corner uvs.

The image is read with OpenImageIO once per file (a ``.usdz``-packaged image through USD's
asset resolver), checked first as ``texture_files`` says (a regular file, its header within the
bounds and the scene's texel budget), then the texture's colour space, channel, ``scale`` and ``bias`` are applied
to the texels: they commute with the bilinear lookup (the colour space is decoded before
filtering, as GPU samplers do with sRGB textures), so the model holds only a linear image and
its wrap rules.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdShade

from ..scene import Texture
from .context import ReadContext
from .texture_files import (
    ImageHeader,
    TexelBudget,
    TextureRefused,
    TextureTooBig,
    decode,
    local_file,
    read_header,
    texels,
)

TEXTURE_SHADER_ID = "UsdUVTexture"
PRIMVAR_READER_ID = "UsdPrimvarReader_float2"
TRANSFORM_2D_ID = "UsdTransform2d"
WRAP_TOKENS = ("repeat", "clamp", "mirror", "black")
CHANNELS = {"r": 0, "g": 1, "b": 2, "a": 3}
# MaterialX image nodes (their ids ND_image_<type>, ND_tiledimage_<type>), the normalmap node
# (ND_normalmap_float / _vector2, ND_normalmap in 1.38), and how their address modes wrap
# ("constant" is the default value outside the image: black here, the common default).
MTLX_IMAGE_PREFIXES = ("ND_image_", "ND_tiledimage_")
MTLX_NORMALMAP_PREFIX = "ND_normalmap"
MTLX_ADDRESS_MODES = {"periodic": "repeat", "clamp": "clamp", "mirror": "mirror", "constant": "black"}
# OmniPBR's textures read texture coordinate 0: USD's st.
OMNI_UV_SET = "st"
# An image node without a texcoord reads the first uv set: USD's st (as usdMtlx and Storm do).
MTLX_FIRST_UV_SET = "st"
UV_TYPES = tuple(t + "[]" for t in ("texCoord2f", "texCoord2d", "texCoord2h", "float2", "double2", "half2"))


@dataclass(frozen=True)
class StSource:
    """Where a texture's st comes from: a mesh primvar, then an optional UsdTransform2d
    (st' = R(rotation) · (st ⊙ scale) + translation, as the UsdTransform2d spec orders it)."""

    primvar: str | None  # None: st is not read from a primvar (USD's fallback (0, 0))
    scale: tuple[float, float] = (1.0, 1.0)
    rotation_deg: float = 0.0
    translation: tuple[float, float] = (0.0, 0.0)

    def apply(self, st: np.ndarray) -> np.ndarray:
        if (self.scale, self.rotation_deg, self.translation) == ((1.0, 1.0), 0.0, (0.0, 0.0)):
            return st
        a = math.radians(self.rotation_deg)
        rotation = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        return (st * np.asarray(self.scale)) @ rotation.T + np.asarray(self.translation)


@dataclass(frozen=True)
class Connected:
    """A surface input fed by a texture: the texture (None when the image cannot be read: the
    fallback is used), the value to use without it, and where its st comes from."""

    texture: Texture | None
    fallback: tuple[float, ...]
    st: StSource


def _value(inp: UsdShade.Input | None, time, default):
    """An input's value, following connections to interface inputs (not to shader outputs)."""
    if not inp:
        return default
    attrs = inp.GetValueProducingAttributes()
    if attrs:
        attr = attrs[0]
        if UsdShade.Utils.GetType(attr.GetName()) == UsdShade.AttributeType.Output:
            return default
        value = attr.Get(time)
        return default if value is None else value
    value = inp.Get(time)
    return default if value is None else value


def source_output(inp: UsdShade.Input | None) -> tuple[UsdShade.Shader, str] | None:
    """The shader and output name that produce ``inp``'s value through connections, if any."""
    if not inp or not inp.HasConnectedSource():
        return None
    for attr in inp.GetValueProducingAttributes():
        name, kind = UsdShade.Utils.GetBaseNameAndType(attr.GetName())
        if kind == UsdShade.AttributeType.Output:
            return UsdShade.Shader(attr.GetPrim()), name
    return None


class TextureReader:
    """Reads the textures of a stage; images are decoded once per file, textures shared."""

    def __init__(self, ctx: ReadContext):
        self.ctx = ctx
        self.headers: dict[str, ImageHeader | None] = {}  # by resolved path
        self.pixels: dict[str, np.ndarray | None] = {}  # decoded, by resolved path
        self.textures: dict[tuple, Texture] = {}
        self.budget = TexelBudget()

    def connected(
        self,
        shader: UsdShade.Shader,
        name: str,
        factor: float = 1.0,
        signed: bool = False,
        scale_bias: tuple[tuple[float, ...], tuple[float, ...]] | None = None,
    ) -> Connected | None:
        """The texture feeding colour input ``name`` of ``shader`` (times ``factor``), or None
        when the input is not fed by a UsdUVTexture or a MaterialX image node. ``signed``: a
        normal map's vectors, not clipped at 0; ``scale_bias``: applied after the node's own
        (a MaterialX normalmap node's decoding)."""
        source = source_output(shader.GetInput(name))
        if source is None:
            return None
        tex_shader, output = source
        shader_id = tex_shader.GetShaderId()
        if shader_id == TEXTURE_SHADER_ID:
            return self._uv_texture(tex_shader, output, factor, signed)
        if shader_id and shader_id.startswith(MTLX_IMAGE_PREFIXES):
            return self._mtlx_image(tex_shader, factor, signed, scale_bias)
        return None

    def normal_map(self, shader: UsdShade.Shader, name: str) -> Connected | None:
        """The tangent-space normal map feeding input ``name``: a UsdUVTexture (its scale and
        bias decode it, as the UsdPreviewSurface spec has it), or a MaterialX ``normalmap`` node
        over an image (v = 2·texel − 1, its x and y times the node's ``scale``); None otherwise."""
        source = source_output(shader.GetInput(name))
        if source is None:
            return None
        node, _ = source
        if not (node.GetShaderId() or "").startswith(MTLX_NORMALMAP_PREFIX):
            return self.connected(shader, name, signed=True)
        time, path = self.ctx.time, str(node.GetPath())
        space = str(_value(node.GetInput("space"), time, "tangent"))
        if space != "tangent":
            self.ctx.unsupported["MaterialX normalmap nodes in object space (not applied)"].append(path)
            return None
        strength = np.resize(np.asarray(_value(node.GetInput("scale"), time, 1.0), dtype=np.float64), 2)
        if not np.all(np.isfinite(strength)):
            self.ctx.problem(node.GetPrim(), "inputs:scale", f"must be finite, got {strength.tolist()}")
            return None
        sx, sy = (float(c) for c in strength)
        return self.connected(node, "in", signed=True, scale_bias=((2 * sx, 2 * sy, 2.0), (-sx, -sy, -1.0)))

    def omni_texture(
        self, shader: UsdShade.Shader, name: str, factor: float = 1.0, signed: bool = False, scale_bias=None
    ) -> Connected | None:
        """An OmniPBR (MDL) material's texture: the asset input ``name`` on the shader itself
        (``diffuse_texture``, ``normalmap_texture``), its colour space from the attribute's
        colorSpace (sRGB; raw; auto, the default: sRGB for 8-bit files, as MDL's gamma auto), at
        the st primvar through ``texture_scale``, ``texture_rotate`` (degrees) and
        ``texture_translate`` (MDL's rotation_translation_scale: scaled, rotated, translated,
        UsdTransform2d's order); None when the input is not authored."""
        inp = shader.GetInput(name)
        if not inp or not inp.GetAttr().HasAuthoredValue():
            return None
        prim, time = shader.GetPrim(), self.ctx.time
        st = StSource(
            OMNI_UV_SET,
            scale=tuple(float(x) for x in _value(shader.GetInput("texture_scale"), time, (1.0, 1.0))),
            rotation_deg=float(_value(shader.GetInput("texture_rotate"), time, 0.0)),
            translation=tuple(float(x) for x in _value(shader.GetInput("texture_translate"), time, (0.0, 0.0))),
        )
        value = (0.0, 0.0, 1.0) if signed else (0.0, 0.0, 0.0)
        resolved = self._resolved(shader, value, name)
        if resolved is None:
            return Connected(None, value, st)
        header = self._header(resolved, prim)
        if header is None:
            return Connected(None, value, st)
        attr = inp.GetAttr()
        space = attr.GetColorSpace() if attr.HasColorSpace() else "auto"
        srgb = not signed and (space == "sRGB" or (space in ("auto", "") and header.eight_bit))
        scale, bias = np.ones(4), np.zeros(4)
        if scale_bias is not None:
            scale[:3], bias[:3] = scale_bias
        texture = self._texture(prim, resolved, header, srgb, None, scale, bias, factor, signed, ["repeat", "repeat"])
        return Connected(texture, value, st)

    def _uv_texture(self, tex_shader: UsdShade.Shader, output: str, factor: float, signed: bool) -> Connected:
        prim, time = tex_shader.GetPrim(), self.ctx.time
        fallback = np.asarray(_value(tex_shader.GetInput("fallback"), time, (0.0, 0.0, 0.0, 1.0)), dtype=np.float64)
        fallback = np.resize(fallback, 4)
        channel = CHANNELS.get(output)
        value = tuple(float(c) for c in (fallback[:3] if channel is None else np.repeat(fallback[channel], 3)))
        st = self._st(tex_shader)
        if output not in ("rgb", *CHANNELS):
            self.ctx.problem(
                prim, f"outputs:{output}", "is not an output of UsdUVTexture (rgb, r, g, b, a) a colour can use"
            )
            return Connected(None, value, st)
        resolved = self._resolved(tex_shader, value)
        if resolved is None:
            return Connected(None, value, st)
        header = self._header(resolved, prim)
        if header is None:
            return Connected(None, value, st)
        space = str(_value(tex_shader.GetInput("sourceColorSpace"), time, "auto"))
        if space not in ("auto", "raw", "sRGB"):
            self.ctx.problem(prim, "inputs:sourceColorSpace", f"must be auto, raw or sRGB, got {space!r}")
            space = "auto"
        srgb = space == "sRGB" or (space == "auto" and header.eight_bit)
        scale = np.resize(np.asarray(_value(tex_shader.GetInput("scale"), time, (1.0,) * 4), dtype=np.float64), 4)
        bias = np.resize(np.asarray(_value(tex_shader.GetInput("bias"), time, (0.0,) * 4), dtype=np.float64), 4)
        wraps = []
        for axis, attr in enumerate(("wrapS", "wrapT")):
            wrap = str(_value(tex_shader.GetInput(attr), time, "useMetadata"))
            if wrap == "useMetadata":
                # The file's own wrap mode, else black (the UsdUVTexture spec).
                wrap = header.wraps[axis] if header.wraps else "black"
            elif wrap not in WRAP_TOKENS:
                self.ctx.problem(
                    prim, f"inputs:{attr}", f"must be one of {', '.join(WRAP_TOKENS)}, useMetadata; got {wrap!r}"
                )
                wrap = "black"
            wraps.append(wrap)
        texture = self._texture(prim, resolved, header, srgb, channel, scale, bias, factor, signed, wraps)
        return Connected(texture, value, st)

    def _mtlx_image(self, node: UsdShade.Shader, factor: float, signed: bool, scale_bias) -> Connected:
        """A MaterialX ``image`` / ``tiledimage`` node (its id ND_image_<type>): ``file`` (its
        colour space from the attribute's colorSpace metadata: srgb_texture is sRGB, anything
        else linear), ``default`` where there is no image, u/v address modes, ``texcoord`` (a
        texcoord or geompropvalue node; unconnected: the first uv set, USD's st), and for
        tiledimage ``uvtiling`` / ``uvoffset``. A float image reads the red channel, as
        MaterialX does."""
        prim, time = node.GetPrim(), self.ctx.time
        shader_id = node.GetShaderId()
        kind = shader_id.rsplit("_", 1)[-1]
        width = {"float": 1, "color3": 3, "vector3": 3, "color4": 4, "vector4": 4, "vector2": 2}.get(kind, 3)
        default = np.resize(np.asarray(_value(node.GetInput("default"), time, (0.0,) * width), dtype=np.float64), 4)
        value = tuple(float(c) for c in (np.repeat(default[0], 3) if width == 1 else default[:3]))
        st = self._mtlx_st(node)
        resolved = self._resolved(node, value)
        if resolved is None:
            return Connected(None, value, st)
        header = self._header(resolved, prim)
        if header is None:
            return Connected(None, value, st)
        file_attr = node.GetInput("file").GetAttr()
        space = file_attr.GetColorSpace() if file_attr.HasColorSpace() else ""
        srgb = kind.startswith("color") and space == "srgb_texture"
        wraps = []
        for attr in ("uaddressmode", "vaddressmode"):
            mode = str(_value(node.GetInput(attr), time, "periodic"))
            if mode not in MTLX_ADDRESS_MODES:
                self.ctx.problem(
                    prim, f"inputs:{attr}", f"must be one of {', '.join(MTLX_ADDRESS_MODES)}; got {mode!r}"
                )
                mode = "periodic"
            wraps.append(MTLX_ADDRESS_MODES[mode])
        scale, bias = np.ones(4), np.zeros(4)
        if scale_bias is not None:
            scale[:3], bias[:3] = scale_bias
        channel = 0 if width == 1 else None
        texture = self._texture(prim, resolved, header, srgb, channel, scale, bias, factor, signed, wraps)
        return Connected(texture, value, st)

    def _mtlx_st(self, node: UsdShade.Shader) -> StSource:
        """Where a MaterialX image node's uvs come from: its ``texcoord`` (a texcoord node: the
        first uv set; a geompropvalue node: the primvar it names), through a tiledimage's
        ``uvtiling`` and ``uvoffset`` (uv · tiling − offset, MaterialX's tiledimage)."""
        time = self.ctx.time
        primvar = MTLX_FIRST_UV_SET
        source = source_output(node.GetInput("texcoord"))
        if source is not None:
            reader, _ = source
            reader_id = reader.GetShaderId() or ""
            if reader_id.startswith("ND_geompropvalue"):
                primvar = str(_value(reader.GetInput("geomprop"), time, "")) or MTLX_FIRST_UV_SET
            elif not reader_id.startswith("ND_texcoord"):
                self.ctx.unsupported["texture coordinates from other shaders (st (0, 0) used)"].append(
                    str(reader.GetPath())
                )
                return StSource(None)
        if not (node.GetShaderId() or "").startswith("ND_tiledimage"):
            return StSource(primvar)
        tiling = tuple(float(x) for x in _value(node.GetInput("uvtiling"), time, (1.0, 1.0)))
        offset = tuple(float(x) for x in _value(node.GetInput("uvoffset"), time, (0.0, 0.0)))
        return StSource(primvar, scale=tiling, translation=(-offset[0], -offset[1]))

    def _resolved(self, node: UsdShade.Shader, value, name: str = "file") -> str | None:
        """The resolved path of a texture node's ``file`` (input ``name``), or None after a
        warning (the node's fallback ``value`` is used)."""
        path = str(node.GetPath())
        asset = _value(node.GetInput(name), self.ctx.time, None)
        resolved = asset.resolvedPath if isinstance(asset, Sdf.AssetPath) else ""
        if resolved:
            return resolved
        if asset is None or (isinstance(asset, Sdf.AssetPath) and not asset.path):
            self.ctx.warn(f"{path}.inputs:{name}: not authored, so there is no image (the fallback {value} is used)")
        else:
            shown = asset.path if isinstance(asset, Sdf.AssetPath) else asset
            self.ctx.warn(f"{path}.inputs:{name}: cannot find the image {shown!r} (the fallback {value} is used)")
        return None

    def _texture(
        self, prim, resolved: str, header: ImageHeader, srgb, channel, scale, bias, factor, signed, wraps
    ) -> Texture | None:
        """The model's texture of an image and how it is decoded, built once per distinct
        decoding; None after a problem or warning (the fallback is used)."""
        path = str(prim.GetPath())
        key = (resolved, srgb, channel, tuple(scale), tuple(bias), factor, signed, *wraps)
        if key not in self.textures:
            try:
                self.budget.charge(header.texels, f"{resolved} ({header.width} x {header.height})")
            except TextureTooBig as e:
                self.ctx.problem(prim, "inputs:file", str(e))
                return None
            pixels = self._pixels(resolved, header, path)
            if pixels is None:
                return None
            image, negative, nonfinite = texels(pixels, srgb, channel, scale, bias, factor, resolved, signed)
            if nonfinite:
                self.ctx.problem(prim, "inputs:file", f"{resolved}: {nonfinite} texel values are not finite")
                return None
            if negative:
                self.ctx.warn(f"{path}: scale and bias give negative colours (clipped to 0)")
            self.textures[key] = Texture(image, wraps[0], wraps[1], source=path, file=resolved)
        return self.textures[key]

    def _st(self, tex_shader: UsdShade.Shader) -> StSource:
        source = source_output(tex_shader.GetInput("st"))
        if source is None:
            return StSource(None)
        shader, _ = source
        time = self.ctx.time
        transform = {}
        if shader.GetShaderId() == TRANSFORM_2D_ID:
            transform = {
                "scale": tuple(float(x) for x in _value(shader.GetInput("scale"), time, (1.0, 1.0))),
                "rotation_deg": float(_value(shader.GetInput("rotation"), time, 0.0)),
                "translation": tuple(float(x) for x in _value(shader.GetInput("translation"), time, (0.0, 0.0))),
            }
            source = source_output(shader.GetInput("in"))
            if source is None:
                return StSource(None, **transform)
            shader, _ = source
        if shader.GetShaderId() != PRIMVAR_READER_ID:
            self.ctx.unsupported["texture coordinates from other shaders (st (0, 0) used)"].append(
                str(shader.GetPath())
            )
            return StSource(None, **transform)
        varname = _value(shader.GetInput("varname"), time, "")
        return StSource(str(varname) or None, **transform)

    def _header(self, resolved: str, prim: Usd.Prim) -> ImageHeader | None:
        """The checked header of an image file, read once per file (texture_files); None when it
        cannot be a texture (after a warning: the fallback is used) or is too big (a problem)."""
        if resolved not in self.headers:
            path = str(prim.GetPath())
            header = None
            try:
                with local_file(resolved) as local:
                    header = read_header(local, resolved)
                    if local != resolved and self.budget.fits(header.texels):
                        # A .usdz-packaged image: decoded now, its copy is temporary (one over the
                        # budget is not: the charge names it).
                        self._pixels(resolved, header, path)
                        header = replace(header, path=resolved)
            except TextureRefused as e:
                self.ctx.warn(f"{path}.inputs:file: {e} (the fallback is used)")
            except TextureTooBig as e:
                self.ctx.problem(prim, "inputs:file", str(e))
            except OSError as e:
                self.ctx.warn(f"{path}.inputs:file: cannot read {resolved}: {e.strerror or e} (the fallback is used)")
            self.headers[resolved] = header
        return self.headers[resolved]

    def _pixels(self, resolved: str, header: ImageHeader, prim_path: str) -> np.ndarray | None:
        """The decoded pixels of a file, decoded once (in their stored precision); None after a
        warning when they cannot be decoded."""
        if resolved not in self.pixels:
            try:
                self.pixels[resolved] = decode(header, resolved)
            except TextureRefused as e:
                self.ctx.warn(f"{prim_path}.inputs:file: {e} (the fallback is used)")
                self.pixels[resolved] = None
        return self.pixels[resolved]


def corner_elements(
    interpolation: str, triangles: np.ndarray, fv: np.ndarray, face_of_tri: np.ndarray
) -> np.ndarray | None:
    """The primvar element of each triangle corner for an interpolation (None: unknown)."""
    if interpolation in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying):
        return triangles
    if interpolation == UsdGeom.Tokens.faceVarying:
        return fv
    if interpolation == UsdGeom.Tokens.uniform:
        return np.repeat(face_of_tri[:, None], 3, axis=1)
    if interpolation == UsdGeom.Tokens.constant:
        return np.zeros_like(fv)
    return None


def mesh_uvs(ctx: ReadContext, prim: Usd.Prim, st: StSource, counts: tuple[int, int, int], fv, triangles, face_of_tri):
    """(uvs (L, 2), uv_indices (M, 3)) of the mesh's st primvar ``st.primvar`` through
    ``st``'s transform; None (after a warning: the texture is not used) without a readable one."""
    path = str(prim.GetPath())
    if st.primvar is None:
        values, element = np.zeros((1, 2)), np.zeros_like(fv)
        return st.apply(values), element
    primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar(st.primvar)
    if not primvar or not primvar.HasAuthoredValue():
        ctx.unsupported["textured meshes without their st primvar (the fallback colour is used)"].append(
            f"{path} ({st.primvar})"
        )
        return None
    name = f"primvars:{st.primvar}"
    type_name = ctx.authored_type(primvar.GetAttr())
    if type_name not in UV_TYPES:
        ctx.problem(prim, name, f"has type {type_name}, expected texCoord2f[]")
        return None
    values = np.asarray(primvar.Get(ctx.time), dtype=np.float64).reshape(-1, 2)
    interpolation = primvar.GetInterpolation()
    n_points, n_corners, n_faces = counts
    expected = {
        UsdGeom.Tokens.vertex: n_points,
        UsdGeom.Tokens.varying: n_points,
        UsdGeom.Tokens.faceVarying: n_corners,
        UsdGeom.Tokens.uniform: n_faces,
        UsdGeom.Tokens.constant: 1,
    }.get(interpolation)
    element = corner_elements(interpolation, triangles, fv, face_of_tri)
    if expected is None or element is None:
        ctx.problem(prim, name, f"has unknown interpolation {interpolation!r}")
        return None
    indices = np.asarray(primvar.GetIndices(ctx.time), dtype=np.int64) if primvar.IsIndexed() else None
    n_elements = len(indices) if indices is not None else len(values)
    if n_elements != expected:
        what = "indices" if indices is not None else "values"
        ctx.problem(prim, name, f"has {n_elements} {what}, expected {expected} for {interpolation} interpolation")
        return None
    if indices is not None:
        if ((indices < 0) | (indices >= len(values))).any():
            ctx.problem(prim, f"{name}:indices", f"indices out of range [0, {len(values)})")
            return None
        element = indices[element]
    if not np.all(np.isfinite(values)):
        ctx.problem(prim, name, "values must be finite")
        return None
    return st.apply(values), element
