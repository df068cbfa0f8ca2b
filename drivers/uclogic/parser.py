"""UC-Logic pen reports, before and after the switch to full resolution.

Before the set-up (or when it found no parameters) the tablet sends its
compatibility reports, which its own report descriptor describes: they are
read by the generic HID parser.  After it, pen reports have the layout of the
parameter kind (raw device bytes, as the kernel's uclogic_raw_event_pen sees
them before rewriting them):

- v1, report 7: d[1] tip 0x01, barrel 0x02, second barrel 0x04, in range
  0x40 *inverted* (0 = in range); x, y, pressure little-endian 16 bits at
  d[2], d[4], d[6].
- v2, report 8: d[1] as v1 but without an in-range bit (every pen report is
  in range; the normaliser's proximity timeout ends a stroke); x = d[2] |
  d[3]<<8 | d[8]<<16, y = d[4] | d[5]<<8 | d[9]<<16 (the high bytes come after
  the pressure), pressure le16 at d[6]; tilt x, y signed bytes at d[10],
  d[11] with y pointing the other way (negated).  d[1] 0xe0 / 0xf0 are frame
  (pad) sub-reports.
- ugee-v2, report 2: d[1] tip 0x01, barrel 0x02, second barrel 0x04, in
  range 0x20; x, y le16 at d[2], d[4]; pressure 13 bits at d[6]; tilt x, y
  signed bytes at d[8], d[9].  d[1] 0xf0 is the frame sub-report.
"""

from __future__ import annotations

import logging

from station.drivers.devicedata import DeviceModel
from station.drivers.hid.base import ReportParser
from station.drivers.hid.descriptor import Descriptor
from station.drivers.hid.errors import ReportError
from station.drivers.hid.pen import GenericPenParser
from station.drivers.raw import Axis, AxisRanges, RawSample
from station.drivers.uclogic.init import UclogicControl, initialise
from station.drivers.uclogic.params import UclogicParams

from station.events import Button, Tool

log = logging.getLogger(__name__)

MIN_LENGTH = {"v1": 8, "v2": 10, "ugee-v2": 8}
TILT_AXIS = Axis(-60, 60, 1.0)  # degrees (the kernel's template: -60..60 degrees)
UGEE_TILT_AXIS = Axis(-61, 60, 1.0)
FRAME_SUBREPORTS = {"v1": (), "v2": (0xE0, 0xF0), "ugee-v2": (0xF0,)}


Decoded = tuple[bool, int, int, int, bool, int, "int | None", "int | None"]
"""(in range, x, y, pressure, tip, buttons, tilt x, tilt y) of one pen report."""
_STYLUS, _STYLUS2 = int(Button.STYLUS), int(Button.STYLUS2)
# d[1] & 0x06 -> button bits
_BUTTONS = tuple((_STYLUS if b & 0x02 else 0) | (_STYLUS2 if b & 0x04 else 0) for b in range(8))


def _s8(v: int) -> int:
    return v - 256 if v & 0x80 else v


def decode_v1(d: bytes) -> Decoded:
    f = d[1]
    return (not f & 0x40, d[2] | d[3] << 8, d[4] | d[5] << 8, d[6] | d[7] << 8, bool(f & 1),
            _BUTTONS[f & 6], None, None)


def decode_v2(d: bytes) -> Decoded:
    f = d[1]
    tx = ty = None
    if len(d) >= 12:
        tx, ty = _s8(d[10]), -_s8(d[11])
    return (True, d[2] | d[3] << 8 | d[8] << 16, d[4] | d[5] << 8 | d[9] << 16, d[6] | d[7] << 8,
            bool(f & 1), _BUTTONS[f & 6], tx, ty)


def decode_ugee_v2(d: bytes) -> Decoded:
    f = d[1]
    return (bool(f & 0x20), d[2] | d[3] << 8, d[4] | d[5] << 8, (d[6] | d[7] << 8) & 0x1FFF,
            bool(f & 1), _BUTTONS[f & 6], _s8(d[8]), _s8(d[9]))


DECODERS = {"v1": decode_v1, "v2": decode_v2, "ugee-v2": decode_ugee_v2}


def decode(kind: str, d: bytes) -> Decoded:
    """The values of one full-resolution pen report of ``kind``."""
    return DECODERS[kind](d)


class UclogicPenParser(ReportParser):
    """One UC-Logic pen interface; :meth:`initialise` performs the set-up over a transport."""

    name = "uclogic"

    def __init__(self, model: DeviceModel | None, desc: Descriptor | None) -> None:
        setup = model.get("uclogic") if model else None
        self.init_kind = str(setup.get("init", "fixed-descriptor")) if setup else "fixed-descriptor"
        self.fallback: GenericPenParser | None = None
        if desc is not None:
            self.fallback = GenericPenParser(desc, model)
            if not self.fallback.is_pen:
                self.fallback = None
        ranges = self.fallback.ranges if self.fallback else AxisRanges(Axis(0, 1), Axis(0, 1))
        super().__init__(ranges, model, [])
        self.why = ""
        if desc is not None and self.fallback is None:
            # Vendor-only interface: a pen only after the set-up (its reports then follow
            # the parameter kind, not this descriptor).
            self.is_pen, self.kind = False, "other"
            self.why = ("UC-Logic interface with no pen collection in its report descriptor; "
                        "its full-resolution reports need the UC-Logic set-up (open it as usb:)")
        self.params: UclogicParams | None = None
        self.tool_in = False
        self.x = self.y = 0
        self.pen_report_ids: frozenset[int] = frozenset()

    @property
    def needs_control(self) -> bool:
        """True when the full-resolution mode needs the USB set-up."""
        return self.init_kind != "fixed-descriptor"

    def initialise(self, control: UclogicControl) -> UclogicParams | None:
        """Run the set-up; switch to full-resolution decoding when parameters were found."""
        params = initialise(control, self.init_kind)
        if params is not None:
            self.use_params(params)
        return params

    def use_params(self, params: UclogicParams) -> None:
        self.params = params
        res = params.resolution_mm
        tilt = None if params.kind == "v1" else (TILT_AXIS if params.kind == "v2" else
                                                  UGEE_TILT_AXIS)  # fmt: skip
        self.ranges = AxisRanges(Axis(0, params.max_x, res), Axis(0, params.max_y, res),
                                 Axis(0, params.max_pressure), tilt, tilt)  # fmt: skip
        self.pen_report_ids = frozenset({params.report_id})
        self.is_pen, self.kind, self.why = True, "pen", ""
        self._decode = DECODERS[params.kind]
        self._frames = FRAME_SUBREPORTS[params.kind]
        self._min = MIN_LENGTH[params.kind]
        self._rid = params.report_id

    def describe(self) -> dict[str, object]:
        out = super().describe()
        out["uclogic_init"] = self.init_kind
        out["uclogic_params"] = None if self.params is None else self.params.kind
        return out

    def reset(self) -> None:
        self.tool_in = False
        if self.fallback:
            self.fallback.reset()

    def parse(self, report: bytes, time: float) -> list[RawSample]:
        p = self.params
        if p is None or not report or report[0] != self._rid:
            if self.fallback is not None:
                return self.fallback.parse(report, time)
            if not report:
                raise ReportError("empty UC-Logic report")
            return self._skip("pre-init" if p is None else "other", report[0])
        if len(report) < self._min:
            raise ReportError(f"UC-Logic {p.kind} pen report is {len(report)} bytes, "
                              f"expected at least {self._min}")  # fmt: skip
        if report[1] in self._frames:
            return self._skip("pad", report[0])
        in_range, x, y, pressure, tip, buttons, tx, ty = self._decode(report)
        if not in_range:
            if not self.tool_in:
                self.dropped += 1
                return []
            self.tool_in = False
            return [RawSample(time=time, proximity=False, x=self.x, y=self.y, tip=False,
                              pressure=0, tool=Tool.PEN, valid=False)]  # fmt: skip
        self.tool_in = True
        self.x = x if x <= p.max_x else p.max_x
        self.y = y if y <= p.max_y else p.max_y
        return [RawSample(time, True, self.x, self.y, tip,
                          pressure if pressure <= p.max_pressure else p.max_pressure, tx, ty,
                          None, None, None, buttons, Tool.PEN)]
