"""UC-Logic tablets: parameter descriptors, the set-up sequence, reports before and after it.

The mock tablet (station.drivers.mock.uclogic) sits behind the pyusb mock
backend and is read by the real UsbTransport, so string-descriptor reads and
the interrupt OUT probe go through pyusb's core like on hardware.
"""

from __future__ import annotations

import pytest
from station.drivers import registry
from station.drivers import synth as S
from station.drivers.hid.errors import ReportError
from station.drivers.mock.uclogic import MockUclogicTablet
from station.drivers.mock.usb import RecordedUsbBackend
from station.drivers.pipeline import HidPenSource, open_device
from station.drivers.transport.base import DeviceGone, DeviceSpecError
from station.drivers.transport.pyusb import UsbTransport
from station.drivers.uclogic import params as P
from station.drivers.uclogic.init import TRANSITION_FIRMWARE, UGEE_V2_PROBE, initialise
from station.drivers.uclogic.parser import UclogicPenParser, decode

from station.events import Button


# -- parameter descriptors ------------------------------------------------------------------
def test_v1_parameters_are_little_endian_words():
    buf = bytes([12, 3, 0x40, 0x9C, 0xA8, 0x61, 0, 0, 0xFF, 0x07, 0xA0, 0x0F])
    p = P.parse_v1(buf)
    assert (p.kind, p.max_x, p.max_y, p.max_pressure, p.resolution_lpi) == ("v1", 40000, 25000,
                                                                            2047, 4000)
    assert p.report_id == 7 and p.resolution_mm == pytest.approx(4000 / 25.4)
    with pytest.raises(ReportError, match="expected 12"):
        P.parse_v1(buf + b"\0")


def test_v2_parameters_have_24_bit_coordinates_and_are_not_text():
    # The HS610 parameter string quoted in the kernel's hid-uclogic-params.c.
    hs610 = bytes([0x13, 0x03, 0x70, 0xC6, 0x00, 0x06, 0x7C, 0x00, 0xFF, 0x1F, 0xD8, 0x13,
                   0x03, 0x0D, 0x10, 0x01, 0x04, 0x3C, 0x3E])
    p = P.parse_v2(hs610)
    assert (p.max_x, p.max_y, p.max_pressure, p.resolution_lpi) == (50800, 31750, 8191, 5080)
    assert p.report_id == 8 and p.resolution_mm == pytest.approx(200.0)
    name = P.string_descriptor("HUION Tablet_H610".encode("utf-16-le"))
    assert P.looks_like_text(name)
    with pytest.raises(ReportError, match="only text"):
        P.parse_v2(name[:32])  # what a 32-byte read of the name returns
    with pytest.raises(ReportError, match=r"18\.\.32"):
        P.parse_v2(hs610[:17])
    assert P.parse_v2(P.encode_v2(50800, 31750, 8191, 5080)) == p


def test_ugee_v2_parameters_carry_the_frame_buttons():
    p = P.parse_ugee_v2(P.encode_ugee_v2(30480, 20320, 8191, 5080, 8))
    assert (p.kind, p.max_x, p.max_y, p.max_pressure, p.frame_buttons) == ("ugee-v2", 30480,
                                                                          20320, 8191, 8)


# -- the set-up sequence -------------------------------------------------------------------------
class FakeControl:
    def __init__(self, strings: dict[int, bytes]) -> None:
        self.strings, self.calls = strings, []

    def get_string_descriptor(self, index: int, length: int) -> bytes | None:
        self.calls.append(("string", index, length))
        buf = self.strings.get(index)
        return None if buf is None else buf[:length]

    def write_interrupt(self, endpoint: int, data: bytes) -> None:
        self.calls.append(("out", endpoint, data))


def _fw(name: str) -> bytes:
    return P.string_descriptor(name.encode("utf-16-le"))


def test_huion_reads_firmware_then_v2_then_v1():
    v1 = P.encode_v1(40000, 25000, 2047, 4000)
    c = FakeControl({201: _fw("HUION_M19_180101"), 100: v1})
    p = initialise(c, "huion")
    assert p is not None and p.kind == "v1"
    assert [x[1] for x in c.calls] == [201, 200, 100]
    assert c.calls[1][2] == 32 and c.calls[2][2] == 12  # v2: up to 32 bytes, v1: exactly 12


def test_huion_transition_firmware_is_not_asked_for_v2():
    c = FakeControl({201: _fw(TRANSITION_FIRMWARE), 200: P.encode_v2(1, 1, 1, 1),
                     100: P.encode_v1(100, 100, 1023, 1000)})  # fmt: skip
    assert initialise(c, "huion").kind == "v1"
    assert 200 not in [x[1] for x in c.calls]


def test_ugee_v2_probes_endpoint_3_before_reading_its_parameters():
    c = FakeControl({100: P.encode_ugee_v2(30480, 20320, 8191, 5080, 8)})
    assert initialise(c, "ugee-v2").kind == "ugee-v2"
    assert c.calls[0] == ("out", 3, UGEE_V2_PROBE) and c.calls[1][:2] == ("string", 100)
    assert bytes([0x02, 0xB0, 0x04, 0, 0, 0, 0, 0, 0, 0]) == UGEE_V2_PROBE


def test_no_parameters_keeps_the_device_reports():
    assert initialise(FakeControl({}), "huion") is None
    assert initialise(FakeControl({}), "fixed-descriptor") is None
    with pytest.raises(ValueError, match="unknown UC-Logic"):
        initialise(FakeControl({}), "magic")


# -- report layouts ---------------------------------------------------------------------------
def test_v2_report_high_bytes_come_after_the_pressure():
    d = bytes([8, 0x81, 0x34, 0x12, 0x78, 0x56, 0x10, 0x20, 0x01, 0x02, 0xF6, 0x05])
    in_range, x, y, p, tip, _buttons, tx, ty = decode("v2", d)
    assert (x, y, p) == (0x011234, 0x025678, 0x2010) and tip and in_range
    assert (tx, ty) == (-10, -5)  # y tilt points the other way on the wire


def test_v1_in_range_bit_is_inverted_and_ugee_pressure_has_13_bits():
    assert decode("v1", bytes([7, 0x40, 1, 0, 2, 0, 3, 0]))[0] is False
    assert decode("v1", bytes([7, 0x03, 1, 0, 2, 0, 3, 0]))[:6] == (True, 1, 2, 3, True,
                                                                     int(Button.STYLUS))
    v = decode("ugee-v2", bytes([2, 0x21, 5, 0, 6, 0, 0xFF, 0xFF, 0x3C, 0xC3]))
    assert v[0] and v[3] == 0x1FFF and (v[6], v[7]) == (60, -61)
    for kind in ("v1", "v2", "ugee-v2"):
        raw = S.uclogic_pen_report(kind, 12345, 2345, 999, True, int(Button.STYLUS2), True, 7, -9)
        got = decode(kind, raw)
        assert got[1:6] == (12345, 2345, 999, True, int(Button.STYLUS2))
        if kind != "v1":
            assert (got[6], got[7]) == (7, -9)


# -- the mock tablet before and after the switch ------------------------------------------------
def _read_all(src: HidPenSource) -> list:
    out = []
    while True:
        try:
            out.extend(src.read_raw(0.01))
        except DeviceGone:
            return out


@pytest.mark.parametrize("kind", ["v1", "v2", "ugee-v2"])
def test_mock_tablet_full_resolution_after_the_set_up(kind):
    tablet = MockUclogicTablet(kind, reports=30)
    transport = UsbTransport(tablet.vid, tablet.pid, backend=RecordedUsbBackend([tablet.device]))
    src = HidPenSource(transport, finite=True)
    assert src.parser.name == "uclogic" and tablet.full
    assert src.uclogic_params.kind == kind
    assert src.ranges.x.maximum == tablet.max_x
    assert src.ranges.pressure.maximum == tablet.max_pressure
    samples = _read_all(src)
    touching = [s for s in samples if s.tip]
    assert len(touching) >= 20
    top = max(s.pressure for s in samples)
    assert 0.7 * tablet.max_pressure <= top <= tablet.max_pressure  # the script peaks at 0.8
    assert max(s.x for s in samples) > tablet.max_x // 4  # past the compat range: full resolution
    if kind != "v1":
        assert any(s.tilt_x for s in samples) and src.ranges.tilt_x is not None
    if kind == "ugee-v2":
        assert "out 0x03 02 b0 04 00 00 00 00 00 00 00" in tablet.device.log


def test_mock_tablet_before_the_set_up_is_read_through_its_descriptor():
    tablet = MockUclogicTablet("v2", reports=30)
    transport = UsbTransport(tablet.vid, tablet.pid, backend=RecordedUsbBackend([tablet.device]))
    src = HidPenSource(transport, finite=True, send_init=False)
    assert not tablet.full and src.uclogic_params is None
    assert src.ranges.x.maximum == tablet.max_x // 4  # compatibility resolution
    samples = _read_all(src)
    assert samples and max(s.x for s in samples) <= tablet.max_x // 4
    assert max(s.pressure for s in samples) <= 1023
    assert not any(e.startswith("string 2") for e in tablet.device.log)


def test_registry_uclogic_interfaces():
    p = registry.parser_for(0x256C, 0x006D, S.huion_like_descriptor())
    assert isinstance(p, UclogicPenParser) and p.is_pen and p.fallback is not None
    assert p.init_kind == "huion" and p.needs_control
    vendor = bytes.fromhex("06 00 ff 09 01 a1 01 85 08 75 68 95 01 09 01 81 02 c0")
    v = registry.parser_for(0x256C, 0x006D, vendor)
    assert not v.is_pen and "UC-Logic set-up" in v.why
    ignored = registry.parser_for(0x256C, 0x006D, S.touch_descriptor(), interface=1)
    assert not ignored.is_pen
    m = registry.find_device(0x28BD, 0x0905)
    assert m["uclogic"] == {"init": "ugee-v2"} and m["parser"] == "uclogic"


def test_mock_uclogic_spec_opens_through_the_driver_pipeline():
    src = open_device("mock-uclogic:ugee-v2?speed=max&reports=20&script=spiral")
    assert src.parser.name == "uclogic" and src.uclogic_params.kind == "ugee-v2"
    samples = _read_all(src)
    assert sum(1 for s in samples if s.tip) >= 15
    with pytest.raises(DeviceSpecError, match="one of v1, v2, ugee-v2"):
        open_device("mock-uclogic:v9")
