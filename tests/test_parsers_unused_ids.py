"""Reports whose ID the descriptor declares but the protocol does not use are skipped and
counted by ID (as the kernel's wacom_graphire_irq ignores them), never bad, never warned;
malformed reports stay bad, warned a few times, then counted (issue 9).

The stream mimics what a PenStation2/PenPartner (056a:0061, Graphire protocol) sends: a
vendor report 0x63 of zeros between its 8-byte pen reports.  Everything is generated here.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

import pytest
from station.drivers import synth as S
from station.drivers.hid.errors import ReportError
from station.drivers.registry import parser_for

from station.cli import main

PENSTATION = (0x056A, 0x0061)
UNUSED = 0x63
DESC = S.wacom_protocol_descriptor(7, [UNUSED])  # report 2 and 0x63: 8 bytes with the ID


def test_a_declared_unused_id_is_skipped_by_id_and_an_undeclared_one_is_bad() -> None:
    p = parser_for(*PENSTATION, DESC)
    assert p.name == "wacom-graphire" and p.unused_report_ids == {1, UNUSED}  # 1: boot mouse
    assert p.parse(bytes([UNUSED]) + bytes(7), 0.0) == []
    assert p.parse(bytes([UNUSED]) + bytes(3), 0.0) == []  # any length: the kernel ignores it
    assert (p.skipped, p.skipped_by_id[UNUSED], p.skipped_by_kind["unused"]) == (2, 2, 2)
    with pytest.raises(ReportError, match="unknown Graphire report ID 66"):
        p.parse(bytes([0x42]) + bytes(7), 0.0)  # not in the descriptor
    with pytest.raises(ReportError, match="9 bytes, expected 8"):
        p.parse(S.graphire_report(100, 200, 50) + b"\0", 0.0)  # a known ID, wrong length
    (s,) = p.parse(S.graphire_report(100, 200, 50, tip=True), 0.01)
    assert (s.x, s.y, s.pressure, s.tip) == (100, 200, 50, True)
    # without a descriptor nothing is declared: the same report is bad
    bare = parser_for(*PENSTATION, None)
    with pytest.raises(ReportError, match="unknown Graphire report ID 99"):
        bare.parse(bytes([UNUSED]) + bytes(7), 0.0)


@pytest.mark.parametrize("pid", [0x0315, 0x00B9, 0x0000, 0x030E])
def test_every_protocol_family_skips_declared_unused_ids(pid: int) -> None:
    """Intuos, Intuos4, PenPartner, Bamboo: the same rule through the base class."""
    p = parser_for(0x056A, pid, S.wacom_protocol_descriptor(9, [UNUSED, 0x70]))
    assert {UNUSED, 0x70} <= p.unused_report_ids
    assert p.parse(bytes([UNUSED]) + bytes(9), 0.0) == []
    assert p.parse(bytes([0x70]) + bytes(9), 0.0) == []
    assert dict(p.skipped_by_id) == {UNUSED: 1, 0x70: 1}
    with pytest.raises(ReportError, match="report ID 81"):
        p.parse(bytes([0x51]) + bytes(9), 0.0)


def _trace(tmp_path: Path, bad: int) -> tuple[Path, int, int]:
    """A PenStation2-like recording: pen strokes with 0x63 reports between, and ``bad``
    malformed pen reports.  Returns (path, unused reports, pen reports)."""
    events: list[bytes] = []
    unused = pen = 0
    for stroke in range(3):
        for i in range(40):
            if i % 7 == 0:
                events.append(bytes([UNUSED]) + bytes(7))
                unused += 1
            x, y = 1000 + 40 * i, 800 + 25 * i + 300 * stroke
            events.append(S.graphire_report(x, y, min(255, 12 * i), tip=5 < i < 35))
            pen += 1
        events.append(S.graphire_report(0, 0, prox=False))
        pen += 1
    for i in range(bad):
        events.insert(10 + 3 * i, S.graphire_report(5, 5, 1) + b"\0\0")  # 10 bytes: bad
    dev = S.RecordedDevice("WACOM FT-0203-UV1.4-2", *PENSTATION, DESC,
                           [(0.008 * k, e) for k, e in enumerate(events)], phys="usb-1/input0")
    path = tmp_path / "penstation.hid"
    S.write_hid_recorder([dev], path)
    return path, unused, pen


def _replay(path: Path, capsys: pytest.CaptureFixture[str],
            caplog: pytest.LogCaptureFixture) -> tuple[dict, list[str]]:
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        assert main(["replay", str(path), "--json"]) == 0
    (dev,) = json.loads(capsys.readouterr().out)["devices"]
    return dev, [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]


def test_replay_counts_unused_reports_as_skipped_without_warnings(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        caplog: pytest.LogCaptureFixture) -> None:
    path, unused, pen = _trace(tmp_path, bad=0)
    dev, warnings = _replay(path, capsys, caplog)
    assert unused == 18 and pen == 123
    assert dev["reports"] == unused + pen
    assert (dev["bad_reports"], dev["bad_reasons"]) == (0, {})
    assert dev["skipped_reports"] == unused
    assert dev["skipped_by_id"] == {"99": unused}
    assert dev["skipped_by_kind"] == {"unused": unused}
    assert dev["samples"] > 100
    assert warnings == []


def test_malformed_reports_stay_bad_with_warnings_limited(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        caplog: pytest.LogCaptureFixture) -> None:
    path, unused, _ = _trace(tmp_path, bad=30)
    dev, warnings = _replay(path, capsys, caplog)
    assert dev["bad_reports"] == 30
    assert dev["bad_reasons"] == {"Graphire report 2 is 10 bytes, expected 8": 30}
    assert dev["skipped_by_id"] == {"99": unused}
    dropped = [w for w in warnings if "dropped report" in w]
    assert len(dropped) == 5  # the first few one by one …
    assert sum("counted without a warning each" in w for w in warnings) == 1
    assert sum("10 bad reports dropped so far" in w for w in warnings) == 1  # … then counts
    assert len(warnings) == 7


def test_replay_text_summary_names_the_skipped_ids(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path, unused, _ = _trace(tmp_path, bad=0)
    assert main(["replay", str(path)]) == 0
    line = capsys.readouterr().out
    assert f"0 bad reports dropped, {unused} non-pen skipped (ID 99: {unused})" in line
