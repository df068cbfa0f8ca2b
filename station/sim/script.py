"""Scripted pen input: write a painting as code, get a session log.

A :class:`Script` is a pen held by a program.  It keeps a session clock and
turns strokes — lines, arcs, smooth curves through points — into the pen
samples a tablet would report (hover, touch, samples at a fixed report rate,
lift), with pressure and tilt given as profiles along the stroke.  Commands
(``brush``, ``wait``, ``dry`` …) go in between.  The result is an ordinary
session log (interfaces.md), so the station paints it exactly like a recorded
session.  Numbers are rounded (positions to 1e-5, time to 1e-4 s) so the text
is short and the same on every machine.

Example::

    s = Script(256, 192, seed=3)
    s.brush(size=20, water=0.9, pigment={"Cerulean Blue": 0.5})
    s.line((0.1, 0.2), (0.9, 0.2), duration=1.2, pressure=taper(0.8))
    s.wait(2.0)
    s.save("session.jsonl")
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, TypedDict

from station.events import Command, PenSample
from station.sessionlog import SessionHeader, SessionLogWriter

Point = tuple[float, float]
Profile = Callable[[float], float]
TiltProfile = Callable[[float], tuple[float, float]]

if TYPE_CHECKING:
    from typing import Unpack  # Python 3.11; annotations only (3.10 runs this module)


class StrokeStyle(TypedDict, total=False):
    """How a stroke is drawn, as :meth:`Script.stroke` takes it."""

    pressure: Profile | float
    tilt: TiltProfile | tuple[float, float]
    gap: float


def constant(value: float) -> Profile:
    """The same value along the whole stroke."""
    return lambda u: value


def taper(peak: float, start: float = 0.3, end: float = 0.15, attack: float = 0.15,
          release: float = 0.25) -> Profile:
    """Pressure that rises from ``start`` to ``peak`` over the first ``attack``
    of the stroke, holds, and falls to ``end`` over the last ``release``
    (smoothstep ramps, like a hand setting the brush down and lifting it)."""

    def f(u: float) -> float:
        if u < attack:
            return start + (peak - start) * _smooth(u / attack)
        if u > 1.0 - release:
            return peak + (end - peak) * _smooth((u - (1.0 - release)) / release)
        return peak

    return f


def swell(low: float, high: float, waves: float = 1.0) -> Profile:
    """Pressure swelling between ``low`` and ``high`` ``waves`` times along the stroke."""
    return lambda u: low + (high - low) * 0.5 * (1.0 - math.cos(2.0 * math.pi * waves * u))


def tilt_const(tilt_x: float, tilt_y: float) -> TiltProfile:
    return lambda u: (tilt_x, tilt_y)


def tilt_sweep(a: tuple[float, float], b: tuple[float, float]) -> TiltProfile:
    """Tilt moving linearly from ``a`` to ``b`` (degrees) along the stroke."""
    return lambda u: (a[0] + (b[0] - a[0]) * u, a[1] + (b[1] - a[1]) * u)


def _smooth(x: float) -> float:
    x = min(1.0, max(0.0, x))
    return x * x * (3.0 - 2.0 * x)


def _clamp01(v: float) -> float:
    return min(1.0, max(0.0, v))


def catmull_rom(points: Sequence[Point]) -> Callable[[float], Point]:
    """A smooth path through ``points`` (centripetal-free, uniform Catmull–Rom),
    parameterised by ``u`` in ``[0, 1]`` spread evenly over the segments."""
    pts = [points[0], *points, points[-1]]
    n = len(points) - 1
    if n < 1:
        raise ValueError("a curve needs at least two points")

    def f(u: float) -> Point:
        s = min(n - 1e-9, max(0.0, u * n))
        i = int(s)
        t = s - i
        p0, p1, p2, p3 = pts[i], pts[i + 1], pts[i + 2], pts[i + 3]
        t2, t3 = t * t, t * t * t
        return (
            0.5 * (2 * p1[0] + (-p0[0] + p2[0]) * t + (2 * p0[0] - 5 * p1[0] + 4 * p2[0] - p3[0])
                   * t2 + (-p0[0] + 3 * p1[0] - 3 * p2[0] + p3[0]) * t3),
            0.5 * (2 * p1[1] + (-p0[1] + p2[1]) * t + (2 * p0[1] - 5 * p1[1] + 4 * p2[1] - p3[1])
                   * t2 + (-p0[1] + 3 * p1[1] - 3 * p2[1] + p3[1]) * t3),
        )

    return f


class Script:
    """A scripted pen session (see the module docstring).

    Attributes:
        header: the session header (canvas size, profile, seed, and the
            simulation ``rate`` in steps per session second when given).
        rate_hz: pen report rate of the scripted pen, samples per second.
        device: device name written into the samples.
        t: the session clock, seconds.
        records: pen samples and commands so far, in time order.
    """

    def __init__(
        self,
        width: int,
        height: int,
        profile: str = "watercolor",
        seed: int = 0,
        device: str = "script-0",
        rate_hz: float = 120.0,
        sim_rate: float | None = None,
        extra: Mapping[str, object] | None = None,
    ) -> None:
        ext = dict(extra or {})
        if sim_rate is not None:
            ext["sim"] = {"rate": sim_rate}
        self.header = SessionHeader(width=width, height=height, profile=profile, seed=seed,
                                    extra=ext)
        self.rate_hz = rate_hz
        self.device = device
        self.t = 0.0
        self.records: list[PenSample | Command] = []
        self._seq = 0

    # -- commands ------------------------------------------------------------
    def cmd(self, command: str, /, **args: object) -> None:
        """Append the command ``command`` with keyword ``args`` at the current time."""
        self.records.append(Command(t=self._time(), cmd=command, args=args))

    def brush(self, size: float, water: float, pigment: dict[str, float] | None = None,
              kind: str = "round") -> None:
        self.cmd("brush", kind=kind, size=size, water=water, pigment=dict(pigment or {}))

    def wait(self, seconds: float) -> None:
        """Let the simulation run ``seconds`` of painting time (a ``wait`` command)."""
        self.cmd("wait", seconds=seconds)

    def pause(self, seconds: float) -> None:
        """Let ``seconds`` of session time pass with the pen away (no record)."""
        self.t += seconds

    def dry(self) -> None:
        self.cmd("dry")

    def new_layer(self) -> None:
        self.cmd("new_layer")

    def clear(self) -> None:
        self.cmd("clear")

    def profile(self, name: str) -> None:
        self.cmd("profile", name=name)

    # -- strokes -------------------------------------------------------------
    def stroke(
        self,
        path: Callable[[float], Point],
        duration: float,
        pressure: Profile | float = 0.7,
        tilt: TiltProfile | tuple[float, float] = (0.0, 0.0),
        gap: float = 0.08,
    ) -> None:
        """One stroke along ``path(u)``, ``u`` from 0 to 1, taking ``duration`` s.

        The pen hovers at the start, touches, reports at :attr:`rate_hz`, lifts
        at the end, then travels for ``gap`` seconds before the next action.
        """
        pf = constant(pressure) if isinstance(pressure, (int, float)) else pressure
        tf = tilt_const(*tilt) if isinstance(tilt, tuple) else tilt
        n = max(2, int(math.ceil(duration * self.rate_hz)))
        x0, y0 = path(0.0)
        self._sample(x0, y0, 0.0, tf(0.0), touching=False)
        self.t += 1.0 / self.rate_hz
        for i in range(n + 1):
            u = i / n
            x, y = path(u)
            self._sample(x, y, pf(u), tf(u), touching=True)
            if i < n:
                self.t += duration / n
        self.t += 1.0 / self.rate_hz
        x1, y1 = path(1.0)
        self._sample(x1, y1, 0.0, tf(1.0), touching=False)
        self.t += gap

    def line(self, a: Point, b: Point, duration: float, **kw: Unpack[StrokeStyle]) -> None:
        self.stroke(lambda u: (a[0] + (b[0] - a[0]) * u, a[1] + (b[1] - a[1]) * u),
                    duration, **kw)

    def arc(self, center: Point, radius: tuple[float, float], start_deg: float,
            end_deg: float, duration: float, **kw: Unpack[StrokeStyle]) -> None:
        """An elliptical arc (radii ``(rx, ry)`` in canvas-normalised units)."""
        a0, a1 = math.radians(start_deg), math.radians(end_deg)

        def path(u: float) -> Point:
            a = a0 + (a1 - a0) * u
            return center[0] + radius[0] * math.cos(a), center[1] + radius[1] * math.sin(a)

        self.stroke(path, duration, **kw)

    def curve(self, points: Sequence[Point], duration: float,
              **kw: Unpack[StrokeStyle]) -> None:
        """A smooth stroke through ``points``."""
        self.stroke(catmull_rom(points), duration, **kw)

    def dab(self, at: Point, duration: float = 0.05, **kw: Unpack[StrokeStyle]) -> None:
        """Touch the paper at one point."""
        self.stroke(lambda u: at, duration, **kw)

    # -- output --------------------------------------------------------------
    def _time(self) -> float:
        return round(self.t, 4)

    def _sample(self, x: float, y: float, p: float, tilt: tuple[float, float],
                touching: bool) -> None:
        self._seq += 1
        self.records.append(
            PenSample(
                t=self._time(),
                device=self.device,
                tool="pen",  # type: ignore[arg-type]  # parsed by PenSample
                x=round(_clamp01(x), 5),
                y=round(_clamp01(y), 5),
                pressure=round(_clamp01(p), 4) if touching else 0.0,
                tilt_x=round(max(-90.0, min(90.0, tilt[0])), 2),
                tilt_y=round(max(-90.0, min(90.0, tilt[1])), 2),
                proximity=True,
                touching=touching,
                seq=self._seq,
            )
        )

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the session log."""
        with SessionLogWriter(path, self.header) as w:
            for rec in self.records:
                w.write(rec)

    def text(self) -> str:
        """The session log as text (exactly what :meth:`save` writes)."""
        import io

        buf = io.StringIO()
        w = SessionLogWriter(buf, self.header)
        for rec in self.records:
            w.write(rec)
        w.close()
        return buf.getvalue()
