"""``station bench fuzz``: the seeded fuzzer over every reader of outside input.

A seeded mutator (deterministic: a failure names its reader and seed and
reproduces) starts from valid inputs made by the station's own writers and
breaks them the ways files and messages break: numbers swapped for extremes
(1e308, nan, inf, 2**64, -1), bytes flipped, lines cut, dropped, doubled or
swapped, random text and deep nesting inserted.  Every reader must return a
clean result or raise :class:`~station.errors.BadInput` (exit 2 at the CLI):
never another exception (a *traceback*), never a hang (each input runs under
an alarm), and never a *silent acceptance*: where a reader accepts an input,
an oracle checks what it made (every number finite, no unit line it should not
have, no page it should not serve).

Readers: session logs (read and played), the three trace formats through the
driver pipeline, wire messages, calibration files (JSON, points CSV, libinput
and tslib lines), device data, paint profiles, brush shapes, blueprints (and
the systemd units made from them), the haptic serial protocol (frames with a
valid CRC, so mutations reach the message decoders) and the gallery's URLs
(the WSGI app in process).  The test suite runs about 14,000 inputs
(tests/test_hostile_fuzz.py); ``station bench fuzz`` runs 100,000 or more and
prints the counts as JSON.
"""

from __future__ import annotations

import argparse
import io
import json
import logging
import math
import random
import re
import signal
import struct
import sys
import tempfile
import time
import traceback
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from importlib import resources
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from station import wire
from station.blueprint.load import loads as load_blueprint
from station.blueprint.plan import resolve
from station.blueprint.systemd import units
from station.brush.geometry import BrushShape
from station.calibration.area import AreaSettings, DeviceGeometry
from station.calibration.export import libinput_line, parse_libinput, parse_tslib, tslib_line
from station.calibration.files import dumps, loads
from station.calibration.model import Calibration, DeviceId, FitInfo
from station.calibration.points import format_points, parse_points
from station.calibration.pointset import PointSet
from station.calibration.pressure import PressureSettings
from station.canvas.palette import default_palette
from station.canvas.profiles import parse_profile
from station.drivers import synth
from station.drivers.mock.evdev import states_to_events, wacom_like_caps
from station.drivers.mock.script import timed_states
from station.drivers.mock.tablet import MockTablet, find_model
from station.drivers.pipeline import TraceReplay
from station.drivers.registry import (
    DEVICES_DIR,
    PARSERS,
    _model_ranges,
    device_ids,
    parse_device_data,
)
from station.drivers.serial import protocol as serial_proto
from station.drivers.traces.evemu import format_evemu, parse_evemu
from station.drivers.traces.hidrecorder import parse_hid_recorder
from station.drivers.traces.libinput_record import format_libinput_record, parse_libinput_record
from station.drivers.traces.model import Trace
from station.errors import BadInput
from station.events import Command, PenSample, Tool
from station.kiosk.gallery import Gallery, make_app, new_id
from station.sessionlog import SessionHeader, SessionLogReader, SessionLogWriter, summarise
from station.sim.player import SessionPlayer

_T = TypeVar("_T")

INTERESTING = [
    "0", "-0", "-1", "1", "2", "255", "256", "65535", "65536", "4294967296",
    "18446744073709551616", "-9223372036854775809", "1e12", "1e13", "1e308", "-1e308",
    "1e-320", "1e400", "nan", "NaN", "inf", "-inf", "Infinity", "-Infinity", "0.5", "1.5",
    "0x7f", "ff", "FF", "zz", "", " ", "true", "null", "[]", "{}", '"', "\\", "\x00",
    "\u2028", "é", "9" * 400,
]
HEX_BYTE = re.compile(r"(?<= )[0-9a-fA-F]{2}(?= |$)", re.MULTILINE)
NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")
ALARM_S = 10.0  # generous: a loaded 2-core CI machine; a real hang never ends


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
    pts = PointSet(*(np.array(v) for v in (
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
def read_session(text: str) -> object:
    with SessionLogReader(io.StringIO(text), name="fuzz.jsonl") as r:
        return summarise(r)


class CountingBackend:
    """The canvas-backend calls the player makes, counted (the simulation itself is
    not what is fuzzed here: the records and command arguments are)."""

    n_slots = 8

    def __init__(self) -> None:
        self.calls: dict[str, int] = {}

    def __getattr__(self, name: str) -> Callable[..., None]:
        def call(*args: object, **kwargs: object) -> None:
            self.calls[name] = self.calls.get(name, 0) + 1
        return call


def play_session(text: str) -> object:
    with SessionLogReader(io.StringIO(text), name="fuzz.jsonl") as r:
        player = SessionPlayer(CountingBackend(), 32, 24, r.header.profile  # type: ignore[arg-type]
                               if r.header.profile in ("watercolor", "gouache", "ink")
                               else "watercolor", rate=1.0, pigments=default_palette())
        player.play(r, lambda: f"fuzz.jsonl:{r.line_no}")
        return player.counters


def replay(trace: Trace) -> int:
    return sum(1 for _ in TraceReplay(trace).samples())


def read_hid(text: str) -> int:
    return replay(parse_hid_recorder(io.StringIO(text), "fuzz.hid"))


def read_evemu(text: str) -> int:
    return replay(parse_evemu(io.StringIO(text), "fuzz.evemu"))


def read_libinput(text: str) -> int:
    return replay(parse_libinput_record(text, "fuzz.yaml"))


def read_device_data(text: str) -> object:
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
        self.kinds: dict[str, int] = {}  # traceback, hang, silent: each must stay 0
        self.seconds: dict[str, float] = {}

    def run(self, name: str, fn: Callable[[_T], object], value: _T, seed: int) -> None:
        c = self.counts.setdefault(name, {"inputs": 0, "ok": 0, "bad_input": 0})
        c["inputs"] += 1
        t0 = time.perf_counter()
        try:
            with alarm(ALARM_S):
                fn(value)
            c["ok"] += 1
        except BadInput:
            c["bad_input"] += 1
        except Exception as exc:  # what the fuzzer exists to find
            kind = "hang" if isinstance(exc, Hang) else \
                "silent" if isinstance(exc, SilentAcceptance) else "traceback"
            self.kinds[kind] = self.kinds.get(kind, 0) + 1
            if len(self.failures) < 20:
                self.failures.append(f"{name} seed {seed}: {type(exc).__name__}: {exc!s:.200}\n"
                                     f"input {value!r:.300}\n{traceback.format_exc(limit=-3)}")
        self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - t0

class SilentAcceptance(Exception):
    """A reader accepted an input it should have refused (an oracle says so)."""


def _all_finite(obj: object, where: str) -> None:
    """Every number reachable in ``obj`` (dataclasses, dicts, lists, arrays) is finite."""
    stack = [obj]
    seen = 0
    while stack and seen < 100_000:
        o = stack.pop()
        seen += 1
        if isinstance(o, bool) or o is None or isinstance(o, str):
            continue
        if isinstance(o, (int, float)):
            if isinstance(o, float) and not math.isfinite(o):
                raise SilentAcceptance(f"{where}: a non-finite number was accepted")
        elif isinstance(o, np.ndarray):
            if o.dtype.kind == "f" and not np.isfinite(o).all():
                raise SilentAcceptance(f"{where}: a non-finite array was accepted")
        elif isinstance(o, dict):
            stack.extend(o.values())
        elif isinstance(o, (list, tuple)):
            stack.extend(o)
        elif hasattr(o, "__dataclass_fields__"):
            stack.extend(getattr(o, f) for f in o.__dataclass_fields__)


# -- the readers added for issue 25 ----------------------------------------------------------
def profile_seeds() -> list[str]:
    folder = resources.files("station").joinpath("data", "profiles")
    return [folder.joinpath(f"{n}.xml").read_text(encoding="utf-8")
            for n in ("watercolor", "gouache", "ink")]


def read_profile(text: str) -> object:
    prof = parse_profile(text.encode("utf-8", "surrogatepass"), "fuzz.xml")
    _all_finite(prof.params, "profile params")
    _all_finite(prof.brush, "profile brush")
    return prof


def brush_seeds() -> list[str]:
    folder = resources.files("station.data").joinpath("brushes")
    return [e.read_text(encoding="utf-8") for e in sorted(folder.iterdir(), key=lambda e: e.name)
            if e.name.endswith(".json") and e.name != "schema.json"][:4]


def read_brush(text: str) -> object:
    shape = BrushShape.loads(text, "fuzz.json")
    _all_finite(shape, "brush shape")
    return shape


def blueprint_seeds() -> list[str]:
    folder = resources.files("station.data").joinpath("blueprints")
    return [e.read_text(encoding="utf-8") for e in sorted(folder.iterdir(), key=lambda e: e.name)
            if e.name.endswith(".xml")]


_UNIT_LINE = re.compile(r"^(#.*|\[(Unit|Service|Install)\]|[A-Z][A-Za-z]+=.*|)$")


def read_blueprint(text: str) -> object:
    bp = load_blueprint(text.encode("utf-8", "surrogatepass"), "fuzz.xml")
    resolve(bp, Path("/run/station-fuzz"), Path("/var/lib/station-fuzz"))
    made = units(bp, per_component=True, station="/usr/bin/station")
    for name, unit in made.items():
        sections = [ln for ln in unit.splitlines() if ln.startswith("[")]
        if len(sections) != len(set(sections)):
            raise SilentAcceptance(f"unit {name}: a section twice (a line was injected)")
        for ln in unit.splitlines():
            if not _UNIT_LINE.match(ln) or ln.startswith(("ExecStartPre", "ExecStartPost")):
                raise SilentAcceptance(f"unit {name}: unexpected line {ln[:80]!r}")
    return made


def serial_seeds() -> list[bytes]:
    """Frame bodies (header + payload, no CRC) of every message kind."""
    p = serial_proto
    msgs = [p.Hello(1, 0, 0x1209, 0x4A50, 1000, 2, 2, 3, (2.5, 2.5, 3.0), 0.0,
                    (160.0, 120.0, 70.0), "SN42", "Test pen"),
            p.Pose(123456, 1.5, -2.25, 7.0, (1.0, 0.0, 0.0, 0.0), 3, 1),
            p.DeviceError(2, "watchdog"), p.HelloRequest(),
            p.Force(0.5, -0.25, 1.5, 0.0, 0.0, 0.0), p.Vibration(0.3, 250.0, 40),
            p.Enable(True), p.Heartbeat(99)]
    out = []
    for i, m in enumerate(msgs):
        body = p.cobs_decode(p.encode_frame(m, i)[:-1])
        out.append(body[:-p.CRC_SIZE])
    return out


def read_serial(body: bytes) -> object:
    """A mutated body, framed with a valid CRC (so it reaches the message decoders)."""
    p = serial_proto
    framed = p.cobs_encode(body + p.crc16(body).to_bytes(2, "big"))
    _seq, msg = p.decode_body(framed)
    _all_finite(msg, f"serial {type(msg).__name__}")
    return msg


class GalleryUrls:
    """The gallery's WSGI app in process, over a gallery with one painting."""

    def __init__(self) -> None:
        self._tmp = tempfile.TemporaryDirectory(prefix="station-fuzz-")
        self.gallery = Gallery(Path(self._tmp.name) / "g")
        self.pid = new_id()
        img = np.zeros((6, 8, 3), np.uint8)
        self.gallery.save(self.pid, img, None, {"width": 8, "height": 6})
        (self.gallery.path(self.pid) / "replay.failed").write_text("no log\n")
        self.app = make_app(self.gallery)
        self.allowed = {f"/p/{self.pid}", f"/p/{self.pid}/painting.png"}

    def seeds(self) -> list[str]:
        return ["/", f"/p/{self.pid}", f"/p/{self.pid}/painting.png",
                f"/p/{self.pid}/replay.webp", f"/p/{self.pid}/session.jsonl",
                f"/p/{self.pid}/painting-2x.png", "/p/20261124-101500-a1b2c3"]

    def get(self, path: str) -> int:
        raw = path.encode("utf-8", "surrogateescape").decode("latin-1")
        env = {"REQUEST_METHOD": "GET", "PATH_INFO": raw.split("?", 1)[0],
               "QUERY_STRING": raw.split("?", 1)[1] if "?" in raw else "",
               "SERVER_NAME": "fuzz", "SERVER_PORT": "80", "wsgi.url_scheme": "http",
               "wsgi.input": io.BytesIO(), "wsgi.errors": io.StringIO(),
               "HTTP_HOST": "fuzz"}
        got: dict[str, Any] = {}

        def start(status: str, headers: list[tuple[str, str]], exc_info: object = None) -> None:
            got["status"], got["headers"] = int(status.split()[0]), dict(headers)

        body = b"".join(self.app(env, start))
        status = got["status"]
        if status >= 500:
            raise SilentAcceptance(f"GET {path[:80]!r}: {status}")
        if "X-Frame-Options" not in got["headers"]:
            raise SilentAcceptance(f"GET {path[:80]!r}: no security headers")
        if status == 200 and env["PATH_INFO"] not in self.allowed:
            raise SilentAcceptance(f"GET {path[:80]!r} served {len(body)} bytes")
        if status in (400, 404, 405):
            raise BadInput(f"HTTP {status}")
        return status

    def close(self) -> None:
        self._tmp.cleanup()


# -- the run ------------------------------------------------------------------------------------
SUITE_ROUNDS = {"session-log": 2000, "session-play": 1000, "hid-recorder": 800, "evemu": 600,
                "libinput-record": 300, "wire": 3000, "calibration-json": 800,
                "points-csv": 1000, "libinput-line": 500, "tslib-line": 500, "device-data": 600,
                "profile": 400, "brush-shape": 300, "blueprint": 300, "serial": 1500,
                "gallery-url": 600}


def run_fuzz(rounds: dict[str, int], tally: Tally | None = None, salt: str = "") -> Tally:
    """Every reader over ``rounds[name]`` mutated inputs; the seeds themselves first
    (they must be clean)."""
    tally = tally or Tally()
    evemu, yaml_ = evdev_seeds()
    cal = calibration_seeds()
    urls = GalleryUrls()
    text_readers: list[tuple[str, list[str], Callable[[str], object]]] = [
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
        ("profile", profile_seeds(), read_profile),
        ("brush-shape", brush_seeds(), read_brush),
        ("blueprint", blueprint_seeds(), read_blueprint),
        ("gallery-url", urls.seeds(), urls.get),
    ]
    try:
        for name, seeds, fn in text_readers:
            n = rounds.get(name, 0)
            if not n:
                continue
            for seed in seeds:
                try:
                    fn(seed)
                except BadInput:
                    if name != "gallery-url":
                        raise
            for k in range(n):
                rng = random.Random(f"{salt}{name}-{k}")
                tally.run(name, fn, mutate_text(rng, rng.choice(seeds), seeds), k)
    finally:
        urls.close()
    frames = wire_seeds()
    for k in range(rounds.get("wire", 0)):
        rng = random.Random(f"{salt}wire-{k}")
        topic, payload = rng.choice(frames)
        if rng.random() < 0.1:
            topic = mutate_bytes(rng, topic)
        tally.run("wire", wire.decode, [topic, mutate_bytes(rng, payload)], k)
    bodies = serial_seeds()
    for k in range(rounds.get("serial", 0)):
        rng = random.Random(f"{salt}serial-{k}")
        tally.run("serial", read_serial, mutate_bytes(rng, rng.choice(bodies)), k)
    return tally


@contextmanager
def quiet_logs() -> Iterator[None]:
    """Thousands of inputs warn by design (cut-off lines, unknown keys): not shown."""
    logging.disable(logging.WARNING)
    try:
        yield
    finally:
        logging.disable(logging.NOTSET)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("fuzz", help="the seeded fuzzer over every reader (JSON counts)",
                       description="Run the seeded fuzzer over every reader of outside input "
                                   "and print the counts: inputs, clean results, bad input "
                                   "(exit 2), and the failures (tracebacks, hangs, silent "
                                   "acceptances), which must be 0.")
    p.add_argument("--inputs", type=int, default=100_000, metavar="N",
                   help="about this many inputs in all (100000), shared like the suite's")
    p.add_argument("--salt", default="bench", help="seed salt (a different run: another salt)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if not 100 <= args.inputs <= 10_000_000:
        raise BadInput("must be 100..10000000", "--inputs")
    scale = args.inputs / sum(SUITE_ROUNDS.values())
    rounds = {k: max(1, math.ceil(v * scale)) for k, v in SUITE_ROUNDS.items()}
    t0 = time.monotonic()
    with quiet_logs():
        tally = run_fuzz(rounds, salt=args.salt)
    counts = tally.counts
    out = {
        "inputs": sum(c["inputs"] for c in counts.values()),
        "seconds": round(time.monotonic() - t0, 1),
        "tracebacks": tally.kinds.get("traceback", 0),
        "hangs": tally.kinds.get("hang", 0),
        "silent_acceptances": tally.kinds.get("silent", 0),
        "readers": counts,
        "failures": tally.failures[:5],
    }
    sys.stdout.write(json.dumps(out, indent=1) + "\n")
    return 0 if not tally.failures else 1
