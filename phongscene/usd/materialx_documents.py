# SPDX-License-Identifier: Apache-2.0
"""MaterialX documents (``.mtlx``) that a USD layer references, read without usd-core's MaterialX
file-format plug-in: the usd-core wheel has none, and USD then refuses the reference ("Cannot
determine file format"), so OpenChessSet's pieces had no materials at all.

Each document is read with the ``MaterialX`` package (its standard data libraries give every node
its definition) and written, in memory, as the USD prims usdMtlx makes of it: one
``UsdShade.Material`` per ``surfacematerial`` under ``/MaterialX/Materials``, its surface shader
(``outputs:mtlx:surface``) and every node upstream of it as ``UsdShade.Shader`` prims inside the
material, ``info:id`` the node definition's name (``ND_standard_surface_surfaceshader``,
``ND_image_color3``, ``ND_normalmap_float`` ...), node graphs flattened (a connection through a
graph's output goes to the node behind it). File names are made absolute (against the document,
with its ``fileprefix``es) and keep their colour space as the attribute's ``colorSpace``. The
reader then reads these prims as it reads MaterialX written into USD (``pbr_networks``,
``textures``).

``repoint`` points a layer's reference (or payload) at that in-memory layer: the user's files are
not touched, only the layer as this process holds it."""

from __future__ import annotations

import os

from pxr import Sdf, Usd, UsdShade

# MaterialX value types → USD's, for the inputs the nodes carry.
_SDF_TYPES = {
    "float": Sdf.ValueTypeNames.Float,
    "integer": Sdf.ValueTypeNames.Int,
    "boolean": Sdf.ValueTypeNames.Bool,
    "color3": Sdf.ValueTypeNames.Color3f,
    "color4": Sdf.ValueTypeNames.Color4f,
    "vector2": Sdf.ValueTypeNames.Float2,
    "vector3": Sdf.ValueTypeNames.Float3,
    "vector4": Sdf.ValueTypeNames.Float4,
    "string": Sdf.ValueTypeNames.String,
    "filename": Sdf.ValueTypeNames.Asset,
    "surfaceshader": Sdf.ValueTypeNames.Token,
}
MATERIALS_SCOPE = "/MaterialX/Materials"


class MaterialXDocumentError(Exception):
    """A .mtlx file that the MaterialX package cannot read (the message says why)."""


def is_materialx_document(path: str) -> bool:
    return path.lower().endswith(".mtlx")


def _libraries():
    """The MaterialX standard data libraries (node definitions), loaded once."""
    global _LIBRARY
    if _LIBRARY is None:
        import MaterialX as mx

        library = mx.createDocument()
        mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), library)
        _LIBRARY = library
    return _LIBRARY


_LIBRARY = None


def is_node_definition(shader_id: str) -> bool:
    """Whether ``shader_id`` names a node definition of MaterialX's standard libraries (such ids
    start with ND_; the libraries are loaded only for those)."""
    return shader_id.startswith("ND_") and _libraries().getNodeDef(shader_id) is not None


def as_layer(path: str) -> Sdf.Layer:
    """The USD prims of the MaterialX document at ``path``, in an anonymous layer.

    Raises:
        MaterialXDocumentError: the document cannot be read (not XML, not MaterialX).
    """
    import MaterialX as mx

    document = mx.createDocument()
    try:
        mx.readFromXmlFile(document, path)
    except Exception as e:  # MaterialX raises its own ExceptionParseError, ExceptionFileMissing ...
        raise MaterialXDocumentError(str(e) or type(e).__name__) from None
    document.importLibrary(_libraries())
    layer = Sdf.Layer.CreateAnonymous(os.path.basename(path) + ".usda")
    stage = Usd.Stage.Open(layer)
    stage.DefinePrim(MATERIALS_SCOPE.rsplit("/", 1)[0], "Scope")
    stage.DefinePrim(MATERIALS_SCOPE, "Scope")
    folder = os.path.dirname(os.path.abspath(path))
    for material_node in document.getMaterialNodes():
        material_path = f"{MATERIALS_SCOPE}/{_prim_name(material_node.getName())}"
        material = UsdShade.Material.Define(stage, material_path)
        written: dict[str, UsdShade.Shader] = {}
        for shader_node in mx.getShaderNodes(material_node):
            if shader_node.getType() != "surfaceshader":
                continue
            shader = _write_node(stage, material_path, shader_node, written, folder)
            material.CreateSurfaceOutput("mtlx").ConnectToSource(shader.ConnectableAPI(), "out")
    return layer


def _prim_name(name: str) -> str:
    valid = "".join(c if c.isalnum() or c == "_" else "_" for c in name)
    return valid if valid and not valid[0].isdigit() else "_" + valid


def _write_node(stage, material_path: str, node, written: dict, folder: str) -> UsdShade.Shader:
    """The Shader prim of MaterialX ``node`` inside the material, with its upstream nodes."""
    key = node.getNamePath()
    if key in written:
        return written[key]
    shader = UsdShade.Shader.Define(stage, f"{material_path}/{_prim_name(key.replace('/', '_'))}")
    written[key] = shader
    definition = node.getNodeDef()
    if definition is not None:
        shader.SetShaderId(definition.getName())
    shader.CreateOutput("out", _SDF_TYPES.get(node.getType(), Sdf.ValueTypeNames.Token))
    for inp in node.getInputs():
        sdf_type = _SDF_TYPES.get(inp.getType())
        if sdf_type is None:
            continue
        usd_input = shader.CreateInput(inp.getName(), sdf_type)
        upstream = inp.getConnectedNode()
        if upstream is not None:
            source = _write_node(stage, material_path, upstream, written, folder)
            usd_input.ConnectToSource(source.ConnectableAPI(), "out")
            continue
        interface = inp.getInterfaceInput() if inp.hasInterfaceName() else None
        value_element = interface if interface is not None else inp
        if not value_element.getValueString():
            continue
        if inp.getType() == "filename":
            name = value_element.getResolvedValueString()
            usd_input.Set(Sdf.AssetPath(name if os.path.isabs(name) else os.path.join(folder, name)))
            space = value_element.getActiveColorSpace()
            if space:
                usd_input.GetAttr().SetColorSpace(space)
            continue
        value = value_element.getValue()
        usd_input.Set(tuple(value.asTuple()) if hasattr(value, "asTuple") else value)
    return shader


def repoint(spec: Sdf.PrimSpec, arc: str, asset_path: str, layer: Sdf.Layer) -> None:
    """Point ``spec``'s reference (``arc`` "references") or payload at ``asset_path`` to ``layer``
    instead (the same target prim and layer offset)."""
    proxy = spec.referenceList if arc == "references" else spec.payloadList
    for item in list(proxy.GetAddedOrExplicitItems()):
        if item.assetPath != asset_path:
            continue
        if arc == "references":
            new = Sdf.Reference(layer.identifier, item.primPath, item.layerOffset, item.customData)
        else:
            new = Sdf.Payload(layer.identifier, item.primPath, item.layerOffset)
        proxy.ReplaceItemEdits(item, new)
