"""Session log reader and writer (interfaces.md)."""

from __future__ import annotations

import io
import json
import logging
import time
from pathlib import Path

import pytest

from station.errors import SessionLogError
from station.events import Command, PenSample, Tool
from station.sessionlog import SessionHeader, SessionLogReader, SessionLogWriter, read_session

HEADER = ('{"format": "station-session", "version": 1, "canvas": {"width": 800, "height": 600},'
          ' "profile": "watercolor", "seed": 7}')
PEN = ('{"type": "pen", "t": 0.125, "device": "mock-0", "tool": "pen", "serial": null, '
       '"x": 0.41, "y": 0.52, "pressure": 0.37, "tilt_x": 12.0, "tilt_y": -4.5, '
       '"proximity": true, "touching": true, "buttons": 0}')


def write(tmp_path: Path, *lines: str) -> Path:
    p = tmp_path / "s.jsonl"
    p.write_text("\n".join(lines) + "\n")
    return p


def test_round_trip(tmp_path: Path) -> None:
    header = SessionHeader(width=320, height=200, profile="ink", seed=3)
    records = [
        Command(t=0.0, cmd="brush", args={"kind": "round", "size": 24, "water": 0.8,
                                          "pigment": {"French Ultramarine": 0.6}}),
        *[PenSample(t=0.01 * i, device="mock-0", tool=Tool.PEN, x=i / 100, y=0.5,
                    pressure=0.3, touching=True, seq=i, serial=77) for i in range(1, 50)],
        Command(t=0.6, cmd="wait", args={"seconds": 2.0}),
    ]
    with SessionLogWriter(tmp_path / "a.jsonl", header) as w:
        for r in records:
            w.write(r)
    h, back = read_session(tmp_path / "a.jsonl")
    assert h == header
    assert back == records


def test_spec_example_reads(tmp_path: Path) -> None:
    h, recs = read_session(write(tmp_path, HEADER, PEN))
    assert (h.width, h.height, h.profile, h.seed) == (800, 600, "watercolor", 7)
    assert isinstance(recs[0], PenSample) and recs[0].pressure == 0.37


@pytest.mark.parametrize(
    ("lines", "where", "needle"),
    [
        ([HEADER, PEN, "{not json"], ":3", "not valid JSON"),
        ([HEADER, PEN.replace('"x": 0.41', '"x": 1.41')], ":2", "x=1.41 outside"),
        ([HEADER, PEN.replace('"tool": "pen"', '"tool": "crayon"')], ":2", "unknown tool"),
        ([HEADER, PEN.replace('"x": 0.41', '"x": NaN')], ":2", "not valid JSON"),
        ([HEADER, "[1, 2]"], ":2", "must be a JSON object"),
        ([HEADER, PEN, PEN.replace('"t": 0.125', '"t": 0.1')], ":3", "goes back"),
        (['{"format": "other"}'], ":1", "not a session header"),
        ([HEADER.replace('"version": 1', '"version": 9')], ":1", "version 9"),
        ([HEADER.replace('"width": 800', '"width": 0')], ":1", "canvas width"),
        ([""], ":1", "empty file"),
        ([HEADER, '{"type": "cmd", "t": 1}'], ":2", "needs 't' and 'cmd'"),
    ],
)
def test_malformed_lines_name_file_and_line(tmp_path: Path, lines: list[str], where: str,
                                            needle: str) -> None:
    path = write(tmp_path, *lines)
    with pytest.raises(SessionLogError) as info:
        read_session(path)
    msg = str(info.value)
    assert f"{path}{where}:" in msg and needle in msg
    assert "\n" not in msg


def test_unknown_records_and_keys_warn(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    path = write(tmp_path, HEADER, '{"type": "hologram", "t": 0.1}',
                 PEN.replace('"buttons": 0', '"buttons": 0, "mood": "happy"'),
                 '{"type": "cmd", "t": 0.2, "cmd": "teleport", "args": {}}')
    with caplog.at_level(logging.WARNING), SessionLogReader(path) as r:
        recs = list(r)
    assert r.unknown == 1
    assert [type(x).__name__ for x in recs] == ["PenSample", "Command"]
    text = caplog.text
    assert ":2: ignoring unknown record type 'hologram'" in text
    assert ":3: ignoring unknown pen keys mood" in text
    assert ":4: unknown command 'teleport'" in text


def test_reader_streams_without_reading_ahead() -> None:
    class CountingLines(io.StringIO):
        reads = 0

        def readline(self, size: int = -1) -> str:  # type: ignore[override]
            CountingLines.reads += 1
            return super().readline(size)

    body = "\n".join([HEADER] + [PEN.replace('"t": 0.125', f'"t": {i}') for i in range(1000)])
    stream = CountingLines(body)
    reader = SessionLogReader(stream, name="mem")
    it = iter(reader)
    next(it), next(it)
    assert CountingLines.reads == 3  # header + two records: nothing more was read


def test_writer_flushes_within_a_second(tmp_path: Path) -> None:
    path = tmp_path / "live.jsonl"
    w = SessionLogWriter(path, SessionHeader(), flush_every=0.05)
    s = PenSample(t=0.0, device="d", tool=Tool.PEN, x=0.5, y=0.5)
    w.write(s)
    time.sleep(0.08)
    w.write(s.with_(t=0.1))  # passes the flush interval: both lines reach the file
    lines = path.read_text().splitlines()
    assert len(lines) == 3 and json.loads(lines[2])["t"] == 0.1
    w.close()


def test_writer_refuses_time_going_back(tmp_path: Path) -> None:
    with SessionLogWriter(tmp_path / "x.jsonl", SessionHeader()) as w:
        w.write(Command(t=1.0, cmd="dry"))
        with pytest.raises(SessionLogError):
            w.write(Command(t=0.5, cmd="dry"))
