"""``station bench parse``: reports per second through every parser (and the normaliser).

Synthetic strokes are encoded with :mod:`station.drivers.synth` (the exact
inverses of the parsers), then parsed in a tight loop on one core (the
process is pinned to one CPU where the OS allows).  Devices send 100-233
reports per second; the target is >= 300 000 reports/s per parser (pen
reports/s for every parser, a Bluetooth report that bundles two pen packets counting
as one report), so one core has ~1500x headroom.  Each result says what was measured:
the report sizes, the pen packets (samples) a report carries, and what a report is.
The normaliser (``station.drivers.normalise``) is measured on the Intuos
parser's samples when it is installed.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time
from collections.abc import Callable
from typing import Any

from station.drivers import synth as S
from station.drivers.hid import usages as U
from station.drivers.hid.descriptor import parse_descriptor
from station.drivers.hid.pen import GenericPenParser
from station.drivers.normalise import Normaliser
from station.drivers.registry import parser_for
from station.drivers.uclogic.params import UclogicParams
from station.progress import Progress

# Reports per second a parser keeps on one idle core (issue 9: >= 300 000).  A report is
# one input report as the device sends it: a Bluetooth report that bundles two pen packets
# counts once (its samples/s are twice its reports/s), so the target is on reports.
TARGET = 300_000
# What one report of each workload is (printed with its figures).
WHAT = {
    "wacom-intuos": "Intuos Pro M (056a:0315) report 2, 10 bytes: one pen packet (pen, "
                    "an Art Pen rotation packet every 50)",
    "wacom-bamboo": "Intuos-HT (056a:030e) report 2, 10 bytes: one pen packet",
    "wacom-graphire": "Graphire (USB, 056a:0081) report 2, 8 bytes: one pen packet",
    "hid-generic/pth660-like": "descriptor path, Intuos Pro 2-like pen report 0x10, 23 "
                               "bytes: one pen packet",
    "hid-generic/huion-like": "descriptor path, Huion-like pen report 0x0a, 10 bytes: one "
                              "pen packet",
    "hid-generic/ntrig-like": "descriptor path, N-trig-like pen report 2, 15 bytes: one "
                              "pen packet",
    "wacom-intuos1": "Intuos2 12x12 (056a:0044) report 2, 10 bytes: one pen packet",
    "wacom-intuos4wl": "Intuos4 WL over Bluetooth (056a:00bd) report 3, 22 bytes: two "
                       "10-byte Intuos pen packets (counted as one report)",
    "wacom-intuos-bt": "Intuos Pro M (PTH-660) over Bluetooth (056a:0360) report 0x81, "
                       "109 bytes: "
                       "seven 14-byte frame slots, two valid pen frames (one report)",
    "wacom-tpc": "ISDv4 Tablet PC (056a:0093) report 2, 8 bytes: one pen packet",
    "uclogic-v2": "UC-Logic v2 (Huion 256c:006d, after the set-up) report 8, 12 bytes: one "
                  "pen packet",
}
# The normaliser (hysteresis, proximity timer, calibration) runs once per sample after the
# parser; it keeps the bus's 100 000 samples/s (the foundation issue's figure), not 300 000.
NORMALISER_TARGET = 100_000


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("parse", help="reports/s through the HID and Wacom parsers (JSON)")
    p.add_argument("--json", action="store_true", help="print JSON (the default output too)")
    p.add_argument("--reports", type=int, default=100_000, help="reports per parser")
    p.add_argument("--repeat", type=int, default=3, help="runs per parser; the best is kept")
    p.add_argument("--no-pin", action="store_true", help="do not pin the process to one CPU")
    p.set_defaults(func=run)


def _stroke(n: int) -> list[tuple[float, float, float, float, float]]:
    """n points of a spiral stroke: (u, v, pressure, tilt_x, tilt_y), each in [0,1] / [-1,1]."""
    out = []
    for i in range(n):
        a = i / max(1, n - 1)
        r = 0.1 + 0.35 * ((i % 2000) / 2000)
        out.append((0.5 + r * math.cos(40 * a), 0.5 + r * math.sin(40 * a),
                    0.5 + 0.5 * math.sin(7 * a), math.sin(3 * a), math.cos(5 * a)))  # fmt: skip
    return out


def _workloads(n: int) -> dict[str, tuple[Any, list[bytes]]]:
    """name -> (parser, reports)."""
    stroke = _stroke(n)
    work: dict[str, tuple[Any, list[bytes]]] = {}
    intuos = parser_for(0x056A, 0x0315, None)
    reps = [S.intuos_prox_in(0x802, 0x1234)]
    for i, (u, v, p, tx, ty) in enumerate(stroke[: n - 1]):
        if i % 50 == 49:
            reps.append(S.intuos_rotation(int(u * 44704), int(v * 27940), int(tx * 899)))
        else:
            reps.append(S.intuos_pen(int(u * 44704), int(v * 27940), int(p * 2047),
                                     int(tx * 63), int(ty * 63), 5, 0))  # fmt: skip
    work["wacom-intuos"] = (intuos, reps)
    bamboo = parser_for(0x056A, 0x030E, None)
    work["wacom-bamboo"] = (bamboo, [S.bamboo_pen(int(u * 15200), int(v * 9500), int(p * 1023),
                                                  tip=p > 0.1, length=10)
                                     for u, v, p, _, _ in stroke])  # fmt: skip
    graphire = parser_for(0x056A, 0x0081, None)
    work["wacom-graphire"] = (graphire, [S.graphire_report(int(u * 16704), int(v * 12064),
                                                           int(p * 511), tip=p > 0.1)
                                         for u, v, p, _, _ in stroke])  # fmt: skip
    for label, raw, rid, xmax, ymax, pmax, tmax in (
        ("pth660-like", S.pth660_like_descriptor(), 0x10, 44800, 29600, 8191, 9000),
        ("huion-like", S.huion_like_descriptor(), 0x0A, 50800, 31750, 8191, 60),
        ("ntrig-like", S.ntrig_like_descriptor(), 0x02, 9600, 7200, 1023, 60),
    ):
        d = parse_descriptor(raw)
        reports = [S.encode_report(d, rid, {
            U.GD_X: int(u * xmax), U.GD_Y: int(v * ymax), U.DG_TIP_PRESSURE: int(p * pmax),
            U.DG_TIP_SWITCH: int(p > 0.1), U.DG_IN_RANGE: 1, U.DG_X_TILT: int(tx * tmax),
            U.DG_Y_TILT: int(ty * tmax), U.DG_TRANSDUCER_SERIAL: 77,
        }) for u, v, p, tx, ty in stroke]  # fmt: skip
        work[f"hid-generic/{label}"] = (GenericPenParser(d), reports)
    _more_workloads(work, stroke)
    return work


def _more_workloads(work: dict[str, tuple[Any, list[bytes]]],
                    stroke: list[tuple[float, float, float, float, float]]) -> None:
    """The protocol families read from the kernel's table (one representative each)."""
    n = len(stroke)
    # Intuos2 12x12 (original protocol: coordinates without the low bit, encoded doubled)
    i1 = parser_for(0x056A, 0x0044, None)
    reps = [S.intuos_prox_in(0x022, 0x42)]
    reps += [S.intuos_pen(2 * int(u * 30480), 2 * int(v * 31680), int(p * 1023),
                          int(tx * 63), int(ty * 63), 5, 0, 1023)
             for u, v, p, tx, ty in stroke[: n - 1]]  # fmt: skip
    work["wacom-intuos1"] = (i1, reps)
    # Intuos4 WL over Bluetooth: two Intuos packets a report
    i4 = parser_for(0x056A, 0x00BD, None, bus=5)
    pens = [S.intuos_pen(int(u * 40640), int(v * 25400), int(p * 2047), int(tx * 63),
                         int(ty * 63), 5, 0) for u, v, p, tx, ty in stroke]  # fmt: skip
    reps = [bytes([3]) + S.intuos_prox_in(0x802, 7) + pens[0] + b"\x07"]
    reps += [bytes([3]) + pens[i] + pens[i + 1] + b"\x07" for i in range(1, n - 1, 2)]
    work["wacom-intuos4wl"] = (i4, reps)
    # Intuos Pro 2 over Bluetooth: up to seven 14-byte frames a report (here 2)
    bt = parser_for(0x056A, 0x0360, None, bus=5)
    tail = bytes(14 * 5) + ((1 << 52) | 0x1234).to_bytes(8, "little") + bytes([2, 8])
    reps = []
    for i in range(0, n - 1, 2):
        frames = b""
        for u, v, p, tx, ty in stroke[i:i + 2]:
            frames += (bytes([0xE0 | (p > 0.1)]) + int(u * 44800).to_bytes(2, "little")
                       + int(v * 29600).to_bytes(2, "little") + int(p * 8191).to_bytes(2, "little")
                       + bytes([int(tx * 60) & 0xFF, int(ty * 60) & 0xFF]) + bytes(4) + b"\x05")
        reps.append(bytes([0x81]) + frames + tail)
    work["wacom-intuos-bt"] = (bt, reps)
    # ISDv4 Tablet PC pen (the single-tool family)
    tpc = parser_for(0x056A, 0x0093, None)
    work["wacom-tpc"] = (tpc, [bytes([2, 0x20 | (p > 0.1)]) + int(u * 26202).to_bytes(2, "little")
                               + int(v * 16325).to_bytes(2, "little")
                               + int(p * 255).to_bytes(2, "little")
                               for u, v, p, _, _ in stroke])  # fmt: skip
    # UC-Logic v2 (after the set-up)
    uc = parser_for(0x256C, 0x006D, S.huion_like_descriptor())
    uc.use_params(UclogicParams("v2", 50800, 31750, 8191, 5080))
    work["uclogic-v2"] = (uc, [S.uclogic_pen_report("v2", int(u * 50800), int(v * 31750),
                                                    int(p * 8191), p > 0.1, 0, True,
                                                    int(tx * 60), int(ty * 60))
                               for u, v, p, tx, ty in stroke])  # fmt: skip


def _time_it(fn: Callable[[], int], repeat: int) -> tuple[float, int]:
    best = math.inf
    count = 0
    for _ in range(repeat):
        t0 = time.perf_counter()
        count = fn()
        best = min(best, time.perf_counter() - t0)
    return best, count


def _pin() -> int | None:
    if not hasattr(os, "sched_setaffinity"):
        return None
    try:
        cpu = min(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {cpu})
        return cpu
    except OSError:
        return None


def _loop(parser: Any, reports: list[bytes]) -> int:
    parser.reset()
    parse = parser.parse
    got = 0
    t = 0.0
    for r in reports:
        t += 0.005
        got += len(parse(r, t))
    return got


def measure(n: int, repeat: int) -> dict[str, Any]:
    results: dict[str, Any] = {}
    work = _workloads(n)
    bar = Progress(repeat + 1, "bench parse", unit="round")
    # Round-robin: every run visits every parser once, so a load change on a shared
    # machine hits all parsers alike and the best-of-R figures stay comparable.
    best = dict.fromkeys(work, math.inf)
    samples_of: dict[str, int] = {}
    for _ in range(repeat):
        for name, (parser, reports) in work.items():
            t0 = time.perf_counter()
            samples_of[name] = _loop(parser, reports)
            best[name] = min(best[name], time.perf_counter() - t0)
        bar.update()
    bar.note("normaliser")
    for name, (_, reports) in work.items():
        seconds = best[name]
        sizes = [len(r) for r in reports]
        results[name] = {
            "what": WHAT.get(name, ""),
            "report_bytes": [min(sizes), max(sizes)],
            "pen_packets_per_report": round(samples_of[name] / len(reports), 3),
            "reports": len(reports),
            "samples": samples_of[name],
            "seconds": round(seconds, 6),
            "reports_per_s": round(len(reports) / seconds),
            "samples_per_s": round(samples_of[name] / seconds),
            "us_per_report": round(seconds / len(reports) * 1e6, 3),
            "meets_target": len(reports) / seconds >= TARGET,
        }
    parser, reports = work["wacom-intuos"]
    parser.reset()
    intuos_samples = [s for i, r in enumerate(reports) for s in parser.parse(r, i * 0.005)]
    intuos_ranges = parser.ranges

    def norm_loop() -> int:
        norm = Normaliser(intuos_ranges, device="bench-0")
        got = 0
        for s in intuos_samples:
            got += len(norm.feed(s))
        return got

    seconds, samples = _time_it(norm_loop, repeat)
    results["normaliser"] = {
        "raw_samples": len(intuos_samples),
        "samples": samples,
        "seconds": round(seconds, 6),
        "reports_per_s": round(len(intuos_samples) / seconds),
        "us_per_report": round(seconds / len(intuos_samples) * 1e6, 3),
        "target_reports_per_s": NORMALISER_TARGET,
        "meets_target": len(intuos_samples) / seconds >= NORMALISER_TARGET,
    }
    bar.update()
    bar.close()
    return results


def run(args: argparse.Namespace) -> int:
    cpu = None if args.no_pin else _pin()
    results = measure(max(10, args.reports), max(1, args.repeat))
    rates = [r["reports_per_s"] for r in results.values() if "reports_per_s" in r]
    parsers = [r["reports_per_s"] for k, r in results.items() if k != "normaliser"]
    out = {
        "benchmark": "parse",
        "target_reports_per_s": TARGET,
        "counting": "reports/s: input reports as the device sends them, one parse() call "
                    "each; a Bluetooth report bundling several pen packets counts once "
                    "(samples/s counts the packets)",
        "slowest_parser_reports_per_s": min(parsers),
        "pinned_cpu": cpu,
        "results": results,
        "slowest_reports_per_s": min(rates),
        "meets_target": all(r.get("meets_target", True) for r in results.values()),
    }
    print(json.dumps(out, indent=2))
    return 0
