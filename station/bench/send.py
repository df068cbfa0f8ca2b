"""``station bench send``: how long one ``station send`` takes, answer included (JSON).

A small live sim (16x16, numpy) runs in this process, in a thread, on a command
endpoint of its own; each call is a fresh ``python -m station send brush size=N``
process (interpreter start, imports, connect, command, answer), timed from its
start to its exit; ``startup_ms`` times a process that only starts the interpreter
and imports ``station send``'s module, so ``process - startup`` is the round trip
itself (connect, command, answer).  The issue's target: a call within 0.3 s on the reference
machine (2 CPU cores).  On a loaded machine wall times mostly measure the wait for
a core: ``cpu_ms`` (user + system time of each call's process) and
``interpreter_ms`` (``python -c pass``, timed beside it) say what the call costs
itself.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from station.errors import BadInput
from station.sim.live import LiveConfig
from station.sim.live_bus import LiveSim


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("send", help="station send round trip, answer included (JSON)")
    p.add_argument("--json", action="store_true", help="print JSON (the default output too)")
    p.add_argument("--calls", type=int, default=10, help="calls to time (1..200)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if not 1 <= args.calls <= 200:
        raise BadInput("must be 1..200", "--calls")
    with tempfile.TemporaryDirectory(prefix="bench-send-") as tmp:
        ep = f"ipc://{tmp}/cmd"
        sim = LiveSim(LiveConfig(bus=f"ipc://{tmp}/bus", width=16, height=16,
                                 backend="numpy", log_path=str(Path(tmp) / "s.jsonl"),
                                 status="none", autosave=0.0, cmd="@" + ep))
        th = threading.Thread(target=sim.run, daemon=True)
        th.start()
        try:
            proc_ms, start_ms, cpu_ms, bare_ms = [], [], [], []
            flags = ["--to", ">" + ep, "--timeout", "10"]
            for i in range(args.calls):
                t0 = time.perf_counter()
                r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
                done = subprocess.run([sys.executable, "-m", "station", "send", "brush",
                                       f"size={i + 1}", *flags],
                                      capture_output=True, text=True, timeout=60)
                proc_ms.append((time.perf_counter() - t0) * 1000)
                r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
                cpu_ms.append((r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime) * 1000)
                if done.returncode != 0:
                    raise BadInput(f"station send failed: {done.stderr.strip()}", "bench send")
                t0 = time.perf_counter()
                subprocess.run([sys.executable, "-c", "import station.cli.cmd_send"],
                               capture_output=True, timeout=60, check=True)
                start_ms.append((time.perf_counter() - t0) * 1000)
                t0 = time.perf_counter()
                subprocess.run([sys.executable, "-c", "pass"], capture_output=True,
                               timeout=60, check=True)
                bare_ms.append((time.perf_counter() - t0) * 1000)
        finally:
            sim.stop_requested = True
            th.join(30)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    out = {"calls": args.calls, "process_ms": {
        "median": statistics.median(proc_ms), "max": max(proc_ms), "min": min(proc_ms)},
        "startup_ms": {"median": statistics.median(start_ms), "max": max(start_ms)},
        "cpu_ms": {"median": statistics.median(cpu_ms), "max": max(cpu_ms)},
        "interpreter_ms": statistics.median(bare_ms),
        "round_trip_ms": statistics.median(proc_ms) - statistics.median(start_ms),
        "target_ms": 300.0, "load_1min": load, "cpus": os.cpu_count()}
    sys.stdout.write(json.dumps(out) + "\n")
    return 0
