# SPDX-License-Identifier: Apache-2.0
"""Every layer a stage would compose, checked before USD composes it: a sublayer, reference or
payload that names a FIFO (or a device) blocks USD's reader forever, so each one must be a
regular file (or a file inside a package that is one) before ``Usd.Stage.Open`` reads it.

Each layer file's size is announced to the memory model before it is read (the sandbox's limit
grows by what the file may take). ``preflight`` opens the layers itself (``Sdf.Layer.FindOrOpen``), and the caller keeps them
alive while it opens the stage, so USD finds them in its layer registry and reads nothing twice.
A dependency that is missing or does not parse is left to USD's own composition errors (the
reader warns about them and draws the rest)."""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator

from pxr import Ar, Sdf, Tf

from ..errors import Problem, SceneError
from ..memory_model import announce, layer_bytes
from .materialx_documents import MaterialXDocumentError, as_layer, is_materialx_document, repoint


def not_regular(path: str) -> str | None:
    """Why reading ``path`` could block or is not a file read (a FIFO, a device, a folder);
    None for a regular file, or a path that does not exist (the reader reports that)."""
    if Ar.IsPackageRelativePath(path):  # pkg.usdz[inner.usda]: the package is the file read
        path = Ar.SplitPackageRelativePathOuter(path)[0]
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None
    if stat.S_ISREG(mode):
        return None
    kind = "a FIFO" if stat.S_ISFIFO(mode) else "a folder" if stat.S_ISDIR(mode) else "a device or socket"
    return f"is {kind}, not a regular file (reading it could block forever)"


def preflight(path: str) -> list[Sdf.Layer]:
    """Open the root layer ``path`` and every layer it depends on (sublayers, references,
    payloads, also inside variants, recursively) after checking each is a regular file. Returns
    the open layers (keep them while opening the stage).

    The specs are walked here, iteratively: USD's ``GetCompositionAssetDependencies`` recurses
    once per nesting level and overflows the C stack (a segfault) at ~30 000 levels.

    Raises:
        SceneError: a dependency is a FIFO, device or folder, naming the layer that names it,
            the prim and the arc (``subLayers``, ``references``, ``payload``).
    """
    resolver = Ar.GetResolver()
    opened: list[Sdf.Layer] = []
    seen: set[str] = set()
    pending = [path]
    announced: set[str] = set()
    while pending:
        next_path = pending.pop()
        _announce_file(next_path, announced)
        layer = _open_layer(next_path)
        if layer is None or layer.identifier in seen:
            continue
        seen.add(layer.identifier)
        opened.append(layer)
        _check_time_rates(layer)
        for dependency, spec, arc in _dependencies(layer):
            anchored = Sdf.ComputeAssetPathRelativeToLayer(layer, dependency)
            resolved = str(resolver.Resolve(anchored)) or anchored
            why = not_regular(resolved)
            if why is not None:
                raise SceneError(
                    Problem(
                        f"@{dependency}@ ({resolved}) {why}",
                        prim=str(spec.path) if spec else "",
                        attribute=arc,
                        file=layer.realPath or layer.identifier,
                    )
                )
            if spec is not None and is_materialx_document(resolved) and os.path.isfile(resolved):
                translated = _materialx_layer(resolved, spec, arc)
                if translated is not None:
                    repoint(spec, arc, dependency, translated)
                    opened.append(translated)
                continue
            pending.append(resolved)
    return opened


def _materialx_layer(path: str, spec: Sdf.PrimSpec, arc: str) -> Sdf.Layer | None:
    """The in-memory USD layer of a referenced MaterialX document (materialx_documents), or None
    after a warning (USD's own error for the arc follows: the rest of the stage is drawn)."""
    try:
        return as_layer(path)
    except MaterialXDocumentError as e:
        Tf.Warn(f"{spec.path}.{arc}: cannot read the MaterialX document {path}: {e}")
        return None


def _check_time_rates(layer: Sdf.Layer) -> None:
    """A layer's ``timeCodesPerSecond`` and ``framesPerSecond`` are positive and finite: USD scales
    a sublayer's or reference's time samples by the ratio of the rates, and at a rate of 0 its
    time-sample queries never return (usd-core 26.11: ``GetNumTimeSamples`` spins at full CPU on
    usd-wg's ``timeCodesPerSecond_0.usda``). Raises SceneError naming the layer and the field."""
    for field, authored in (
        ("timeCodesPerSecond", layer.HasTimeCodesPerSecond),
        ("framesPerSecond", layer.HasFramesPerSecond),
    ):
        if not authored():
            continue
        value = getattr(layer, field)
        if not (0.0 < value < float("inf")):
            raise SceneError(
                Problem(
                    f"must be a positive, finite number of time codes (frames) per second, not {value!r}",
                    attribute=field,
                    file=layer.realPath or layer.identifier,
                )
            )


def _announce_file(path: str, announced: set[str]) -> None:
    """Tell the memory model (``phongscene.memory_model``) the file a layer is about to be read
    from, once per file (a package's layers are read from one file)."""
    if Ar.IsPackageRelativePath(path):
        path = Ar.SplitPackageRelativePathOuter(path)[0]
    try:
        key, size = os.path.realpath(path), os.path.getsize(path)
    except OSError:
        return  # missing: USD's composition errors say so
    if key not in announced:
        announced.add(key)
        announce(layer_bytes(size), path)


def _open_layer(path: str) -> Sdf.Layer | None:
    try:
        return Sdf.Layer.FindOrOpen(path)
    except Tf.ErrorException:  # missing or corrupt: USD's composition errors say so later
        return None


def _dependencies(layer: Sdf.Layer) -> Iterator[tuple[str, Sdf.PrimSpec | None, str]]:
    """(asset path, prim spec or None for the layer itself, arc) of every external composition
    arc in ``layer``: its sublayers, and each prim's (and variant's) references and payloads."""
    for sublayer in layer.subLayerPaths:
        yield sublayer, None, "subLayers"
    stack = list(layer.rootPrims)
    while stack:
        spec = stack.pop()
        for arc, items in (("references", spec.referenceList), ("payload", spec.payloadList)):
            for item in items.GetAddedOrExplicitItems():
                if item.assetPath:  # an internal reference (</Prim>) names no file
                    yield item.assetPath, spec, arc
        stack.extend(spec.nameChildren)
        for variant_set in spec.variantSets.values():
            stack.extend(variant.primSpec for variant in variant_set.variants.values())
