"""The mock tablet: scripted strokes encoded as a real device's report bytes.

``mock:MODEL?script=spiral&rate=200`` opens one: MODEL is a device-data id
(``wacom-intuos-pro-m``, or without the ``wacom-`` prefix) or one of the
generic descriptor-only pens ``huion-like`` / ``ntrig-like``.  The reports
come from :mod:`station.drivers.synth`'s encoders — the exact inverse of the
parsers — and are served through a :class:`MockHidrawNode`, so the driver
reads them with the real hidraw read path.

Like a real Wacom, a model with init feature reports starts in mouse mode:
it sends boot-mouse reports (report ID 1) until the driver sends the ``02 02``
mode switch; only then do pen reports flow.  (Unpaced, it sends three mouse
reports and waits up to 2 s for the switch, so tests are deterministic.)

Options: ``script`` (see :mod:`~station.drivers.mock.script`), ``rate`` (Hz,
default the model's), ``speed`` (1.0 real time, ``max``), ``repeat`` (0 =
forever), ``reports`` (per stroke), ``pressure`` (peak 0..1), ``tilt``
(degrees), ``seed``, ``tool`` (``pen``/``pencil``/``brush``/``airbrush``/
``artpen``: the tool id used), ``unplug=1`` (end as an unplugged device
instead of the end of a recording).
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from dataclasses import replace
from typing import TYPE_CHECKING

from station.drivers import synth
from station.drivers.devicedata import DeviceModel
from station.drivers.hid import usages as U
from station.drivers.hid.descriptor import parse_descriptor
from station.drivers.hid.pen import GenericPenParser
from station.drivers.mock.script import SCRIPTS, PenState, timed_states
from station.drivers.raw import Axis, AxisRanges
from station.drivers.registry import load_devices
from station.drivers.transport.base import DeviceSpecError, HidDeviceInfo, TimedReport
from station.drivers.wacom.modes import PEN_MODE_FEATURE

from station.events import Tool

if TYPE_CHECKING:
    from station.drivers.pipeline.spec import DeviceSpec

GENERIC_MODELS: dict[str, DeviceModel] = {
    "huion-like": {"id": "huion-like", "name": "Mock Huion-like pen", "vendor_id": "256c",
                   "product_id": "006d", "bus": "usb", "parser": "hid-generic",
                   "report_rate_hz": 233, "descriptor": "huion"},
    "ntrig-like": {"id": "ntrig-like", "name": "Mock N-trig-like pen", "vendor_id": "1b96",
                   "product_id": "0001", "bus": "i2c", "parser": "hid-generic",
                   "report_rate_hz": 133, "descriptor": "ntrig"},
}
TOOL_IDS = {"pen": (Tool.PEN, 0x802), "pencil": (Tool.PENCIL, 0x812),
            "brush": (Tool.BRUSH, 0x832), "airbrush": (Tool.AIRBRUSH, 0x902),
            "artpen": (Tool.PEN, 0x10804)}  # fmt: skip
ERASER_IDS = {0x802: 0x80A, 0x812: 0x81A, 0x832: 0x83A, 0x902: 0x90A, 0x10804: 0x1080C}
BUS = {"usb": 3, "bluetooth": 5, "i2c": 0x18}
MOUSE_REPORT = bytes([1, 0, 0, 0])
# Protocols the mock encodes (synth's encoders); UC-Logic has its own mock (mock/uclogic.py).
MOCK_PROTOCOLS = frozenset({"wacom-intuos", "wacom-bamboo", "wacom-graphire", "wacom-graphire-bt",
                            "wacom-graphire4", "hid-generic"})


def find_model(name: str) -> DeviceModel:
    """Device data of a mock MODEL name (``intuos-pro-m``, ``wacom-intuos-pro-m`` …)."""
    if name in GENERIC_MODELS:
        return GENERIC_MODELS[name].copy()
    models = load_devices()
    for m in models:
        if m.get("id") in (name, f"wacom-{name}"):
            return m
    known = sorted([str(m.get("id")) for m in models] + list(GENERIC_MODELS))
    raise DeviceSpecError(f"no mock model {name!r} (one of {', '.join(known)})", "--device")


def _units(v: float, axis: Axis | None) -> int:
    if axis is None:
        return 0
    return round(axis.minimum + min(1.0, max(0.0, v)) * axis.span)


class MockTablet:
    """Encodes timed pen states into one model's reports (see module docstring)."""

    def __init__(self, model: DeviceModel, script: str = "demo", rate: float | None = None,
                 seed: int = 0, repeat: int = 1, reports: int = 120, peak: float = 0.8,
                 tilt: float = 30.0, tool: str = "pen", paced: bool = False) -> None:
        if script not in SCRIPTS:
            raise DeviceSpecError(f"unknown script {script!r} (one of {', '.join(SCRIPTS)})",
                                  "--device")
        if tool not in TOOL_IDS:
            raise DeviceSpecError(f"unknown tool {tool!r} (one of {', '.join(TOOL_IDS)})",
                                  "--device")
        self.model = model
        self.protocol = str(model["parser"])
        if self.protocol not in MOCK_PROTOCOLS:
            raise DeviceSpecError(f"mock {model.get('id')}: no mock encoder for the "
                                  f"{self.protocol} protocol (mock protocols: "
                                  f"{', '.join(sorted(MOCK_PROTOCOLS))})", "--device")
        self.script, self.seed, self.repeat = script, seed, repeat
        self.reports_per_stroke, self.peak, self.tilt = reports, peak, tilt
        self.tool_type, self.tool_id = TOOL_IDS[tool]
        self.rate = float(rate or model.get("report_rate_hz") or 200)
        self.paced = paced
        self.pen_mode = threading.Event()
        self.features: list[bytes] = []
        self.init_features = [bytes.fromhex(h) for h in model.get("init_feature_reports", [])]
        if not self.init_features:
            self.pen_mode.set()
        self.max_pressure = int(model.get("max_pressure", 2047))
        self.max_distance = int(model.get("max_distance", 63))
        self.descriptor = self._descriptor()
        self.generic = None
        if self.protocol == "hid-generic":
            self.generic = GenericPenParser(parse_descriptor(self.descriptor), model)
            if self.generic.primary is None:
                raise DeviceSpecError(f"mock {model['id']}: descriptor has no pen report")
            self.ranges: AxisRanges = self.generic.ranges
        else:
            self.ranges = AxisRanges(Axis(0, int(model["max_x"])), Axis(0, int(model["max_y"])))
        self.info = HidDeviceInfo(
            name=str(model.get("name", model["id"])), vid=int(model["vendor_id"], 16),
            pid=int(model["product_id"], 16), bus=BUS.get(str(model.get("bus")), 3),
            path=f"mock:{model['id']}", descriptor=self.descriptor, phys="mock/input0",
        )

    def _descriptor(self) -> bytes:
        kind = self.model.get("descriptor")
        if kind == "huion":
            return synth.huion_like_descriptor()
        if kind == "ntrig":
            return synth.ntrig_like_descriptor()
        if self.protocol == "hid-generic":
            return synth.pth660_like_descriptor()
        pen_bytes = {"wacom-intuos": 9, "wacom-bamboo": 8}.get(self.protocol, 7)
        return synth.wacom_protocol_descriptor(pen_bytes)

    # -- the device's behaviour ------------------------------------------------
    def feature(self, data: bytes) -> None:
        """A feature report arrived (the node calls this)."""
        self.features.append(bytes(data))
        if bytes(data) == PEN_MODE_FEATURE or bytes(data) in self.init_features:
            self.pen_mode.set()

    def timed_reports(self) -> Iterator[TimedReport]:
        period = 1.0 / self.rate
        t = 0.0
        sent = 0
        if self.init_features:
            # Mouse mode until the switch (unpaced: exactly three reports, then wait for it).
            while (sent < 3 and not self.paced) or not self.pen_mode.is_set():
                yield TimedReport(t, MOUSE_REPORT)
                t += period
                sent += 1
                if not self.paced and sent >= 3 and not self.pen_mode.wait(2.0):
                    return  # never switched: a mouse is all the driver gets
        start = t + period
        states = timed_states(self.script, self.rate, self.seed, self.repeat,
                              self.reports_per_stroke, self.peak, self.tilt)
        in_prox = False
        for ts, state in states:
            if state.proximity:
                tool = state.tool
                tool_id = state.tool_id
                if tool is Tool.PEN and state.tool_id == 0x802:
                    tool, tool_id = self.tool_type, self.tool_id
                if tool is Tool.ERASER:
                    tool_id = ERASER_IDS.get(self.tool_id, 0x80A)
                state = replace(state, tool=tool, tool_id=tool_id)
            for data in self.encode(state, entering=state.proximity and not in_prox):
                yield TimedReport(start + ts, data)
            in_prox = state.proximity

    def encode(self, s: PenState, entering: bool) -> list[bytes]:
        """The report(s) one state becomes in this model's protocol."""
        p = self.protocol
        if p == "wacom-intuos":
            return self._intuos(s, entering)
        if p == "wacom-bamboo":
            return [self._bamboo(s)]
        if p in ("wacom-graphire", "wacom-graphire-bt", "wacom-graphire4"):
            return [self._graphire(s, p.endswith("-bt"))]
        return [self._generic(s)]

    def _xy(self, s: PenState) -> tuple[int, int]:
        return _units(s.x, self.ranges.x), _units(s.y, self.ranges.y)

    def _intuos(self, s: PenState, entering: bool) -> list[bytes]:
        if not s.proximity:
            return [synth.intuos_prox_out()]
        x, y = self._xy(s)
        pressure = round(min(1.0, s.pressure) * self.max_pressure)
        dist = round(s.distance * self.max_distance)
        tx, ty = max(-64, min(63, round(s.tilt_x))), max(-64, min(63, round(s.tilt_y)))
        out = [synth.intuos_prox_in(s.tool_id, s.serial)] if entering else []
        out.append(synth.intuos_pen(x, y, pressure, tx, ty, dist, s.buttons, self.max_pressure))
        if s.tool_id in (0x902, 0x90A):
            out.append(synth.intuos_airbrush(x, y, round(s.wheel * 1023), tx, ty, dist))
        elif s.tool_id in (0x10804, 0x1080C):
            out.append(synth.intuos_rotation(x, y, max(-900, min(899, round(s.rotation * 5))),
                                             dist))
        return out

    def _bamboo(self, s: PenState) -> bytes:
        x, y = self._xy(s)
        if not s.proximity:
            return synth.bamboo_pen(x, y, in_range=False, prox=False, ready=False)
        pressure = round(min(1.0, s.pressure) * self.max_pressure)
        dist = round(s.distance * self.max_distance)
        return synth.bamboo_pen(x, y, pressure, tip=pressure > 0, buttons=s.buttons,
                                eraser=s.tool is Tool.ERASER,
                                raw_distance=self.max_distance - dist)

    def _graphire(self, s: PenState, bluetooth: bool) -> bytes:
        x, y = self._xy(s)
        tool = synth.GRAPHIRE_ERASER if s.tool is Tool.ERASER else synth.GRAPHIRE_PEN
        if not s.proximity:
            return synth.graphire_report(x, y, tool=tool, prox=False, bluetooth=bluetooth)
        pressure = round(min(1.0, s.pressure) * self.max_pressure)
        return synth.graphire_report(x, y, pressure, tool, tip=pressure > 0, buttons=s.buttons,
                                     bluetooth=bluetooth)

    def _generic(self, s: PenState) -> bytes:
        assert self.generic is not None and self.generic.primary is not None
        r = self.ranges
        fields = self.generic.primary.fields
        # a pen without an eraser end (no Eraser/Invert usage) touches with its tip
        eraser = s.tool is Tool.ERASER and ("eraser" in fields or "invert" in fields)
        values: dict[int, int | bool] = {U.DG_IN_RANGE: s.proximity, U.WD_SENSE: s.proximity}
        if s.proximity:
            x, y = self._xy(s)
            pressure = _units(s.pressure, r.pressure) if s.pressure > 0 else 0
            values.update({
                U.GD_X: x, U.GD_Y: y, U.DG_TIP_PRESSURE: pressure,
                U.DG_TIP_SWITCH: pressure > 0 and not eraser,
                U.DG_ERASER: pressure > 0 and eraser, U.DG_INVERT: eraser,
                U.DG_BARREL_SWITCH: bool(s.buttons & 1),
                U.DG_SECONDARY_BARREL_SWITCH: bool(s.buttons & 2),
                U.DG_X_TILT: self._tilt_units(s.tilt_x, r.tilt_x),
                U.DG_Y_TILT: self._tilt_units(s.tilt_y, r.tilt_y),
                U.DG_TRANSDUCER_SERIAL: s.serial, U.WD_TOOL_TYPE: s.tool_id,
                U.WD_DISTANCE: round(s.distance * 63),
                U.DG_TWIST: round((s.rotation + 180.0) % 360.0) % 360,
            })
        return synth.encode_report(self.generic.descriptor, self.generic.primary.report_id,
                                   values)

    @staticmethod
    def _tilt_units(deg: float, axis: Axis | None) -> int:
        if axis is None:
            return 0
        units = deg * axis.resolution if axis.resolution else (deg / 64.0 + 1) / 2 * axis.span \
            + axis.minimum
        return max(axis.minimum, min(axis.maximum, round(units)))


def mock_tablet_from_spec(spec: DeviceSpec) -> tuple[MockTablet, float | None]:
    model = find_model(spec.target)
    speed = spec.speed(1.0)
    tablet = MockTablet(
        model,
        script=spec.options.get("script", "demo"),
        rate=spec.number("rate", float(model.get("report_rate_hz", 200)), 1, 2000),
        seed=int(spec.number("seed", 0, 0, 2**31)),
        repeat=int(spec.number("repeat", 1, 0, 1e6)),
        reports=int(spec.number("reports", 120, 2, 100000)),
        peak=spec.number("pressure", 0.8, 0.0, 1.0),
        tilt=spec.number("tilt", 30.0, 0.0, 60.0),
        tool=spec.options.get("tool", "pen"),
        paced=speed is not None,
    )
    return tablet, speed
