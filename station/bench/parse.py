"""``station bench parse``: reports per second through every parser (and the normaliser).

Synthetic strokes are encoded with :mod:`station.drivers.synth` (the exact
inverses of the parsers), then parsed in a tight loop on one core (the
process is pinned to one CPU where the OS allows).  Devices send 100-233
reports per second; the target is >= 100 000 reports/s per parser, so one
core has ~500x headroom.  The normaliser (``station.drivers.normalise``)
is measured on the Intuos parser's samples when it is installed.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time
from collections.abc import Callable
from typing import Any

from station.progress import Progress

TARGET = 100_000


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
    from station.drivers import synth as S
    from station.drivers.hid import usages as U
    from station.drivers.hid.descriptor import parse_descriptor
    from station.drivers.hid.pen import GenericPenParser
    from station.drivers.registry import parser_for

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
    return work


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


def measure(n: int, repeat: int) -> dict[str, Any]:
    results: dict[str, Any] = {}
    intuos_samples = []
    workloads = _workloads(n)
    bar = Progress(len(workloads) + 1, "bench parse", unit="parser")
    for name, (parser, reports) in workloads.items():
        bar.note(name)
        def loop(parser: Any = parser, reports: list[bytes] = reports) -> int:
            parser.reset()
            parse = parser.parse
            got = 0
            t = 0.0
            for r in reports:
                t += 0.005
                got += len(parse(r, t))
            return got

        seconds, samples = _time_it(loop, repeat)
        results[name] = {
            "reports": len(reports),
            "samples": samples,
            "seconds": round(seconds, 6),
            "reports_per_s": round(len(reports) / seconds),
            "us_per_report": round(seconds / len(reports) * 1e6, 3),
            "meets_target": len(reports) / seconds >= TARGET,
        }
        if name == "wacom-intuos":
            parser.reset()
            intuos_samples = [s for i, r in enumerate(reports) for s in parser.parse(r, i * 0.005)]
            intuos_ranges = parser.ranges
        bar.update()
    bar.note("normaliser")
    try:
        from station.drivers.normalise import Normaliser
    except ImportError:
        results["normaliser"] = {"skipped": "station.drivers.normalise is not installed"}
    else:
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
            "meets_target": len(intuos_samples) / seconds >= TARGET,
        }
    bar.update()
    bar.close()
    return results


def run(args: argparse.Namespace) -> int:
    cpu = None if args.no_pin else _pin()
    results = measure(max(10, args.reports), max(1, args.repeat))
    rates = [r["reports_per_s"] for r in results.values() if "reports_per_s" in r]
    out = {
        "benchmark": "parse",
        "target_reports_per_s": TARGET,
        "pinned_cpu": cpu,
        "results": results,
        "slowest_reports_per_s": min(rates),
        "meets_target": all(r.get("meets_target", True) for r in results.values()),
    }
    print(json.dumps(out, indent=2))
    return 0
