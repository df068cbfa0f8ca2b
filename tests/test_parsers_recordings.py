"""Synthetic hid-recorder recordings of every protocol, read back and parsed via the registry."""

from __future__ import annotations

import itertools

import pytest
from station.drivers import synth as S
from station.drivers.registry import parser_for

from station.events import Tool

KINDS = ["intuos-pro", "intuos4", "cintiq-22hd", "intuos-s", "bamboo-pen", "graphire",
         "graphire-bt", "pth660", "huion", "ntrig"]  # fmt: skip


def test_writer_format_lines():
    dev = S.RecordedDevice("Pen", 0x056A, 0x0315, b"\x05\x0d", [(0.5, b"\x02\xc2"),
                                                                 (1.000001, b"\x02\x80")])
    text = S.write_hid_recorder([dev], start=100.0)
    lines = [ln for ln in text.splitlines() if not ln.startswith("#")]
    assert lines == ["R: 2 05 0d", "N: Pen", "P: ", "I: 3 056a 0315",
                     "E: 000100.500000 2 02 c2", "E: 000101.000001 2 02 80"]  # fmt: skip
    upper = S.write_hid_recorder([dev], upper=True, pad=False, comments=False)
    assert upper.splitlines() == ["R: 2 5 D", "N: Pen", "P: ", "I: 3 56A 315",
                                  "E: 0.500000 2 2 C2", "E: 1.000001 2 2 80"]  # fmt: skip


def test_writer_multi_device_interleaves_with_d_lines():
    a = S.RecordedDevice("A", 1, 2, b"\x01", [(0.0, b"\x01"), (0.2, b"\x02")])
    b = S.RecordedDevice("B", 3, 4, b"\x02", [(0.1, b"\x03")])
    text = S.write_hid_recorder([a, b], comments=False)
    ev = [ln for ln in text.splitlines() if ln.startswith(("D:", "E:"))]
    assert ev == ["D: 0", "D: 1", "D: 0", "E: 000000.000000 1 01", "D: 1",
                  "E: 000000.100000 1 03", "D: 0", "E: 000000.200000 1 02"]  # fmt: skip


def test_times_alternate_on_usb_frames():
    rec = S.stroke_recording("intuos-s", n=10)
    times = [t for t, _ in rec.events]
    gaps = {round(b - a, 6) for a, b in itertools.pairwise(times)}
    assert gaps == {0.007, 0.008}  # 133 Hz: 7/8 ms alternating, never a fixed period


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("variant", [{}, {"upper": True, "pad": False, "start": 12345.678}])
def test_recording_round_trip_through_the_registry(kind, variant, tmp_path):
    traces = pytest.importorskip("station.drivers.traces.hidrecorder")
    rec = S.stroke_recording(kind, n=40, serial=0x00C0FFEE)
    path = tmp_path / f"{kind}.hid"
    S.write_hid_recorder([rec], path, **variant)
    trace = traces.read_hid_recorder(path)
    (dev,) = trace.devices
    assert (dev.vid, dev.pid, dev.bus, dev.descriptor) == (rec.vid, rec.pid, rec.bus,
                                                           rec.descriptor)  # fmt: skip
    parser = parser_for(dev.vid, dev.pid, dev.descriptor, dev.bus)
    assert parser.is_pen
    samples = [s for r in dev.reports for s in parser.parse(r.data, r.time)]
    valid = [s for s in samples if s.valid]
    assert len(valid) == 40 + 5  # 3 hover + 40 stroke + 2 hover
    r = parser.ranges
    for s in valid:
        assert r.x.minimum <= s.x <= r.x.maximum and r.y.minimum <= s.y <= r.y.maximum
        assert s.proximity and s.tool == Tool.PEN
    touching = [s for s in valid if s.pressure]
    assert 30 <= len(touching) <= 40
    peak = max(s.pressure or 0 for s in valid)
    assert r.pressure is not None and peak >= 0.95 * r.pressure.maximum
    assert samples[-1].proximity is False  # the stroke ends out of proximity
    assert samples[0].time == pytest.approx(variant.get("start", 0.0), abs=1e-6)
    if kind in ("intuos-pro", "intuos4", "cintiq-22hd", "pth660", "ntrig"):
        assert {s.serial for s in valid} == {0x00C0FFEE}
    if kind in ("intuos-pro", "intuos4", "cintiq-22hd", "pth660"):
        assert {s.tool_id for s in valid} == {0x802}


def test_multi_interface_recording_keeps_pen_and_skips_touch(tmp_path):
    traces = pytest.importorskip("station.drivers.traces.hidrecorder")
    pen = S.stroke_recording("pth660", n=20)
    touch = S.stroke_recording("touch", n=30, start=0.001)
    path = tmp_path / "multi.hid"
    S.write_hid_recorder([pen, touch], path)
    trace = traces.read_hid_recorder(path)
    assert len(trace.devices) == 2
    parsers = [parser_for(d.vid, d.pid, d.descriptor, d.bus) for d in trace.devices]
    assert [p.is_pen for p in parsers] == [True, False]
    assert parsers[1].kind == "touch"
    counts = [sum(len(p.parse(r.data, r.time)) for r in d.reports)
              for p, d in zip(parsers, trace.devices, strict=True)]  # fmt: skip
    assert counts == [len(pen.events), 0] and parsers[1].skipped == 30
