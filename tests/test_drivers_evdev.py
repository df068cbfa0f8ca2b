"""evdev driver: capabilities, frame assembly, SYN_DROPPED resync, evemu/libinput traces."""

from __future__ import annotations

from itertools import pairwise
from pathlib import Path

import pytest
from station.drivers.evdev import codes as c
from station.drivers.evdev.frames import (
    AbsInfo,
    EvdevCaps,
    FrameAssembler,
    InputEvent,
    StaticState,
    is_pen_device,
    ranges_from_caps,
)
from station.drivers.mock.evdev import states_to_events, touchpad_caps, wacom_like_caps
from station.drivers.mock.script import timed_states
from station.drivers.pipeline import TraceReplay, open_device
from station.drivers.traces import TraceError, read_trace
from station.drivers.traces.evemu import format_evemu
from station.drivers.traces.libinput_record import format_libinput_record
from station.drivers.traces.replay import iter_trace_samples

from station.events import Button, PenSample, Tool

CAPS = wacom_like_caps()


def frame(t: float, abs_: dict[int, int] | None = None, keys: dict[int, int] | None = None,
          serial: int | None = None) -> list[InputEvent]:
    evs = [InputEvent(t, c.EV_ABS, k, v) for k, v in (abs_ or {}).items()]
    evs += [InputEvent(t, c.EV_KEY, k, v) for k, v in (keys or {}).items()]
    if serial is not None:
        evs.append(InputEvent(t, c.EV_MSC, c.MSC_SERIAL, serial))
    return [*evs, InputEvent(t, c.EV_SYN, c.SYN_REPORT, 0)]


def run(asm: FrameAssembler, events: list[InputEvent]):
    return [s for s in (asm.feed(e) for e in events) if s is not None]


def test_pen_devices_found_by_capabilities() -> None:
    assert is_pen_device(CAPS)
    assert not is_pen_device(touchpad_caps())
    stylus_only = EvdevCaps("n-trig", {c.ABS_X: AbsInfo(0, 9), c.ABS_Y: AbsInfo(0, 9)},
                            frozenset({c.BTN_STYLUS, c.BTN_TOUCH}))
    assert is_pen_device(stylus_only)
    keyboard = EvdevCaps("kbd", {}, frozenset({30, 31}))
    assert not is_pen_device(keyboard)


def test_ranges_from_absinfo_convert_tilt_resolution_per_radian() -> None:
    r = ranges_from_caps(CAPS)
    assert (r.x.maximum, r.x.resolution, r.y.maximum) == (44704, 200.0, 27940)
    assert r.tilt_x is not None and r.tilt_x.resolution == pytest.approx(57 * 3.14159265 / 180)
    assert r.rotation is not None and r.rotation.minimum == -900
    assert r.has_resolution
    bare = EvdevCaps("cheap pen", {c.ABS_X: AbsInfo(0, 4095), c.ABS_Y: AbsInfo(0, 4095),
                                   c.ABS_PRESSURE: AbsInfo(0, 1023)},
                     frozenset({c.BTN_TOOL_PEN, c.BTN_TOUCH}))
    assert not ranges_from_caps(bare).has_resolution


def test_frames_make_raw_samples_with_tool_buttons_serial_and_tool_id() -> None:
    asm = FrameAssembler(CAPS)
    evs = frame(1.0, {c.ABS_X: 1000, c.ABS_Y: 2000, c.ABS_MISC: 0x802, c.ABS_DISTANCE: 30},
                {c.BTN_TOOL_PEN: 1}, serial=0x1234ABCD)
    evs += frame(1.005, {c.ABS_PRESSURE: 900, c.ABS_TILT_X: -20, c.ABS_TILT_Y: 15},
                 {c.BTN_TOUCH: 1, c.BTN_STYLUS: 1})
    evs += frame(1.010, {c.ABS_X: 1010}, {c.BTN_STYLUS2: 1, c.BTN_STYLUS: 0})
    evs += frame(1.015, {c.ABS_PRESSURE: 0, c.ABS_MISC: 0}, {c.BTN_TOUCH: 0, c.BTN_STYLUS2: 0,
                                                            c.BTN_TOOL_PEN: 0})
    evs += frame(1.020, {c.ABS_X: 5})  # out of proximity: nothing
    s = run(asm, evs)
    assert len(s) == 4
    a, b, d, out = s
    assert (a.x, a.y, a.tool, a.serial, a.tool_id, a.tip, a.distance) == \
        (1000, 2000, Tool.PEN, 0x1234ABCD, 0x802, False, 30)
    assert (b.pressure, b.tilt_x, b.tilt_y, b.tip, b.buttons) == (900, -20, 15, True,
                                                                   int(Button.STYLUS))
    assert (d.x, d.buttons, d.time) == (1010, int(Button.STYLUS2), 1.010)
    assert not out.proximity and not out.valid and out.time == 1.015
    assert asm.stats.frames == 5 and asm.stats.samples == 4


@pytest.mark.parametrize("code,tool", sorted(c.PEN_TOOL_KEYS.items()))
def test_every_btn_tool_maps_to_its_tool(code: int, tool: Tool) -> None:
    asm = FrameAssembler(CAPS)
    (s,) = run(asm, frame(0.0, {c.ABS_X: 1}, {code: 1}))
    assert s.tool is tool and s.eraser == (tool is Tool.ERASER)


def test_syn_dropped_discards_until_syn_report_then_resyncs_from_device_state() -> None:
    state = StaticState()
    asm = FrameAssembler(CAPS, state)
    evs = frame(0.0, {c.ABS_X: 100, c.ABS_Y: 100}, {c.BTN_TOOL_PEN: 1})
    evs += [InputEvent(0.005, c.EV_ABS, c.ABS_X, 999999),  # partial frame, then the overflow
            InputEvent(0.005, c.EV_SYN, c.SYN_DROPPED, 0),
            InputEvent(0.006, c.EV_ABS, c.ABS_X, 777777),  # garbage after the drop
            InputEvent(0.006, c.EV_KEY, c.BTN_TOOL_RUBBER, 1)]
    state.abs.update({c.ABS_X: 4000, c.ABS_Y: 3000, c.ABS_PRESSURE: 1500})
    state.keys.update({c.BTN_TOOL_PEN, c.BTN_TOUCH, 0x1FF})  # a key the device lacks: ignored
    evs.append(InputEvent(0.007, c.EV_SYN, c.SYN_REPORT, 0))
    evs += frame(0.010, {c.ABS_Y: 3100})
    first, resynced, after = run(asm, evs)
    assert first.x == 100
    assert (resynced.x, resynced.y, resynced.pressure, resynced.tip, resynced.tool) == \
        (4000, 3000, 1500, True, Tool.PEN)
    assert (after.x, after.y) == (4000, 3100)
    assert asm.stats.dropped == 1 and asm.stats.resyncs == 1
    assert asm.stats.discarded_events == 3  # the partial X and the two after the drop
    # without a state source the assembler keeps what it had
    asm2 = FrameAssembler(CAPS)
    out = run(asm2, [*frame(0.0, {c.ABS_X: 5}, {c.BTN_TOOL_PEN: 1}),
                     InputEvent(0.1, c.EV_SYN, c.SYN_DROPPED, 0),
                     InputEvent(0.1, c.EV_ABS, c.ABS_X, 6),
                     InputEvent(0.1, c.EV_SYN, c.SYN_REPORT, 0)])
    assert [s.x for s in out] == [5, 5]


def test_empty_frames_and_autorepeat_do_not_make_samples() -> None:
    asm = FrameAssembler(CAPS)
    evs = frame(0.0, {c.ABS_X: 5}, {c.BTN_TOOL_PEN: 1})
    evs += [InputEvent(0.01, c.EV_SYN, c.SYN_REPORT, 0)]
    evs += frame(0.02, keys={c.BTN_STYLUS: 2})
    assert len(run(asm, evs)) == 1  # neither the empty frame nor the autorepeat one
    assert asm._keys == {c.BTN_TOOL_PEN}


def _script_events(script: str = "demo", reports: int = 40):
    return states_to_events(CAPS, timed_states(script, rate=200, reports=reports))


def test_evemu_trace_round_trip_and_replay(tmp_path: Path) -> None:
    events = _script_events()
    path = tmp_path / "pen.evemu"
    path.write_text(format_evemu(CAPS, events))
    trace = read_trace(path)
    (dev,) = trace.devices
    assert trace.format == "evemu" and dev.kind == "evdev" and len(dev.events) == len(events)
    assert [(e.type, e.code, e.value) for e in dev.events] == \
        [(e.type, e.code, e.value) for e in events]
    assert max(abs(a.time - b.time) for a, b in zip(dev.events, events, strict=True)) < 1e-6
    assert dev.caps is not None and dev.caps.keys == CAPS.keys
    assert dev.caps.absinfo[c.ABS_TILT_X] == CAPS.absinfo[c.ABS_TILT_X]
    samples = list(iter_trace_samples(path))
    check_samples(samples)
    tools = {s.tool for s in samples}
    assert tools == {Tool.PEN, Tool.ERASER}
    assert {s.serial for s in samples} == {0x0A1B2C3D}
    assert any(s.buttons == int(Button.STYLUS) for s in samples)
    assert any(s.buttons == int(Button.STYLUS2) for s in samples)
    strokes = sum(1 for a, b in pairwise(samples) if b.touching and not a.touching)
    assert strokes == 5  # line, arc, spiral, eraser, buttons (hover never touches)


def check_samples(samples) -> None:
    assert samples, "no samples"
    for s in samples:
        assert 0.0 <= s.x <= 1.0 and 0.0 <= s.y <= 1.0
        if not s.touching:
            assert s.pressure == 0.0
    assert [s.seq for s in samples] == list(range(1, len(samples) + 1))
    assert all(b.t >= a.t for a, b in pairwise(samples))


def test_libinput_record_with_pen_and_touch_keeps_only_the_pen(tmp_path: Path) -> None:
    touch_events = [InputEvent(0.001, c.EV_KEY, c.BTN_TOUCH, 1),
                    InputEvent(0.001, c.EV_ABS, c.ABS_X, 100),
                    InputEvent(0.001, c.EV_SYN, c.SYN_REPORT, 0)]
    text = format_libinput_record([(touchpad_caps(), touch_events), (CAPS, _script_events("line"))])
    path = tmp_path / "rec.yaml"
    path.write_text(text + "extra_top_level_key: ignored\n")
    trace = read_trace(path)
    assert trace.format == "libinput-record" and len(trace.devices) == 2
    replay = TraceReplay(trace)
    assert [d.index for d in replay.pen_devices] == [1]
    assert replay.skipped == [{"device": 0, "name": "Mock Wacom Intuos Pro M Finger",
                               "reason": "evdev device without a pen (touch/pad)", "reports": 3}]
    samples = list(replay.samples())
    check_samples(samples)
    touching = [s for s in samples if s.touching]
    assert touching and max(s.pressure for s in touching) > 0.7
    # diagonal line (0.1, 0.2) → (0.9, 0.8)
    assert touching[0].x == pytest.approx(0.1, abs=0.01)
    assert touching[-1].y == pytest.approx(0.8, abs=0.01)
    # tilt: -30 → +30 degrees with resolution 57 units/radian
    assert touching[0].tilt_x == pytest.approx(-30 / (57 * 3.14159265 / 180), abs=0.05)


def test_trace_spec_opens_an_evdev_source(tmp_path: Path) -> None:
    path = tmp_path / "pen.evemu"
    path.write_text(format_evemu(CAPS, _script_events("hover")))
    src = open_device(f"trace:{path}")
    assert src.describe()["parser"] == "evdev" and src.finite
    assert src.name == "mock-wacom-intuos-pro-m-pen"


@pytest.mark.parametrize("line,needle", [
    ("E: 0.1 0003 0000 abc", "malformed"),
    ("E: 0.1 0003", "needs sec.usec"),
    ("A: 00 0 x 0 0", "not numbers"),
    ("A: 00 10 5 0 0", "max 5 < min 10"),
    ("B: 01 1ff", "mask bytes"),
    ("E: -1.0 0003 0000 5", "out of range"),
])
def test_malformed_evemu_names_file_and_line(tmp_path: Path, line: str, needle: str) -> None:
    good = format_evemu(CAPS, _script_events("line", 4)).splitlines()
    good.insert(6, line)
    path = tmp_path / "bad.evemu"
    path.write_text("\n".join(good) + "\n")
    with pytest.raises(TraceError) as err:
        read_trace(path)
    assert err.value.where == f"{path}:7"
    assert needle in str(err.value)


def test_malformed_libinput_record(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text("devices:\n- evdev: {name: x, id: [3, 1, 2, 0]}\n  events:\n"
                    "  - evdev: [[0, 10, 3, 0]]\n")
    with pytest.raises(TraceError, match="sec, usec, type, code, value"):
        read_trace(path)
    path.write_text("devices: [\n  {evdev: \n")
    with pytest.raises(TraceError) as err:
        read_trace(path)
    assert err.value.where is not None and err.value.where.startswith(f"{path}:")


# -- the live evdev transport over a mock node (python-evdev's InputDevice interface) ---------
def _fields(samples):
    return [(s.tool, s.x, s.y, s.pressure, s.tilt_x, s.tilt_y, s.touching, s.proximity,
             s.buttons, s.serial, s.tool_id) for s in samples]


def test_live_evdev_path_with_syn_dropped_resyncs_to_the_same_samples(tmp_path: Path) -> None:
    path = tmp_path / "pen.evemu"
    path.write_text(format_evemu(CAPS, _script_events("demo", 20)))
    reference = list(iter_trace_samples(path))
    from station.drivers.pipeline import PenDriver

    src = open_device(f"mock-evdev:{path}?speed=max&drop=4,5,30,77&grab=1")
    node = src.mock
    assert node.grabbed and node.grabs == 1  # exclusive grab taken on open
    driver = PenDriver(src)
    samples = list(driver.samples())
    status = driver.status()
    assert status["syn_dropped"] == 4 and status["resyncs"] == 4
    # each lost frame comes back as the state read after it: nothing missing, nothing wrong
    assert _fields(samples) == _fields(reference)
    assert not node.grabbed  # released on close


def test_evdev_unplug_and_reconnect_through_the_driver(tmp_path: Path) -> None:
    from station.cli import main
    from station.sessionlog import read_session

    path = tmp_path / "pen.evemu"
    path.write_text(format_evemu(CAPS, _script_events("line", 10)))
    out = tmp_path / "d.jsonl"
    assert main(["driver", "--device", f"mock-evdev:{path}?speed=max&unplug=1",
                 "--bus", f"ipc://{tmp_path}/bus", "--max-reconnects", "1",
                 "--jsonl", str(out)]) == 0
    _, records = read_session(out)
    pens = [r for r in records if isinstance(r, PenSample)]
    strokes = sum(1 for a, b in pairwise(pens) if b.touching and not a.touching)
    assert strokes == 2


def test_missing_evdev_node_is_a_clear_failure(capsys) -> None:
    from station.cli import main

    assert main(["driver", "--device", "evdev:/nonexistent/event99", "--bus", "ipc:x"]) == 1
    err = capsys.readouterr().err
    assert "/nonexistent/event99" in err and err.count("\n") == 1


def test_record_an_evdev_device_as_evemu(tmp_path: Path) -> None:
    from station.cli import main

    path = tmp_path / "pen.evemu"
    path.write_text(format_evemu(CAPS, _script_events("arc", 15)))
    out = tmp_path / "again.evemu"
    assert main(["record", "--device", f"mock-evdev:{path}?speed=max", "-o", str(out)]) == 0
    assert _fields(list(iter_trace_samples(out))) == _fields(list(iter_trace_samples(path)))


def test_a_replugged_pen_is_found_on_its_new_event_node(tmp_path: Path) -> None:
    import errno

    from station.drivers.mock.evdev import MockEvdevNode
    from station.drivers.transport.evdev import find_evdev_node, list_evdev

    root = tmp_path / "input"
    root.mkdir()
    nodes = {"event2": touchpad_caps(), "event11": CAPS, "event3": None}  # event3: no access
    for name in nodes:
        (root / name).write_text("")
    (root / "mouse0").write_text("")

    def opener(path: str) -> MockEvdevNode:
        caps = nodes[Path(path).name]
        if caps is None:
            raise PermissionError(errno.EACCES, "Permission denied")
        return MockEvdevNode(caps, [], path=path)

    listed = list_evdev(str(root), opener)
    assert [Path(e["path"]).name for e in listed] == ["event2", "event3", "event11"]
    assert "udev rules" in listed[1]["error"]
    found = find_evdev_node(CAPS.name, CAPS.vid, CAPS.pid, str(root), opener)
    assert found == str(root / "event11")
    assert find_evdev_node("other pen", CAPS.vid, CAPS.pid, str(root), opener) is None
