"""``station tablet-test``: what a pen sends, raw and normalised, as it moves.

The model behind both faces of the tester (the terminal lines and the glfw + imgui
window in :mod:`station.calibrate.tablettest_window`): one pen source (any device SPEC: evdev,
hidraw, hidapi, a UC-Logic tablet, a mock, a trace played in real time) read raw,
each raw sample shown beside the normalised sample the station makes of it, with
the pressure curve and the tip threshold the person is trying.  Changing either
renormalises from the next sample on; :meth:`TabletTester.save` writes them into
the device's calibration file (``~/.config/station/calibration/``), which
``station driver --calibration auto`` (the default) applies to that tablet.
"""

from __future__ import annotations

import collections
from dataclasses import dataclass, replace
from pathlib import Path

from station.calibration.errors import CalibrationError
from station.calibration.files import default_path, find_for_device, read_file, write_file
from station.calibration.model import Calibration, DeviceId
from station.calibration.pressure import LINEAR, PressureSettings
from station.drivers.normalise import Normaliser, NormaliserConfig
from station.drivers.pipeline import PenSource
from station.drivers.raw import Axis, RawSample
from station.errors import BadInput
from station.events import PenSample
from station.pressure import BezierCurve

TRAIL = 4000  # samples of the pen's trail kept (20 s at 200 Hz)
RAW_AXES = ("x", "y", "pressure", "tilt_x", "tilt_y", "distance", "rotation", "wheel")


@dataclass(frozen=True)
class TesterSettings:
    """What the person tries, exactly as a calibration file's ``pressure`` applies it
    in ``station driver`` (:class:`PressureSettings`): ``curve`` the Bézier control
    points ``(x1, y1, x2, y2)`` in [0, 1]; ``threshold`` the tip threshold, a fraction
    of the normalised pressure in [0, 0.9) below which the pen does not paint (0: the
    device's own contact)."""

    curve: tuple[float, float, float, float] = LINEAR
    threshold: float = 0.0

    def __post_init__(self) -> None:
        if len(self.curve) != 4 or not all(0.0 <= v <= 1.0 for v in self.curve):
            raise BadInput(f"pressure curve {self.curve} needs x1,y1,x2,y2 in [0, 1]",
                           "--pressure-curve")
        if not 0.0 <= self.threshold < 0.9:
            raise BadInput(f"tip threshold {self.threshold} must be in [0, 0.9)",
                           "--tip-threshold")

    def pressure(self) -> PressureSettings:
        return PressureSettings(self.threshold, 1.0, self.curve)


@dataclass(frozen=True)
class TrailPoint:
    """One point of the trail: device-normalised ``x``, ``y`` in [0, 1], ``pressure``
    in [0, 1] after the curve, ``touching``."""

    x: float
    y: float
    pressure: float
    touching: bool


class TabletTester:
    """Reads one pen source raw, normalises each sample with the settings tried."""

    def __init__(self, source: PenSource, settings: TesterSettings | None = None) -> None:
        self.source = source
        self.settings = settings or TesterSettings()
        # the driver's normaliser (linear), then the pressure shaping a calibration file
        # with these settings gives (station.calibration.model.Calibration.apply)
        self.normaliser = Normaliser(source.ranges, device=source.name,
                                     config=NormaliserConfig())
        self.shaping = self.settings.pressure()
        self.curve = BezierCurve(*self.settings.curve)
        self.last_in: float | None = None  # the last normalised pressure, before shaping
        self.trail: collections.deque[TrailPoint] = collections.deque(maxlen=TRAIL)
        self.last_raw: RawSample | None = None
        self.last_sample: PenSample | None = None
        self.raw_count = 0
        self.sample_count = 0

    # -- input ---------------------------------------------------------------------
    def poll(self, timeout: float | None = 0.01) -> list[tuple[RawSample, list[PenSample]]]:
        """The next report's raw samples, each with the samples it normalised to.
        ``EndOfStream``/``DeviceGone`` from the source end the test."""
        out = []
        for raw in self.source.read_raw(timeout):
            out.append((raw, self.feed(raw)))
        return out

    def feed(self, raw: RawSample) -> list[PenSample]:
        self.raw_count += 1
        self.last_raw = raw
        samples = [self._shape(s) for s in self.normaliser.feed(raw)]
        for s in samples:
            self.sample_count += 1
            self.last_sample = s
            if s.proximity:
                self.trail.append(TrailPoint(s.x, s.y, s.pressure, s.touching))
        return samples

    def _shape(self, s: PenSample) -> PenSample:
        if s.proximity:  # the live point stays where the pen left it
            self.last_in = s.pressure
        p = self.shaping
        touching = s.touching and s.pressure >= p.threshold
        return s.with_(touching=touching, pressure=p.map_one(s.pressure) if touching else 0.0)

    def apply(self, settings: TesterSettings) -> None:
        """Try other settings: samples from now on are shaped with them (the trail
        drawn so far stays as it was painted)."""
        self.settings = settings
        self.shaping = settings.pressure()
        self.curve = BezierCurve(*settings.curve)

    # -- what is shown -------------------------------------------------------------
    def raw_fields(self) -> list[tuple[str, str]]:
        """The last raw sample's fields by name, with each axis's range."""
        r = self.last_raw
        if r is None:
            return []
        ranges = self.source.ranges
        out = [("proximity", str(r.proximity)), ("tip", str(r.tip)),
               ("tool", r.tool.value if r.tool is not None else "-")]
        for name in RAW_AXES:
            value = getattr(r, name)
            axis: Axis | None = getattr(ranges, name, None)
            rng = f" [{axis.minimum}..{axis.maximum}]" if axis is not None else ""
            out.append((name, "-" if value is None else f"{value}{rng}"))
        out += [("buttons", f"{r.buttons:#06x}"),
                ("serial", "-" if r.serial is None else f"{r.serial:#x}"),
                ("tool_id", "-" if r.tool_id is None else f"{r.tool_id:#x}")]
        return out

    def sample_fields(self) -> list[tuple[str, str]]:
        """The last normalised sample's fields (session-log names and units)."""
        s = self.last_sample
        if s is None:
            return []
        return [("x", f"{s.x:.4f}"), ("y", f"{s.y:.4f}"), ("pressure", f"{s.pressure:.3f}"),
                ("tilt_x", f"{s.tilt_x:.1f} deg"), ("tilt_y", f"{s.tilt_y:.1f} deg"),
                ("proximity", str(s.proximity)), ("touching", str(s.touching)),
                ("tool", s.tool.value), ("buttons", str(s.buttons))]

    def live_point(self) -> tuple[float, float] | None:
        """The last pressure in and out of the shaping (the curve's live point)."""
        if self.last_in is None:
            return None
        return self.last_in, float(self.shaping.map_one(self.last_in))

    def curve_points(self, n: int = 64) -> list[tuple[float, float]]:
        """The shaping: normalised pressure in, painted pressure out, ``n`` points."""
        xs = [i / (n - 1) for i in range(n)]
        return [(x, float(self.shaping.map_one(x))) for x in xs]

    def line(self, raw: RawSample, samples: list[PenSample]) -> str:
        """One terminal line: raw fields, then the normalised sample."""
        if raw.proximity and not raw.valid:
            return f"{'raw in range (no data: tool identity only)':<52} | (no sample)"
        bits = [f"raw x={raw.x} y={raw.y}"]
        if raw.pressure is not None:
            bits.append(f"p={raw.pressure}")
        if raw.tilt_x is not None and raw.tilt_y is not None:
            bits.append(f"tilt={raw.tilt_x},{raw.tilt_y}")
        if raw.buttons:
            bits.append(f"buttons={raw.buttons:#x}")
        bits.append("tip" if raw.tip else ("in" if raw.proximity else "out"))
        norm = "; ".join(
            f"x={s.x:.3f} y={s.y:.3f} p={s.pressure:.3f} tilt={s.tilt_x:.0f},{s.tilt_y:.0f}"
            + (" touching" if s.touching else "") + ("" if s.proximity else " out")
            for s in samples) or "(no sample)"
        return f"{' '.join(bits):<52} | {norm}"

    # -- saving ----------------------------------------------------------------------
    def device_id(self) -> DeviceId:
        d = self.source.describe()
        return DeviceId(int(d.get("vid", 0)), int(d.get("pid", 0)), None,
                        str(d.get("product") or d.get("name") or ""))

    def save(self, directory: str | Path | None = None) -> Path:
        """Write the curve and the threshold into this device's calibration file (its
        mapping, area and tilt kept; a new file maps the whole tablet).  Returns where."""
        dev = self.device_id()
        found = find_for_device(dev.vid, dev.pid, None, directory)
        cal = Calibration(dev)
        if found is not None:
            try:
                cal = read_file(found)
            except CalibrationError as exc:
                raise BadInput(f"the calibration file there is damaged, not overwritten: "
                               f"{exc}", str(found)) from None
        s = self.settings
        pressure = replace(cal.pressure, threshold=s.threshold, curve=s.curve)
        if pressure.maximum <= pressure.threshold:
            pressure = replace(pressure, maximum=1.0)
        path = found or default_path(dev, directory)
        return write_file(cal.with_(pressure=PressureSettings(
            pressure.threshold, pressure.maximum, pressure.curve)), path)
