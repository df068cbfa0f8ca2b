"""The pen-event model: normalised pen samples and commands.

Every driver turns what its device reports into :class:`PenSample` values; the
simulation, the session log and the bus all speak this one type.  Values are
validated on construction, so a sample that exists is a sample that is right:
out-of-range numbers, NaN and unknown tools raise :class:`EventError`.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field, replace
from typing import Any

from station.errors import EventError


class Tool(str, enum.Enum):
    """What is in proximity: the vocabulary of the session log's ``tool`` key."""

    PEN = "pen"
    ERASER = "eraser"
    BRUSH = "brush"
    PENCIL = "pencil"
    AIRBRUSH = "airbrush"
    MOUSE = "mouse"
    LENS = "lens"
    FINGER = "finger"

    @classmethod
    def parse(cls, value: object, where: str | None = None) -> Tool:
        if isinstance(value, Tool):
            return value
        try:
            return cls(value)
        except ValueError:
            names = ", ".join(t.value for t in cls)
            raise EventError(f"unknown tool {value!r} (one of {names})", where) from None


TOOL_CODES: tuple[Tool, ...] = tuple(Tool)
"""Stable small-integer codes of the tools, used by the wire format."""


class Button(enum.IntFlag):
    """Bits of :attr:`PenSample.buttons`."""

    STYLUS = 1  # first barrel button (BTN_STYLUS, HID Barrel Switch)
    STYLUS2 = 2  # second barrel button (BTN_STYLUS2, Secondary Barrel Switch)
    STYLUS3 = 4  # third barrel button (Pro Pen 3D)
    PAD = 8  # any express key seen with the pen (informative)


BUTTON_MASK = 0xFFFF


def _check_finite(name: str, value: object, lo: float, hi: float, where: str | None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise EventError(f"{name} must be a number, got {value!r}", where)
    try:
        v = float(value)
    except OverflowError:  # an integer of hundreds of digits
        raise EventError(f"{name} is too large a number", where) from None
    if math.isnan(v) or math.isinf(v):
        raise EventError(f"{name} is {v}, not a finite number", where)
    if not lo <= v <= hi:
        raise EventError(f"{name}={v} outside [{lo}, {hi}]", where)
    return v


@dataclass(frozen=True, slots=True)
class PenSample:
    """One normalised pen sample.

    Attributes:
        t: seconds since the session (or publisher) start, >= 0.
        device: name of the publishing device, e.g. ``"mock-0"``; no dots or spaces.
        tool: the tool in proximity.
        serial: the tool's serial number, ``None`` where the device has none.
        x: horizontal position in ``[0, 1]``, origin left (canvas-normalised once
            calibration is applied, device-normalised in a raw dump).
        y: vertical position in ``[0, 1]``, origin top, y down.
        pressure: tip pressure in ``[0, 1]``; 0 when not touching.
        tilt_x: degrees in ``[-90, 90]``; positive = pen top leaning right.
        tilt_y: degrees in ``[-90, 90]``; positive = pen top leaning toward the user.
        proximity: the tool is in range of the sensor.
        touching: the tip is in contact (after hysteresis).
        buttons: bit set of :class:`Button`.
        rotation: barrel rotation / twist in degrees ``[-360, 360]`` (Art Pen), or None.
        distance: hover distance in ``[0, 1]`` of the device range, or None.
        wheel: airbrush finger wheel in ``[0, 1]``, or None.
        seq: per-publisher sequence number, >= 0 (0 where unknown).
        t_mono: ``time.monotonic()`` seconds when the sample was read, or 0.0.
        tool_id: the device's tool type id (Wacom tool id), or None.
    """

    t: float
    device: str
    tool: Tool
    x: float
    y: float
    pressure: float = 0.0
    tilt_x: float = 0.0
    tilt_y: float = 0.0
    proximity: bool = True
    touching: bool = False
    buttons: int = 0
    serial: int | None = None
    rotation: float | None = None
    distance: float | None = None
    wheel: float | None = None
    seq: int = 0
    t_mono: float = 0.0
    tool_id: int | None = None
    where: str | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if self.where is None and _plainly_valid(self):
            return  # the common case, checked in one expression (the bus decodes ~1e5/s)
        self._validate()

    def _validate(self) -> None:
        w = self.where
        set_ = object.__setattr__
        set_(self, "t", _check_finite("t", self.t, 0.0, 1e12, w))
        if not isinstance(self.device, str) or not self.device or len(self.device) > 64:
            raise EventError(f"device must be a name of 1..64 characters, got {self.device!r}", w)
        if any(c in self.device for c in ". \t\n\0"):
            raise EventError(f"device name {self.device!r} must not hold dots or spaces", w)
        set_(self, "tool", Tool.parse(self.tool, w))
        set_(self, "x", _check_finite("x", self.x, 0.0, 1.0, w))
        set_(self, "y", _check_finite("y", self.y, 0.0, 1.0, w))
        set_(self, "pressure", _check_finite("pressure", self.pressure, 0.0, 1.0, w))
        set_(self, "tilt_x", _check_finite("tilt_x", self.tilt_x, -90.0, 90.0, w))
        set_(self, "tilt_y", _check_finite("tilt_y", self.tilt_y, -90.0, 90.0, w))
        for name in ("proximity", "touching"):
            if not isinstance(getattr(self, name), bool):
                raise EventError(f"{name} must be true or false, got {getattr(self, name)!r}", w)
        if self.touching and not self.proximity:
            raise EventError("touching requires proximity", w)
        if (
            isinstance(self.buttons, bool)
            or not isinstance(self.buttons, int)
            or not 0 <= self.buttons <= BUTTON_MASK
        ):
            raise EventError(f"buttons must be a bit set 0..65535, got {self.buttons!r}", w)
        if self.serial is not None and (
            isinstance(self.serial, bool)
            or not isinstance(self.serial, int)
            or not 0 <= self.serial < 2**64
        ):
            raise EventError(f"serial must be null or an unsigned integer, got {self.serial!r}", w)
        if self.tool_id is not None and (
            isinstance(self.tool_id, bool)
            or not isinstance(self.tool_id, int)
            or not 0 <= self.tool_id < 2**32
        ):
            raise EventError(f"tool_id must be null or an unsigned int, got {self.tool_id!r}", w)
        if self.rotation is not None:
            set_(self, "rotation", _check_finite("rotation", self.rotation, -360.0, 360.0, w))
        if self.distance is not None:
            set_(self, "distance", _check_finite("distance", self.distance, 0.0, 1.0, w))
        if self.wheel is not None:
            set_(self, "wheel", _check_finite("wheel", self.wheel, 0.0, 1.0, w))
        if isinstance(self.seq, bool) or not isinstance(self.seq, int) or not 0 <= self.seq < 2**64:
            raise EventError(f"seq must be an unsigned integer, got {self.seq!r}", w)
        set_(self, "t_mono", _check_finite("t_mono", self.t_mono, 0.0, 1e12, w))
        set_(self, "where", None)

    def with_(self, **changes: Any) -> PenSample:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    # -- session-log JSON -------------------------------------------------
    def to_record(self) -> dict[str, object]:
        """The session-log ``pen`` record (interfaces.md)."""
        rec: dict[str, object] = {
            "type": "pen",
            "t": self.t,
            "device": self.device,
            "tool": self.tool.value,
            "serial": self.serial,
            "x": self.x,
            "y": self.y,
            "pressure": self.pressure,
            "tilt_x": self.tilt_x,
            "tilt_y": self.tilt_y,
            "proximity": self.proximity,
            "touching": self.touching,
            "buttons": self.buttons,
        }
        for name in ("rotation", "distance", "wheel", "tool_id"):
            value = getattr(self, name)
            if value is not None:
                rec[name] = value
        if self.seq:
            rec["seq"] = self.seq
        return rec

    @classmethod
    def from_record(
        cls, rec: dict[str, Any], where: str | None = None, unknown: list[str] | None = None
    ) -> PenSample:
        """Build from a session-log ``pen`` record.

        Unknown keys are collected into ``unknown`` (the caller warns); missing
        required keys raise :class:`EventError`.
        """
        required = ("t", "device", "tool", "x", "y", "pressure", "proximity", "touching")
        missing = [k for k in required if k not in rec]
        if missing:
            raise EventError(f"pen record lacks {', '.join(missing)}", where)
        known = _PEN_RECORD_KEYS
        if unknown is not None:
            unknown.extend(k for k in rec if k not in known)
        return cls(
            t=rec["t"],
            device=rec["device"],
            tool=Tool.parse(rec["tool"], where),
            x=rec["x"],
            y=rec["y"],
            pressure=rec["pressure"],
            tilt_x=rec.get("tilt_x", 0.0),
            tilt_y=rec.get("tilt_y", 0.0),
            proximity=rec["proximity"],
            touching=rec["touching"],
            buttons=rec.get("buttons", 0),
            serial=rec.get("serial"),
            rotation=rec.get("rotation"),
            distance=rec.get("distance"),
            wheel=rec.get("wheel"),
            seq=rec.get("seq", 0),
            tool_id=rec.get("tool_id"),
            where=where,
        )


def _plainly_valid(s: PenSample) -> bool:
    """True when every field already has its exact type and range (NaN fails every test)."""
    f = float
    return (
        type(s.t) is f and 0.0 <= s.t <= 1e12
        and type(s.x) is f and 0.0 <= s.x <= 1.0
        and type(s.y) is f and 0.0 <= s.y <= 1.0
        and type(s.pressure) is f and 0.0 <= s.pressure <= 1.0
        and type(s.tilt_x) is f and -90.0 <= s.tilt_x <= 90.0
        and type(s.tilt_y) is f and -90.0 <= s.tilt_y <= 90.0
        and type(s.t_mono) is f and 0.0 <= s.t_mono <= 1e12
        and type(s.tool) is Tool
        and type(s.proximity) is bool and type(s.touching) is bool
        and (s.proximity or not s.touching)
        and type(s.buttons) is int and 0 <= s.buttons <= BUTTON_MASK
        and type(s.seq) is int and 0 <= s.seq < 2**64
        and type(s.device) is str and 0 < len(s.device) <= 64
        and "." not in s.device and " " not in s.device and "\t" not in s.device
        and "\n" not in s.device and "\0" not in s.device
        and s.serial is None and s.tool_id is None
        and s.rotation is None and s.distance is None and s.wheel is None
    )  # fmt: skip


_PEN_RECORD_KEYS = frozenset(
    {
        "type", "t", "device", "tool", "serial", "x", "y", "pressure", "tilt_x", "tilt_y",
        "proximity", "touching", "buttons", "rotation", "distance", "wheel", "seq", "tool_id",
    }
)  # fmt: skip


KNOWN_COMMANDS = frozenset(
    {"brush", "profile", "wait", "dry", "new_layer", "clear", "tissue", "eraser", "mask",
     "diffusion", "palette", "stop", "save", "hairdryer", "mask_remove", "tilt",
     "undo", "redo", "well"}
)  # fmt: skip
"""Command names the station knows today; others pass with a warning (forward-compatible)."""


@dataclass(frozen=True, slots=True)
class Command:
    """A command record: ``{"type": "cmd", "t": s, "cmd": NAME, "args": {...}}``.

    Attributes:
        t: seconds since the session start, >= 0.
        cmd: the command name (``brush``, ``wait``, ``dry`` …).
        args: JSON-compatible arguments, validated by whoever executes the command.
    """

    t: float
    cmd: str
    args: dict[str, Any] = field(default_factory=dict)
    where: str | None = field(default=None, compare=False, repr=False)
    # on the bus only: where the taking process answers (station.answer); never logged
    reply: dict[str, object] | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        w = self.where
        object.__setattr__(self, "t", _check_finite("t", self.t, 0.0, 1e12, w))
        if not isinstance(self.cmd, str) or not self.cmd.isidentifier():
            raise EventError(f"cmd must be a command name, got {self.cmd!r}", w)
        if not isinstance(self.args, dict):
            raise EventError(f"args of {self.cmd!r} must be an object, got {self.args!r}", w)
        object.__setattr__(self, "where", None)

    @property
    def known(self) -> bool:
        return self.cmd in KNOWN_COMMANDS

    def to_record(self) -> dict[str, object]:
        rec: dict[str, object] = {"type": "cmd", "t": self.t, "cmd": self.cmd, "args": self.args}
        if self.reply is not None:
            rec["reply"] = self.reply
        return rec

    @classmethod
    def from_record(cls, rec: dict[str, Any], where: str | None = None) -> Command:
        if "t" not in rec or "cmd" not in rec:
            raise EventError("cmd record needs 't' and 'cmd'", where)
        reply = rec.get("reply")
        return cls(t=rec["t"], cmd=rec["cmd"], args=rec.get("args", {}) or {}, where=where,
                   reply=reply if isinstance(reply, dict) else None)
