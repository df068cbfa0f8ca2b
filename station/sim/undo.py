"""Undo and redo of whole strokes and tool dabs under a live simulation (issue 14, item 7).

The paint goes on moving after a stroke, so undo cannot just paste an old picture back:
it restores the canvas *as it would be now had the stroke never been made*. It does so by
checkpoints and deterministic replay. Before the first record of every undoable unit the
history keeps a checkpoint: the canvas state (pigment planes of the used slots only) and a
deep copy of the player (brush, reservoir, pending stamps, tool settings, clocks). Undo of
a unit restores the checkpoint taken before it and replays every later record, without the
unit's, through the same player, up to the step the session had reached; the later units'
checkpoints are taken afresh on the way. Replay is the session player's own, so the result
is bit-identical (CPU backends) to a session in which the stroke was never made (tested).
Redo puts the unit's records back where they were and replays the same way; a new unit
clears the redo stack.

Units: a pen stroke (a device's touching samples up to and including its lift, whatever
the tool in hand: brush, masking fluid, eraser, tissue) or a one-dab tool command
(``tissue``/``eraser``/``mask`` with ``x``/``y``). Other records (hovering samples,
``brush``, ``wait``, ``profile`` ...) are never undone; they stay in place and replay.

Bounded memory: at most ``limit`` units (default :data:`DEFAULT_LIMIT` = 20) and at most
``budget`` bytes of checkpoints (default :data:`DEFAULT_BUDGET` = 512 MiB) are kept,
undo and redo stacks together; the oldest checkpoint goes first and its unit can no
longer be undone. A checkpoint holds ``(10 + 3 S) H W + 3 H W`` float32 values (S pigments
in the layer): 44 MB for 800x600 with 3 pigments, so about 11 strokes fit the default
budget there; a 256x192 canvas keeps all 20. The records replayed after a checkpoint are
kept too, at most ``max_records`` of them (default :data:`DEFAULT_MAX_RECORDS` = 50,000:
about 4 minutes of one pen at 200 Hz, some 30 MB of Python objects): beyond it the oldest
units are let go until a quarter of the cap is free, and records nothing could replay any
more are forgotten. Under a bus flood (one endless stroke of touching samples) this is
what keeps the sim's memory flat: the stroke stops being undoable, and says so. Every
unit let go is counted by why (``limit``, ``budget``, ``records``) in
:meth:`UndoHistory.status` and logged (at most one line per 10 s, with the counts); an
``undo`` with nothing left names the cap that let the older steps go (:attr:`last`).

API (the kiosk's undo button): ``hist = UndoHistory(player)`` attaches itself to the
player (``player.history``); from then on every record the player applies is recorded;
``hist.can_undo()`` / ``hist.can_redo()`` say whether the buttons are live,
``hist.undo()`` / ``hist.redo()`` act (``True`` when something was undone/redone) and
:meth:`UndoHistory.status` gives depth, limit and bytes for a status line. The
session-log commands ``undo`` and ``redo`` call the same methods, so a logged session
replays its undos exactly.
"""

from __future__ import annotations

import copy
import logging
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from station.canvas.state import ARRAY_FIELDS, STEP_FIELDS, CanvasState
from station.events import Command, PenSample, Tool

if TYPE_CHECKING:
    from station.sim.player import SessionPlayer

log = logging.getLogger(__name__)

DEFAULT_LIMIT = 20
DEFAULT_BUDGET = 512 << 20
DEFAULT_MAX_RECORDS = 50_000
DROP_LOG_S = 10.0  # at most one line per this many seconds about units let go
DAB_COMMANDS = frozenset({"tissue", "eraser", "mask"})
_SHARED = ("backend", "history", "pigments")  # player attributes a checkpoint does not copy
_STACKS = ("p", "q", "removed_p")
#: The arrays only a command or a tool's dab writes (never a step, never a brush sample:
#: :data:`~station.canvas.state.STEP_FIELDS`): the paper, the mask, the blocking, the dried
#: layers.  Checkpoints with no such write between them hold one copy of them.
STEADY_FIELDS = tuple(n for n in ARRAY_FIELDS if n not in STEP_FIELDS)
#: Commands that write no steady array (a brush swap, a wait: their only canvas writes
#: are a step's).
STEADY_KEEPING_COMMANDS = frozenset({"brush", "wait"})

Record = PenSample | Command


@dataclass
class Checkpoint:
    """The canvas and the player just before a unit's first record."""

    state: CanvasState  # pigment stacks cut to the used slots
    n_slots: int
    player: dict[str, Any]
    nbytes: int
    #: the steady arrays' version (:attr:`UndoHistory.epoch`): checkpoints of one epoch
    #: hold the same steady arrays, counted once (:meth:`UndoHistory.held_bytes`)
    epoch: int = -1
    steady_bytes: int = 0  # of ``nbytes``, the steady arrays' (:data:`STEADY_FIELDS`)


@dataclass
class Unit:
    """One undoable stroke or dab: its records' ids and the checkpoint before it."""

    uid: int
    checkpoint: Checkpoint | None
    records: list[int] = field(default_factory=list)  # ids into UndoHistory._recs


def _pack(state: CanvasState) -> tuple[CanvasState, int]:
    ns = state.n_slots
    used = max(len(state.slots), 1)
    for name in _STACKS:
        setattr(state, name, np.ascontiguousarray(getattr(state, name)[:used]))
    return state, ns


def _unpack(cp: Checkpoint) -> CanvasState:
    st = cp.state.copy()
    for name in _STACKS:
        a = getattr(st, name)
        full = np.zeros((cp.n_slots, *a.shape[1:]), np.float32)
        full[: a.shape[0]] = a
        setattr(st, name, full)
    return st


def _state_bytes(st: CanvasState) -> int:
    return sum(v.nbytes for v in vars(st).values() if isinstance(v, np.ndarray))


def steady_bytes(st: CanvasState) -> int:
    """Bytes of the steady arrays (:data:`STEADY_FIELDS`) of ``st``."""
    return sum(int(getattr(st, n).nbytes) for n in STEADY_FIELDS)


class UndoHistory:
    """Undo/redo for one :class:`SessionPlayer` (see the module docstring)."""

    def __init__(self, player: SessionPlayer, limit: int = DEFAULT_LIMIT,
                 budget: int = DEFAULT_BUDGET, max_records: int = DEFAULT_MAX_RECORDS) -> None:
        if limit < 1 or budget < 1 or max_records < 4:
            raise ValueError("undo limit, budget and record cap must be positive")
        self.player = player
        self.limit = int(limit)
        self.budget = int(budget)
        self.max_records = int(max_records)
        self.dropped: dict[str, int] = {"limit": 0, "budget": 0, "records": 0}
        self.forgotten = 0  # records let go once no undo or redo could replay them
        self.last = ""  # what the last undo/redo did, or why it did nothing
        self._drop_logged = -DROP_LOG_S
        self._recs: dict[int, Record] = {}
        self._order: list[int] = []  # record ids in session order (undone units left out)
        self._unit_of: dict[int, int] = {}  # record id -> unit id
        self._units: dict[int, Unit] = {}
        self._done: list[int] = []  # undoable unit ids, oldest first
        self._redo: list[tuple[Unit, list[int]]] = []  # (unit, its record positions)
        self._open: dict[str, int] = {}  # device -> unit id of its stroke in progress
        self._next = 0
        self._uids = 0
        self.replaying = False
        # the steady arrays' version: a new one after every record that may write them
        # (a function of the records alone, so a replay of the log counts the bytes held
        # as the live session did, and lets the same units go)
        self.epoch = 0
        self._epochs = 0  # versions handed out (never one twice)
        self._newest: Checkpoint | None = None  # the last checkpoint taken
        self.undone = 0
        self.redone = 0
        self.replayed_steps = 0
        player.history = self

    # -- recording -----------------------------------------------------------------
    def before(self, rec: Record) -> None:
        """Called by the player just before it applies ``rec``."""
        try:
            self._record(rec)
        finally:
            if self._writes_steady(rec):  # after the checkpoint taken before rec
                self.new_epoch()

    def _writes_steady(self, rec: Record) -> bool:
        """Whether applying ``rec`` may write a steady array: a command other than a brush
        swap or a wait; a pen sample with a tool in hand, the eraser, or the brush while
        a diffusion controller writes the blocking."""
        if isinstance(rec, Command):
            return rec.cmd not in STEADY_KEEPING_COMMANDS
        p = self.player
        return p.tool is not None or rec.tool is Tool.ERASER or p.controller is not None

    def new_epoch(self) -> None:
        """The steady arrays may change: later checkpoints share none with earlier ones."""
        self._epochs += 1
        self.epoch = self._epochs

    def _record(self, rec: Record) -> None:
        if self.replaying or (isinstance(rec, Command) and rec.cmd in ("undo", "redo")):
            return
        uid = self._unit_for(rec)
        rid = self._next
        self._next += 1
        self._recs[rid] = rec
        self._order.append(rid)
        if uid is not None and self._units[uid].checkpoint is not None:
            self._unit_of[rid] = uid
            self._units[uid].records.append(rid)
        if len(self._recs) > self.max_records:
            self._cap_records()

    def _unit_for(self, rec: Record) -> int | None:
        if isinstance(rec, PenSample):
            uid = self._open.get(rec.device)
            if rec.touching:
                if uid is None:
                    uid = self._start_unit()
                    self._open[rec.device] = uid
                return uid
            if uid is not None:  # the lift ends the stroke and belongs to it
                del self._open[rec.device]
            return uid
        if rec.cmd in DAB_COMMANDS and ("x" in rec.args or "y" in rec.args):
            return self._start_unit()
        return None

    def _start_unit(self) -> int:
        self._redo.clear()
        uid = self._next_uid()
        self._units[uid] = Unit(uid, self._checkpoint())
        self._done.append(uid)
        self._trim()
        return uid

    def _next_uid(self) -> int:
        self._uids += 1
        return self._uids

    def _checkpoint(self) -> Checkpoint:
        p = self.player
        st, ns, nbytes = self.canvas_checkpoint()
        memo = {id(getattr(p, k)): getattr(p, k) for k in _SHARED if hasattr(p, k)}
        snap = {k: copy.deepcopy(v, memo) for k, v in vars(p).items() if k not in _SHARED}
        cp = Checkpoint(st, ns, snap, nbytes, self.epoch, steady_bytes(st))
        self._newest = cp
        return cp

    def canvas_checkpoint(self) -> tuple[CanvasState, int, int]:
        """A checkpoint's canvas part: the state (pigment stacks cut to the used slots),
        the slot count and the bytes it counts.  The steady arrays are the newest
        checkpoint's when nothing may have written them since (the same epoch): one copy
        for all the checkpoints of an epoch (a 1920×1080 canvas's dried layers alone are
        94 MiB)."""
        st, ns = _pack(self.player.backend.state())
        last = self._newest
        if last is not None and last.epoch == self.epoch:
            for name in STEADY_FIELDS:
                mine, theirs = getattr(st, name), getattr(last.state, name)
                if mine.shape == theirs.shape and mine.dtype == theirs.dtype:
                    setattr(st, name, theirs)
        return st, ns, _state_bytes(st)

    def held_bytes(self) -> int:
        """The bytes the kept checkpoints hold, the steady arrays of an epoch once (a
        function of the records: a replay counts what the live session counted)."""
        cps = [self._units[u].checkpoint for u in self._done] + [
            u.checkpoint for u, _ in self._redo]
        steady: dict[int, int] = {}
        total = 0
        for cp in cps:
            if cp is None:
                continue
            total += cp.nbytes - cp.steady_bytes
            steady[cp.epoch] = max(steady.get(cp.epoch, 0), cp.steady_bytes)
        return total + sum(steady.values())

    def _trim(self) -> None:
        """Drop the oldest checkpoints beyond the limit or the byte budget."""
        def held() -> list[Unit]:
            return [self._units[u] for u in self._done if self._units[u].checkpoint] + [
                u for u, _ in self._redo if u.checkpoint]

        while True:
            kept = held()
            total = self.held_bytes()
            if len(kept) <= self.limit and (total <= self.budget or len(kept) <= 1):
                return
            self._let_go(self._done[0], "limit" if len(kept) > self.limit else "budget")

    def _let_go(self, uid: int, why: str) -> None:
        """The oldest undoable unit ``uid`` can no longer be undone (counted, logged)."""
        unit = self._units[uid]
        unit.checkpoint = None  # its records stay in the order: later units replay them
        for r in unit.records:
            self._unit_of.pop(r, None)
        unit.records.clear()
        self._done.remove(uid)
        self.dropped[why] += 1
        now = time.monotonic()
        if now >= self._drop_logged + DROP_LOG_S:
            self._drop_logged = now
            log.info("undo history: the oldest steps can no longer be undone (at most %d "
                     "steps, %d MiB of checkpoints, %d records; let go so far: %s)",
                     self.limit, self.budget >> 20, self.max_records,
                     ", ".join(f"{k} {v}" for k, v in self.dropped.items()))

    def _cap_records(self) -> None:
        """Keep at most :attr:`max_records` records: forget those nothing can replay, then
        let the oldest units go until a quarter of the cap is free (so this runs once per
        ``max_records / 4`` records at most, not per record)."""
        low = self.max_records * 3 // 4
        self._forget()
        while len(self._recs) > low and (self._done or self._redo):
            if self._done:
                self._let_go(self._done[0], "records")
            else:  # only undone units hold records now: the oldest redo goes
                unit, _ = self._redo.pop(0)
                for r in unit.records:
                    self._recs.pop(r, None)
                    self._unit_of.pop(r, None)
                self._units.pop(unit.uid, None)
                self.dropped["records"] += 1
            self._forget()

    def _forget(self) -> None:
        """Let go of the records before the first one an undo or redo would replay."""
        starts = [self._order.index(self._units[u].records[0]) for u in self._done
                  if self._units[u].records]
        starts += [pos[0] for _, pos in self._redo if pos]
        cut = min(starts, default=len(self._order))
        for rid in self._order[:cut]:
            del self._recs[rid]
            self._unit_of.pop(rid, None)
        self.forgotten += cut
        self._order = self._order[cut:]
        self._redo = [(u, [p - cut for p in pos]) for u, pos in self._redo]
        live = set(self._done) | {u.uid for u, _ in self._redo}
        for rid in [r for r, u in self._unit_of.items() if u not in live]:
            del self._unit_of[rid]
        keep = live | set(self._open.values())
        for uid in [u for u in self._units if u not in keep]:
            del self._units[uid]

    # -- undo / redo ---------------------------------------------------------------
    def can_undo(self) -> bool:
        return any(self._units[u].checkpoint is not None for u in self._done)

    def can_redo(self) -> bool:
        return bool(self._redo)

    def undo(self) -> bool:
        """Undo the newest unit still undoable; ``False`` when there is none."""
        if not self.can_undo():
            self.last = self._nothing("undo")
            return False
        unit = self._units[self._done.pop()]
        for dev, uid in list(self._open.items()):
            if uid == unit.uid:
                del self._open[dev]
        positions = [self._order.index(r) for r in unit.records]
        start = positions[0] if positions else len(self._order)
        for r in unit.records:
            self._order.remove(r)
        self._redo.append((unit, positions))
        self._rewind(unit, start)
        self.undone += 1
        self.last = f"undone ({self.undo_depth()} more can be undone)"
        return True

    def undo_depth(self) -> int:
        return sum(1 for u in self._done if self._units[u].checkpoint)

    def _nothing(self, what: str) -> str:
        gone = sum(self.dropped.values())
        if what == "undo" and gone:
            return (f"nothing left to undo: the {gone} oldest steps were let go to keep "
                    f"memory bounded (at most {self.limit} steps, {self.budget >> 20} MiB of "
                    f"checkpoints, {self.max_records} records)")
        return f"nothing to {what}"

    def redo(self) -> bool:
        """Redo the unit undone last; ``False`` when there is none."""
        if not self._redo:
            self.last = self._nothing("redo")
            return False
        unit, positions = self._redo.pop()
        for pos, rid in zip(positions, unit.records, strict=True):
            self._order.insert(pos, rid)
        self._done.append(unit.uid)
        self._done.sort(key=lambda u: self._first_pos(u))
        start = positions[0] if positions else len(self._order)
        self._rewind(unit, start)
        self.redone += 1
        self.last = f"redone ({len(self._redo)} more can be redone)"
        return True

    def _first_pos(self, uid: int) -> int:
        recs = self._units[uid].records
        return self._order.index(recs[0]) if recs and recs[0] in self._order else -1

    def _rewind(self, unit: Unit, start: int) -> None:
        """Restore ``unit``'s checkpoint and replay ``_order[start:]`` to the present step."""
        cp = unit.checkpoint
        if cp is None:  # cannot happen for units in _done/_redo (trim drops them)
            raise RuntimeError("undo unit without a checkpoint")
        p = self.player
        target = p.counters.steps
        p.backend.load_state(_unpack(cp))
        self.new_epoch()  # (not the epoch's arrays: later records' writes are replayed)
        memo = {id(getattr(p, k)): getattr(p, k) for k in _SHARED if hasattr(p, k)}
        for k, v in cp.player.items():
            setattr(p, k, copy.deepcopy(v, memo))
        self.replaying = True
        steps0 = p.counters.steps
        try:
            for rid in self._order[start:]:
                rec = self._recs[rid]
                uid = self._unit_of.get(rid)
                p.advance_to(rec.t)
                if uid is not None and self._units[uid].records[0] == rid and (
                        uid in self._done or uid == unit.uid):
                    self._units[uid].checkpoint = self._checkpoint()
                p.apply(rec)
                if isinstance(rec, Command) and rec.cmd == "wait":
                    p.advance_to(rec.t)
            while p.counters.steps < target:
                p.step()
        finally:
            self.replaying = False
        self.replayed_steps += p.counters.steps - steps0
        self._trim()

    def status(self) -> dict[str, object]:
        """Depth of both stacks, the limits and the bytes held (for a status line)."""
        return {"undo_depth": self.undo_depth(),
                "redo_depth": len(self._redo), "limit": self.limit, "budget": self.budget,
                "bytes": self.held_bytes(),
                "max_records": self.max_records, "records": len(self._recs),
                "forgotten_records": self.forgotten, "let_go": dict(self.dropped),
                "undone": self.undone, "redone": self.redone,
                "replayed_steps": self.replayed_steps}


def log_mentions_undo(path: str, chunk: int = 1 << 20) -> bool:
    """Whether a session log may hold ``undo``/``redo`` commands (a byte search, so a
    replay knows to keep an undo history from its first record)."""
    tail = b""
    try:
        with open(path, "rb") as f:
            while True:
                block = f.read(chunk)
                if not block:
                    return False
                data = tail + block
                if b'"undo"' in data or b'"redo"' in data:
                    return True
                tail = data[-8:]
    except OSError:
        return False
