"""Rank 0 drives, the other ranks follow: a one-process program on a distributed canvas.

``station sim --distributed`` keeps the bus, the clock, the session log, the status
and the output files on rank 0 (a live station cannot be SPMD: only one process may
read the bus). Rank 0 talks to a :class:`Leader`, which broadcasts every canvas
call (name and arguments, brush stamps included) before making it; the other
ranks run :func:`follow`, which makes the same calls on their
:class:`~station.backends.distributed.canvas.DistributedCanvas`, so the collective
operations meet.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from station.backends.distributed import exchange
from station.backends.distributed.canvas import DistributedCanvas
from station.canvas.state import CanvasState
from station.canvas.stats import CanvasStats
from station.errors import BadInput

STOP = "__stop__"


class Leader:
    """The canvas backend protocol on rank 0, relaying each call to the followers."""

    def __init__(self, canvas: DistributedCanvas) -> None:
        self.canvas = canvas
        self._stopped = False

    def _send(self, msg: tuple[str, tuple[object, ...], dict[str, object]]) -> None:
        comm, root = self.canvas.comm, self.canvas.root
        exchange.wait_all([comm.isend(msg, dest=r, tag=exchange.TAG_RELAY)
                           for r in range(comm.Get_size()) if r != root])

    def _relay(self, name: str, *args: object, **kw: object) -> Any:
        self._send((name, args, kw))
        return getattr(self.canvas, name)(*args, **kw)

    # properties are local (replicated on every rank)
    @property
    def renderer(self) -> str:
        return self.canvas.renderer

    @property
    def width(self) -> int:
        return self.canvas.width

    @property
    def height(self) -> int:
        return self.canvas.height

    @property
    def n_slots(self) -> int:
        return self.canvas.n_slots

    def add_sources(self, dw: np.ndarray | None = None,
                    dp: Mapping[str, np.ndarray] | None = None,
                    dvx: np.ndarray | None = None, dvy: np.ndarray | None = None,
                    *, y0: int = 0, x0: int = 0) -> None:
        self._relay("add_sources", dw, dict(dp or {}), dvx, dvy, y0=y0, x0=x0)

    def step(self, dt: float | None = None) -> None:
        self._relay("step", dt)

    def dry(self) -> None:
        self._relay("dry")

    def new_layer(self) -> None:
        self._relay("new_layer")

    def clear(self) -> None:
        self._relay("clear")

    def set_profile(self, name: str) -> None:
        self._relay("set_profile", name)

    def render(self) -> np.ndarray:
        out: np.ndarray = self._relay("render")
        return out

    def state(self) -> CanvasState:
        out: CanvasState = self._relay("state")
        return out

    def stats(self) -> CanvasStats:
        out: CanvasStats = self._relay("stats")
        return out

    def load_state(self, state: CanvasState) -> None:
        """The state stays on rank 0; each follower receives its rows only."""
        self._send(("load_state", (), {}))
        self.canvas.load_state(state)

    def close(self) -> None:
        """Let the followers return (once)."""
        if not self._stopped:
            self._stopped = True
            self._send((STOP, (), {}))


def follow(canvas: DistributedCanvas) -> int:
    """Make the leader's calls until it stops; returns 0.

    A call the leader's canvas refuses as bad input is refused here identically (the
    checks come before any communication), so it is skipped on both sides.
    """
    while True:
        # a follower waits most of the time (the leader waits for the pen): it naps
        # between polls instead of spinning in a blocking receive
        req = canvas.comm.irecv(source=canvas.root, tag=exchange.TAG_RELAY)
        name, args, kw = exchange.wait_obj(req)
        if name == STOP:
            return 0
        if name == "load_state":
            canvas.load_state(None)
            continue
        try:
            getattr(canvas, name)(*args, **kw)
        except BadInput:
            pass
