# SPDX-License-Identifier: Apache-2.0
"""A stage opened once and read at many times (``reader.OpenStage``: a Dask worker's kept stage)
whose values cannot change in time is read once; every later read at a time is the first one's
model, prim mapping and warnings, which is what reading the file anew at that time gives.

Why that holds. A read takes from the stage only
- attribute values at its time code (``Get(time)``, and through them transforms, visibility,
  material inputs, primvars): when no attribute of the stage might vary in time
  (``Usd.Attribute.ValueMightBeTimeVarying``, which USD guarantees false only when the value is
  the same at every time code, value clips and splines included), every numeric time reads the
  same values. The default time code reads default values, not held samples: default and
  numeric reads are kept apart;
- relationship targets, metadata and composition, which USD does not vary in time;
- PointInstancer transforms, which USD extrapolates from a positions (orientations) sample by the
  instancer's velocities (angular velocities, accelerations) to the time: an instancer that has
  any of them authored counts as varying;
- the files asset attributes name (textures): each is kept with its state (modification time,
  size, inode) and the stage is read again when one changes, appears or goes;
- the time itself, in the warning about which time is read (``reader._time_to_read``): each read
  makes that anew, outside this cache.
The layers the stage was composed from are not watched here: a changed layer makes a new stage
(``phongscene.usd.stage_reuse.open_stage``), and with it a new cache.

When something varies, and it is only lights' and gprims' own inputs (their attributes, their
ancestors' and descendants'), the others are read once and replayed (``read_parts``); when a
material, render setting, visibility or purpose varies (an attribute a material input is
connected to counts as the material's), the whole stage is read at each time. PointInstancers
are read at every time (their prototypes may be anywhere). The asset files of what does not
vary are watched in both cases."""

from __future__ import annotations

import os
from dataclasses import dataclass

from pxr import Sdf, Tf, Usd, UsdGeom

from .read_parts import EveryPart, PartsRecord, RecordParts, ReplayParts

# PointInstancer attributes that move instances between its positions' samples (USD extrapolates
# by them to the time asked): an instancer that authors one is read at every time.
_INSTANCE_MOTION = ("velocities", "accelerations", "angularVelocities")
_ASSET_TYPES = (Sdf.ValueTypeNames.Asset, Sdf.ValueTypeNames.AssetArray)
# Attributes that decide which prims a read traverses and draws.
_TRAVERSAL = ("visibility", "purpose")


@dataclass(frozen=True)
class KeptRead:
    """One read of a stage that does not vary in time, without the warning about its time."""

    scene: object  # phongscene.scene.Scene (frozen, its arrays read-only: shared by every read)
    warnings: tuple[str, ...]  # the reader's own warnings (USD's diagnostics are in usd_text)
    nodes: tuple[tuple[str, str], ...]
    usd_text: str  # what USD printed while the stage was read (each read makes warnings of it)
    assets: tuple[tuple[str, tuple | None], ...]  # (file as the reader opens it, its state)
    cameras: tuple[str, ...] = ()  # every camera prim of the stage (ReadResult.cameras)


class ReadCache:
    """The reads of one open stage at default and at numeric time codes (see the module)."""

    def __init__(self) -> None:
        self._surveyed = False
        self.invariant = False  # nothing in the stage may vary in time
        self.by_parts = False  # what varies is only lights' and gprims' own inputs (read_parts)
        self._varying: set[Sdf.Path] = set()  # prims with an attribute that may vary
        self._above_varying: set[Sdf.Path] = set()  # those and their ancestors
        self._asset_attributes: tuple[Usd.Attribute, ...] = ()  # those that do not vary
        self._kept: dict[bool, KeptRead] = {}  # time code is default -> its read
        self._parts: dict[bool, tuple[PartsRecord, tuple]] = {}  # ... -> (its parts, the assets' states)

    def survey(self, stage: Usd.Stage) -> None:
        """Decide, once per stage, what in it may vary in time (every attribute of every prim,
        instance proxies and abstract and inactive prims included), and collect its asset
        attributes that do not."""
        if self._surveyed:
            return
        self._surveyed = True
        assets, varying_attributes, sources = [], set(), set()
        by_parts = True
        try:
            for prim in Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate)):
                if prim.IsA(UsdGeom.PointInstancer) and any(
                    prim.GetAttribute(name).HasAuthoredValue() for name in _INSTANCE_MOTION
                ):
                    self._varying.add(prim.GetPath())
                # A GeomSubset is its mesh's (only the mesh reads it).
                imageable = bool(UsdGeom.Imageable(prim)) or prim.IsA(UsdGeom.Subset)
                for attr in prim.GetAttributes():
                    if attr.HasAuthoredConnections():
                        sources.update(attr.GetConnections())
                    if attr.ValueMightBeTimeVarying():
                        self._varying.add(prim.GetPath())
                        varying_attributes.add(attr.GetPath())
                        name = attr.GetName()
                        # What the traversal decides (which prims are drawn) and what is not a
                        # light's or a gprim's own (materials, shaders, render settings,
                        # collections) is not read by parts: the whole stage is read again.
                        if not imageable or name in _TRAVERSAL or name.startswith("collection:"):
                            by_parts = False
                    elif attr.GetTypeName() in _ASSET_TYPES and attr.HasAuthoredValue():
                        assets.append(attr)
        except Tf.ErrorException:
            return  # USD cannot say: read at every time (the reader reports what it cannot read)
        # A material input connected to an attribute that varies (on a light, say) varies too.
        by_parts = by_parts and not (sources & varying_attributes)
        self.invariant = not self._varying
        self.by_parts = by_parts and not self.invariant
        for path in self._varying:
            self._above_varying.update(path.GetAncestorsRange())
        self._asset_attributes = tuple(assets)

    def static_part(self, path: Sdf.Path) -> bool:
        """Whether nothing a light or gprim at ``path`` reads may vary: no attribute of it, of an
        ancestor (its transform, inherited primvars) or of a descendant (GeomSubsets)."""
        return path not in self._above_varying and not any(p in self._varying for p in path.GetAncestorsRange())

    def assets(self, code: Usd.TimeCode) -> tuple[tuple[str, tuple | None], ...] | None:
        """The files the stage's asset attributes that do not vary name at ``code``, with their
        states now; None when USD cannot resolve one."""
        files = set()
        try:
            for attr in self._asset_attributes:
                value = attr.Get(code)
                for asset in value if isinstance(value, Sdf.AssetPathArray) else (value,):
                    if isinstance(asset, Sdf.AssetPath) and (asset.resolvedPath or asset.path):
                        files.add(asset.resolvedPath or asset.path)  # as the reader opens it
        except Tf.ErrorException:
            return None
        return tuple((file, file_state(file)) for file in sorted(files))

    def replay(self, code: Usd.TimeCode) -> KeptRead | None:
        """The kept read for ``code``'s kind of time, if every file it read is as it was."""
        kept = self._kept.get(code.IsDefault())
        if kept is None or not _unchanged(kept.assets):
            return None
        return kept

    def keep(self, code: Usd.TimeCode, read: KeptRead) -> None:
        if self.invariant:
            self._kept[code.IsDefault()] = read

    def parts(self, code: Usd.TimeCode, assets) -> EveryPart | None:
        """How to read the parts at ``code``: replaying the kept ones (their files unchanged),
        or recording them (the first read, or one after a file changed); None: not by parts."""
        if not self.by_parts or assets is None:
            return None
        kept = self._parts.get(code.IsDefault())
        if kept is not None and _unchanged(kept[1]):
            return ReplayParts(kept[0])
        return RecordParts(self.static_part)

    def keep_parts(self, code: Usd.TimeCode, parts: RecordParts, assets) -> None:
        self._parts[code.IsDefault()] = (parts.record(), assets)


def _unchanged(assets) -> bool:
    return all(file_state(file) == state for file, state in assets)


def file_state(file: str) -> tuple | None:
    """(modification time, size, inode) of ``file``, None when it is not there: an edited,
    replaced or removed file has another."""
    try:
        st = os.stat(file)
    except OSError:
        return None
    return (st.st_mtime_ns, st.st_size, st.st_ino)
