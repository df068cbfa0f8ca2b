"""Wacom Intuos family protocol (Intuos3 and later, Cintiq): report 2 (or 16), 10 bytes used.

Byte layout (d[0] is the report ID; as in the kernel's wacom_wac.c):

- ``d[1] & 0xfc == 0xc0``: tool enters proximity; serial and tool id in d[2..8];
- ``d[1] & 0xfe == 0x20``: in range, no valid data;
- ``d[1] & 0xfe == 0x80``: tool leaves proximity;
- otherwise a data packet of type ``(d[1] >> 1) & 0xf``: 0-3 pen (x, y with
  an extra low bit in d[9], 11-bit pressure, tilt, distance, side buttons),
  5 Art Pen rotation, 0xa airbrush wheel, 4/6 mouse, 8/0xc lens.

The protocol is stateful: the proximity-in packet names the tool (id and
serial) for the packets that follow, and a packet only carries the values of
its type.  :class:`IntuosState` holds that state explicitly; each emitted
:class:`RawSample` is the full pen state after the packet (like an evdev
frame).  Data packets before any proximity-in are dropped (counted), as the
kernel does.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from station.drivers.devicedata import DeviceModel
from station.drivers.hid.base import ReportParser
from station.drivers.raw import Axis, AxisRanges, RawSample
from station.drivers.wacom.common import WacomParams, check_length, unknown_id
from station.drivers.wacom.modes import PEN_MODE_FEATURE
from station.drivers.wacom.tools import tool_from_id

from station.events import Button, Tool

REPORT_LENGTH = 10  # the bytes the protocol uses (d[0]..d[9])
# Lengths a pen report arrives with: 10 (Intuos3/4, Cintiq) or 16 (Intuos5 and Intuos
# Pro 0x314-0x317 declare report 2 as 16 bytes; the kernel's wacom_intuos_irq reads
# d[0..9] whatever the length).
PEN_LENGTHS = tuple(range(REPORT_LENGTH, 17))
TOUCH_LENGTH = 64  # WACOM_PKGLEN_BBTOUCH3: Intuos5/Pro touch frames (kernel wacom_wac_irq)
STATUS_REPORT_ID = 192  # WACOM_REPORT_USB: wireless/USB status, not a pen report
PEN_REPORT_IDS = frozenset({2, 16})  # 2: WACOM_REPORT_PENABLED, 16: Intuos/Cintiq pen
ROTATION_AXIS = Axis(-900, 899, 5.0)  # Art Pen: 1800 units per turn, 5 per degree
WHEEL_AXIS = Axis(0, 1023, None)  # airbrush finger wheel
TILT_AXIS = Axis(-64, 63, 1.0)  # about one unit per degree

# d[1] & 0x06 -> pen button bits, as plain ints (IntFlag arithmetic is slow per report)
_PEN_BUTTONS = tuple((int(Button.STYLUS) if b & 2 else 0) | (int(Button.STYLUS2) if b & 4 else 0)
                     for b in range(8))

# d[1] -> 1 for the proximity packets (in: 0xc0-0xc3; in range: 0x20/21; out: 0x80/81)
_PROXIMITY = bytes(int(b & 0xFC == 0xC0 or b & 0xFE in (0x20, 0x80)) for b in range(256))
# One packet in one call: ID, d[1], x and y (big-endian 16 bits at d[2], d[4]), d[6..9].
_PACKET = struct.Struct(">BBHHBBBB")
# RawSample is a named tuple: tuple.__new__ with the values in field order skips its
# Python-level __new__ (about a third of the cost of building one per report).
_tuple_new = tuple.__new__

# packet types (d[1] >> 1) & 0xf
PEN_TYPES = frozenset({0, 1, 2, 3})
TYPE_MOUSE_4D, TYPE_ROTATION, TYPE_MOUSE_I4, TYPE_AIRBRUSH = 0x4, 0x5, 0x6, 0xA
LENS_TYPES = frozenset({0x8, 0xC})


def decode_serial(d: bytes) -> int:
    """Tool serial number of a proximity-in packet."""
    return ((d[3] & 0x0F) << 28) | (d[4] << 20) | (d[5] << 12) | (d[6] << 4) | (d[7] >> 4)


def decode_tool_id(d: bytes) -> int:
    """Tool id of a proximity-in packet."""
    return (d[2] << 4) | (d[3] >> 4) | ((d[7] & 0x0F) << 16) | ((d[8] & 0xF0) << 8)


def decode_rotation(d: bytes) -> int:
    """Art Pen barrel rotation (-900..899) of a type-5 packet (Intuos3 and later)."""
    t = (d[6] << 3) | ((d[7] >> 5) & 7)
    if d[7] & 0x20:
        # t >= 1 here (bit 0 of t is d[7] bit 5), so C division == floor division
        return (t - 1) // 2 - 1350 if t > 900 else (t - 1) // 2 + 450
    return 450 - t // 2


def decode_tilt(d: bytes) -> tuple[int, int]:
    return (((d[7] << 1) & 0x7E) | (d[8] >> 7)) - 64, (d[8] & 0x7F) - 64


@dataclass(slots=True)
class IntuosState:
    """Protocol state between packets: the tool in proximity and its last values.

    Pen packets (the hot path) do not write the values back one by one: they keep
    the sample they emit in ``last``, and :meth:`sync` copies its values into the
    fields before any other packet reads or changes them.
    """

    tool_id: int = 0  # 0: no tool identified (kernel: wacom->id[idx] == 0)
    serial: int = 0
    tool: Tool | None = None
    x: int = 0
    y: int = 0
    distance: int = 0
    pressure: int = 0
    tilt_x: int = 0
    tilt_y: int = 0
    rotation: int | None = None
    wheel: int | None = None
    buttons: int = 0
    cursor: bool = False  # the tool is a mouse or lens cursor (no pressure, no tip)
    no_tilt: bool = False  # its samples carry no tilt (the lens, or a device without tilt)
    eraser: bool = False
    last: RawSample | None = None  # the last data sample since proximity-in
    synced: RawSample | None = None  # the sample the fields were last copied from

    @property
    def reporting(self) -> bool:
        """A data packet was reported since proximity-in."""
        return self.last is not None

    def set_tool(self, tool_id: int, tool: Tool | None, tilt: bool) -> None:
        """The tool now in proximity (0, None: none), with the facts each sample repeats."""
        self.tool_id, self.tool = tool_id, tool
        self.cursor = tool is Tool.MOUSE or tool is Tool.LENS
        self.no_tilt = tool is Tool.LENS or not tilt
        self.eraser = tool is Tool.ERASER
        self.last = self.synced = None

    def sync(self) -> None:
        """The fields from the last pen packet's sample (only what that sample shows:
        a cursor's pressure and a lens's tilt are never emitted, so never read back)."""
        s = self.last
        if s is None or s is self.synced:
            return
        self.synced = s
        self.x, self.y, self.distance, self.buttons = s.x, s.y, int(s.distance or 0), s.buttons
        if s.pressure is not None:
            self.pressure = s.pressure
        if s.tilt_x is not None and s.tilt_y is not None:
            self.tilt_x, self.tilt_y = s.tilt_x, s.tilt_y

    def clear_values(self) -> None:
        self.x = self.y = self.distance = self.pressure = self.tilt_x = self.tilt_y = 0
        self.rotation = self.wheel = None
        self.buttons = 0


# Quirks inside the family (device data ``protocol_quirks``; wacom_intuos_general's type tests).
QUIRKS = frozenset({"no-lens", "ready-bit", "old-styli-invalid", "no-tilt", "distance-inverted"})
# Report IDs that may carry proximity packets: the answers to the kernel's tool query
# (WACOM_REPORT_INTUOS_ID1/ID2) come in as reports 5 and 6.
PROX_REPORT_IDS = frozenset({5, 6})


class IntuosParser(ReportParser):
    """Intuos family pen interface (report IDs 2 and 16).

    ``original=True`` is the first protocol generation (Intuos, Intuos2: kernel
    type INTUOS): two tool slots chosen by ``d[1] & 1`` (a pen and a puck can
    be in proximity together), coordinates and distance without the extra low
    bit (the kernel shifts them right once), and packet type 5 is the 4D
    mouse's second packet instead of the Art Pen rotation.
    """

    name = "wacom-intuos"
    pen_report_ids = PEN_REPORT_IDS

    def __init__(self, params: WacomParams, model: DeviceModel | None = None,
                 init_features: list[bytes] | None = None, original: bool = False,
                 quirks: frozenset[str] | None = None) -> None:
        self.params = params
        self.original = original
        if original:
            self.name = "wacom-intuos1"
        if quirks is None:
            quirks = frozenset((model or {}).get("protocol_quirks", []))
        unknown = quirks - QUIRKS
        if unknown:
            raise ValueError(f"unknown Intuos quirks {sorted(unknown)}")
        self.quirks = quirks
        self.tilt = "no-tilt" not in quirks
        self._inverted = "distance-inverted" in quirks
        self._drops = bool(quirks & {"no-lens", "ready-bit", "old-styli-invalid"})
        # Devices with less than 11 bits of pressure get the 11-bit value halved.
        self.halve_pressure = params.max_pressure < 2047
        ranges = AxisRanges(
            x=params.x_axis(),
            y=params.y_axis(),
            pressure=Axis(0, params.max_pressure),
            tilt_x=TILT_AXIS if self.tilt else None,
            tilt_y=TILT_AXIS if self.tilt else None,
            distance=Axis(0, params.max_distance),
            rotation=None if original else ROTATION_AXIS,
            wheel=WHEEL_AXIS,
        )
        feats = [PEN_MODE_FEATURE] if init_features is None else init_features
        super().__init__(ranges, model, feats)
        self.slots = (IntuosState(), IntuosState())
        self.state = self.slots[0]
        # Read once per packet as one tuple (fewer attribute loads on the hot path).
        self._mode = (original, self._drops, self._inverted, self.halve_pressure)

    def reset(self) -> None:
        self.slots = (IntuosState(), IntuosState())
        self.state = self.slots[0]

    def parse(self, report: bytes, time: float) -> list[RawSample]:
        # The common case first: a pen-ID report of a pen length (no other checks apply).
        if 9 < len(report) < 17 and report[0] in PEN_REPORT_IDS:
            s = self.packet(report, 0, time)
            return [] if s is None else [s]
        if not report:
            raise unknown_id(b"\0", "Intuos")
        rid = report[0]
        if rid not in PEN_REPORT_IDS:
            if rid in PROX_REPORT_IDS and len(report) >= REPORT_LENGTH and (
                    report[1] & 0xFC == 0xC0 or report[1] & 0xFE in (0x20, 0x80)):
                pass  # a proximity packet answering the tool query: read below
            elif rid in self.params.skip_report_ids:
                return self._skip("mouse" if rid == 1 else "pad", rid)
            elif rid == STATUS_REPORT_ID or rid in PROX_REPORT_IDS:
                return self._skip("status", rid)
            else:
                return self._not_pen(report, "Intuos")
        if len(report) == TOUCH_LENGTH:
            return self._skip("touch", rid)
        check_length(report, PEN_LENGTHS, "Intuos")
        s = self.packet(report, 0, time)
        return [] if s is None else [s]

    def packet(self, d: bytes, at: int, time: float) -> RawSample | None:
        """The sample of the 10-byte Intuos packet at ``d[at:]`` (its first byte the report
        ID), or None when the packet carries none (counted in :attr:`dropped`).

        The caller has checked the ID and the length; the Intuos4 WL parser calls this for
        each packet of a bundle, in place (no slice, no list per packet).
        """
        d1 = d[at + 1]
        original, drops, inverted, halve = self._mode
        if original:
            st = self.state = self.slots[d1 & 1]
        else:
            st = self.state
        if _PROXIMITY[d1]:  # proximity in, in range without data, proximity out
            return self._proximity(d[at:at + REPORT_LENGTH], d1, st, time)
        if not st.tool_id or d[at] in PROX_REPORT_IDS:  # data before the tool was identified
            self.dropped += 1
            return None
        if drops and self._invalid(d1, st):
            self.dropped += 1
            return None
        _, _, x, y, d6, d7, d8, d9 = _PACKET.unpack_from(d, at)
        # Intuos3 and later: one extra bit of x and y in d[9]; the original protocol has none.
        if original:
            distance = d9 >> 3
        else:
            x = (x << 1) | ((d9 >> 1) & 1)
            y = (y << 1) | (d9 & 1)
            distance = d9 >> 2
        if inverted:
            distance = self.params.max_distance - distance
        if d1 & 0x18:  # packet type (d1 >> 1) & 0xf of 4 or more: not a pen packet
            return self._other(d[at:at + REPORT_LENGTH], (d1 >> 1) & 0xF, x, y, distance, st,
                               time)  # fmt: skip
        t = (d6 << 3) | ((d7 & 0xC0) >> 5) | (d1 & 1)
        if halve:
            t >>= 1
        if st.no_tilt:
            tx = ty = None
        else:
            tx = (((d7 << 1) & 0x7E) | (d8 >> 7)) - 64
            ty = (d8 & 0x7F) - 64
        # positional, in RawSample's field order; tip: the kernel's rule, pressure > 10
        if st.cursor:
            s = st.last = _tuple_new(RawSample, (
                time, True, x, y, False, None, tx, ty, distance, st.rotation, st.wheel,
                _PEN_BUTTONS[d1 & 6], st.tool, st.serial, st.tool_id, st.eraser, True))
        else:
            s = st.last = _tuple_new(RawSample, (
                time, True, x, y, t > 10, t, tx, ty, distance, st.rotation, st.wheel,
                _PEN_BUTTONS[d1 & 6], st.tool, st.serial, st.tool_id, st.eraser, True))
        return s

    def _other(self, d: bytes, ptype: int, x: int, y: int, distance: int, st: IntuosState,
               time: float) -> RawSample:
        """Airbrush, Art Pen rotation, mouse and lens packets (the state kept in fields)."""
        st.sync()
        st.x, st.y, st.distance = x, y, distance
        if ptype == TYPE_AIRBRUSH:
            st.wheel = (d[6] << 2) | ((d[7] >> 6) & 3)
            st.tilt_x, st.tilt_y = decode_tilt(d)
        elif ptype == TYPE_ROTATION:
            if not self.original:  # original protocol: the 4D mouse's throttle packet
                st.rotation = decode_rotation(d)
        elif ptype == TYPE_MOUSE_I4:
            st.buttons = _mouse_buttons(d[6], side=0x08, extra=0x10)
            st.tilt_x, st.tilt_y = decode_tilt(d)
        elif ptype == TYPE_MOUSE_4D or ptype in LENS_TYPES:
            st.buttons = _mouse_buttons(d[8], side=0x10 if ptype in LENS_TYPES else 0x20,
                                        extra=0x08 if ptype in LENS_TYPES else 0x10)
        # types 7, 9, 0xb, 0xd-0xf carry only position and distance
        s = st.last = st.synced = self._sample(time, True, valid=True)
        return s

    def _proximity(self, d: bytes, d1: int, st: IntuosState, time: float) -> RawSample | None:
        """Proximity in (identify the tool), in range without data, proximity out."""
        if d1 & 0xFC == 0xC0:  # enter proximity: identify the tool
            tool_id = decode_tool_id(d)
            st.serial = decode_serial(d)
            st.set_tool(tool_id, tool_from_id(tool_id), self.tilt)
            st.clear_values()
            st.distance = self.params.max_distance
            return self._sample(time, True, valid=False)
        st.sync()
        if d1 & 0xFE == 0x20:  # in range, no valid data: not touching
            st.pressure = 0
            st.distance = self.params.max_distance
            return self._sample(time, True, valid=False)
        # leave proximity
        if not st.tool_id:  # the kernel does not report an exit for an unknown tool
            st.last = st.synced = None
            self.dropped += 1
            return None
        st.clear_values()
        out = self._sample(time, False, valid=False)
        st.set_tool(0, None, self.tilt)
        st.serial = 0
        return out

    def _invalid(self, d1: int, st: IntuosState) -> bool:
        """Data the kernel drops for this device type (wacom_intuos_general)."""
        q = self.quirks
        if "old-styli-invalid" in q and not (st.tool_id >> 16) & 1:
            return True  # Intuos4-generation styli do not work on the 21UX2
        if "no-lens" in q and st.tool == Tool.LENS:
            return True  # only the large Intuos3/4/5 take the lens cursor
        return "ready-bit" in q and not d1 & 0x40  # the first Cintiq: data only when ready

    def _sample(self, time: float, proximity: bool, valid: bool) -> RawSample:
        st = self.state
        tool = st.tool
        cursor = tool is Tool.MOUSE or tool is Tool.LENS
        no_tilt = st.no_tilt if tool is not None else not self.tilt
        # Positional, in RawSample's field order (time, proximity, x, y, tip, pressure,
        # tilt x/y, distance, rotation, wheel, buttons, tool, serial, tool id, eraser,
        # valid): built for every report.  tip: the kernel's BTN_TOUCH rule, pressure > 10.
        return RawSample(time, proximity, st.x, st.y, False if cursor else st.pressure > 10,
                         None if cursor else st.pressure, None if no_tilt else st.tilt_x,
                         None if no_tilt else st.tilt_y, st.distance,
                         None if self.original else st.rotation, st.wheel, st.buttons,
                         tool, st.serial if st.tool_id else None, st.tool_id or None,
                         st.eraser, valid)


def _mouse_buttons(bits: int, side: int, extra: int) -> int:
    """Mouse/lens buttons onto the pen button bits: left, right, middle; side/extra as PAD."""
    b = 0
    if bits & 0x01:
        b |= Button.STYLUS  # left
    if bits & 0x04:
        b |= Button.STYLUS2  # right
    if bits & 0x02:
        b |= Button.STYLUS3  # middle
    if bits & (side | extra):
        b |= Button.PAD
    return int(b)
