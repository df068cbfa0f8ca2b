"""Pen sources for interactive calibration, chosen by a device SPEC string.

* ``mock-user:KEY=VALUE,…`` — a simulated installer who looks at each target
  shown and taps the device point that a known distortion sends there, with
  noise, optional misclicks and screen-tablet parallax.  Keys (defaults):
  ``rot`` degrees (0), ``scale`` SX:SY (1:1), ``offset`` OX:OY (0:0),
  ``persp`` PX:PY (0:0; projective terms), ``swap`` 0/1 (device axes swapped),
  ``noise`` canvas-normalised sigma (0.0005), ``misclick`` tap numbers that
  miss by ``miss`` (0.08), e.g. ``misclick=3`` or ``misclick=3:7``;
  ``parallax`` HX:HY device-normalised per tan(tilt) (0:0), ``tilt`` TX:TY of
  the natural pen hold in degrees (0:0), ``contact`` seconds (0.06),
  ``delay`` seconds before a tap (0.05), ``tiltbias`` TX:TY degrees added to
  every reported tilt (0:0; a tilt offset), ``light``/``hard`` pressure levels
  of the pressure pass (0.08/0.7), ``seed`` (0), ``vid``/``pid`` hex
  (056a/00fa).  :meth:`MockUserSource.truth` is the distortion's matrix.
* ``mock-taps:FILE.csv`` — replays taps from a CSV (``device_x,device_y``
  device-normalised, optional ``tilt_x,tilt_y``), one per target shown.
* anything else — a drivers SPEC (``evdev:/dev/input/event5``, ``hidraw:…``,
  ``mock:…``, ``trace:…``) read through the drivers' pipeline (normaliser with
  no transform: device-normalised samples).

Every source has ``device`` (:class:`DeviceId`), ``geometry``,
``show_target(index, xy, tilt_hint)``, ``poll(now) -> list[PenSample]``,
``exhausted`` and ``close()``; ``now`` is seconds since the session start.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np

from station import boundedio
from station.calibration.area import DeviceGeometry
from station.calibration.errors import CalibrationError
from station.calibration.geometry import Array, project, rotation, scaling, translation
from station.calibration.model import DeviceId
from station.drivers.pipeline import PenDriver, PenSource, open_device
from station.drivers.transport.base import DeviceGone
from station.events import PenSample, Tool

SAMPLE_PERIOD = 0.005  # 200 Hz, an Intuos-class report rate


class CalibrationSource(Protocol):
    device: DeviceId
    geometry: DeviceGeometry
    name: str

    def show_target(self, index: int, xy: tuple[float, float],
                    tilt_hint: tuple[float, float] | None, step: str = "tap") -> None: ...

    def poll(self, now: float) -> list[PenSample]: ...

    @property
    def exhausted(self) -> bool: ...

    def close(self) -> None: ...


def _options(text: str, where: str) -> dict[str, str]:
    out: dict[str, str] = {}
    for part in filter(None, (p.strip() for p in text.split(","))):
        key, sep, value = part.partition("=")
        if not sep:
            raise CalibrationError(f"option {part!r} is not KEY=VALUE", where)
        out[key.strip()] = value.strip()
    return out


def _nums(
    opts: dict[str, str], key: str, default: tuple[float, ...], where: str
) -> tuple[float, ...]:
    if key not in opts:
        return default
    try:
        vals = tuple(float(v) for v in opts[key].split(":"))
    except ValueError:
        raise CalibrationError(f"{key}={opts[key]!r} must be numbers separated by ':'",
                               where) from None
    if len(vals) == 1 and len(default) == 2:
        vals = vals * 2
    if len(vals) != len(default) or not all(math.isfinite(v) for v in vals):
        raise CalibrationError(f"{key}={opts[key]!r} needs {len(default)} number(s)", where)
    return vals


@dataclass
class _ScheduledTaps:
    """Samples of taps queued for delivery at their times."""

    pending: list[PenSample] = field(default_factory=list)
    seq: int = 0

    def tap(self, name: str, start: float, xy: tuple[float, float], tilt: tuple[float, float],
            contact: float, jitter: float, rng: np.random.Generator,
            pressure: float | None = None) -> None:
        x, y = (min(1.0, max(0.0, v)) for v in xy)
        tx, ty = (min(90.0, max(-90.0, v)) for v in tilt)
        t = start
        # hover in, touch down, hold (with a little sensor jitter), lift, hover out
        for _ in range(3):
            self._add(name, t, x, y, tx, ty, False, 0.0)
            t += SAMPLE_PERIOD
        steps = max(2, int(round(contact / SAMPLE_PERIOD)))
        for k in range(steps):
            jx, jy = rng.normal(0.0, jitter, 2) if jitter > 0 else (0.0, 0.0)
            if pressure is None:  # a tap: pressure rises and falls
                p = 0.3 + 0.4 * math.sin(math.pi * (k + 1) / (steps + 1))
            else:  # a held press at a level, with the hand's wobble
                p = min(1.0, max(0.001, pressure * (1.0 + 0.08 * float(rng.normal()))))
            self._add(name, t, min(1.0, max(0.0, x + jx)), min(1.0, max(0.0, y + jy)), tx, ty,
                      True, p)
            t += SAMPLE_PERIOD
        for _ in range(2):
            self._add(name, t, x, y, tx, ty, False, 0.0)
            t += SAMPLE_PERIOD

    def _add(self, name: str, t: float, x: float, y: float, tx: float, ty: float,
             touching: bool, pressure: float) -> None:
        self.seq += 1
        self.pending.append(PenSample(
            t=t, device=name, tool=Tool.PEN, x=x, y=y, pressure=pressure, tilt_x=tx,
            tilt_y=ty, proximity=True, touching=touching, seq=self.seq,
        ))

    def due(self, now: float) -> list[PenSample]:
        k = 0
        while k < len(self.pending) and self.pending[k].t <= now:
            k += 1
        out, self.pending = self.pending[:k], self.pending[k:]
        return out


class MockUserSource:
    """A simulated installer tapping the targets through a known distortion."""

    name = "mock-user"

    def __init__(self, options: str) -> None:
        where = "--device mock-user"
        opts = _options(options, where)
        known = {"rot", "scale", "offset", "persp", "swap", "noise", "misclick", "miss",
                 "parallax", "tilt", "contact", "delay", "seed", "vid", "pid", "tiltbias",
                 "light", "hard"}
        unknown = sorted(set(opts) - known)
        if unknown:
            raise CalibrationError(f"unknown option(s) {', '.join(unknown)}", where)
        rot = _nums(opts, "rot", (0.0,), where)[0]
        sx, sy = _nums(opts, "scale", (1.0, 1.0), where)
        ox, oy = _nums(opts, "offset", (0.0, 0.0), where)
        px, py = _nums(opts, "persp", (0.0, 0.0), where)
        self.noise = _nums(opts, "noise", (0.0005,), where)[0]
        self.miss = _nums(opts, "miss", (0.08,), where)[0]
        self.parallax = _nums(opts, "parallax", (0.0, 0.0), where)
        self.tilt = _nums(opts, "tilt", (0.0, 0.0), where)
        self.contact = _nums(opts, "contact", (0.06,), where)[0]
        self.delay = _nums(opts, "delay", (0.05,), where)[0]
        self.tiltbias = _nums(opts, "tiltbias", (0.0, 0.0), where)
        self.levels = {"light": _nums(opts, "light", (0.08,), where)[0],
                       "hard": _nums(opts, "hard", (0.7,), where)[0]}
        self.misclicks = {int(v) for v in opts.get("misclick", "").split(":") if v.strip()}
        self.rng = np.random.default_rng(int(opts.get("seed", "0")))
        try:
            vid, pid = int(opts.get("vid", "056a"), 16), int(opts.get("pid", "00fa"), 16)
        except ValueError:
            raise CalibrationError("vid/pid must be hexadecimal", where) from None
        self.device = DeviceId(vid, pid, None, "mock screen tablet")
        self.geometry = DeviceGeometry(0, 95840, 0, 54260, 200.0, 200.0)
        # truth: device-normalised -> screen-normalised
        persp = np.eye(3)
        persp[2, :2] = (px, py)
        m = (
            translation(0.5 + ox, 0.5 + oy)
            @ rotation(rot)
            @ scaling(sx, sy)
            @ translation(-0.5, -0.5)
        )
        # perspective about the centre so that the centre stays put
        m = m @ translation(0.5, 0.5) @ persp @ translation(-0.5, -0.5)
        if opts.get("swap", "0") in ("1", "true", "yes"):
            m = m @ np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
        self._truth = m / m[2, 2]
        self._inverse = np.linalg.inv(self._truth)
        self._queue = _ScheduledTaps()
        self.taps = 0
        self._last_now = 0.0

    def truth(self) -> Array:
        """The distortion: device-normalised → screen-normalised (3×3)."""
        return self._truth.copy()

    def show_target(self, index: int, xy: tuple[float, float],
                    tilt_hint: tuple[float, float] | None, step: str = "tap") -> None:
        self.taps += 1
        tilt = tilt_hint if tilt_hint is not None else self.tilt
        target = np.array([xy], dtype=np.float64)
        if self.noise > 0:
            target = target + self.rng.normal(0.0, self.noise, (1, 2))
        if self.taps in self.misclicks:
            ang = self.rng.uniform(0, 2 * math.pi)
            target = target + self.miss * np.array([[math.cos(ang), math.sin(ang)]])
        dev = project(self._inverse, target)[0]
        # the sensor sees the nib displaced against the parallax the calibration corrects
        dev = dev - np.asarray(self.parallax) * np.tan(np.radians(tilt))
        reported = (float(tilt[0] + self.tiltbias[0]), float(tilt[1] + self.tiltbias[1]))
        level = self.levels.get(step)
        contact = self.contact if step == "tap" else 0.4  # presses are held
        self._queue.tap(self.name, self._last_now + self.delay, (float(dev[0]), float(dev[1])),
                        reported, contact, 0.0002, self.rng, level)

    def poll(self, now: float) -> list[PenSample]:
        self._last_now = max(self._last_now, now)
        return self._queue.due(now)

    @property
    def exhausted(self) -> bool:
        return False

    def close(self) -> None:
        pass


class MockTapsSource:
    """Replays taps from a CSV: one tap per target shown, in file order."""

    name = "mock-taps"

    def __init__(self, path: str) -> None:
        p = Path(path)
        try:
            lines = boundedio.read_text(p, boundedio.CAP_POINTS, str(p)).splitlines()
        except (OSError, UnicodeDecodeError) as exc:
            raise CalibrationError(f"cannot read taps ({exc})", str(p)) from None
        rows = [(i, ln) for i, ln in enumerate(lines, 1) if ln.strip() and not ln.startswith("#")]
        if not rows:
            raise CalibrationError("empty taps file", f"{p}:1")
        header = [h.strip() for h in rows[0][1].split(",")]
        if "device_x" not in header or "device_y" not in header:
            raise CalibrationError("taps header needs device_x,device_y", f"{p}:{rows[0][0]}")
        has_tilt = "tilt_x" in header and "tilt_y" in header
        self.taps: list[tuple[float, float, float, float]] = []
        for number, line in rows[1:]:
            f = line.split(",")
            try:
                x, y = float(f[header.index("device_x")]), float(f[header.index("device_y")])
                tx = float(f[header.index("tilt_x")]) if has_tilt else 0.0
                ty = float(f[header.index("tilt_y")]) if has_tilt else 0.0
            except (ValueError, IndexError):
                raise CalibrationError(f"bad tap row {line.strip()!r}", f"{p}:{number}") from None
            if not (0 <= x <= 1 and 0 <= y <= 1 and abs(tx) <= 90 and abs(ty) <= 90):
                raise CalibrationError("tap outside [0, 1] or tilt outside ±90°", f"{p}:{number}")
            self.taps.append((x, y, tx, ty))
        self.device = DeviceId(0x056A, 0x00FA, None, "mock taps")
        self.geometry = DeviceGeometry(0, 95840, 0, 54260, 200.0, 200.0)
        self._queue = _ScheduledTaps()
        self._next = 0
        self._last_now = 0.0
        self.rng = np.random.default_rng(0)

    def show_target(self, index: int, xy: tuple[float, float],
                    tilt_hint: tuple[float, float] | None, step: str = "tap") -> None:
        if self._next >= len(self.taps):
            return
        x, y, tx, ty = self.taps[self._next]
        self._next += 1
        self._queue.tap(self.name, self._last_now + 0.05, (x, y), (tx, ty), 0.06, 0.0, self.rng)

    def poll(self, now: float) -> list[PenSample]:
        self._last_now = max(self._last_now, now)
        return self._queue.due(now)

    @property
    def exhausted(self) -> bool:
        return self._next >= len(self.taps) and not self._queue.pending

    def close(self) -> None:
        pass


class DriverSource:
    """A real (or drivers-mock) device through the drivers' pipeline, device-normalised."""

    def __init__(self, spec: str) -> None:
        self._source: PenSource = open_device(spec)
        self._driver = PenDriver(self._source, live=True)
        self.name = self._source.name
        desc = self._source.describe()
        vid, pid = int(desc.get("vid", 0) or 0), int(desc.get("pid", 0) or 0)
        serial = desc.get("serial") or None
        self.device = DeviceId(vid, pid, str(serial) if serial else None, desc.get("name"))
        r = self._source.ranges
        self.geometry = DeviceGeometry(r.x.minimum, r.x.maximum, r.y.minimum, r.y.maximum,
                                       r.x.resolution, r.y.resolution)
        self._ended = False
        self._gone: type[Exception] = DeviceGone  # EndOfStream (a recording ended) too

    def show_target(self, index: int, xy: tuple[float, float],
                    tilt_hint: tuple[float, float] | None, step: str = "tap") -> None:
        pass

    def poll(self, now: float) -> list[PenSample]:
        if self._ended:
            return []
        try:
            return self._driver.poll(0.0)
        except self._gone:
            self._ended = True
            return []

    @property
    def exhausted(self) -> bool:
        return self._ended

    def close(self) -> None:
        self._source.close()


def open_source(spec: str) -> CalibrationSource:
    """The calibration source a ``--device`` SPEC names."""
    if spec.startswith("mock-user:") or spec == "mock-user":
        return MockUserSource(spec.partition(":")[2])
    if spec.startswith("mock-taps:"):
        return MockTapsSource(spec.partition(":")[2])
    return DriverSource(spec)
