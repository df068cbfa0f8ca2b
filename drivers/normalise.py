"""Raw samples (device units) → normalised :class:`PenSample` (libinput-grade).

What it does, in order, for each raw sample:

* **forced proximity-out** (libinput's tablet proximity timer): a tool that
  sends nothing for ``proximity_timeout`` seconds (50 ms) is taken out of
  proximity — on the next report or on :meth:`Normaliser.tick`, both driven by
  transport time, so it is testable without sleeping — but never while the tip
  touches or a button is held (libinput re-arms the timer then: a USB or
  Bluetooth stall mid-stroke must not split the stroke), and never again once
  the device has sent a proximity-out of its own (it is then a device that
  reports leaving, and the timer is for those that do not);
* **tool identity** ``(type, serial, tool id)``: Wacom sends serial and tool id
  only at proximity-in; they are kept for the whole proximity and after it
  (devices that never repeat them keep the last ones); per-tool state (the
  worn-nib offset) is kept across proximity;
* **coordinates** to ``[0, 1]`` of the active area (default: the whole axis), clamped;
* **pressure**: worn-nib offset (on proximity-in a resting pressure ≤ 50 % of
  the range becomes the tool's new zero; lower resting values seen while
  hovering lower it); contact follows the device's tip switch where it has one
  (``RawSample.tip`` not ``None``; above a worn nib's resting pressure, as
  firmware that derives the tip bit from pressure would otherwise keep a
  worn nib in contact), else hysteresis (down at 5 %, up at 1 % of the range
  above the offset); the pressure is renormalised so the contact threshold
  (the offset for a tip switch, the down threshold otherwise) maps to 0 and
  grows continuously from there, then the cubic-Bézier pressure curve, if the
  config names one (:class:`station.pressure.PressureShaping`, the code a
  calibration's curve goes through too); 0 and ``touching=False`` out of contact;
* **tilt** in degrees (resolution in units per degree; without one the range
  maps to ±64°); a tilt or rotation axis that has never left its minimum is taken
  as absent (0° tilt, no rotation; said once in the log and in
  ``stats.absent_axes``): a pen that sends zero tilt bytes (the DTK-2241's)
  otherwise reads as fully tilted, and a brush that follows tilt paints with a
  phantom slant; rotation in degrees (without
  resolution the range maps to ±180°), distance and wheel to ``[0, 1]``;
* optional **smoothing** as an exponential filter with a time constant given
  in milliseconds of latency (off by default);
* sequence numbers and timestamps from the transport (``t`` counts from the
  first report, or from ``origin``);
* the optional ``transform`` hook last (device → canvas calibration); without
  one, the **mapping** to a canvas of known size: ``fit`` (the default) keeps
  the tablet's aspect ratio — the active area (in millimetres where the device
  gives a resolution) is letterboxed, centred, into the canvas so a circle on
  the tablet paints a circle — and ``stretch`` maps it onto the whole canvas.
  Without a canvas (``canvas=None``) samples stay device-normalised (what
  calibration and raw dumps need).

A sample that fails :class:`PenSample` validation is counted and dropped,
never published.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from station.drivers.raw import Axis, AxisRanges, RawSample

from station.errors import BadInput, EventError
from station.events import PenSample, Tool
from station.pressure import PressureShaping

log = logging.getLogger(__name__)


class NormaliserConfigError(BadInput):
    """A normaliser setting is out of range."""


MAPPINGS = ("fit", "stretch")
"""Device → canvas mappings without a calibration (see :class:`NormaliserConfig`)."""


@dataclass(frozen=True)
class NormaliserConfig:
    """Normaliser settings.

    Attributes:
        area: active area ``(x0, y0, x1, y1)`` in device units; ``None`` = whole tablet.
        tip_down: pressure fraction (of the range above the offset) that starts contact.
        tip_up: pressure fraction that ends contact (< ``tip_down``).
        worn_nib: detect the worn-nib offset on proximity-in.
        worn_nib_max: largest resting pressure (fraction of range) taken as an offset.
        proximity_timeout: seconds without reports before a forced proximity-out;
            ``None`` disables it.
        smoothing_ms: time constant of the position filter in ms (0 = off).
        pressure_curve: Bézier control points ``(x1, y1, x2, y2)`` in ``[0, 1]``;
            ``None`` = linear.
        tilt_range_degrees: degrees the tilt range maps to when there is no resolution.
        validate: build samples through the full PenSample constructor (slower);
            by default the normaliser checks the same ranges with plain comparisons.
        mapping: ``"fit"`` (keep the tablet's aspect ratio, letterboxed) or
            ``"stretch"`` (the whole area onto the whole canvas); used only with a
            ``canvas`` and without a ``transform`` (a calibration is the mapping).
        canvas: ``(width, height)`` of the canvas the samples are for (cells or
            pixels: only the ratio counts); ``None`` = device-normalised samples.
    """

    area: tuple[float, float, float, float] | None = None
    tip_down: float = 0.05
    tip_up: float = 0.01
    worn_nib: bool = True
    worn_nib_max: float = 0.5
    proximity_timeout: float | None = 0.05
    smoothing_ms: float = 0.0
    pressure_curve: tuple[float, float, float, float] | None = None
    tilt_range_degrees: float = 64.0
    validate: bool = False
    mapping: str = "fit"
    canvas: tuple[int, int] | None = None

    def __post_init__(self) -> None:
        if not 0.0 < self.tip_up < self.tip_down < 1.0:
            raise NormaliserConfigError(
                f"need 0 < tip_up ({self.tip_up}) < tip_down ({self.tip_down}) < 1")
        if not 0.0 <= self.worn_nib_max < 1.0:
            raise NormaliserConfigError(f"worn_nib_max {self.worn_nib_max} must be in [0, 1)")
        if self.proximity_timeout is not None and not self.proximity_timeout > 0:
            raise NormaliserConfigError("proximity_timeout must be > 0 seconds or None")
        if not (math.isfinite(self.smoothing_ms) and 0.0 <= self.smoothing_ms <= 1000.0):
            raise NormaliserConfigError(f"smoothing {self.smoothing_ms} ms must be 0..1000")
        curve = self.pressure_curve
        if curve is not None and (len(curve) != 4 or not all(
                isinstance(v, (int, float)) and 0.0 <= v <= 1.0 for v in curve)):
            raise NormaliserConfigError(f"pressure curve {curve} needs x1,y1,x2,y2 in [0, 1]")
        if self.area is not None:
            x0, y0, x1, y1 = self.area
            if not (x1 > x0 and y1 > y0):
                raise NormaliserConfigError(f"active area {self.area} is empty")
        if self.mapping not in MAPPINGS:
            raise NormaliserConfigError(
                f"mapping {self.mapping!r} is not one of {', '.join(MAPPINGS)}")
        if self.canvas is not None and not (
                len(self.canvas) == 2 and all(isinstance(v, (int, float)) and math.isfinite(v)
                                              and v > 0 for v in self.canvas)):
            raise NormaliserConfigError(f"canvas {self.canvas} needs a positive width, height")


ToolKey = tuple[Tool, int | None, int | None]


@dataclass
class ToolState:
    """Per-tool state kept across proximity: the worn-nib pressure offset (device units)."""

    pressure_offset: int = 0


@dataclass
class NormaliserStats:
    """Counters of what the normaliser did (all plain integers)."""

    raw: int = 0
    samples: int = 0
    rejected: int = 0
    forced_out: int = 0
    nib_offsets: int = 0
    time_backwards: int = 0
    tool_changes: int = 0  # tools replaced while in proximity (old one left first)
    reasons: dict[str, int] = field(default_factory=dict)
    absent_axes: list[str] = field(default_factory=list)  # stuck at their minimum so far


def _other_tool(before: ToolKey, after: ToolKey) -> bool:
    """A different physical tool: another type, or another serial / tool id where both
    are known (a serial that only appears later is the same tool, not a new one)."""
    if before[0] != after[0]:
        return True
    return any(b is not None and a is not None and a != b
               for b, a in zip(before[1:], after[1:], strict=True))


def _unit(value: int, axis: Axis) -> float:
    span = axis.span or 1
    return min(1.0, max(0.0, (value - axis.minimum) / span))


class Normaliser:
    """Turns one device's raw samples into pen samples (see module docstring).

    Args:
        ranges: the device's axes.
        device: device name published in the samples (no dots or spaces).
        config: settings.
        origin: transport time that maps to ``t = 0`` (default: the first report).
        transform: applied last to each sample (calibration); raising
            :class:`EventError` drops and counts the sample.
        on_device_sample: receives each device-normalised sample before ``transform``.
        t_offset: seconds added to every ``t`` (a driver that reopens a device
            continues its session time instead of starting again at 0).
    """

    def __init__(
        self,
        ranges: AxisRanges,
        device: str = "pen-0",
        config: NormaliserConfig | None = None,
        origin: float | None = None,
        transform: Callable[[PenSample], PenSample] | None = None,
        on_device_sample: Callable[[PenSample], None] | None = None,
        t_offset: float = 0.0,
    ) -> None:
        self.ranges = ranges
        self.t_offset = t_offset
        self.device = device
        self.config = config or NormaliserConfig()
        self.origin = origin
        self.transform = transform
        self.on_device_sample = on_device_sample
        self.stats = NormaliserStats()
        self.tools: dict[ToolKey, ToolState] = {}
        cfg = self.config
        # Shaped by the code a calibration's curve goes through (station.pressure);
        # station driver gives a device one curve, never this one and a calibration's.
        self.pressure = PressureShaping(curve=cfg.pressure_curve) if cfg.pressure_curve \
            else None
        if cfg.area is not None:
            x0, y0, x1, y1 = cfg.area
            self._area = (float(x0), float(y0), float(x1), float(y1))
        else:
            self._area = (float(ranges.x.minimum), float(ranges.y.minimum),
                          float(ranges.x.maximum), float(ranges.y.maximum))
        self._fit = self._fit_scale()
        self._seq = 0
        self._in_prox = False
        self._touching = False
        self._buttons = 0
        self._device_sends_out = False  # a real proximity-out seen: no forced ones
        self._last_time: float | None = None
        self._last_t = t_offset
        self._last: PenSample | None = None
        self._tool = Tool.PEN
        self._serial: int | None = None
        self._tool_id: int | None = None
        self._pressure: int | None = None
        self._smooth: tuple[float, float, float] | None = None  # (x, y, time)
        self._alive: set[str] = set()  # axes seen away from their minimum

    def _fit_scale(self) -> tuple[float, float] | None:
        """Factors that letterbox the area into the canvas (``fit``), or None."""
        cfg = self.config
        if cfg.canvas is None or cfg.mapping != "fit" or self.transform is not None:
            return None
        x0, y0, x1, y1 = self._area
        w, h = x1 - x0, y1 - y0
        r = self.ranges
        if r.has_resolution:  # millimetres; without a resolution the units are taken square
            w, h = w / float(r.x.resolution or 1.0), h / float(r.y.resolution or 1.0)
        tablet = w / h if h > 0 else 1.0
        canvas = cfg.canvas[0] / cfg.canvas[1]
        if tablet >= canvas:  # wider than the canvas: bands above and below
            return 1.0, canvas / tablet
        return tablet / canvas, 1.0

    # -- public API -------------------------------------------------------
    @property
    def can_map_mm(self) -> bool:
        """False when the device has no x/y resolution (normalised units only)."""
        return self.ranges.has_resolution

    @property
    def last_t(self) -> float:
        """``t`` of the last sample emitted (session seconds)."""
        return self._last_t

    @property
    def in_proximity(self) -> bool:
        return self._in_prox

    def tool_key(self) -> ToolKey:
        return (self._tool, self._serial, self._tool_id)

    def feed(self, raw: RawSample, t_mono: float = 0.0) -> list[PenSample]:
        """Normalise one raw sample; returns 0, 1 or 2 samples (a forced out first)."""
        self.stats.raw += 1
        out: list[PenSample] = []
        time, proximity = raw.time, raw.proximity  # read once (a named tuple's fields)
        if self.origin is None:
            self.origin = time
        due = self._forced_out_due(time)
        if due is not None:
            self._force_out(due, out)
        last_time = self._last_time
        if last_time is not None and time < last_time:
            self.stats.time_backwards += 1
        self._last_time = time if last_time is None else max(time, last_time)
        before = self.tool_key()
        if proximity:  # an out report names no tool: the one in proximity leaves
            self._update_identity(raw)
        if self._in_prox and proximity and _other_tool(before, self.tool_key()):
            # A new tool while the old one is in proximity (a pen flipped to its eraser
            # end without an out report): the old tool leaves first, as the kernel's
            # hid-input releases it in a frame of its own and libinput reports it.
            after = self.tool_key()
            self._tool, self._serial, self._tool_id = before
            self._leave(time, out, t_mono)
            self._tool, self._serial, self._tool_id = after
            self.stats.tool_changes += 1
        if not proximity:
            self._device_sends_out = True  # libinput: a real BTN_TOOL_PEN 0 unloads the timer
            if self._in_prox:
                self._leave(time, out, t_mono)
            return out
        if not raw.valid:
            return out  # in range without data / proximity-in packet: identity only
        entering = not self._in_prox
        self._in_prox = True
        self._buttons = raw.buttons & 0xFFFF  # a held button re-arms the proximity timer
        sample = self._make(raw, entering, t_mono)
        if sample is not None:
            self._emit(sample, out)
        return out

    def tick(self, now: float) -> list[PenSample]:
        """Call when no report came: forces proximity-out once ``now`` is past the timeout."""
        out: list[PenSample] = []
        due = self._forced_out_due(now)
        if due is not None:
            self._force_out(due, out)
        return out

    def _forced_out_due(self, now: float) -> float | None:
        """libinput's proximity timer: the time of a forced proximity-out due by ``now``,
        or None (not due, re-armed by contact or a held button, or unloaded)."""
        timeout = self.config.proximity_timeout
        if (not self._in_prox or timeout is None or self._last_time is None
                or self._device_sends_out or self._touching or self._buttons):
            return None
        return self._last_time + timeout if now - self._last_time > timeout else None

    def flush(self) -> list[PenSample]:
        """End of stream: a tool in proximity leaves it (timeout after its last report)."""
        out: list[PenSample] = []
        if self._in_prox and self._last_time is not None:
            self._force_out(self._last_time + (self.config.proximity_timeout or 0.0), out)
        return out

    # -- internals --------------------------------------------------------
    def _update_identity(self, raw: RawSample) -> None:
        tool, eraser = raw.tool, raw.eraser
        if tool is not None:
            self._tool = tool
        if eraser and self._tool in (Tool.PEN, Tool.PENCIL, Tool.BRUSH):
            self._tool = Tool.ERASER
        elif not eraser and tool is None and self._tool is Tool.ERASER and \
                raw.proximity and raw.valid and not self._in_prox:
            # Generic HID: the invert bit cleared on a new proximity means the tip end.
            self._tool = Tool.PEN
        serial, tool_id = raw.serial, raw.tool_id
        if serial is not None:
            self._serial = serial
        if tool_id is not None:
            self._tool_id = tool_id

    def _tool_state(self) -> ToolState:
        key = self.tool_key()
        state = self.tools.get(key)
        if state is None:
            state = self.tools[key] = ToolState()
        return state

    def _time(self, time: float) -> float:
        origin = self.origin if self.origin is not None else time
        t = max(0.0, time - origin) + self.t_offset
        return max(t, self._last_t)

    def _force_out(self, time: float, out: list[PenSample]) -> None:
        self.stats.forced_out += 1
        self._leave(time, out, 0.0)

    def _leave(self, time: float, out: list[PenSample], t_mono: float) -> None:
        self._in_prox = False
        self._touching = False
        self._buttons = 0
        self._smooth = None
        last = self._last
        if last is None:
            return
        try:
            sample = PenSample(
                t=self._time(time), device=self.device, tool=self._tool, x=last.x, y=last.y,
                pressure=0.0, tilt_x=last.tilt_x, tilt_y=last.tilt_y, proximity=False,
                touching=False, buttons=0, serial=self._serial, seq=self._next_seq(),
                t_mono=t_mono, tool_id=self._tool_id,
            )
        except EventError as exc:
            self._reject(str(exc))
            return
        self._emit(sample, out)

    def _next_seq(self) -> int:
        self._seq += 1
        return self._seq

    def _reject(self, reason: str) -> None:
        self.stats.rejected += 1
        key = reason.split(" ", 1)[0]
        self.stats.reasons[key] = self.stats.reasons.get(key, 0) + 1

    def _emit(self, sample: PenSample, out: list[PenSample]) -> None:
        self._last = sample
        self._last_t = sample.t
        if self.on_device_sample is not None:
            self.on_device_sample(sample)
        if self.transform is not None:
            try:
                sample = self.transform(sample)
            except EventError as exc:
                self._reject(f"transform {exc}")
                return
        elif self._fit is not None:
            sx, sy = self._fit
            sample = dataclasses.replace(sample, x=0.5 + (sample.x - 0.5) * sx,
                                         y=0.5 + (sample.y - 0.5) * sy)
        self.stats.samples += 1
        out.append(sample)

    def _pressure_and_contact(self, raw: RawSample, entering: bool) -> tuple[float, bool]:
        axis = self.ranges.pressure
        if axis is None:
            touching = bool(raw.tip)
            self._touching = touching
            return (1.0 if touching else 0.0), touching
        if raw.pressure is not None:
            self._pressure = raw.pressure
        if self._pressure is None:
            return 0.0, False
        cfg = self.config
        full = axis.span or 1
        p = min(max(self._pressure - axis.minimum, 0), full)
        state = self._tool_state()
        if cfg.worn_nib:
            resting = raw.tip is not True and not (
                raw.distance is not None and self.ranges.distance is not None
                and raw.distance <= self.ranges.distance.minimum)
            if entering and resting and p <= cfg.worn_nib_max * full:
                if p != state.pressure_offset and p > 0:
                    self.stats.nib_offsets += 1
                state.pressure_offset = p
            elif not self._touching and p < state.pressure_offset:
                state.pressure_offset = p
        offset = state.pressure_offset
        span = max(full - offset, 1)
        down = offset + cfg.tip_down * span
        up = offset + cfg.tip_up * span
        if raw.tip is not None:
            # The tip switch rules contact, so its first sample is never dropped for a
            # pressure below the hysteresis threshold.  A worn nib rests above zero and
            # firmware that derives the bit from pressure (Intuos: > 10) then reports a
            # hovering pen as touching: above an offset the pressure must clear it too.
            touching = raw.tip and (offset == 0 or p >= up)
            zero = float(offset) if offset == 0 else up
        else:
            touching = p >= up if self._touching else p >= down
            zero = down
        self._touching = touching
        if not touching:
            return 0.0, False
        value = min(1.0, max(0.0, (p - zero) / max(full - zero, 1e-9)))
        if self.pressure is not None:
            value, _ = self.pressure(value, True)
        return value, True

    def _stuck(self, value: int, axis: Axis, name: str) -> bool:
        """Whether ``name`` has never left its minimum (then it is taken as absent,
        said once); the first other value makes it a real axis for good."""
        if name in self._alive:
            return False
        if value == axis.minimum:  # never moved: a pen without this axis, not a slant
            if name not in self.stats.absent_axes:
                self.stats.absent_axes.append(name)
                log.warning("%s: %s stays at its minimum (%d): taken as absent until it "
                            "moves", self.device, name, value)
            return True
        self._alive.add(name)
        if name in self.stats.absent_axes:
            self.stats.absent_axes.remove(name)
            log.warning("%s: %s moved after all: reported from now on", self.device, name)
        return False

    def _tilt(self, value: int | None, axis: Axis | None, name: str) -> float:
        if value is None or axis is None or self._stuck(value, axis, name):
            return 0.0
        if axis.resolution:
            deg = value / axis.resolution
        else:
            span = axis.span or 1
            deg = ((value - axis.minimum) / span * 2.0 - 1.0) * self.config.tilt_range_degrees
        return min(90.0, max(-90.0, deg))

    def _rotation(self, value: int | None) -> float | None:
        axis = self.ranges.rotation
        if value is None or axis is None or self._stuck(value, axis, "rotation"):
            return None
        if axis.resolution:
            deg = value / axis.resolution
        else:
            deg = (value - axis.minimum) / (axis.span or 1) * 360.0 - 180.0
        return min(360.0, max(-360.0, deg))

    def _position(self, raw: RawSample, entering: bool) -> tuple[float, float]:
        x0, y0, x1, y1 = self._area
        x = min(1.0, max(0.0, (raw.x - x0) / (x1 - x0 or 1.0)))
        y = min(1.0, max(0.0, (raw.y - y0) / (y1 - y0 or 1.0)))
        tau = self.config.smoothing_ms / 1000.0
        if tau <= 0.0:
            return x, y
        if entering or self._smooth is None:
            self._smooth = (x, y, raw.time)
            return x, y
        sx, sy, st = self._smooth
        dt = max(0.0, raw.time - st)
        alpha = 1.0 - math.exp(-dt / tau)
        sx += alpha * (x - sx)
        sy += alpha * (y - sy)
        self._smooth = (sx, sy, raw.time)
        return sx, sy

    def _make(self, raw: RawSample, entering: bool, t_mono: float) -> PenSample | None:
        r = self.ranges
        try:
            x, y = self._position(raw, entering)
            pressure, touching = self._pressure_and_contact(raw, entering)
            values: dict[str, Any] = {  # PenSample's fields: typed where PenSample checks them
                "t": self._time(raw.time),
                "device": self.device,
                "tool": self._tool,
                "x": x,
                "y": y,
                "pressure": pressure,
                "tilt_x": self._tilt(raw.tilt_x, r.tilt_x, "tilt_x"),
                "tilt_y": self._tilt(raw.tilt_y, r.tilt_y, "tilt_y"),
                "proximity": True,
                "touching": touching,
                "buttons": raw.buttons & 0xFFFF,
                "serial": self._serial,
                "rotation": self._rotation(raw.rotation),
                "distance": (_unit(raw.distance, r.distance)
                             if raw.distance is not None and r.distance else None),
                "wheel": _unit(raw.wheel, r.wheel)
                if raw.wheel is not None and r.wheel else None,
                "seq": self._next_seq(),
                "t_mono": t_mono,
                "tool_id": self._tool_id,
            }
            if self.config.validate:
                return PenSample(**values)
            return _checked_sample(values)
        except (EventError, ValueError, OverflowError, TypeError) as exc:
            self._reject(str(exc))
            return None


_PEN_FIELDS = tuple(f.name for f in dataclasses.fields(PenSample))
_PEN_DEFAULTS = {f.name: f.default for f in dataclasses.fields(PenSample)
                 if f.default is not dataclasses.MISSING}
# The slot descriptors' __set__ writes a frozen dataclass's slot directly (what
# object.__setattr__ does, without the attribute lookup per field).
_PEN_SLOTS = tuple((name, getattr(PenSample, name).__set__) for name in _PEN_FIELDS)
_UNIT_FIELDS = ("x", "y", "pressure")
_OPTIONAL_UNIT_FIELDS = ("distance", "wheel")


def _checked_sample(values: dict[str, Any]) -> PenSample:
    """A PenSample from values the normaliser made, with a cheap range check.

    Every number here was clamped on the way, so the full constructor
    validation (the largest cost per sample) is replaced by the same range
    checks done with plain comparisons (NaN fails every one of them).  Values
    that fail go through the constructor, which raises :class:`EventError`.
    """
    ok = 0.0 <= values["t"] < 1e12 and -90.0 <= values["tilt_x"] <= 90.0 \
        and -90.0 <= values["tilt_y"] <= 90.0
    for name in _UNIT_FIELDS:
        ok = ok and 0.0 <= values[name] <= 1.0
    for name in _OPTIONAL_UNIT_FIELDS:
        v = values[name]
        ok = ok and (v is None or 0.0 <= v <= 1.0)
    rot, serial, tool_id = values["rotation"], values["serial"], values["tool_id"]
    ok = ok and (rot is None or -360.0 <= rot <= 360.0)
    ok = ok and (serial is None or 0 <= serial < 1 << 64)
    ok = ok and (tool_id is None or 0 <= tool_id < 1 << 32)
    ok = ok and (values["touching"] is False or values["proximity"] is True)
    if not ok:
        return PenSample(**values)  # raises EventError naming the bad field
    sample = object.__new__(PenSample)
    for name, set_slot in _PEN_SLOTS:
        set_slot(sample, values[name] if name in values else _PEN_DEFAULTS[name])
    return sample
