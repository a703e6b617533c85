# SPDX-License-Identifier: Apache-2.0
"""A stage opened once and read at many times, part by part: the lights and gprims whose inputs
cannot change in time (``read_cache.ReadCache.static_part``) are read at the first time, and
each later read replays what reading them did; only the others are read again.

What a part's read does is appends: to the context's problems, warnings, prim mapping and
lists of unsupported things, and to the model's lists (lights, ambient lights, spheres,
meshes). A part is recorded as the tails it appended (``Delta``) and replayed by appending them
again, in the traversal's order, among the parts read anew, so every list is as a read of the
file at that time makes it. The traversal itself (visibility, purpose, transforms), the render
settings, the camera and every check of the whole model run at every read.

Materials are shared between parts: a material is read at its first use in a read (its
warnings come there) and reused after. The stage's materials do not vary when parts are kept
(``ReadCache.survey``), so each is read once, recorded with its own appends, and handed out at
later reads; its appends come at its first use, which must be the same part as in the first
read: when a part read anew asks for a material first that another part asked for first before
(a GeomSubset whose indices vary from none to some), or a key of the unsupported lists a
replayed part extended does not exist yet, the read is made anew in full (``Redo``)."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass

from pxr import Usd

from .context import ReadContext
from .materials import MaterialReader


class Redo(Exception):
    """The replay cannot give what a read of the file gives: read the stage in full."""


@dataclass(frozen=True)
class Delta:
    """What one read appended: to each list (in ``_Lists`` order) and to each unsupported list."""

    tails: tuple[tuple, ...]
    unsupported: tuple[tuple[str, tuple], ...]  # (kind, its new entries), in the dict's order
    existing: frozenset[str]  # the kinds that existed before (their order was set by others)


@dataclass(frozen=True)
class Part:
    delta: Delta
    materials: tuple[str, ...]  # the material prims it asked for, in order


@dataclass(frozen=True)
class PartsRecord:
    """The first read's kept parts and every material it read."""

    parts: dict[str, Part]
    materials: dict[str, tuple[object, Delta]]  # material path -> (PhongMaterial, its appends)
    first_user: dict[str, str]  # material path -> the part that asked for it first
    st_of: dict  # MaterialReader.st_of: where each textured material's st comes from


class _Lists:
    """The lists a part's read appends to."""

    def __init__(self, ctx: ReadContext, outputs: tuple[list, ...]):
        self.ctx = ctx
        self.lists = (ctx.problems, ctx.warnings, ctx.nodes, *outputs)

    def mark(self):
        return tuple(len(x) for x in self.lists), {k: len(v) for k, v in self.ctx.unsupported.items()}

    def since(self, mark) -> Delta:
        lengths, kinds = mark
        tails = tuple(tuple(x[n:]) for x, n in zip(self.lists, lengths))
        unsupported = tuple(
            (k, tuple(v[kinds.get(k, 0) :])) for k, v in self.ctx.unsupported.items() if len(v) > kinds.get(k, 0)
        )
        return Delta(tails, unsupported, frozenset(k for k, _ in unsupported if k in kinds))

    def append(self, delta: Delta) -> None:
        if any(k not in self.ctx.unsupported for k in delta.existing):
            raise Redo()
        for x, tail in zip(self.lists, delta.tails):
            x.extend(tail)
        for kind, tail in delta.unsupported:
            self.ctx.unsupported[kind].extend(tail)


class EveryPart:
    """Read every part (a read of the file, or of a stage whose materials or traversal vary)."""

    def materials(self, ctx: ReadContext) -> MaterialReader:
        return MaterialReader(ctx)

    def start(self, ctx: ReadContext, outputs: tuple[list, ...]) -> None:
        pass

    def read(self, prim: Usd.Prim, read: Callable[[], None], keep: bool = True) -> None:
        read()


class RecordParts(EveryPart):
    """Read every part and record those ``static(path)`` says cannot change in time."""

    def __init__(self, static: Callable[[object], bool]):
        self.static = static
        self.parts: dict[str, Part] = {}
        self.recorded: dict[str, tuple[object, Delta]] = {}
        self.first_user: dict[str, str] = {}
        self.asked: dict[str, list[str]] = defaultdict(list)
        self.current = ""
        self.reader: MaterialReader | None = None

    def materials(self, ctx: ReadContext) -> MaterialReader:
        self.reader = _RecordingMaterials(ctx, self)
        return self.reader

    def start(self, ctx: ReadContext, outputs: tuple[list, ...]) -> None:
        self.lists = _Lists(ctx, outputs)

    def read(self, prim: Usd.Prim, read: Callable[[], None], keep: bool = True) -> None:
        path = prim.GetPath()
        self.current = key = str(path)
        mark = self.lists.mark()
        read()
        self.current = ""
        if keep and self.static(path):
            self.parts[key] = Part(self.lists.since(mark), tuple(self.asked[key]))

    def record(self) -> PartsRecord:
        return PartsRecord(self.parts, self.recorded, self.first_user, dict(self.reader.st_of))


class _RecordingMaterials(MaterialReader):
    def __init__(self, ctx: ReadContext, parts: RecordParts):
        super().__init__(ctx)
        self.parts = parts

    def for_material(self, material):
        parts, key = self.parts, str(material.GetPath())
        parts.asked[parts.current].append(key)
        if key in self.cache:
            return self.cache[key]
        mark = parts.lists.mark()
        found = super().for_material(material)
        parts.recorded[key] = (found, parts.lists.since(mark))
        parts.first_user[key] = parts.current
        return found


class ReplayParts(EveryPart):
    """Replay the recorded parts, read the others (see the module)."""

    def __init__(self, record: PartsRecord):
        self.record = record
        self.used: set[str] = set()  # materials asked for so far in this read
        self.current = ""

    def materials(self, ctx: ReadContext) -> MaterialReader:
        return _ReplayedMaterials(ctx, self)

    def start(self, ctx: ReadContext, outputs: tuple[list, ...]) -> None:
        self.lists = _Lists(ctx, outputs)

    def read(self, prim: Usd.Prim, read: Callable[[], None], keep: bool = True) -> None:
        key = str(prim.GetPath())
        part = self.record.parts.get(key)
        if part is None:
            self.current = key
            read()
            self.current = ""
            return
        if any(m not in self.used and self.record.first_user[m] != key for m in part.materials):
            raise Redo()  # its first use of a material was another part's
        self.lists.append(part.delta)
        self.used.update(part.materials)

    def material(self, key: str):
        found = self.record.materials.get(key)
        if found is None:
            raise Redo()  # not read at the first time
        if key not in self.used:
            if self.record.first_user[key] != self.current:
                raise Redo()
            self.lists.append(found[1])
            self.used.add(key)
        return found[0]


class _ReplayedMaterials(MaterialReader):
    def __init__(self, ctx: ReadContext, parts: ReplayParts):
        super().__init__(ctx)
        self.parts = parts
        self.st_of.update(parts.record.st_of)

    def for_material(self, material):
        return self.parts.material(str(material.GetPath()))
