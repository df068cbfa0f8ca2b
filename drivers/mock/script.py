"""Scripted pen motion for the mock tablet, in device-independent units.

A script is a list of timed :class:`PenState` values (x, y and pressure in
``[0, 1]`` of the device, tilt in degrees) that the mock tablet encodes into
the device's real report bytes.  Report times follow USB: reports leave on
1 ms frames, so at 200 Hz the intervals jitter between 4 and 6 ms, never a
fixed period.

Scripts: ``line``, ``arc``, ``spiral`` (pressure and tilt profiles),
``eraser`` (the eraser end), ``hover`` (in range, never touching),
``buttons`` (barrel buttons pressed while drawing), ``proximity``
(in/out several times), ``demo`` (all of them in turn).
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace

from station.events import Button, Tool


@dataclass(frozen=True)
class PenState:
    """One pen state the mock reports; ``proximity=False`` is a proximity-out report."""

    proximity: bool = True
    x: float = 0.5
    y: float = 0.5
    pressure: float = 0.0
    tilt_x: float = 0.0
    tilt_y: float = 0.0
    tool: Tool = Tool.PEN
    buttons: int = 0
    distance: float = 0.5
    rotation: float = 0.0
    wheel: float = 0.0
    serial: int = 0x0A1B2C3D
    tool_id: int = 0x802

    @property
    def touching(self) -> bool:
        return self.proximity and self.pressure > 0.0


Path = Callable[[float], tuple[float, float]]
"""s in [0, 1] → (x, y) in [0, 1]."""


def line(x0: float, y0: float, x1: float, y1: float) -> Path:
    return lambda s: (x0 + (x1 - x0) * s, y0 + (y1 - y0) * s)


def arc(cx: float, cy: float, r: float, a0: float, a1: float) -> Path:
    """Circular arc, angles in degrees (0 = +x, 90 = +y i.e. down)."""
    def at(s: float) -> tuple[float, float]:
        a = math.radians(a0 + (a1 - a0) * s)
        return cx + r * math.cos(a), cy + r * math.sin(a)
    return at


def spiral(cx: float, cy: float, r0: float, r1: float, turns: float) -> Path:
    def at(s: float) -> tuple[float, float]:
        a = 2 * math.pi * turns * s
        r = r0 + (r1 - r0) * s
        return cx + r * math.cos(a), cy + r * math.sin(a)
    return at


def pressure_profile(kind: str, peak: float) -> Callable[[float], float]:
    """``sine`` (0 → peak → 0), ``ramp`` (rising), ``constant``."""
    if kind == "ramp":
        return lambda s: peak * (0.1 + 0.9 * s)
    if kind == "constant":
        return lambda s: peak
    return lambda s: peak * max(0.08, math.sin(math.pi * s))


@dataclass(frozen=True)
class StrokePlan:
    """One proximity period: approach (hover), a stroke along ``path``, lift, leave."""

    path: Path
    reports: int
    tool: Tool = Tool.PEN
    pressure: Callable[[float], float] = pressure_profile("sine", 0.8)  # noqa: RUF009
    tilt_from: tuple[float, float] = (0.0, 0.0)
    tilt_to: tuple[float, float] = (0.0, 0.0)
    buttons: Callable[[float], int] = lambda s: 0
    hover_reports: int = 6
    touch: bool = True
    tool_id: int = 0x802
    serial: int = 0x0A1B2C3D


def plan_states(plan: StrokePlan) -> list[PenState]:
    """States of one proximity period (hover in, stroke, hover out, proximity-out)."""
    states: list[PenState] = []
    x0, y0 = plan.path(0.0)
    x1, y1 = plan.path(1.0)
    base = PenState(tool=plan.tool, tool_id=plan.tool_id, serial=plan.serial,
                    tilt_x=plan.tilt_from[0], tilt_y=plan.tilt_from[1])
    for i in range(plan.hover_reports):  # approach: distance shrinking
        states.append(replace(base, x=x0, y=y0, distance=0.6 * (1 - i / plan.hover_reports)))
    n = max(2, plan.reports)
    for i in range(n):
        s = i / (n - 1)
        x, y = plan.path(s)
        tx = plan.tilt_from[0] + (plan.tilt_to[0] - plan.tilt_from[0]) * s
        ty = plan.tilt_from[1] + (plan.tilt_to[1] - plan.tilt_from[1]) * s
        p = plan.pressure(s) if plan.touch else 0.0
        states.append(replace(base, x=x, y=y, pressure=p, tilt_x=tx, tilt_y=ty,
                              buttons=plan.buttons(s), distance=0.0 if plan.touch else 0.3,
                              rotation=360.0 * s - 180.0, wheel=s))
    for i in range(plan.hover_reports):  # lift
        states.append(replace(base, x=x1, y=y1, tilt_x=plan.tilt_to[0], tilt_y=plan.tilt_to[1],
                              distance=0.6 * (i + 1) / plan.hover_reports))
    states.append(replace(base, proximity=False, x=x1, y=y1))
    return states


def _plans(name: str, reports: int, peak: float, tilt: float) -> list[StrokePlan]:
    pen = dict(pressure=pressure_profile("sine", peak), tilt_from=(-tilt, tilt / 2),
               tilt_to=(tilt, -tilt / 2))
    if name == "line":
        return [StrokePlan(line(0.1, 0.2, 0.9, 0.8), reports, **pen)]  # type: ignore[arg-type]
    if name == "arc":
        return [StrokePlan(arc(0.5, 0.5, 0.35, 180, 360), reports, **pen)]  # type: ignore[arg-type]
    if name == "spiral":
        return [StrokePlan(spiral(0.5, 0.5, 0.02, 0.45, 3.0), reports,
                           pressure=pressure_profile("ramp", peak),
                           tilt_from=(-tilt, -tilt), tilt_to=(tilt, tilt))]
    if name == "eraser":
        return [StrokePlan(line(0.2, 0.5, 0.8, 0.5), reports, tool=Tool.ERASER, tool_id=0x80A,
                           pressure=pressure_profile("constant", peak))]
    if name == "hover":
        return [StrokePlan(line(0.3, 0.3, 0.7, 0.3), reports, touch=False)]
    if name == "buttons":
        return [StrokePlan(line(0.1, 0.9, 0.9, 0.1), reports,
                           buttons=lambda s: int(Button.STYLUS) if 0.25 <= s < 0.5 else
                           (int(Button.STYLUS2) if 0.5 <= s < 0.75 else 0), **pen)]  # type: ignore[arg-type]
    if name == "proximity":
        return [StrokePlan(line(0.1 + 0.2 * k, 0.5, 0.25 + 0.2 * k, 0.5), max(4, reports // 4),
                           hover_reports=3, **pen) for k in range(4)]  # type: ignore[arg-type]
    if name == "demo":
        return [p for n in ("line", "arc", "spiral", "eraser", "hover", "buttons")
                for p in _plans(n, reports, peak, tilt)]
    raise ValueError(name)


SCRIPTS = ("line", "arc", "spiral", "eraser", "hover", "buttons", "proximity", "demo")


def report_times(rate: float, seed: int = 0) -> Iterator[float]:
    """Report times at ``rate`` Hz, each delayed to the next 1 ms USB frame.

    The frame phase of each report is random, so at 200 Hz intervals are 4, 5
    or 6 ms and at 133 Hz 6 to 9 ms, as real tablets show.
    """
    rng = random.Random(seed)
    period_ms = 1000.0 / rate
    last = -1
    k = 0
    while True:
        ms = round(k * period_ms) + rng.choice((0, 1))  # sent on this frame or the next
        ms = max(ms, last + 1)
        last = ms
        yield ms / 1000.0
        k += 1


def script_states(name: str, reports: int = 120, peak: float = 0.8, tilt: float = 30.0,
                  gap: float = 0.2) -> list[tuple[float, PenState]]:
    """A script as (time offset, state) pairs: offsets 0 within a proximity period
    mean "next report"; ``gap`` seconds of silence separate proximity periods."""
    if name not in SCRIPTS:
        raise ValueError(f"unknown script {name!r} (one of {', '.join(SCRIPTS)})")
    out: list[tuple[float, PenState]] = []
    for k, plan in enumerate(_plans(name, reports, peak, tilt)):
        for j, state in enumerate(plan_states(plan)):
            out.append((gap if (k and j == 0) else 0.0, state))
    return out


def timed_states(name: str, rate: float = 200.0, seed: int = 0, repeat: int = 1,
                 reports: int = 120, peak: float = 0.8, tilt: float = 30.0,
                 ) -> Iterator[tuple[float, PenState]]:
    """The script with USB-frame report times; ``repeat=0`` repeats forever."""
    states = script_states(name, reports, peak, tilt)
    times = report_times(rate, seed)
    offset = 0.0
    loop = 0
    while repeat == 0 or loop < repeat:
        if loop:
            offset += 0.2  # the pen is away between repetitions
        for pause, state in states:
            offset += pause
            yield next(times) + offset, state
        loop += 1
