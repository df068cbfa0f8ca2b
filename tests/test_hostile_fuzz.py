"""Fuzzing every reader of outside input (issue 8, item 5).

A seeded mutator (deterministic: a failure names its seed and reproduces)
starts from valid inputs made by the station's own writers and breaks them the
ways files and messages break: numbers swapped for extremes (1e308, nan, inf,
2**64, -1), bytes flipped, lines cut, dropped, doubled or swapped, random
text and deep nesting inserted.  Every reader must return a clean result or
raise :class:`~station.errors.BadInput` (exit 2 at the CLI) — never another
exception, never a hang (each input runs under a 2 s alarm).

Readers: the session log, the three trace formats (hid-recorder, evemu,
libinput-record) through the whole driver pipeline (descriptor and report
parsers, normaliser), wire messages, calibration files (JSON, points CSV,
libinput and tslib lines) and device data files.  A sample of the fuzzed
files also goes through the CLI in process: exit 0 or 2, and one line on
stderr when 2.
"""

from __future__ import annotations

import io
import json
import logging
import random
import re
import signal
import struct
import time
import traceback
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
from station.calibration.area import AreaSettings, DeviceGeometry
from station.calibration.export import libinput_line, parse_libinput, parse_tslib, tslib_line
from station.calibration.files import dumps, loads
from station.calibration.model import Calibration, DeviceId, FitInfo
from station.calibration.points import format_points, parse_points
from station.calibration.pointset import PointSet
from station.calibration.pressure import PressureSettings
from station.drivers import synth
from station.drivers.mock.evdev import states_to_events, wacom_like_caps
from station.drivers.mock.script import timed_states
from station.drivers.mock.tablet import MockTablet, find_model
from station.drivers.pipeline import TraceReplay
from station.drivers.registry import DEVICES_DIR, parse_device_data
from station.drivers.traces.evemu import format_evemu, parse_evemu
from station.drivers.traces.hidrecorder import parse_hid_recorder
from station.drivers.traces.libinput_record import format_libinput_record, parse_libinput_record

from station import wire
from station.cli import main
from station.errors import BadInput
from station.events import Command, PenSample, Tool
from station.sessionlog import SessionHeader, SessionLogReader, SessionLogWriter, summarise

INTERESTING = [
    "0", "-0", "-1", "1", "2", "255", "256", "65535", "65536", "4294967296",
    "18446744073709551616", "-9223372036854775809", "1e12", "1e13", "1e308", "-1e308",
    "1e-320", "1e400", "nan", "NaN", "inf", "-inf", "Infinity", "-Infinity", "0.5", "1.5",
    "0x7f", "ff", "FF", "zz", "", " ", "true", "null", "[]", "{}", '"', "\\", "\x00",
    "\u2028", "é", "9" * 400,
]
HEX_BYTE = re.compile(r"(?<= )[0-9a-fA-F]{2}(?= |$)", re.MULTILINE)
NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")
ALARM_S = 2.0


class Hang(Exception):
    """A single input took longer than the alarm."""


@contextmanager
def alarm(seconds: float) -> Iterator[None]:
    def ring(*_: object) -> None:
        raise Hang(f"no answer after {seconds} s")

    old = signal.signal(signal.SIGALRM, ring)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


# -- the mutator -------------------------------------------------------------------------
def mutate_text(rng: random.Random, text: str, seeds: list[str]) -> str:
    """1..4 random mutations of ``text`` (``seeds`` lend lines for splicing)."""
    for _ in range(rng.randint(1, 4)):
        op = rng.randrange(13)
        lines = text.splitlines(keepends=True) or [""]
        if op >= 11:  # a hex byte changed (HID reports and descriptors stay well-formed)
            hexes = list(HEX_BYTE.finditer(text))
            if hexes:
                m = rng.choice(hexes)
                text = text[:m.start()] + f"{rng.randrange(256):02x}" + text[m.end():]
        elif op <= 2:  # a number becomes an extreme value (the most telling mutation)
            nums = list(NUMBER.finditer(text))
            if nums:
                m = rng.choice(nums)
                text = text[:m.start()] + rng.choice(INTERESTING) + text[m.end():]
        elif op == 3 and text:  # flip one character
            i = rng.randrange(len(text))
            text = text[:i] + chr(rng.randrange(1, 0x250)) + text[i + 1:]
        elif op == 4 and text:  # cut at a random place (with or without a newline after)
            text = text[:rng.randrange(len(text))] + rng.choice(["", "\n"])
        elif op == 5:  # drop a line
            del lines[rng.randrange(len(lines))]
            text = "".join(lines)
        elif op == 6:  # double a line
            i = rng.randrange(len(lines))
            lines.insert(i, lines[i])
            text = "".join(lines)
        elif op == 7 and len(lines) > 1:  # swap two lines
            i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
            lines[i], lines[j] = lines[j], lines[i]
            text = "".join(lines)
        elif op == 8:  # a line from another seed
            donor = rng.choice(seeds).splitlines(keepends=True) or [""]
            lines.insert(rng.randrange(len(lines) + 1), rng.choice(donor))
            text = "".join(lines)
        elif op == 9 and text:  # random junk
            i = rng.randrange(len(text))
            junk = "".join(rng.choice("[]{}\":,0123456789.eE-+ \t\nabcxyz#:\x00") for _ in
                           range(rng.randint(1, 12)))
            text = text[:i] + junk + text[i:]
        elif op == 10:  # deep nesting, once in a while 50,000 levels
            depth = rng.choice([50, 1000, 50_000])
            i = rng.randrange(len(text) + 1)
            text = text[:i] + rng.choice(["[", "{\"a\":", "- "]) * depth + text[i:]
    return text


def mutate_bytes(rng: random.Random, data: bytes) -> bytes:
    buf = bytearray(data)
    for _ in range(rng.randint(1, 4)):
        op = rng.randrange(6)
        if op == 0 and buf:
            buf[rng.randrange(len(buf))] = rng.randrange(256)
        elif op == 1 and len(buf) >= 8:  # an extreme double somewhere
            i = rng.randrange(len(buf) - 7)
            buf[i:i + 8] = struct.pack("<d", rng.choice(
                [float("nan"), float("inf"), -1.0, 1e308, 1e12, 2.0, -0.0, 5e-324]))
        elif op == 2 and len(buf) >= 4:  # an extreme integer
            i = rng.randrange(len(buf) - 3)
            buf[i:i + 4] = struct.pack("<I", rng.choice([0, 1, 0xFFFF, 0xFFFFFFFF, 1 << 31]))
        elif op == 3 and buf:
            del buf[rng.randrange(len(buf)):]
        elif op == 4:
            buf += bytes(rng.randrange(256) for _ in range(rng.randint(1, 64)))
        elif op == 5 and buf:
            i = rng.randrange(len(buf))
            buf[i] ^= 1 << rng.randrange(8)
    return bytes(buf)


# -- seeds: valid inputs from the station's own writers ----------------------------------------
def session_seeds() -> list[str]:
    out = []
    for k in range(3):
        fh = io.StringIO()
        w = SessionLogWriter(fh, SessionHeader(width=64, height=48, seed=k))
        w.write(Command(t=0.0, cmd="brush", args={"size": 6.0, "water": 0.8,
                                                  "pigment": {"Cerulean Blue": 0.5}}))
        for i in range(6):
            w.write(PenSample(t=0.01 * i + 0.01, device="mock-0", tool=Tool.PEN, x=0.2 + 0.1 * i,
                              y=0.5, pressure=0.5, touching=0 < i < 5, tilt_x=10.0,
                              serial=123, rotation=4.0))
        w.write(Command(t=0.1, cmd="wait", args={"seconds": 1.0}))
        w.write(Command(t=0.1, cmd="dry"))
        out.append(fh.getvalue())
    return out


def hid_seeds() -> list[str]:
    out = []
    for model in ("intuos-pro-m", "graphire-usb", "bamboo-pen-ctl460", "huion-like",
                  "ntrig-like", "intuos-pro-2-m-pth660"):
        tablet = MockTablet(find_model(model), script="line", reports=8)
        for feature in tablet.init_features:
            tablet.feature(feature)
        info = tablet.info
        dev = synth.RecordedDevice(info.name, info.vid, info.pid, info.descriptor or b"",
                                   [(r.time, r.data) for r in tablet.timed_reports()],
                                   bus=info.bus)
        out.append(synth.write_hid_recorder([dev]))
    return out


def evdev_seeds() -> tuple[list[str], list[str]]:
    caps = wacom_like_caps()
    events = states_to_events(caps, timed_states("line", rate=200, reports=8))
    # libinput-record: fewer events (pure-Python YAML is the slow reader here)
    short = [e for e in events if e.time <= events[0].time + 0.012]
    return [format_evemu(caps, events)], [format_libinput_record([(caps, short)])]


def wire_seeds() -> list[list[bytes]]:
    pen = PenSample(t=1.0, device="mock-0", tool=Tool.PEN, x=0.5, y=0.25, pressure=0.5,
                    touching=True, serial=7, rotation=3.0, distance=0.1, wheel=0.2, tool_id=5)
    return [
        wire.encode("pen.mock-0", pen, 9, 1),
        wire.encode_pen_batch("pen.mock-0", [pen, pen, pen], 9, 1),
        wire.encode("cmd", Command(t=1.0, cmd="brush", args={"size": 3}), 9, 2),
        wire.encode("status.sim", {"kind": "sim", "steps": 3, "nested": {"a": [1, 2]}}, 9, 3),
        wire.encode("haptic.pen", wire.Haptic(t=1.0, amplitude=0.5, frequency_hz=200.0,
                                              duration_s=0.1), 9, 4),
    ]


DEVICE = DeviceId(0x056A, 0x0315)
GEOMETRY = DeviceGeometry(0, 44704, 0, 27940, 200.0, 200.0)


def calibration_seeds() -> dict[str, list[str]]:
    fit = FitInfo(model="affine", matrix=((1.02, 0.01, -0.01), (0.0, 0.98, 0.02), (0, 0, 1)))
    cal = Calibration(DEVICE, geometry=GEOMETRY, fit=fit,
                      area=AreaSettings(left_handed=True), pressure=PressureSettings(0.02, 0.9))
    pts = PointSet(*(__import__("numpy").array(v) for v in (
        [[0.1, 0.1], [0.9, 0.1], [0.9, 0.9], [0.1, 0.9], [0.5, 0.5]],
        [[0.11, 0.1], [0.9, 0.12], [0.88, 0.9], [0.1, 0.91], [0.5, 0.5]],
        [[10, -5], [0, 0], [5, 5], [-20, 3], [0, 30]])))
    return {"json": [dumps(cal), dumps(Calibration(DEVICE))],
            "csv": [format_points(pts)],
            "libinput": [libinput_line(cal)],
            "tslib": [tslib_line(cal, 1920, 1080)]}


def device_data_seeds() -> list[str]:
    return [p.read_text() for p in sorted(DEVICES_DIR.glob("*.json"))
            if not p.name.endswith(".schema.json")][:6]


# -- the readers, as the station uses them -------------------------------------------------
def read_session(text: str) -> Any:
    with SessionLogReader(io.StringIO(text), name="fuzz.jsonl") as r:
        return summarise(r)


class CountingBackend:
    """The canvas-backend calls the player makes, counted (the simulation itself is
    not what is fuzzed here: the records and command arguments are)."""

    n_slots = 8

    def __init__(self) -> None:
        self.calls: dict[str, int] = {}

    def __getattr__(self, name: str) -> Callable[..., None]:
        def call(*args: Any, **kwargs: Any) -> None:
            self.calls[name] = self.calls.get(name, 0) + 1
        return call


def play_session(text: str) -> Any:
    from station.canvas.palette import default_palette
    from station.sim.player import SessionPlayer

    with SessionLogReader(io.StringIO(text), name="fuzz.jsonl") as r:
        player = SessionPlayer(CountingBackend(), 32, 24, r.header.profile
                               if r.header.profile in ("watercolor", "gouache", "ink")
                               else "watercolor", rate=1.0, pigments=default_palette())
        player.play(r, lambda: f"fuzz.jsonl:{r.line_no}")
        return player.counters


def replay(trace: Any) -> int:
    return sum(1 for _ in TraceReplay(trace).samples())


def read_hid(text: str) -> int:
    return replay(parse_hid_recorder(io.StringIO(text), "fuzz.hid"))


def read_evemu(text: str) -> int:
    return replay(parse_evemu(io.StringIO(text), "fuzz.evemu"))


def read_libinput(text: str) -> int:
    return replay(parse_libinput_record(text, "fuzz.yaml"))


def read_device_data(text: str) -> Any:
    from station.drivers.registry import PARSERS, _model_ranges, device_ids

    model = parse_device_data(text, "fuzz.json")
    device_ids(model)
    _model_ranges(model)
    factory = PARSERS.get(model["parser"])
    return factory(model, None) if factory is not None else None


class Tally:
    """How many inputs each reader took, how they ended, and what went wrong."""

    def __init__(self) -> None:
        self.counts: dict[str, dict[str, int]] = {}
        self.failures: list[str] = []
        self.seconds: dict[str, float] = {}

    def run(self, name: str, fn: Callable[[Any], Any], value: Any, seed: int) -> None:
        c = self.counts.setdefault(name, {"inputs": 0, "ok": 0, "bad_input": 0})
        c["inputs"] += 1
        t0 = time.perf_counter()
        try:
            with alarm(ALARM_S):
                fn(value)
            c["ok"] += 1
        except BadInput:
            c["bad_input"] += 1
        except Exception as exc:  # what the test exists to find
            if len(self.failures) < 20:
                self.failures.append(f"{name} seed {seed}: {type(exc).__name__}: {exc!s:.200}\n"
                                     f"input {value!r:.300}\n{traceback.format_exc(limit=-3)}")
        self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - t0


ROUNDS = {"session-log": 2000, "session-play": 1000, "hid-recorder": 800, "evemu": 600,
          "libinput-record": 300, "wire": 3000, "calibration-json": 800, "points-csv": 1000,
          "libinput-line": 500, "tslib-line": 500, "device-data": 600}


@pytest.fixture(autouse=True)
def quiet() -> Iterator[None]:
    """Thousands of inputs warn by design (cut-off lines, unknown keys): not shown."""
    logging.disable(logging.WARNING)
    try:
        yield
    finally:
        logging.disable(logging.NOTSET)


def test_every_reader_gives_a_result_or_bad_input_never_a_crash_or_hang() -> None:
    tally = Tally()
    t0 = time.monotonic()
    text_readers: list[tuple[str, list[str], Callable[[str], Any]]] = []
    evemu, yaml_ = evdev_seeds()
    cal = calibration_seeds()
    text_readers += [
        ("session-log", session_seeds(), read_session),
        ("session-play", session_seeds(), play_session),
        ("hid-recorder", hid_seeds(), read_hid),
        ("evemu", evemu, read_evemu),
        ("libinput-record", yaml_, read_libinput),
        ("calibration-json", cal["json"], lambda t: loads(t, "fuzz.json")),
        ("points-csv", cal["csv"], lambda t: parse_points(t, "fuzz.csv")),
        ("libinput-line", cal["libinput"], lambda t: parse_libinput(t, DEVICE, "fuzz")),
        ("tslib-line", cal["tslib"],
         lambda t: parse_tslib(t, DEVICE, GEOMETRY, "fuzz", xres=1920, yres=1080)),
        ("device-data", device_data_seeds(), read_device_data),
    ]
    for name, seeds, fn in text_readers:
        for seed in seeds:  # the seeds themselves are clean
            fn(seed)
        for k in range(ROUNDS[name]):
            rng = random.Random(f"{name}-{k}")
            tally.run(name, fn, mutate_text(rng, rng.choice(seeds), seeds), k)
    frames = wire_seeds()
    for k in range(ROUNDS["wire"]):
        rng = random.Random(f"wire-{k}")
        topic, payload = rng.choice(frames)
        if rng.random() < 0.1:
            topic = mutate_bytes(rng, topic)
        tally.run("wire", wire.decode, [topic, mutate_bytes(rng, payload)], k)
    elapsed = time.monotonic() - t0
    total = sum(c["inputs"] for c in tally.counts.values())
    print(f"\nfuzzed {total} inputs in {elapsed:.1f} s: {json.dumps(tally.counts)}")
    print("seconds per reader:", {k: round(v, 2) for k, v in tally.seconds.items()})
    assert not tally.failures, "\n\n".join(tally.failures)
    assert total >= 10_000
    for name, c in tally.counts.items():  # the mutations reach both outcomes
        assert c["ok"] > 0 and c["bad_input"] > 0, (name, c)


# -- the CLI on a sample of fuzzed files ---------------------------------------------------
def cli_cases(tmp: Path) -> Iterator[tuple[list[str], str]]:
    cal = calibration_seeds()
    evemu, yaml_ = evdev_seeds()
    kinds: list[tuple[str, list[str], Callable[[Path], list[str]]]] = [
        (".jsonl", session_seeds(), lambda p: ["log", "stats", str(p)]),
        (".jsonl", session_seeds(), lambda p: ["log", "cat", str(p)]),
        (".hid", hid_seeds(), lambda p: ["replay", str(p), "--jsonl", str(p) + ".out"]),
        (".evemu", evemu, lambda p: ["replay", str(p), "--json"]),
        (".yaml", yaml_, lambda p: ["replay", str(p), "--json"]),
        (".csv", cal["csv"], lambda p: ["calibrate", "--fit", str(p), "--json"]),
        (".json", cal["json"], lambda p: ["calibrate", "--check", str(p)]),
    ]
    for index, (suffix, seeds, argv) in enumerate(kinds):
        for k in range(12):
            rng = random.Random(f"cli-{index}-{k}")
            path = tmp / f"fuzz-{index}-{k}{suffix}"
            path.write_text(mutate_text(rng, rng.choice(seeds), seeds), encoding="utf-8")
            yield argv(path), f"cli-{index}-{k}"


def test_the_cli_on_fuzzed_files_exits_0_or_2_with_one_line(tmp_path: Path, capsys) -> None:
    codes: dict[int, int] = {}
    for argv, seed in cli_cases(tmp_path):
        try:
            with alarm(10.0):
                rc = main(argv)
        except SystemExit as exc:  # argparse usage errors
            rc = int(exc.code or 0)
        err = capsys.readouterr().err
        codes[rc] = codes.get(rc, 0) + 1
        assert rc in (0, 2), (seed, argv, err)
        assert "Traceback" not in err, (seed, err)
        if rc == 2:
            errors = [ln for ln in err.splitlines() if "WARNING" not in ln]
            assert len(errors) == 1, (seed, argv, err)
    print(f"\nCLI exit codes over {sum(codes.values())} fuzzed files: {codes}")
    assert codes.get(0, 0) > 0 and codes.get(2, 0) > 0


@pytest.mark.parametrize("payload", [
    "[" * 50_000, "{\"a\":" * 50_000, "- " * 50_000, "&a [*a, *a, *a, *a, *a, *a, *a, *a]",
])
def test_pathological_yaml_and_json_are_bad_input(payload: str) -> None:
    with alarm(ALARM_S), pytest.raises(BadInput):
        parse_libinput_record("devices:\n  - " + payload, "deep.yaml")
    with alarm(ALARM_S), pytest.raises(BadInput):
        loads(payload, "deep.json")
    with alarm(ALARM_S), pytest.raises(BadInput):
        parse_device_data(payload, "deep.json")
