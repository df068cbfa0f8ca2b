"""A mock UC-Logic tablet behind the pyusb mock backend, before and after the set-up.

It behaves like the tablets the kernel's hid-uclogic driver sets up: until the
driver reads its parameter string descriptor it sends compatibility reports
(report 9, a quarter of the resolution, 10-bit pressure, described by its
report descriptor); reading string 200 (v2 tablets), string 100 (v1) or —
after the ``02 b0 04`` probe on interrupt OUT endpoint 3 — string 100 (UGEE v2)
switches it to full-resolution reports of that kind.  String 201 holds the
firmware name; indexes it does not have stall, like a real device.

    tablet = MockUclogicTablet("v2")
    transport = UsbTransport(tablet.vid, tablet.pid, backend=RecordedUsbBackend([tablet.device]))
"""

from __future__ import annotations

from collections.abc import Iterator

from station.drivers import synth
from station.drivers.mock.script import PenState, timed_states
from station.drivers.mock.usb import RecordedUsbDevice
from station.drivers.transport.base import TimedReport
from station.drivers.uclogic import params as P
from station.drivers.uclogic.init import TRANSITION_FIRMWARE, UGEE_V2_ENDPOINT, UGEE_V2_PROBE

# (vid, pid, name, x max, y max, pressure max, lpi) per kind: numbers of that size class
# (a 10x6.25 inch Huion at 5080 lpi, a 6x4 inch UGEE at 5080 lpi); ids from the device data.
TABLETS = {
    "v1": (0x256C, 0x006E, "Mock Huion v1 tablet", 40000, 25000, 2047, 4000),
    "v2": (0x256C, 0x006D, "Mock Huion v2 tablet", 50800, 31750, 8191, 5080),
    "ugee-v2": (0x28BD, 0x0905, "Mock XP-Pen Deco 01 v2", 30480, 20320, 8191, 5080),
}
COMPAT_BUTTON_MASK = 0x03


class MockUclogicTablet:
    """One simulated UC-Logic tablet of ``kind`` (``v1``, ``v2``, ``ugee-v2``)."""

    def __init__(self, kind: str = "v2", script: str = "line", rate: float = 200.0,
                 reports: int = 40, firmware: str = "HUION_T21h_230511",
                 compat_reports: int = 3) -> None:
        self.kind = kind
        vid, pid, name, self.max_x, self.max_y, self.max_pressure, self.lpi = TABLETS[kind]
        self.vid, self.pid = vid, pid
        self.full = False
        self.probed = False
        strings = {P.FIRMWARE_INDEX: P.string_descriptor(firmware.encode("utf-16-le"))}
        if kind == "v1":
            strings[P.V1_INDEX] = P.encode_v1(self.max_x, self.max_y, self.max_pressure, self.lpi)
        elif kind == "v2":
            strings[P.V2_INDEX] = P.encode_v2(self.max_x, self.max_y, self.max_pressure, self.lpi)
            # Newer Huions answer string 100 with their name (text, not parameters).
            strings[P.V1_INDEX] = P.string_descriptor("HUION Tablet".encode("utf-16-le"))
        else:
            strings[P.V1_INDEX] = P.encode_ugee_v2(self.max_x, self.max_y, self.max_pressure,
                                                   self.lpi, 8)  # fmt: skip
        self.transition = firmware == TRANSITION_FIRMWARE
        self.states = timed_states(script, rate, 0, 1, reports, 0.8, 30.0)
        self.compat_reports = compat_reports
        self.device = RecordedUsbDevice(
            vid, pid, name, synth.uclogic_compat_descriptor(self.max_x, self.max_y),
            self._reports(), strings=strings,
            out_endpoint=UGEE_V2_ENDPOINT if kind == "ugee-v2" else None,
            on_string=self._string_read, on_out=self._out)

    # -- the device's behaviour ------------------------------------------------------
    def _string_read(self, index: int) -> None:
        v2 = self.kind == "v2" and index == P.V2_INDEX and not self.transition
        v1 = self.kind == "v1" and index == P.V1_INDEX
        ugee = self.kind == "ugee-v2" and index == P.V1_INDEX and self.probed
        if v2 or v1 or ugee:
            self.full = True

    def _out(self, endpoint: int, data: bytes) -> None:
        if endpoint == UGEE_V2_ENDPOINT and data == UGEE_V2_PROBE:
            self.probed = True

    def _reports(self) -> Iterator[TimedReport]:
        t = 0.0
        for _ in range(self.compat_reports):  # the compatibility reports seen before the set-up
            if self.full:
                break
            yield TimedReport(t, synth.uclogic_compat_report(0, 0, 0, False, False))
            t += 0.005
        for ts, state in self.states:
            data = self.encode(state)
            if data is not None:
                yield TimedReport(t + ts, data)

    def encode(self, s: PenState) -> bytes | None:
        """One pen state in the report format of the tablet's current mode (None: silent)."""
        x = round(min(1.0, max(0.0, s.x)) * self.max_x)
        y = round(min(1.0, max(0.0, s.y)) * self.max_y)
        if not self.full:
            p = round(min(1.0, s.pressure) * 1023)
            return synth.uclogic_compat_report(x // 4, y // 4, p, s.touching, s.proximity)
        if self.kind == "v2" and not s.proximity:
            return None  # v2 firmware has no in-range bit: out of range it is silent
        p = round(min(1.0, s.pressure) * self.max_pressure)
        tx = max(-60, min(60, round(s.tilt_x)))
        ty = max(-60, min(60, round(s.tilt_y)))
        return synth.uclogic_pen_report(self.kind, x, y, p, s.touching, s.buttons, s.proximity,
                                        tx, ty)  # fmt: skip
