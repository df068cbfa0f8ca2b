"""Deterministic report streams for every protocol family, and their parsed outputs as plain data.

``tests/data/parse_golden.json.gz`` holds the outputs the parsers gave before the
parse-speed rework (issue 9), written by ``python tests/parse_streams.py --write``;
``test_parsers_golden.py`` holds today's parsers to them, report for report.

A stream is the bench's synthetic stroke for the family plus mutated copies of its
reports (random bytes after the ID, random lengths, random IDs), so proximity in/out,
every Intuos packet type, both Intuos1 tool slots, invalid Bluetooth frames and
malformed reports all occur.
"""

from __future__ import annotations

import gzip
import json
import random
import sys
from pathlib import Path
from typing import Any

from station.drivers import synth as S
from station.drivers.registry import parser_for

from station.bench.parse import _workloads

GOLDEN = Path(__file__).resolve().parent / "data" / "parse_golden.json.gz"
FIELDS = ("time", "proximity", "x", "y", "tip", "pressure", "tilt_x", "tilt_y", "distance",
          "rotation", "wheel", "buttons", "tool", "serial", "tool_id", "eraser", "valid")
# Families the bench does not cover, as (label, vid, pid, bus): one model each.
EXTRA = (
    ("wacom-graphire4", 0x056A, 0x0017, 3), ("wacom-graphire-bt", 0x056A, 0x0081, 5),
    ("wacom-penpartner", 0x056A, 0x0000, 3), ("wacom-ptu", 0x056A, 0x0003, 3),
    ("wacom-pl", 0x056A, 0x0030, 3), ("wacom-dtu", 0x056A, 0x00CE, 3),
    ("wacom-dtus", 0x056A, 0x00FB, 3), ("wacom-intuos/no-lens", 0x056A, 0x0026, 3),
    ("wacom-intuos/ready-bit", 0x056A, 0x003F, 3),
    ("wacom-intuos/old-styli", 0x056A, 0x00CC, 3),
    ("wacom-intuos/no-tilt", 0x056A, 0x033B, 3), ("wacom-intuos-bt/ctl", 0x056A, 0x0377, 5),
)


# Tools entering proximity in turn (pen, eraser, airbrush, mouse, lens, Art Pen, an
# Intuos1 stylus, an Intuos4-generation grip pen), so every tool branch runs.
TOOL_IDS = (0x802, 0x80A, 0x902, 0x007, 0x096, 0x804, 0x022, 0x10802, 0x094, 0x812)


def _intuos_tools(reports: list[bytes], bundled: bool = False) -> list[bytes]:
    """Intuos packets with a tool change every 37 (bundles: 13) reports and a proximity-out
    every 53 (29)."""
    out = []
    at, every, out_every = (1, 13, 29) if bundled else (0, 37, 53)
    for i, r in enumerate(reports):
        rid = r[at]
        if i % every == 5:
            packet = S.intuos_prox_in(TOOL_IDS[(i // every) % len(TOOL_IDS)], 1000 + i, rid)
        elif i % out_every == 7:
            packet = S.intuos_prox_out(rid)
        else:
            out.append(r)
            continue
        out.append(r[:at] + packet[:10] + r[at + 10:])
    return out


def _mutate(rng: random.Random, report: bytes, ids: list[int]) -> bytes:
    roll = rng.random()
    if roll < 0.25:  # same ID and length, random payload
        return report[:1] + bytes(rng.randrange(256) for _ in report[1:])
    if roll < 0.30:
        return bytes(rng.randrange(256) for _ in range(rng.randrange(0, 40)))
    if roll < 0.35:
        return bytes([rng.choice(ids)]) + report[1:]
    if roll < 0.40:
        cut = rng.randrange(len(report) + 4)
        return (report + bytes(4))[:cut]
    if roll < 0.55 and len(report) > 2:  # flip bits of one byte
        i = rng.randrange(1, len(report))
        return report[:i] + bytes([report[i] ^ (1 << rng.randrange(8))]) + report[i + 1:]
    return report


def streams(n: int = 400, seed: int = 9) -> dict[str, tuple[Any, list[bytes]]]:
    """label -> (a fresh parser, its report stream)."""
    work = {k: v for k, v in _workloads(n).items() if not k.startswith("hid-generic")}
    bases = {"wacom-intuos": work["wacom-intuos"][1], "wacom-graphire": work["wacom-graphire"][1],
             "wacom-intuos-bt": work["wacom-intuos-bt"][1], "wacom-tpc": work["wacom-tpc"][1]}
    for label, vid, pid, bus in EXTRA:
        family = label.split("/")[0]
        base = bases.get(family) or bases["wacom-intuos" if "intuos" in family
                                          else "wacom-graphire" if "graphire" in family
                                          else "wacom-tpc"]
        if family == "wacom-graphire-bt":
            base = [b"\x03" + r[1:] for r in base]
        elif family in ("wacom-penpartner", "wacom-dtus", "wacom-pl", "wacom-ptu", "wacom-dtu"):
            rid = {"wacom-dtus": 17}.get(family, 2)
            base = [bytes([rid]) + r[1:] for r in base]
        work[label] = (parser_for(vid, pid, None, bus), base)
    for label in list(work):
        if "intuos" in label and "-bt" not in label:
            parser, reports = work[label]
            work[label] = (parser, _intuos_tools(reports, bundled=label == "wacom-intuos4wl"))
    rng = random.Random(seed)
    out: dict[str, tuple[Any, list[bytes]]] = {}
    for label, (parser, reports) in work.items():
        ids = sorted({r[0] for r in reports if r} | {1, 2, 3, 4, 5, 6, 12, 16, 17, 21, 99, 192})
        out[label] = (parser, [_mutate(rng, r, ids) for r in reports])
    return out


def plain(sample: Any) -> list[Any]:
    values = [getattr(sample, f) for f in FIELDS]
    tool = values[12]
    values[12] = None if tool is None else tool.name
    return values


def outputs(parser: Any, reports: list[bytes]) -> list[Any]:
    """Per report: the samples as lists, or the error text; then the parser's counters."""
    parser.reset()
    got: list[Any] = []
    for i, r in enumerate(reports):
        try:
            got.append([plain(s) for s in parser.parse(r, i * 0.005)])
        except Exception as exc:
            got.append(f"{type(exc).__name__}: {exc}")
    got.append({"dropped": parser.dropped, "skipped": parser.skipped})
    return got


def all_outputs() -> dict[str, list[Any]]:
    return {label: outputs(p, r) for label, (p, r) in streams().items()}


if __name__ == "__main__":
    if "--write" in sys.argv:
        GOLDEN.parent.mkdir(exist_ok=True)
        with gzip.open(GOLDEN, "wt", encoding="utf-8") as f:
            json.dump(all_outputs(), f, separators=(",", ":"))
        print(GOLDEN, GOLDEN.stat().st_size)
