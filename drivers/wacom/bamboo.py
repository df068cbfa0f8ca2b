"""Wacom Bamboo / Intuos-HT pen protocol: report 2, 9 or 10 bytes (kernel: wacom_bpt_pen).

``d[1]`` bits: 0x80 in range, 0x40 proximity (coordinates valid), 0x20 data
ready (pressure and buttons valid), 0x08 eraser, 0x01 tip, 0x02/0x04 side
buttons.  x, y and pressure are little-endian 16-bit at d[2], d[4], d[6];
``distance = max_distance - d[8]`` while in range (never negative).  Pressure
can be non-zero while the tip bit is 0 — the normaliser decides contact.

Reports of 20 or 64 bytes with ID 2 are touch frames of the touch interface,
and report 192 carries the touch-switch state: both skipped and counted.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from station.drivers.devicedata import DeviceModel
from station.drivers.hid.base import ReportParser
from station.drivers.raw import Axis, AxisRanges, RawSample
from station.drivers.wacom.common import WacomParams, check_length, unknown_id
from station.drivers.wacom.modes import PEN_MODE_FEATURE
from station.drivers.wacom.tools import ERASER_DEVICE_ID, STYLUS_DEVICE_ID

from station.events import Button, Tool

PEN_REPORT_ID = 2
# WACOM_REPORT_USB: Intuos-HT pen interfaces send report 192 with the state of the
# touch on/off switch (kernel: wacom_bpt_pen -> SW_MUTE_DEVICE); not a pen report.
STATUS_REPORT_ID = 192
PEN_LENGTHS = (9, 10)  # Bamboo "fun" pen packets are 9 bytes, Intuos-HT pen packets 10
TOUCH_LENGTHS = (20, 64)
# ID, d[1], x, y, pressure (little-endian 16 bits at d[2], d[4], d[6]), d[8]: one call
_PEN = struct.Struct("<BBHHHB")
_PEN_BUTTONS = tuple((int(Button.STYLUS) if b & 2 else 0) | (int(Button.STYLUS2) if b & 4 else 0)
                     for b in range(8))  # d[1] & 0x06 -> button bits
_tuple_new = tuple.__new__  # RawSample is a named tuple: built without its __new__ frame


@dataclass(slots=True)
class BambooState:
    """The tool seen in proximity, whether a sample was reported, and the last position."""

    tool: Tool = Tool.PEN
    tool_id: int = 0
    reporting: bool = False
    x: int = 0
    y: int = 0


class BambooParser(ReportParser):
    """Bamboo (CTL-460 …) and Intuos-HT (CTL-480 …) pen interface."""

    name = "wacom-bamboo"
    pen_report_ids = frozenset({PEN_REPORT_ID})

    def __init__(self, params: WacomParams, model: DeviceModel | None = None,
                 init_features: list[bytes] | None = None) -> None:
        self.params = params
        ranges = AxisRanges(
            x=params.x_axis(),
            y=params.y_axis(),
            pressure=Axis(0, params.max_pressure),
            distance=Axis(0, params.max_distance),
        )
        feats = [PEN_MODE_FEATURE] if init_features is None else init_features
        super().__init__(ranges, model, feats)
        self.state = BambooState()

    def reset(self) -> None:
        self.state = BambooState()

    def parse(self, report: bytes, time: float) -> list[RawSample]:
        if 8 < len(report) < 11 and report[0] == PEN_REPORT_ID:  # PEN_LENGTHS: the hot path
            return self._pen(report, time)
        if not report:
            raise unknown_id(b"\0", "Bamboo")
        if report[0] != PEN_REPORT_ID:
            if report[0] == STATUS_REPORT_ID:
                return self._skip("status", report[0])
            if report[0] in self.params.skip_report_ids:
                return self._skip("mouse" if report[0] == 1 else "pad", report[0])
            return self._not_pen(report, "Bamboo")
        if len(report) in TOUCH_LENGTHS:
            return self._skip("touch", report[0])
        check_length(report, PEN_LENGTHS, "Bamboo pen")
        return self._pen(report, time)

    def _pen(self, d: bytes, time: float) -> list[RawSample]:
        _, d1, x, y, pressure, d8 = _PEN.unpack_from(d)
        st = self.state
        if d1 & 0x20:  # ready: pressure, tip and buttons are valid
            tip = bool(d1 & 0x01)
            buttons = _PEN_BUTTONS[d1 & 6]
        else:
            pressure, tip, buttons = 0, False, 0
        if d1 & 0x40:  # in proximity: coordinates and the tool
            st.x, st.y = x, y
            if d1 & 0x08:
                st.tool, st.tool_id = Tool.ERASER, ERASER_DEVICE_ID
            else:
                st.tool, st.tool_id = Tool.PEN, STYLUS_DEVICE_ID
            st.reporting = True
        distance = 0
        in_range = d1 & 0x80
        if in_range:
            # distance counts up from "out of proximity"; past max it means pressing.
            far = self.params.max_distance
            if d8 <= far:
                distance = far - d8
        else:
            st.tool_id = 0
        if not st.reporting:  # in range, too far for coordinates, no tool yet
            self.dropped += 1
            return []
        if not in_range:
            st.x = st.y = 0  # the kernel reports 0, 0 on the way out
            st.reporting = False
        tool = st.tool
        # positional, in RawSample's field order (built per report)
        return [_tuple_new(RawSample, (
            time, bool(in_range), st.x, st.y, tip, pressure, None, None, distance, None, None,
            buttons, tool, None, st.tool_id or None, tool is Tool.ERASER, bool(d1 & 0x40)))]
