"""Single-tool Wacom protocols: PenPartner, PL/DTF pen displays, Cintiq Partner (PTU),
DTU, DTUS/DTK and the ISDv4 Tablet PC pens.

Byte facts from the kernel's wacom_wac.c (``wacom_penpartner_irq``,
``wacom_pl_irq``, ``wacom_ptu_irq``, ``wacom_dtu_irq``, ``wacom_dtus_irq``,
``wacom_tpc_pen``); d[0] is the report ID.  Each protocol is a pure decode
function ``bytes -> Decoded``; :class:`LegacyPenParser` adds what they share:
report ID and length checks, the tool kept while it is in proximity, and a
proximity-out sample.

- PenPartner, report 1/2: proximity d5&0x80 (report 2: always); eraser d5&0x20;
  x, y le16 at d1, d3; pressure (s8)d6 + 127; tip (s8)d6 > -127 (report 2: > -80
  and not d5&0x20); barrel d5&0x40.
- PL, report 2: proximity d1&0x40; eraser at entry when d4&0x20 (or d0&0x10); x, y
  in 7-bit groups (see ``pl``); pressure (s8)(d7<<1 | d4>>2&1), one more bit
  (d4>>6&1) above 255, plus (max+1)/2; tip d4&0x08; buttons d4&0x10, d4&0x20 (pen).
- PTU, report 2: proximity d1&0x20; eraser d1&0x04; x, y, pressure le16 at d2, d4,
  d6; tip d1&0x01 (eraser: d1&0x08); buttons d1&0x02, d1&0x10.
- DTU, report 2: proximity d1&0x20; eraser d1&0x0c; x, y le16 at d2, d4; pressure
  d6 | (d7&1)<<8; tip d1&0x05; buttons d1&0x02, d1&0x10.
- DTUS, report 17 (pad 21): proximity d1&0x80; (d1>>3)&3: 1 eraser, 2 pen; x, y
  big-endian at d3, d5; pressure (d1&3)<<8 | d2; tip pressure > 10; buttons
  d1&0x20, d1&0x40.
- Tablet PC, report 2 (or any 8-byte report): proximity d1&0x20; eraser d1&0x0c at
  entry; x, y le16 at d2, d4; pressure (d7&7)<<8 | d6; tip d1&0x05; buttons
  d1&0x02, d1&0x10.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from station.drivers.devicedata import DeviceModel
from station.drivers.hid.base import ReportParser
from station.drivers.hid.errors import ReportError
from station.drivers.raw import Axis, AxisRanges, RawSample
from station.drivers.wacom.common import WacomParams, unknown_id
from station.drivers.wacom.modes import PEN_MODE_FEATURE
from station.drivers.wacom.tools import ERASER_DEVICE_ID, STYLUS_DEVICE_ID

from station.events import Button, Tool

Decoded = tuple[bool, int, int, int, bool, int, "bool | None"]
"""One report's pen values in device units: (proximity, x, y, pressure, tip, buttons,
eraser); eraser None: the report does not say.  A plain tuple: it is built per report."""


def _le16(d: bytes, i: int) -> int:
    return d[i] | (d[i + 1] << 8)


def _s8(v: int) -> int:
    v &= 0xFF
    return v - 256 if v & 0x80 else v


_STYLUS, _STYLUS2 = int(Button.STYLUS), int(Button.STYLUS2)  # plain ints: built per report


def _buttons(b1: int, b2: int) -> int:
    return (_STYLUS if b1 else 0) | (_STYLUS2 if b2 else 0)


def penpartner(d: bytes, max_pressure: int) -> Decoded:
    p = _s8(d[6])
    if d[0] == 1:
        prox = bool(d[5] & 0x80)
        return (prox, _le16(d, 1), _le16(d, 3), p + 127 if prox else 0,
                prox and p > -127, _buttons(d[5] & 0x40, 0), bool(d[5] & 0x20))
    return (True, _le16(d, 1), _le16(d, 3), p + 127, p > -80 and not d[5] & 0x20,
                   _buttons(d[5] & 0x40, 0), False)  # fmt: skip


def pl(d: bytes, max_pressure: int) -> Decoded:
    pressure = _s8((d[7] << 1) | ((d[4] >> 2) & 1))
    if max_pressure > 255:
        pressure = (pressure << 1) | ((d[4] >> 6) & 1)
    pressure += (max_pressure + 1) // 2
    x = d[3] | (d[2] << 7) | ((d[1] & 0x03) << 14)
    y = d[6] | (d[5] << 7) | ((d[4] & 0x03) << 14)
    eraser = bool(d[0] & 0x10 or d[4] & 0x20)
    # STYLUS2 only for the pen: with the eraser in, d4&0x20 is always set.
    return (bool(d[1] & 0x40), x, y, pressure, bool(d[4] & 0x08),
            _buttons(d[4] & 0x10, d[4] & 0x20), eraser)


def ptu(d: bytes, max_pressure: int) -> Decoded:
    eraser = bool(d[1] & 0x04)
    tip = bool(d[1] & 0x08) if eraser else bool(d[1] & 0x01)
    return (bool(d[1] & 0x20), _le16(d, 2), _le16(d, 4), _le16(d, 6), tip,
                   _buttons(d[1] & 0x02, d[1] & 0x10), eraser)  # fmt: skip


def dtu(d: bytes, max_pressure: int) -> Decoded:
    prox = bool(d[1] & 0x20)
    return (prox, _le16(d, 2), _le16(d, 4), ((d[7] & 0x01) << 8) | d[6],
                   bool(d[1] & 0x05), _buttons(d[1] & 0x02, d[1] & 0x10),
                   bool(d[1] & 0x0C) if prox else None)  # fmt: skip


def dtus(d: bytes, max_pressure: int) -> Decoded:
    prox = bool(d[1] & 0x80)
    kind = (d[1] >> 3) & 3
    eraser = {1: True, 2: False}.get(kind) if prox else None
    pressure = ((d[1] & 0x03) << 8) | d[2]
    return (prox, (d[3] << 8) | d[4], (d[5] << 8) | d[6], pressure, pressure > 10,
                   _buttons(d[1] & 0x20, d[1] & 0x40), eraser)  # fmt: skip


def tpc(d: bytes, max_pressure: int) -> Decoded:
    return (bool(d[1] & 0x20), _le16(d, 2), _le16(d, 4), ((d[7] & 0x07) << 8) | d[6],
                   bool(d[1] & 0x05), _buttons(d[1] & 0x02, d[1] & 0x10),
                   bool(d[1] & 0x0C))  # fmt: skip


@dataclass(frozen=True, slots=True)
class Protocol:
    """How one legacy protocol is framed."""

    name: str
    decode: Callable[[bytes, int], Decoded]
    pen_ids: frozenset[int]
    min_length: int
    pad_ids: frozenset[int] = frozenset()
    mouse_mode: bool = True  # report 1 is the boot mouse before the mode switch
    tool_at_entry: bool = True  # the tool is chosen when it enters proximity, then kept
    any_id_length: int | None = None  # a report of this length is a pen report whatever its ID


PROTOCOLS: dict[str, Protocol] = {
    "wacom-penpartner": Protocol("wacom-penpartner", penpartner, frozenset({1, 2}), 7,
                                 mouse_mode=False, tool_at_entry=False),
    "wacom-pl": Protocol("wacom-pl", pl, frozenset({2}), 8),
    "wacom-ptu": Protocol("wacom-ptu", ptu, frozenset({2}), 8, tool_at_entry=False),
    "wacom-dtu": Protocol("wacom-dtu", dtu, frozenset({2}), 8),
    "wacom-dtus": Protocol("wacom-dtus", dtus, frozenset({17}), 7, pad_ids=frozenset({21})),
    "wacom-tpc": Protocol("wacom-tpc", tpc, frozenset({2}), 8, any_id_length=8),
}
MAX_LENGTH = 64


class LegacyPenParser(ReportParser):
    """One of :data:`PROTOCOLS` on a pen interface."""

    def __init__(self, protocol: str, params: WacomParams, model: DeviceModel | None = None,
                 init_features: list[bytes] | None = None) -> None:
        self.protocol = PROTOCOLS[protocol]
        self.name = protocol
        self.params = params
        self.pen_report_ids = self.protocol.pen_ids
        ranges = AxisRanges(x=params.x_axis(), y=params.y_axis(),
                            pressure=Axis(0, params.max_pressure))  # fmt: skip
        feats = [PEN_MODE_FEATURE] if init_features is None else init_features
        super().__init__(ranges, model, feats)
        self.tool: Tool | None = None  # None: nothing in proximity
        self.x = self.y = 0

    @classmethod
    def for_protocol(cls, protocol: str) -> Callable[..., LegacyPenParser]:
        """A constructor with the protocol bound (what the registry's factories call)."""

        def make(params: WacomParams, model: DeviceModel | None = None,
                 init_features: list[bytes] | None = None) -> LegacyPenParser:
            return cls(protocol, params, model, init_features)

        return make

    def reset(self) -> None:
        self.tool = None

    def parse(self, report: bytes, time: float) -> list[RawSample]:
        proto = self.protocol
        if not report:
            raise unknown_id(b"\0", proto.name)
        rid = report[0]
        pen = rid in proto.pen_ids or len(report) == proto.any_id_length
        if not pen:
            if rid in proto.pad_ids or rid in self.params.skip_report_ids - {1}:
                return self._skip("pad", rid)
            if rid == 1 and proto.mouse_mode:
                return self._skip("mouse", rid)
            return self._not_pen(report, proto.name)
        if not proto.min_length <= len(report) <= MAX_LENGTH:
            raise ReportError(f"{proto.name} report {rid} is {len(report)} bytes, expected "
                              f"{proto.min_length}..{MAX_LENGTH}")  # fmt: skip
        prox, x, y, pressure, tip, buttons, eraser = proto.decode(report, self.params.max_pressure)
        out: list[RawSample] = []
        if prox:
            tool = self.tool
            if tool is None or (eraser is not None and not proto.tool_at_entry):
                tool = Tool.ERASER if eraser else Tool.PEN
            if proto.name == "wacom-pl" and tool is Tool.ERASER and not buttons & _STYLUS2:
                # PL: STYLUS2 always accompanies the eraser; without it the entry was
                # misread, so the eraser leaves and the pen comes in (as the kernel does).
                if self.tool is Tool.ERASER:
                    out.append(self._sample(time, False, Tool.ERASER, 0, False, 0))
                self.tool, tool = None, Tool.PEN
            if tool != self.tool and self.tool is not None:
                out.append(self._sample(time, False, self.tool, 0, False, 0))
            self.tool = tool
            self.x, self.y = x, y
            if proto.name == "wacom-pl" and tool != Tool.PEN:
                buttons &= ~_STYLUS2  # PL: STYLUS2 only for the pen
            out.append(self._sample(time, True, tool, pressure, tip, buttons))
            return out
        if self.tool is None:
            self.dropped += 1  # nothing in proximity and nothing to end
            return []
        tool, self.tool = self.tool, None
        self.x, self.y = x, y
        return [self._sample(time, False, tool, 0, False, 0)]

    def _sample(self, time: float, prox: bool, tool: Tool, pressure: int, tip: bool,
                buttons: int) -> RawSample:
        eraser = tool is Tool.ERASER
        top = self.params.max_pressure
        # positional: (time, proximity, x, y, tip, pressure, tilt x/y, distance, rotation,
        # wheel, buttons, tool, serial, tool id, eraser, valid) -- built per report
        return RawSample(time, prox, self.x, self.y, tip,
                         0 if pressure < 0 else top if pressure > top else pressure,
                         None, None, None, None, None, buttons, tool, None,
                         ERASER_DEVICE_ID if eraser else STYLUS_DEVICE_ID, eraser, prox)
