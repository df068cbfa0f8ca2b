"""A mouse or a touchscreen as the kiosk's pen (``station kiosk --input mouse|pen|auto``).

A visitor without a tablet paints with the mouse (or a finger: an X server's
touchscreen drives the pointer) through :class:`MousePen`, which turns the
window's pointer events into :class:`~station.events.PenSample` s in window
coordinates, as a calibrated tablet's driver sends them:

* the button (or the finger) down is the tip down; the pointer over the window
  is the pen in proximity (a mouse always hovers: there is no "lifted away");
* pressure from speed (``--mouse-pressure speed``, the default: a slow stroke
  presses, a fast one flicks, as a brush does — :data:`SPEED_FULL` window heights
  a second and faster gives the lightest), or a fixed one (``--mouse-pressure
  0.7``).  Either way the brush is set down as a hand sets it down: the pressure
  rises from :data:`ATTACK_FROM` of its value over the first :data:`ATTACK_S` of
  the stroke, so a stroke starts at the tip, narrow and light, and swells — not
  with the round stamp of the whole brush that read as a felt-tip pen;
* smooth strokes: a mouse reports whole pixels at irregular intervals, and a
  finger jitters.  The position goes through a one-euro filter (Casiez et al.,
  CHI 2012): a low cut-off while the pointer moves slowly (jitter removed), a
  high one as it speeds up (no lag on a fast stroke).  The brush spaces its
  stamps along the filtered path, as it does along a pen's.

Where a pen is there too (``auto``), the pen wins: pointer events are ignored
while pen samples came in the last :data:`PEN_WINS_S`.  The window's cursor,
when the mouse paints, is the brush's shadow.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from station.errors import BadInput
from station.events import PenSample, Tool

INPUTS = ("auto", "pen", "mouse")
DEVICE = "mouse"  # the device name in the session log

#: Pointer speed (window heights a second: the same hand on a 4K screen moves twice the
#: pixels) at which pressure-from-speed is lightest.
SPEED_FULL = 1.4
#: The pressures pressure-from-speed moves between (slow, fast).
PRESSURE_SLOW = 0.85
PRESSURE_FAST = 0.25
#: The brush set down: the pressure rises over this long (s) after the button goes down,
#: from this share of its value (smoothstep), as a painter's stroke starts at the tip.
ATTACK_S = 0.1
ATTACK_FROM = 0.3
#: A pen heard this recently (s) takes precedence over the mouse in ``auto``.
PEN_WINS_S = 1.0


def parse_pressure(text: str) -> float | None:
    """``--mouse-pressure``: a number in (0, 1], or ``speed`` (``None``)."""
    if text == "speed":
        return None
    try:
        p = float(text)
    except ValueError:
        raise BadInput(f"{text!r} is neither a pressure in (0, 1] nor 'speed'",
                       "--mouse-pressure") from None
    if not 0.0 < p <= 1.0:
        raise BadInput(f"{p} is not a pressure in (0, 1]", "--mouse-pressure")
    return p


@dataclass
class OneEuro:
    """The one-euro filter of one coordinate (pixels, seconds)."""

    min_cutoff: float = 3.0  # Hz at rest: jitter removed
    beta: float = 0.02  # cut-off grows with speed (per px/s): no lag on fast strokes
    d_cutoff: float = 10.0  # Hz, the speed's own smoothing
    x: float | None = None
    dx: float = 0.0
    t: float = 0.0

    @staticmethod
    def _alpha(cutoff: float, dt: float) -> float:
        tau = 1.0 / (2.0 * math.pi * cutoff)
        return 1.0 / (1.0 + tau / dt)

    def __call__(self, x: float, t: float) -> float:
        if self.x is None:
            self.x, self.t = x, t
            return x
        dt = max(t - self.t, 1e-3)
        a_d = self._alpha(self.d_cutoff, dt)
        self.dx = a_d * (x - self.x) / dt + (1 - a_d) * self.dx
        a = self._alpha(self.min_cutoff + self.beta * abs(self.dx), dt)
        self.x = a * x + (1 - a) * self.x
        self.t = t
        return self.x

    def reset(self) -> None:
        self.x, self.dx = None, 0.0


class MousePen:
    """Pointer events → pen samples (see the module docstring).

    ``size``: the window in pixels (samples are normalised to it); ``pressure``: the
    pressure while the button is down, or ``None`` for pressure from speed.
    """

    def __init__(self, size: tuple[int, int], pressure: float | None = None) -> None:
        self.size = size
        self.pressure = pressure
        self.fx, self.fy = OneEuro(), OneEuro()
        self.down = False
        self.inside = False
        self.seq = 0
        self._raw: tuple[float, float, float] | None = None  # last raw x, y, t
        self._last: tuple[float, float, float] | None = None  # last smoothed x, y, t
        self._speed = 0.0  # px/s, smoothed
        self._t_down = 0.0  # when the button went down (the stroke's attack)
        self.pending: list[PenSample] = []

    def move(self, x: float, y: float, t: float, t_mono: float) -> None:
        """The pointer is at window pixel (x, y) at time ``t`` (s)."""
        self.inside = True
        self._raw = (x, y, t)
        self._emit(t, t_mono)

    def button(self, down: bool, t: float, t_mono: float) -> None:
        """The button (or finger) went down or up at the last position."""
        if down == self.down:
            return
        self.down = down
        if down:  # a stroke starts where the pointer is, not where the filter lags
            self._speed = 0.0
            self._t_down = t
            self._last = None
            if self._raw is not None:
                self.fx.reset()
                self.fy.reset()
        self._emit(t, t_mono)

    def leave(self, t: float, t_mono: float) -> None:
        """The pointer left the window: the pen leaves proximity (a stroke ends)."""
        self.inside = False
        self.down = False
        self._emit(t, t_mono)

    def _current_pressure(self, t: float) -> float:
        if self.pressure is not None:
            held = self.pressure
        else:
            f = min(1.0, self._speed / (SPEED_FULL * self.size[1]))
            held = PRESSURE_SLOW + (PRESSURE_FAST - PRESSURE_SLOW) * f
        a = min(max((t - self._t_down) / ATTACK_S, 0.0), 1.0)
        return held * (ATTACK_FROM + (1.0 - ATTACK_FROM) * a * a * (3.0 - 2.0 * a))

    def _emit(self, t: float, t_mono: float) -> None:
        if self._raw is None:
            return
        rx, ry, _ = self._raw
        x, y = self.fx(rx, t), self.fy(ry, t)
        if self._last is not None:  # the speed of the smoothed path (jitter is no speed)
            lx, ly, lt = self._last
            dt = t - lt
            if dt > 1e-4:
                v = math.hypot(x - lx, y - ly) / dt
                self._speed += min(1.0, dt / 0.05) * (v - self._speed)  # ~50 ms average
        self._last = (x, y, t)
        w, h = self.size
        self.seq += 1
        touching = self.down and self.inside
        self.pending.append(PenSample(
            t=t, device=DEVICE, tool=Tool.PEN, x=min(max(x / w, 0.0), 1.0),
            y=min(max(y / h, 0.0), 1.0), pressure=self._current_pressure(t) if touching else 0.0,
            proximity=self.inside, touching=touching, seq=self.seq, t_mono=t_mono))

    def take(self) -> list[PenSample]:
        """The samples made since the last call."""
        out, self.pending = self.pending, []
        return out
