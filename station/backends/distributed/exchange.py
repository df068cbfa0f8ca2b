"""Moving rectangles of canvas fields between ranks (non-blocking point-to-point MPI).

A *rect* is ``(r0, r1, c0, c1)`` in canvas cells. Every rank builds the same plan
(who sends which rects to whom) from replicated data, so messages need no headers:
the receiver knows the sizes. All rects from one rank to another travel in one
float32 buffer, in plan order.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from mpi4py import MPI

from station.canvas.state import CanvasState

Rect = tuple[int, int, int, int]

PLANES = ("vx", "vy", "w", "wc", "h", "mask", "block", "block_time", "evaporated",
          "removed_w", "wet_area")
STACKS = ("p", "q", "removed_p")
ALL_FIELDS = (*PLANES, *STACKS, "r_composed", "fibre")
"""Every per-cell field of :class:`CanvasState` (rebalancing and scattering move these;
the paper's ``fibre`` texture (2, H, W) is static but belongs to its rows)."""
DYNAMIC_FIELDS = ("vx", "vy", "w", "wc", "p", "q", "wet_area")
"""The fields a step changes and its neighbours read (the halo exchange moves these;
``evaporated`` also changes but is never read across cells; ``wet_area`` is read by the
flow-outward blur)."""

TAG_HALO = 11
TAG_MOVE = 12
TAG_RELAY = 13

SPIN_S = 2e-4
"""How long a waiting rank polls flat out before it starts sleeping between polls [s]."""
NAP_S = 5e-5
"""Sleep between polls after that [s]."""


def wait_obj(req: MPI.Request) -> Any:
    """The object of a pickled receive (``comm.irecv``), waited for like :func:`wait_all`."""
    give_up_spin = time.perf_counter() + SPIN_S
    while True:
        done, obj = req.test()
        if done:
            return obj
        if time.perf_counter() > give_up_spin:
            time.sleep(NAP_S)


def wait_all(reqs: Sequence[MPI.Request]) -> None:
    """``Waitall`` that gives the core away: MPICH's blocking waits spin at 100 % CPU,
    so a rank waiting for a busier neighbour would take the core that neighbour needs
    on an oversubscribed or shared machine. Spin briefly, then test and nap."""
    if not reqs:
        return
    give_up_spin = time.perf_counter() + SPIN_S
    while not MPI.Request.Testall(list(reqs)):
        if time.perf_counter() > give_up_spin:
            time.sleep(NAP_S)


def _views(st: CanvasState, off: int, rect: Rect, names: Sequence[str],
           slots: int) -> list[np.ndarray]:
    r0, r1, c0, c1 = rect
    a, b = r0 - off, r1 - off
    out = []
    for n in names:
        arr = getattr(st, n)
        if n in STACKS:
            out.append(arr[:slots, a:b, c0:c1])
        elif n == "fibre":
            out.append(arr[:, a:b, c0:c1])
        else:  # planes (H, W) and r_composed (H, W, bands)
            out.append(arr[a:b, c0:c1])
    return out


def rect_size(rect: Rect, names: Sequence[str], slots: int, bands: int = 3) -> int:
    """float32 values of ``names`` in ``rect`` (``bands``: r_composed's render bands)."""
    cells = (rect[1] - rect[0]) * (rect[3] - rect[2])
    per = sum(slots if n in STACKS else bands if n == "r_composed" else 2 if n == "fibre"
              else 1 for n in names)
    return cells * per


def pack(st: CanvasState, off: int, rects: Sequence[Rect], names: Sequence[str],
         slots: int) -> np.ndarray:
    """The fields of ``rects`` (``st`` holds canvas row ``off`` at its row 0) in one buffer."""
    parts = [v.ravel() for r in rects for v in _views(st, off, r, names, slots)]
    if not parts:
        return np.zeros(0, np.float32)
    return np.concatenate(parts).astype(np.float32, copy=False)


def unpack(buf: np.ndarray, st: CanvasState, off: int, rects: Sequence[Rect],
           names: Sequence[str], slots: int) -> None:
    """Write a buffer made by :func:`pack` for the same rects into ``st``."""
    pos = 0
    for r in rects:
        for v in _views(st, off, r, names, slots):
            n = v.size
            v[...] = buf[pos:pos + n].reshape(v.shape)
            pos += n


@dataclass
class Pending:
    """Messages of one :func:`start`, not yet waited for (see :func:`finish`)."""

    reqs: list[MPI.Request]
    incoming: list[tuple[np.ndarray, Sequence[Rect]]]
    outgoing: list[np.ndarray]  # send buffers, kept alive until the sends complete
    dst: CanvasState
    dst_off: int
    names: Sequence[str]
    slots: int
    sent: int


def start(comm: MPI.Comm, src: CanvasState | None, src_off: int, dst: CanvasState,
          dst_off: int, plan: Mapping[tuple[int, int], Sequence[Rect]],
          names: Sequence[str], slots: int, tag: int) -> Pending:
    """Post ``plan`` (``(from_rank, to_rank) -> rects``) and return at once.

    Receives are posted first, then the sends (their rects are packed now, so ``src``
    may change right after); rects a rank moves to itself are copied now. The
    received rects are written into ``dst`` by :func:`finish`, and nothing in them
    may be read before. ``src`` may be ``None`` on a rank that sends nothing.
    """
    me = comm.Get_rank()
    pend = Pending([], [], [], dst, dst_off, names, slots, 0)
    for (a, b), rects in plan.items():
        if b == me and a != me:
            bands = dst.r_composed.shape[-1]
            buf = np.empty(sum(rect_size(r, names, slots, bands) for r in rects), np.float32)
            pend.reqs.append(comm.Irecv(buf, source=a, tag=tag))
            pend.incoming.append((buf, rects))
    for (a, b), rects in plan.items():
        if a == me and b != me and src is not None:
            buf = pack(src, src_off, rects, names, slots)
            pend.outgoing.append(buf)
            pend.reqs.append(comm.Isend(buf, dest=b, tag=tag))
            pend.sent += buf.nbytes
    own = plan.get((me, me))
    if own and src is not None:
        unpack(pack(src, src_off, own, names, slots), dst, dst_off, own, names, slots)
    return pend


def finish(pend: Pending) -> int:
    """Wait for the messages of :func:`start` and unpack them; returns bytes sent."""
    wait_all(pend.reqs)
    for buf, rects in pend.incoming:
        unpack(buf, pend.dst, pend.dst_off, rects, pend.names, pend.slots)
    pend.reqs, pend.incoming, pend.outgoing = [], [], []
    return pend.sent


def move(comm: MPI.Comm, src: CanvasState | None, src_off: int, dst: CanvasState,
         dst_off: int, plan: Mapping[tuple[int, int], Sequence[Rect]],
         names: Sequence[str], slots: int, tag: int) -> int:
    """Carry out ``plan`` and wait for it (:func:`start` then :func:`finish`);
    returns bytes sent."""
    return finish(start(comm, src, src_off, dst, dst_off, plan, names, slots, tag))
