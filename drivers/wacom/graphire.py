"""Wacom Graphire protocol: 8-byte reports, USB report ID 2, Bluetooth report ID 3.

(kernel: wacom_graphire_irq.)  ``d[1] & 0x80`` proximity; tool
``(d[1] >> 5) & 3`` (0 pen, 1 eraser, 2 mouse with wheel, 3 mouse); x, y
little-endian 16-bit at d[2], d[4]; pen pressure ``d[6] | (d[7] & 3) << 8``
(Bluetooth: the high bit is ``d[1] & 0x08``); tip ``d[1] & 1``; side buttons
``d[1] & 2``, ``d[1] & 4``.  Mouse: left/right ``d[1] & 1``/``& 2``, distance
``d[7] & 0x3f`` (Graphire4: ``d[6] & 0x3f``; Bluetooth: ``clamp(44 - (d[6] >> 2), 0, 31)``).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from station.drivers.devicedata import DeviceModel
from station.drivers.hid.base import ReportParser
from station.drivers.raw import Axis, AxisRanges, RawSample
from station.drivers.wacom.common import WacomParams, check_length, unknown_id
from station.drivers.wacom.modes import PEN_MODE_FEATURE
from station.drivers.wacom.tools import CURSOR_DEVICE_ID, ERASER_DEVICE_ID, STYLUS_DEVICE_ID

from station.events import Button, Tool

REPORT_LENGTH = 8
USB_REPORT_ID = 2
BT_REPORT_ID = 3
# ID, d[1], x, y (little-endian 16 bits at d[2], d[4]), d[6], d[7]: one call
_REPORT = struct.Struct("<BBHHBB")
_PEN_BUTTONS = tuple((int(Button.STYLUS) if b & 2 else 0) | (int(Button.STYLUS2) if b & 4 else 0)
                     for b in range(8))  # d[1] & 0x06 -> button bits
_STYLUS3 = int(Button.STYLUS3)
_tuple_new = tuple.__new__  # RawSample is a named tuple: built without its __new__ frame
_TOOLS = ((Tool.PEN, STYLUS_DEVICE_ID), (Tool.ERASER, ERASER_DEVICE_ID),
          (Tool.MOUSE, CURSOR_DEVICE_ID), (Tool.MOUSE, CURSOR_DEVICE_ID))  # fmt: skip


@dataclass(slots=True)
class GraphireState:
    tool: Tool = Tool.PEN
    tool_id: int = 0  # 0: nothing in proximity


class GraphireParser(ReportParser):
    """Graphire pen (and mouse) over USB (``bluetooth=False``) or Bluetooth."""

    name = "wacom-graphire"

    def __init__(self, params: WacomParams, model: DeviceModel | None = None,
                 init_features: list[bytes] | None = None, bluetooth: bool = False,
                 graphire4: bool = False) -> None:
        self.params = params
        self.bluetooth = bluetooth
        # Graphire4 (kernel WACOM_G4): the mouse distance is in d[6], its wheel in d[7].
        self.graphire4 = graphire4 and not bluetooth
        if self.graphire4:
            self.name = "wacom-graphire4"
        self.report_id = BT_REPORT_ID if bluetooth else USB_REPORT_ID
        self.pen_report_ids = frozenset({self.report_id})
        if bluetooth:
            self.name = "wacom-graphire-bt"
        ranges = AxisRanges(
            x=params.x_axis(),
            y=params.y_axis(),
            pressure=Axis(0, params.max_pressure),
            distance=Axis(0, params.max_distance),
        )
        if init_features is None:
            init_features = [] if bluetooth else [PEN_MODE_FEATURE]
        super().__init__(ranges, model, init_features)
        self.state = GraphireState()

    def reset(self) -> None:
        self.state = GraphireState()

    def parse(self, report: bytes, time: float) -> list[RawSample]:
        if len(report) == REPORT_LENGTH and report[0] == self.report_id:  # the hot path
            return self._report(report, time)
        if not report:
            raise unknown_id(b"\0", "Graphire")
        if report[0] != self.report_id:
            if report[0] in self.params.skip_report_ids:
                return self._skip("mouse" if report[0] == 1 else "pad", report[0])
            return self._not_pen(report, "Graphire")
        check_length(report, (REPORT_LENGTH,), "Graphire")
        return self._report(report, time)

    def _report(self, d: bytes, time: float) -> list[RawSample]:
        _, d1, x, y, d6, d7 = _REPORT.unpack_from(d)
        st = self.state
        prox = d1 & 0x80
        if not prox and not st.tool_id:
            self.dropped += 1  # nothing in proximity and nothing to end
            return []
        if prox:
            st.tool, st.tool_id = _TOOLS[(d1 >> 5) & 3]
        tool = st.tool
        pressure: int | None
        if tool is not Tool.MOUSE:
            pressure = d6 | ((d1 & 0x08) << 5 if self.bluetooth else (d7 & 0x03) << 8)
            tip = bool(d1 & 0x01)
            buttons = _PEN_BUTTONS[d1 & 6]
            distance = None
        else:
            pressure, tip = None, False
            buttons = _PEN_BUTTONS[(d1 << 1) & 6]  # left, right
            if (d1 >> 5) & 3 == 2 and d1 & 0x04:
                buttons |= _STYLUS3  # middle button of the wheel mouse
            if self.bluetooth:
                distance = min(31, max(0, 44 - (d6 >> 2)))
            else:
                distance = (d6 if self.graphire4 else d7) & 0x3F
        tool_id = st.tool_id
        if not prox:
            st.tool_id = 0
        # positional, in RawSample's field order (built per report)
        return [_tuple_new(RawSample, (
            time, bool(prox), x, y, tip, pressure, None, None, distance, None, None, buttons,
            tool, None, tool_id, tool is Tool.ERASER, bool(prox)))]
