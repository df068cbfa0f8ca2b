"""``station bench haptic``: rate and jitter of the 1 kHz haptic loop against the mock device.

The mock device (the pty pair with its spring-mass handle, pressing the
round brush into the paper) runs in a child process, as a real device runs on
its own microcontroller; this process runs the station's loop exactly as
``station driver`` does (pyserial, decoding, contact force, safety, sending).
Three timing strategies in one run, so they compare as ratios on the same
machine load: ``sleep`` (sleep until each deadline: the driver's default),
``sleep+spin`` (sleep until 0.2 ms before it, then spin) and ``fifo`` (sleep,
with the loop thread at SCHED_FIFO priority 50: ``rt=50`` in the SPEC; where
the system refuses it the entry says so).  A fourth entry, ``deformable``, is
``sleep`` with the deformable brush's reaction solved beside the loop at 40 Hz
(``contact=deformable``: a :class:`~station.drivers.haptic.reaction.ReactionWorker`
process beside the loop), the hand pressing 2 mm into the tuft: its jitter
against ``sleep``'s is what the solves cost the loop (on a machine with a core
to spare, nothing; on an overloaded one, the CPU they take);
``deformable+fifo`` is the same with the loop at SCHED_FIFO 50.

Period statistics come from the loop's own tick start times (monotonic
clock).  Target: 1 kHz with a p99 period jitter (|period − 1 ms|) ≤ 0.5 ms.
"""

from __future__ import annotations

import argparse
import itertools
import json
import multiprocessing as mp
import os
import sys
import time
from multiprocessing.connection import Connection
from typing import Any

from station.drivers.haptic.deformable import DeformableBrushContact
from station.drivers.haptic.loop import HapticConfig, HapticSession
from station.drivers.mock.haptic import MockHapticDevice
from station.drivers.serial.transport import SerialTransport
from station.errors import BadInput

TARGET_RATE_HZ = 1000.0
TARGET_JITTER_P99_MS = 0.5


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("haptic", help="haptic loop rate and jitter against the mock device")
    p.add_argument("--json", action="store_true", help="print JSON (the default output too)")
    p.add_argument("--seconds", type=float, default=2.0, help="seconds per strategy (0.2..30)")
    p.add_argument("--rate", type=float, default=1000.0, help="loop rate in Hz (100..4000)")
    p.set_defaults(func=run)


def _device(conn: Connection) -> None:
    mock = MockHapticDevice("rest").start()
    conn.send(mock.path)
    conn.recv()  # "stop"
    received = len(mock.received)
    conn.send({"frames_received": received, "violations": mock.violations,
               "watchdog_trips": mock.watchdog_trips, "bad_frames": mock.bad_frames,
               "seconds": mock.now()})
    mock.stop()


def _pct(values: list[float], q: float) -> float:
    return values[min(len(values) - 1, int(q * len(values)))]


def _one(path: str, rate: float, seconds: float, spin_s: float, rt: int = 0,
         deformable: bool = False) -> dict[str, Any]:
    config = HapticConfig(rate_hz=rate, spin_s=spin_s, input=False, realtime=rt)
    if deformable:
        model = DeformableBrushContact()
        config.contact, config.reaction, config.surface = None, model, model.surface
    session = HapticSession(SerialTransport(path), config)
    session.handshake()
    session.start()
    if deformable:  # the reaction process has loaded its solver and answers
        deadline = time.monotonic() + 30.0
        while session.stats.reaction_frames < 3 and time.monotonic() < deadline:
            time.sleep(0.05)
        session.tick_times = type(session.tick_times)("d")  # time the loop from here
    over0 = session.stats.overruns
    cpu0 = time.process_time()
    time.sleep(seconds)
    pressing = session.status()  # the force while the hand presses (stop zeroes it)
    session.stop()
    cpu = time.process_time() - cpu0
    ticks = list(session.tick_times)
    periods = [(b - a) * 1000.0 for a, b in itertools.pairwise(ticks)]
    nominal = 1000.0 / rate
    jitter = sorted(abs(p - nominal) for p in periods)
    periods.sort()
    span = ticks[-1] - ticks[0]
    st = session.status()
    return {
        "spin_ms": spin_s * 1000.0, "scheduling": st["realtime"],
        "ticks": len(ticks), "rate_hz": round((len(ticks) - 1) / span, 1),
        "period_ms": {"p50": round(_pct(periods, 0.5), 4), "p99": round(_pct(periods, 0.99), 4),
                      "p999": round(_pct(periods, 0.999), 4), "max": round(periods[-1], 4)},
        "jitter_p99_ms": round(_pct(jitter, 0.99), 4),
        "overruns": st["overruns"] - over0, "poses": st["poses"], "bad_frames": st["bad_frames"],
        "cpu_fraction": round(cpu / seconds, 3),
        **({"reaction_frames": st["reaction_frames"], "reaction_ms": st["reaction_ms"],
            "force_n": pressing["force_n"]} if deformable else {}),
        "meets_target": (len(ticks) - 1) / span >= 0.99 * TARGET_RATE_HZ
        and _pct(jitter, 0.99) <= TARGET_JITTER_P99_MS,
    }


def run(args: argparse.Namespace) -> int:
    if not 0.2 <= args.seconds <= 30:
        raise BadInput(f"{args.seconds} outside 0.2..30", "--seconds")
    if not 100 <= args.rate <= 4000:
        raise BadInput(f"{args.rate} outside 100..4000", "--rate")
    ctx = mp.get_context("spawn")
    parent, child = ctx.Pipe()
    proc = ctx.Process(target=_device, args=(child,), daemon=True)
    proc.start()
    try:
        if not parent.poll(30):
            raise RuntimeError("mock device did not start")
        path = parent.recv()
        report: dict[str, Any] = {
            "targets": {"rate_hz": TARGET_RATE_HZ, "jitter_p99_ms": TARGET_JITTER_P99_MS},
            "rate_setting_hz": args.rate,
            "sleep": _one(path, args.rate, args.seconds, 0.0),
            "sleep+spin": _one(path, args.rate, args.seconds, 0.0002),
            "fifo": _one(path, args.rate, args.seconds, 0.0, rt=50),
            "deformable": _one(path, args.rate, args.seconds, 0.0, deformable=True),
            "deformable+fifo": _one(path, args.rate, args.seconds, 0.0, rt=50,
                                    deformable=True),
        }
        parent.send("stop")
        if parent.poll(10):
            report["device"] = parent.recv()
    finally:
        proc.join(5)
        if proc.is_alive():
            proc.kill()
    base = max(report["sleep"]["jitter_p99_ms"], 1e-9)
    report["jitter_ratio_vs_sleep"] = {k: round(report[k]["jitter_p99_ms"] / base, 3)
                                       for k in ("sleep+spin", "fifo", "deformable",
                                                 "deformable+fifo")}
    report["cpus"] = os.cpu_count()
    report["load_average"] = [round(v, 2) for v in os.getloadavg()]
    json.dump(report, sys.stdout, indent=2)
    sys.stdout.write("\n")
    return 0
