"""One painting: the live simulation running inside the kiosk process.

:class:`KioskSession` wraps :class:`~station.sim.live.LiveSim` (the same bus
subscription, session clock, session log and exact-replay time stamping as
``station sim``) and adds what a window needs:

* pen samples arrive in *screen* coordinates (a calibrated driver maps the
  tablet onto the screen); the view maps them to canvas coordinates before
  the player sees them, and samples over the UI panel never reach the canvas;
* the tiles that may have changed since the last frame (dirty tiles), so the
  CPU display re-renders only those;
* for the latency benchmark, the driver read time of every sample that made
  paint, until a frame shows it.

Why in-process and not a separate ``station sim`` feeding the window over the
bus: the window needs the canvas every frame (60 per second); across a
process boundary that is a 800×600×3 float image per frame on the CPU, or a
shared GL context that two processes cannot have.  The pen still comes over
the bus, so drivers, recorders and the blueprint see the same traffic as with
``station sim``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from station.events import Command, PenSample, Tool
from station.sim.live import SYNC_EVERY_S, LiveConfig, LiveSim

#: Commands that may change every cell: the display re-renders the whole canvas.
WHOLE_CANVAS_COMMANDS = frozenset({"dry", "new_layer", "clear", "profile", "undo"})

PenMapper = Callable[[PenSample], "PenSample | None"]
KioskCommands = Callable[[Command], bool]


class KioskSession(LiveSim):
    """The live simulation of one painting (see the module docstring).

    ``map_pen`` turns a screen-space sample into the canvas-space sample to
    paint, or ``None`` when the canvas must not see it (the pen is over the UI).
    """

    def __init__(self, cfg: LiveConfig, map_pen: PenMapper | None = None,
                 kiosk_command: KioskCommands | None = None) -> None:
        super().__init__(cfg)
        self.map_pen = map_pen
        self.kiosk_command = kiosk_command
        self.started_wall = time.time()
        ty, tx = self._tile_shape()
        self.dirty = np.ones((ty, tx), bool)  # everything needs its first render
        self.whole_dirty = True
        self.awaiting_paint: list[float] = []  # driver read times (monotonic) not yet shown
        self.last_pen: PenSample | None = None  # last screen-space sample
        self.last_canvas_pen: PenSample | None = None
        self.painted_stamps = 0
        self.painting_id = ""  # the gallery id the window gives this painting

    # -- geometry ----------------------------------------------------------------
    def _tile_shape(self) -> tuple[int, int]:
        canvas: Any = self.canvas  # every backend has params (the protocol does not say)
        ts = int(canvas.params.tile_size)
        return -(-self.cfg.height // ts), -(-self.cfg.width // ts)

    @property
    def cpu_state(self) -> Any:
        """The live :class:`CanvasState` of a CPU backend (no copy), else ``None``."""
        return getattr(self.canvas, "live_state", None)

    # -- input -------------------------------------------------------------------
    def handle(self, kind: str, value: Any, topic: str = "", replay: bool = False) -> None:
        if kind == "pen" and isinstance(value, PenSample):
            self.last_pen = value
            sample = self.map_pen(value) if self.map_pen is not None else value
            if sample is None:
                return
            self.last_canvas_pen = sample
            before = self.player.brush.stamps
            super().handle(kind, sample, topic, replay)
            made = self.player.brush.stamps - before
            if made > 0:
                self.painted_stamps += made
                if value.t_mono > 0.0:
                    self.awaiting_paint.append(value.t_mono)
            return
        if (kind == "cmd" and isinstance(value, Command) and self.kiosk_command is not None
                and self.kiosk_command(value)):
            return  # the window's own command (view, save, screenshot): not the canvas's
        super().handle(kind, value, topic, replay)
        if kind == "cmd" and isinstance(value, Command) and value.cmd in WHOLE_CANVAS_COMMANDS:
            self.mark_all_dirty()

    def command(self, name: str, **args: Any) -> None:
        """Apply a command from the UI exactly as one from the bus (and log it)."""
        self.handle("cmd", Command(t=self.now(), cmd=name, args=args))

    def eraser_selected(self) -> bool:
        return self.last_pen is not None and self.last_pen.tool is Tool.ERASER

    # -- stepping ------------------------------------------------------------------
    def step(self) -> None:
        st = self.cpu_state
        if st is not None:
            self._note_active(st)
        super().step()
        if st is not None:
            self._note_active(self.cpu_state)

    def _note_active(self, st: Any) -> None:
        if not st.tiling:
            self.whole_dirty = True
            return
        self.dirty |= st.tile_ttl > 0

    def run_due_steps(self, max_steps: int = 2) -> int:
        """Run the steps due by the session clock: one, or up to ``max_steps`` when more
        than three are due (a frame waits for at most that many; a slow machine falls
        behind and catches up as ``station sim`` does); then ``station sim``'s
        housekeeping (autosave between strokes, log sync, silent devices)."""
        limit = max_steps if self.steps_due() > 3 else 1
        n = 0
        while n < limit and self.steps_due() > 0:
            self.step()
            n += 1
        if n:
            self.maybe_autosave()
        self.journal.maybe_sync(SYNC_EVERY_S)
        self.check_devices()
        return n

    def pump(self) -> None:
        """Handle every message waiting on the bus (no blocking)."""
        self.drain(0)

    def mark_all_dirty(self) -> None:
        self.whole_dirty = True
        self.dirty[:] = True

    def take_dirty(self) -> np.ndarray:
        """Tiles whose pixels may have changed since the last call: the active ones
        grown by one tile (a pass reaches one cell into a quiet neighbour)."""
        if self.whole_dirty:
            out = np.ones_like(self.dirty)
        else:
            d = self.dirty
            out = d.copy()
            out[1:] |= d[:-1]
            out[:-1] |= d[1:]
            out[:, 1:] |= out[:, :-1].copy()
            out[:, :-1] |= out[:, 1:].copy()
        self.dirty[:] = False
        self.whole_dirty = False
        return out

    # -- status --------------------------------------------------------------------
    def wet_fraction(self) -> float | None:
        """Share of cells holding surface water (CPU backends; ``None`` on GL)."""
        st = self.cpu_state
        if st is None:
            return None
        return float(np.count_nonzero(st.w > 0)) / float(st.w.size)

    def active_tiles(self) -> int | None:
        st = self.cpu_state
        return None if st is None else int(np.count_nonzero(st.tile_ttl > 0))
