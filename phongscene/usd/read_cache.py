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
(``phongscene.workers.open_stage``), and with it a new cache.

What varies is not cached at all (the whole stage is read at each time): reading only the
time-varying prims again is not built."""

from __future__ import annotations

import os
from dataclasses import dataclass

from pxr import Sdf, Tf, Usd, UsdGeom

# PointInstancer attributes that move instances between its positions' samples (USD extrapolates
# by them to the time asked): an instancer that authors one is read at every time.
_INSTANCE_MOTION = ("velocities", "accelerations", "angularVelocities")
_ASSET_TYPES = (Sdf.ValueTypeNames.Asset, Sdf.ValueTypeNames.AssetArray)


@dataclass(frozen=True)
class KeptRead:
    """One read of a stage that does not vary in time, without the warning about its time."""

    scene: object  # phongscene.scene.Scene (frozen, its arrays read-only: shared by every read)
    warnings: tuple[str, ...]  # the reader's own warnings (USD's diagnostics are in usd_text)
    nodes: tuple[tuple[str, str], ...]
    usd_text: str  # what USD printed while the stage was read (each read makes warnings of it)
    assets: tuple[tuple[str, tuple | None], ...]  # (file as the reader opens it, its state)


class ReadCache:
    """The reads of one open stage at default and at numeric time codes (see the module)."""

    def __init__(self) -> None:
        self._asset_attributes: tuple[Usd.Attribute, ...] | None = None  # None: varies, or not surveyed
        self._surveyed = False
        self._kept: dict[bool, KeptRead] = {}  # time code is default -> its read

    def survey(self, stage: Usd.Stage) -> None:
        """Decide, once per stage, whether anything in it may vary in time (every attribute of
        every prim, instance proxies and abstract and inactive prims included), and collect its
        asset attributes."""
        if self._surveyed:
            return
        self._surveyed = True
        assets = []
        try:
            for prim in Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate)):
                if prim.IsA(UsdGeom.PointInstancer) and any(
                    prim.GetAttribute(name).HasAuthoredValue() for name in _INSTANCE_MOTION
                ):
                    return
                for attr in prim.GetAttributes():
                    if attr.ValueMightBeTimeVarying():
                        return
                    if attr.GetTypeName() in _ASSET_TYPES and attr.HasAuthoredValue():
                        assets.append(attr)
        except Tf.ErrorException:
            return  # USD cannot say: read at every time (the reader reports what it cannot read)
        self._asset_attributes = tuple(assets)

    def assets(self, code: Usd.TimeCode) -> tuple[tuple[str, tuple | None], ...] | None:
        """The files the stage's asset attributes name at ``code``, with their states now; None
        when the stage varies in time (or was not surveyed), or USD cannot resolve one."""
        if self._asset_attributes is None:
            return None
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
        if kept is None or any(file_state(file) != state for file, state in kept.assets):
            return None
        return kept

    def keep(self, code: Usd.TimeCode, read: KeptRead) -> None:
        if self._asset_attributes is not None:
            self._kept[code.IsDefault()] = read


def file_state(file: str) -> tuple | None:
    """(modification time, size, inode) of ``file``, None when it is not there: an edited,
    replaced or removed file has another."""
    try:
        st = os.stat(file)
    except OSError:
        return None
    return (st.st_mtime_ns, st.st_size, st.st_ino)
