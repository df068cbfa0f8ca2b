"""Wacom Graphire protocol: 8-byte reports, USB report ID 2, Bluetooth report ID 3.

(kernel: wacom_graphire_irq.)  ``d[1] & 0x80`` proximity; tool
``(d[1] >> 5) & 3`` (0 pen, 1 eraser, 2 mouse with wheel, 3 mouse); x, y
little-endian 16-bit at d[2], d[4]; pen pressure ``d[6] | (d[7] & 3) << 8``
(Bluetooth: the high bit is ``d[1] & 0x08``); tip ``d[1] & 1``; side buttons
``d[1] & 2``, ``d[1] & 4``.  Mouse: left/right ``d[1] & 1``/``& 2``, distance
``d[7] & 0x3f`` (Graphire4: ``d[6] & 0x3f``; Bluetooth: ``clamp(44 - (d[6] >> 2), 0, 31)``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from station.drivers.hid.base import ReportParser
from station.drivers.raw import Axis, AxisRanges, RawSample
from station.drivers.wacom.common import WacomParams, check_length, unknown_id
from station.drivers.wacom.modes import PEN_MODE_FEATURE
from station.drivers.wacom.tools import CURSOR_DEVICE_ID, ERASER_DEVICE_ID, STYLUS_DEVICE_ID

from station.events import Button, Tool

REPORT_LENGTH = 8
USB_REPORT_ID = 2
BT_REPORT_ID = 3
_TOOLS = ((Tool.PEN, STYLUS_DEVICE_ID), (Tool.ERASER, ERASER_DEVICE_ID),
          (Tool.MOUSE, CURSOR_DEVICE_ID), (Tool.MOUSE, CURSOR_DEVICE_ID))  # fmt: skip


@dataclass(slots=True)
class GraphireState:
    tool: Tool = Tool.PEN
    tool_id: int = 0  # 0: nothing in proximity


class GraphireParser(ReportParser):
    """Graphire pen (and mouse) over USB (``bluetooth=False``) or Bluetooth."""

    name = "wacom-graphire"

    def __init__(self, params: WacomParams, model: dict[str, Any] | None = None,
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
        if not report:
            raise unknown_id(b"\0", "Graphire")
        if report[0] != self.report_id:
            if report[0] in self.params.skip_report_ids:
                return self._skip("mouse" if report[0] == 1 else "pad")
            raise unknown_id(report, "Graphire")
        check_length(report, (REPORT_LENGTH,), "Graphire")
        d = report
        st = self.state
        prox = bool(d[1] & 0x80)
        if not prox and not st.tool_id:
            self.dropped += 1  # nothing in proximity and nothing to end
            return []
        if prox:
            st.tool, st.tool_id = _TOOLS[(d[1] >> 5) & 3]
        x = d[2] | (d[3] << 8)
        y = d[4] | (d[5] << 8)
        pressure: int | None
        if st.tool != Tool.MOUSE:
            high = (d[1] & 0x08) << 5 if self.bluetooth else (d[7] & 0x03) << 8
            pressure = d[6] | high
            tip = bool(d[1] & 0x01)
            buttons = (Button.STYLUS if d[1] & 0x02 else 0) | (Button.STYLUS2 if d[1] & 0x04 else 0)
            distance = None
        else:
            pressure, tip = None, False
            buttons = (Button.STYLUS if d[1] & 0x01 else 0) | (Button.STYLUS2 if d[1] & 0x02 else 0)
            if (d[1] >> 5) & 3 == 2 and d[1] & 0x04:
                buttons |= Button.STYLUS3  # middle button of the wheel mouse
            if self.bluetooth:
                distance = min(31, max(0, 44 - (d[6] >> 2)))
            else:
                distance = (d[6] if self.graphire4 else d[7]) & 0x3F
        sample = RawSample(
            time=time,
            proximity=prox,
            x=x,
            y=y,
            tip=tip,
            pressure=pressure,
            distance=distance,
            buttons=int(buttons),
            tool=st.tool,
            serial=None,
            tool_id=st.tool_id,
            eraser=st.tool == Tool.ERASER,
            valid=prox,
        )
        if not prox:
            st.tool_id = 0
        return [sample]
