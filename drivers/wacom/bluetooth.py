"""Wacom Bluetooth pen protocols: the Intuos4 WL and the Intuos Pro 2 / Intuos (CTL-4100/6100).

Byte facts from the kernel's wacom_wac.c.

**Intuos4 WL** (``wacom_intuos_bt_irq``): report 0x03 (at least 22 bytes) carries
two 10-byte Intuos packets at d[1] and d[11], then a power byte; report 0x04
(at least 32 bytes) carries three, at d[1], d[11], d[21].  Each packet is an
ordinary Intuos packet whose first byte is its own report ID (2: pen, 12:
pad); it is read by the Intuos parser.  Packets with any other ID are filler.

**Intuos Pro 2 / Intuos BT** (``wacom_intuos_pro2_bt_pen``): reports 0x80 and
0x81.  Pro 2 (``pro2-frames``): seven 14-byte frames from d[1], the serial as
little-endian 64 bits at d[99] and the tool id as 16 bits at d[107]; the
Intuos CTL-4100/6100: four 8-byte frames, serial at d[33], id at d[41].  When
the serial's top 12 bits are 1, bits 32..51 of the serial complete the id.
A frame: f[0] 0x80 valid, 0x40 proximity, 0x20 in range, 0x10 invert,
0x01|0x08 tip, 0x02/0x04 buttons; x, y, pressure little-endian 16 bits at
f[1], f[3], f[5]; Pro 2: tilt x/y signed bytes f[7], f[8], rotation signed
16 bits at f[9] (+450, wrapped into -900..899), wheel f[11], distance f[13];
the CTL: distance f[7].  The first frame without proximity ends the report
with a proximity-out.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from station.drivers.devicedata import DeviceModel
from station.drivers.hid.base import ReportParser
from station.drivers.hid.errors import ReportError
from station.drivers.raw import Axis, AxisRanges, RawSample
from station.drivers.wacom.common import WacomParams, unknown_id
from station.drivers.wacom.intuos import (
    PEN_REPORT_IDS,
    ROTATION_AXIS,
    TILT_AXIS,
    WHEEL_AXIS,
    IntuosParser,
)
from station.drivers.wacom.tools import tool_from_id

from station.events import Button, Tool

_BUTTONS = tuple((int(Button.STYLUS) if b & 2 else 0) | (int(Button.STYLUS2) if b & 4 else 0)
                 for b in range(8))  # f[0] & 0x06 -> button bits
# A frame in one call: f[0]; x, y, pressure (little-endian 16 bits); Pro 2: tilt x, y (signed
# bytes), rotation (signed 16 bits), wheel (16 bits), distance; the CTL: distance.
_PRO2_FRAME = struct.Struct("<BHHHbbhHB")
_CTL_FRAME = struct.Struct("<BHHHB")
_tuple_new = tuple.__new__  # RawSample is a named tuple: built without its __new__ frame
_SERIAL_ID = struct.Struct("<QH")  # serial (64 bits) and tool id (16 bits), adjacent
_VALID = bytes(b >> 7 for b in range(256))  # f[0] -> 1 for a valid frame (0x80 set)
I4WL_FRAMES = {0x03: (2, 22), 0x04: (3, 32)}  # report ID -> (packets, minimum length)
I4WL_PACKET = 10
# report ID -> (offsets of its packets, minimum length)
_I4WL_OFFSETS = {rid: (tuple(range(1, 1 + n * I4WL_PACKET, I4WL_PACKET)), minimum)
                 for rid, (n, minimum) in I4WL_FRAMES.items()}


class Intuos4WirelessParser(ReportParser):
    """Intuos4 WL over Bluetooth: Intuos packets bundled two or three to a report."""

    name = "wacom-intuos4wl"
    pen_report_ids = frozenset(I4WL_FRAMES)

    def __init__(self, params: WacomParams, model: DeviceModel | None = None,
                 init_features: list[bytes] | None = None) -> None:
        # The kernel checks no lens rule for this type: every Intuos4 tool works.
        self.inner = IntuosParser(params, model, [], quirks=frozenset())
        super().__init__(self.inner.ranges, model, list(init_features or []))

    def reset(self) -> None:
        self.inner.reset()

    def parse(self, report: bytes, time: float) -> list[RawSample]:
        if not report:
            raise unknown_id(b"\0", "Intuos4 WL")
        framing = _I4WL_OFFSETS.get(report[0])
        if framing is None:
            return self._not_pen(report, "Intuos4 WL")
        offsets, minimum = framing
        if len(report) < minimum:
            raise ReportError(f"Intuos4 WL report {report[0]:#04x} is {len(report)} bytes, "
                              f"expected at least {minimum}")  # fmt: skip
        out: list[RawSample] = []
        inner = self.inner
        before = inner.dropped
        for at in offsets:  # each packet read in place by the Intuos parser
            rid = report[at]
            if rid in PEN_REPORT_IDS:
                s = inner.packet(report, at, time)
                if s is not None:
                    out.append(s)
            elif rid in (3, 12, 17):
                self._skip("pad")
            # other IDs: an unused slot of the bundle
        if inner.dropped != before:
            self.dropped += inner.dropped - before
        return out


@dataclass(slots=True)
class _BtState:
    tool: Tool | None = None
    x: int = 0
    y: int = 0
    tilt_x: int = 0
    tilt_y: int = 0
    rotation: int | None = None
    wheel: int | None = None


class IntuosBluetoothParser(ReportParser):
    """Intuos Pro 2 (``pro2=True``) or Intuos CTL-4100/6100 over Bluetooth."""

    name = "wacom-intuos-bt"
    pen_report_ids = frozenset({0x80, 0x81})

    def __init__(self, params: WacomParams, model: DeviceModel | None = None,
                 init_features: list[bytes] | None = None, pro2: bool | None = None) -> None:
        if pro2 is None:
            pro2 = "pro2-frames" in (model or {}).get("protocol_quirks", [])
        self.params = params
        self.pro2 = pro2
        self.frame_len, self.frames = (14, 7) if pro2 else (8, 4)
        self.serial_at, self.id_at = (99, 107) if pro2 else (33, 41)
        self.frame = _PRO2_FRAME if pro2 else _CTL_FRAME
        self.starts = tuple(range(1, 1 + self.frames * self.frame_len, self.frame_len))
        self.flags_end = 1 + self.frames * self.frame_len  # f[0] of every frame: d[1:end:len]
        ranges = AxisRanges(
            x=params.x_axis(), y=params.y_axis(), pressure=Axis(0, params.max_pressure),
            tilt_x=TILT_AXIS if pro2 else None, tilt_y=TILT_AXIS if pro2 else None,
            distance=Axis(0, params.max_distance), rotation=ROTATION_AXIS if pro2 else None,
            wheel=WHEEL_AXIS if pro2 else None,
        )
        super().__init__(ranges, model, list(init_features or []))
        self.state = _BtState()

    def reset(self) -> None:
        self.state = _BtState()

    def parse(self, report: bytes, time: float) -> list[RawSample]:
        if not report:
            raise unknown_id(b"\0", "Intuos BT")
        if report[0] not in self.pen_report_ids:
            return self._not_pen(report, "Intuos BT")
        need = self.id_at + 2
        if len(report) < need:
            raise ReportError(f"Intuos BT report {report[0]:#04x} is {len(report)} bytes, "
                              f"expected at least {need}")  # fmt: skip
        d = report
        serial, tool_id = _SERIAL_ID.unpack_from(d, self.serial_at)
        if serial >> 52 == 1:  # non-USI pens: the id's missing bits ride in the serial
            tool_id |= (serial >> 32) & 0xFFFFF
        # the kernel reads the first valid_count frames, valid_count the frames with 0x80
        valid_count = d[1:self.flags_end:self.frame_len].translate(_VALID).count(1)
        st = self.state
        out: list[RawSample] = []
        frame = self.frame
        pro2 = self.pro2
        top, far = self.params.max_pressure, self.params.max_distance
        serial_out, id_out = serial or None, tool_id or None
        for s in self.starts[:valid_count]:
            f = frame.unpack_from(d, s)
            f0 = f[0]
            if not f0 & 0x80:
                continue
            in_range = f0 & 0x20
            if not f0 & 0x40:  # out of proximity: the report ends here
                if st.tool is not None:
                    out.append(self._sample(time, False, False, 0, False, 0, 0, serial, tool_id))
                else:
                    self.dropped += 1
                self.state = _BtState()
                return out
            if in_range:
                if st.tool is None:
                    st.tool = (Tool.ERASER if f0 & 0x10 else
                               tool_from_id(tool_id) if tool_id else Tool.PEN)  # fmt: skip
                st.x, st.y = f[1], f[2]
                if pro2:
                    st.tilt_x, st.tilt_y = f[4], f[5]
                    rot = f[6] + 450
                    st.rotation = rot - 1800 if rot > 899 else rot
                    st.wheel = f[7]
            if st.tool is None:
                self.dropped += 1  # near but never in range: nothing identified yet
                continue
            pressure = f[3]
            distance = (f[8] if pro2 else f[4]) if in_range else far
            tool = st.tool
            # positional, in RawSample's field order (built per frame)
            out.append(_tuple_new(RawSample, (
                time, True, st.x, st.y, bool(f0 & 0x09), pressure if pressure <= top else top,
                st.tilt_x if pro2 else None, st.tilt_y if pro2 else None,
                distance if distance <= far else far, st.rotation, st.wheel, _BUTTONS[f0 & 6],
                tool, serial_out, id_out, tool is Tool.ERASER, bool(in_range))))
        return out

    def _sample(self, time: float, prox: bool, valid: bool, pressure: int, tip: bool,
                buttons: int, distance: int, serial: int, tool_id: int) -> RawSample:
        st = self.state
        tool = st.tool or Tool.PEN
        top, far = self.params.max_pressure, self.params.max_distance
        pro2 = self.pro2
        # positional (built per frame): see RawSample's field order
        return RawSample(time, prox, st.x, st.y, tip, pressure if pressure <= top else top,
                         st.tilt_x if pro2 else None, st.tilt_y if pro2 else None,
                         distance if distance <= far else far, st.rotation, st.wheel, buttons,
                         tool, serial or None, tool_id or None, tool is Tool.ERASER, valid)
