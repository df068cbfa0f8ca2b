"""hid-recorder traces of every supported protocol: reading, replay, golden samples, errors.

Recordings are synthetic: the mock tablet (drivers/mock/tablet.py) turns a
pen script into each model's real report bytes with drivers/synth.py's
encoders, and synth.write_hid_recorder writes them in the recorder variants
seen in the wild (upper/lower case, padded or not, any start time, comments,
several devices).  No third-party capture is used.
"""

from __future__ import annotations

import json
from itertools import pairwise
from pathlib import Path
from typing import Any

import pytest
from station.drivers import synth
from station.drivers.mock.tablet import MockTablet, find_model
from station.drivers.pipeline import TraceReplay
from station.drivers.traces import TraceError, read_trace
from station.drivers.traces.hidrecorder import HidRecorderWriter, parse_hid_recorder
from station.drivers.traces.replay import iter_trace_samples

from station.cli import main
from station.events import Button, PenSample, Tool

MODELS = ["intuos-pro-m", "intuos4-4x6", "cintiq-22hd", "intuos-s-ctl480", "bamboo-pen-ctl460",
          "graphire-usb", "graphire-bt", "intuos-pro-2-m-pth660", "huion-like", "ntrig-like"]
# What each protocol can say: (serial reported, eraser end exists)
CAPABILITIES = {
    "intuos-pro-m": (True, True), "intuos4-4x6": (True, True), "cintiq-22hd": (True, True),
    "intuos-s-ctl480": (False, True), "bamboo-pen-ctl460": (False, True),
    "graphire-usb": (False, True), "graphire-bt": (False, True),
    "intuos-pro-2-m-pth660": (True, True), "huion-like": (False, False),
    "ntrig-like": (True, True),
}  # fmt: skip
SERIAL = 0x0A1B2C3D


def recording(model: str, script: str = "demo", reports: int = 30, **kw: object
              ) -> synth.RecordedDevice:
    """A synthetic recording of ``model`` playing ``script`` (mode switch already sent)."""
    tablet = MockTablet(find_model(model), script=script, reports=reports)
    for feature in tablet.init_features:
        tablet.feature(feature)
    events = [(r.time, r.data) for r in tablet.timed_reports()]
    info = tablet.info
    return synth.RecordedDevice(info.name, info.vid, info.pid, info.descriptor or b"", events,
                                bus=info.bus, **kw)


def replay_jsonl(path: Path, tmp_path: Path, *extra: str) -> list[PenSample]:
    out = tmp_path / "out.jsonl"
    assert main(["replay", str(path), "--jsonl", str(out), *extra]) == 0
    lines = out.read_text().splitlines()
    assert json.loads(lines[0])["format"] == "station-session"
    return [PenSample.from_record(json.loads(line)) for line in lines[1:]]


def check_stream(samples: list[PenSample]) -> None:
    assert samples
    for s in samples:
        assert 0.0 <= s.x <= 1.0 and 0.0 <= s.y <= 1.0
        if not s.touching:
            assert s.pressure == 0.0
        if not s.proximity:
            assert not s.touching
    assert all(b.t >= a.t for a, b in pairwise(samples))


@pytest.mark.parametrize("model", MODELS)
def test_replay_of_every_supported_device(model: str, tmp_path: Path) -> None:
    path = tmp_path / f"{model}.hid"
    synth.write_hid_recorder([recording(model)], path, upper=model.startswith("intuos"),
                             pad=not model.startswith("graphire"), start=1234.5)
    samples = replay_jsonl(path, tmp_path)
    check_stream(samples)
    has_serial, has_eraser = CAPABILITIES[model]
    tools = {s.tool for s in samples}
    assert tools == ({Tool.PEN, Tool.ERASER} if has_eraser else {Tool.PEN})
    serials = {s.serial for s in samples}
    assert serials == ({SERIAL} if has_serial else {None})
    touching = [s for s in samples if s.touching]
    # five strokes touch (line, arc, spiral, eraser, buttons); hover never does
    strokes = sum(1 for a, b in pairwise(samples)
                  if b.touching and not a.touching)
    assert strokes == 5
    assert 0.7 < max(s.pressure for s in touching) <= 0.8 + 1 / 511  # one device unit
    buttons = {0, int(Button.STYLUS)} | ({int(Button.STYLUS2)} if model != "ntrig-like" else set())
    assert {s.buttons for s in samples} == buttons  # N-trig-like: one barrel switch only
    # the line script starts at (0.1, 0.2): x/y land within one device unit
    first = touching[0]
    assert first.x == pytest.approx(0.1, abs=0.002) and first.y == pytest.approx(0.2, abs=0.004)
    outs = [s for s in samples if not s.proximity]
    assert len(outs) == 6  # every stroke ends with a proximity-out
    assert all(s.pressure == 0.0 for s in outs)


def test_golden_intuos_samples_field_by_field(tmp_path: Path) -> None:
    reports = [
        (100.000, synth.intuos_prox_in(0x802, 0x12345678)),
        (100.005, synth.intuos_pen(22352, 13970, 0, tilt_x=10, tilt_y=-20, distance=40)),
        (100.010, synth.intuos_pen(44704, 0, 2047, distance=0, buttons=Button.STYLUS)),
        (100.016, synth.intuos_pen(0, 27940, 1100, tilt_x=-64, tilt_y=63, distance=0)),
        (100.021, synth.intuos_prox_out()),
    ]
    dev = synth.RecordedDevice("Wacom Intuos Pro M", 0x056A, 0x0315,
                               synth.wacom_protocol_descriptor(9), reports)
    path = tmp_path / "golden.hid"
    synth.write_hid_recorder([dev], path)
    got = list(iter_trace_samples(path))
    common: dict[str, Any] = dict(device="wacom-intuos-pro-m", serial=0x12345678,
                                  tool_id=0x802, tool=Tool.PEN)
    expected = [
        PenSample(t=0.005, x=0.5, y=0.5, pressure=0.0, tilt_x=10.0, tilt_y=-20.0,
                  proximity=True, touching=False, distance=40 / 63, seq=1, **common),
        PenSample(t=0.010, x=1.0, y=0.0, pressure=1.0, proximity=True, touching=True,
                  buttons=int(Button.STYLUS), distance=0.0, seq=2, **common),
        # the Intuos protocol has a tip bit (set above 10): pressure counts from zero
        PenSample(t=0.016, x=0.0, y=1.0, pressure=1100 / 2047,
                  tilt_x=-64.0, tilt_y=63.0, proximity=True, touching=True, distance=0.0,
                  seq=3, **common),
        PenSample(t=0.021, x=0.0, y=1.0, pressure=0.0, tilt_x=-64.0, tilt_y=63.0,
                  proximity=False, touching=False, seq=4, **common),
    ]
    assert len(got) == len(expected)
    for g, e in zip(got, expected, strict=True):
        for name in ("device", "tool", "serial", "tool_id", "proximity", "touching", "buttons",
                     "seq", "rotation", "wheel"):
            assert getattr(g, name) == getattr(e, name), name
        for name in ("t", "x", "y", "pressure", "tilt_x", "tilt_y"):
            assert getattr(g, name) == pytest.approx(getattr(e, name), abs=1e-9), name
        if e.distance is not None:
            assert g.distance == pytest.approx(e.distance)


def test_art_pen_rotation_and_airbrush_wheel(tmp_path: Path) -> None:
    for tool, attr in (("artpen", "rotation"), ("airbrush", "wheel")):
        tablet = MockTablet(find_model("intuos4-4x6"), script="line", reports=20, tool=tool)
        tablet.feature(b"\x02\x02")
        dev = synth.RecordedDevice("Intuos4", tablet.info.vid, tablet.info.pid,
                                   tablet.info.descriptor or b"",
                                   [(r.time, r.data) for r in tablet.timed_reports()])
        path = tmp_path / f"{tool}.hid"
        synth.write_hid_recorder([dev], path)
        samples = [s for s in iter_trace_samples(path) if s.proximity]
        values = [getattr(s, attr) for s in samples if getattr(s, attr) is not None]
        assert values, attr
        if attr == "wheel":
            assert {s.tool for s in samples} == {Tool.AIRBRUSH}
            assert min(values) == 0.0 and max(values) == pytest.approx(1.0)
        else:
            assert min(values) < -170 and max(values) > 170  # a full turn of the barrel


def test_pen_and_touch_interleaved_keeps_only_the_pen(tmp_path: Path) -> None:
    pen = recording("intuos-pro-m", "line")
    touch_desc = synth.touch_descriptor(2)
    from station.drivers.hid.descriptor import parse_descriptor

    desc = parse_descriptor(touch_desc)
    touch_events = [(t + 0.0025, synth.encode_report(desc, 3, {0x000D0042: True}))
                    for t, _ in pen.events[::3]]
    touch = synth.RecordedDevice("Wacom Intuos Pro M Finger", 0x056A, 0x0315, touch_desc,
                                 touch_events)
    path = tmp_path / "both.hid"
    synth.write_hid_recorder([touch, pen], path)
    trace = read_trace(path)
    assert [len(d.reports) for d in trace.devices] == [len(touch_events), len(pen.events)]
    replay = TraceReplay(trace)
    assert [d.index for d in replay.pen_devices] == [1]
    assert replay.skipped[0]["device"] == 0 and "touch" in replay.skipped[0]["reason"]
    alone = tmp_path / "pen.hid"
    synth.write_hid_recorder([pen], alone)
    assert [s.to_record() for s in replay.samples()] == \
        [s.to_record() for s in iter_trace_samples(alone)]


def test_recorder_variants_read_the_same(tmp_path: Path) -> None:
    dev = recording("bamboo-pen-ctl460", "line", reports=10)
    texts = [synth.write_hid_recorder([dev]),
             synth.write_hid_recorder([dev], upper=True, pad=False, start=98765.25,
                                      comments=False),
             synth.write_hid_recorder([dev], always_device_lines=True, start=3.0)]
    texts.append("# odd lines\nX: what is this\nnot a tag line\n" + texts[0] + "Z: 1 2 3\n")
    traces = [parse_hid_recorder(t.splitlines(), f"v{i}.hid") for i, t in enumerate(texts)]
    for tr in traces:
        (d,) = tr.devices
        assert (d.vid, d.pid, d.bus) == (0x056A, 0x00D4, 3)
        assert d.descriptor == dev.descriptor
        assert [r.data for r in d.reports] == [e[1] for e in dev.events]
        gaps = [b.time - a.time for a, b in zip(d.reports, d.reports[1:], strict=False)]
        ref = [b[0] - a[0] for a, b in zip(dev.events, dev.events[1:], strict=False)]
        assert gaps == pytest.approx(ref, abs=2e-6)


BAD_LINES = [
    ("E: 0.010000 10 02 c2 00 00 00", "says 10 bytes but has 5"),
    ("E: 0.010000 3 02 zz 00", "'zz' is not a hex byte"),
    ("E: 0.010000 2 02 1ff", "is not a byte"),
    ("E: 0.010000 x 02", "not a decimal number"),
    ("E: later 2 02 00", "not sec.usec"),
    ("R: 4 05 0d 09", "says 4 bytes but has 3"),
    ("I: 3 056a", "needs bus vid pid"),
    ("I: 3 zz 0315", "not hex"),
    ("D: x", "one device number"),
    ("E: 0.000001 2 02 00", "goes back"),
]


@pytest.mark.parametrize("line,needle", BAD_LINES)
def test_malformed_hid_recorder_exit_2_with_file_and_line(tmp_path: Path, capsys,
                                                           line: str, needle: str) -> None:
    text = synth.write_hid_recorder([recording("intuos-pro-m", "line", reports=4)],
                                    comments=False)
    lines = text.splitlines()
    lines.insert(10, line)  # after some reports (time > 0)
    path = tmp_path / "bad.hid"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(TraceError) as err:
        read_trace(path)
    assert err.value.where == f"{path}:11" and needle in str(err.value)
    capsys.readouterr()
    assert main(["replay", str(path), "--jsonl", str(tmp_path / "o.jsonl")]) == 2
    message = capsys.readouterr().err
    assert message.count("\n") == 1 and f"{path}:11" in message and "Traceback" not in message


def test_truncated_trace_is_a_clear_error(tmp_path: Path) -> None:
    text = synth.write_hid_recorder([recording("graphire-usb", "line", reports=4)])
    path = tmp_path / "cut.hid"
    cut = text[: text.rindex(" ") - 3]
    path.write_text(cut + "\n")  # a report short of bytes in a whole line: malformed
    with pytest.raises(TraceError, match="truncated"):
        read_trace(path)
    # the recorder killed mid-write (no newline after the cut): played up to the cut
    # (tests/test_hostile_input.py checks the warning naming the line)
    path.write_text(cut)
    assert len(read_trace(path).devices[0].reports) == text.count("E: ") - 1
    empty = tmp_path / "empty.hid"
    empty.write_text("# nothing\n")
    with pytest.raises(TraceError, match="no device"):
        read_trace(empty)
    binary = tmp_path / "bin.hid"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(TraceError, match="not a text file"):
        read_trace(binary)


def test_bad_reports_inside_a_trace_are_counted_and_dropped(tmp_path: Path, capsys) -> None:
    dev = recording("intuos-pro-m", "line", reports=10)
    t_mid = dev.events[10][0]
    dev.events[10:10] = [(t_mid, b"\x02\xe0\x01"),  # truncated pen report
                         (t_mid, bytes([0x02]) + bytes(40)),  # oversized
                         (t_mid, bytes([0x37]) + bytes(9))]  # unknown report ID
    path = tmp_path / "noisy.hid"
    synth.write_hid_recorder([dev], path)
    samples = replay_jsonl(path, tmp_path, "--json")
    check_stream(samples)
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    (d,) = summary["devices"]
    assert d["bad_reports"] + d["skipped_reports"] >= 3 + 3  # 3 mouse-mode + 3 bad
    assert d["bad_reports"] >= 2
    clean = tmp_path / "clean.hid"
    synth.write_hid_recorder([recording("intuos-pro-m", "line", reports=10)], clean)
    assert [(s.x, s.y, s.pressure) for s in samples] == \
        [(s.x, s.y, s.pressure) for s in iter_trace_samples(clean)]


def test_trace_without_pen_is_exit_2(tmp_path: Path, capsys) -> None:
    touch = synth.RecordedDevice("touch only", 0x1234, 0x5678, synth.touch_descriptor(1),
                                 [(0.0, bytes(8))])
    path = tmp_path / "touch.hid"
    synth.write_hid_recorder([touch], path)
    assert main(["replay", str(path)]) == 2
    err = capsys.readouterr().err
    # one line, naming the device that was skipped and why
    assert "no pen device" in err and "device 0 'touch only'" in err
    assert len(err.strip().splitlines()) == 1


def test_hid_recorder_writer_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "w.hid"
    with path.open("w") as fh:
        w = HidRecorderWriter(fh)
        w.add_device("Pen", 0x056A, 0x0315, 3, b"\x05\x0d", "usb-1/input0")
        w.write_report(50.5, b"\x02\xc2")
        w.write_report(50.505, b"\x02\x80")
    (d,) = read_trace(path).devices
    assert (d.name, d.phys, d.descriptor) == ("Pen", "usb-1/input0", b"\x05\x0d")
    assert [(r.time, r.data) for r in d.reports] == [(0.0, b"\x02\xc2"), (0.005, b"\x02\x80")]


def test_replay_speed_flag_validation(tmp_path: Path, capsys) -> None:
    path = tmp_path / "a.hid"
    synth.write_hid_recorder([recording("graphire-bt", "line", reports=4)], path)
    assert main(["replay", str(path), "--speed", "fast"]) == 2
    assert "--speed" in capsys.readouterr().err
    assert main(["replay", str(path), "--speed", "50", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["samples"] > 10


@pytest.mark.parametrize("descriptor,why", [
    (bytes.fromhex("05 0d 09 02 a1 01 09 20 a1 00"), "unbalanced collections"),
    (bytes.fromhex("05 0d 09 02 a1 01 75 ff 96 58 02 81 02 c0"), "report past 16 KiB"),
])
def test_unknown_device_with_a_broken_descriptor_is_exit_2(tmp_path: Path, capsys,
                                                           descriptor: bytes, why: str) -> None:
    dev = synth.RecordedDevice("odd pen", 0x1234, 0x5678, descriptor, [(0.0, b"\x01\x02")])
    path = tmp_path / "odd.hid"
    synth.write_hid_recorder([dev], path)
    assert main(["replay", str(path)]) == 2, why
    err = capsys.readouterr().err
    assert "no pen device" in err and "no parser" in err and "Traceback" not in err


def test_worn_nib_through_a_bamboo_trace(tmp_path: Path) -> None:
    # A Bamboo pen whose worn nib rests at 60/1023 while hovering (tip bit 0, pressure > 0).
    reports = [(0.000, synth.bamboo_pen(7000, 4000, 60, tip=False, raw_distance=20))]
    pressures = [60, 100, 108, 109, 400, 1023, 70, 69, 60]
    for i, p in enumerate(pressures[1:], 1):
        reports.append((i * 0.0075, synth.bamboo_pen(7000 + i, 4000, p, tip=p > 100)))
    reports.append((0.08, synth.bamboo_pen(0, 0, in_range=False, prox=False, ready=False)))
    dev = synth.RecordedDevice("Bamboo", 0x056A, 0x00D4, synth.wacom_protocol_descriptor(8),
                               reports)
    path = tmp_path / "nib.hid"
    synth.write_hid_recorder([dev], path)
    samples = list(iter_trace_samples(path))
    assert len(samples) == len(pressures) + 1
    # offset 60; the Bamboo has a tip bit, so contact follows it (set here above 100) as
    # long as the pressure clears the worn nib's up threshold 60 + 1 % of 963 = 69.63,
    # and the pressure counts from that threshold
    assert [s.touching for s in samples[:-1]] == [False, False, True, True, True, True, False,
                                                   False, False]
    up = 60 + 0.01 * 963
    assert samples[2].pressure == pytest.approx((108 - up) / (1023 - up))
    assert samples[4].pressure == pytest.approx((400 - up) / (1023 - up))
    assert samples[5].pressure == 1.0
    assert all(s.pressure == 0.0 for s in samples if not s.touching)


def test_lost_proximity_out_is_forced_after_50_ms(tmp_path: Path) -> None:
    # A Graphire stroke whose proximity-out report never came; the next stroke starts 300 ms later.
    reports = [(0.01 * i, synth.graphire_report(1000 + 100 * i, 2000, 200 if 2 <= i < 8 else 0,
                                                tip=2 <= i < 8)) for i in range(10)]
    reports += [(0.39 + 0.01 * i, synth.graphire_report(5000, 5000, 0)) for i in range(3)]
    dev = synth.RecordedDevice("Graphire", 0x056A, 0x0081, synth.wacom_protocol_descriptor(7),
                               reports)
    path = tmp_path / "lost.hid"
    synth.write_hid_recorder([dev], path)
    samples = list(iter_trace_samples(path))
    outs = [s for s in samples if not s.proximity]
    assert len(outs) == 2  # forced after the first stroke, and at the end of the trace
    assert outs[0].t == pytest.approx(0.09 + 0.05)
    assert outs[0].x == pytest.approx(1900 / 16704) and not outs[0].touching
    i = samples.index(outs[0])
    assert samples[i + 1].proximity and samples[i + 1].t == pytest.approx(0.39)
