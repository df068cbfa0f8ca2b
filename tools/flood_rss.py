"""Flood a live ``station sim`` with touching pen samples and print its memory (JSON).

A publisher in this process binds the bus and sends one endless stroke per device
name (``--devices``) as fast as it can for ``--seconds``; the sim (a process of its
own, 64x48 numpy) connects to it.  Each second the sim's resident memory (VmRSS) is
read from /proc; at the end the sim stops (SIGTERM) and its last status says what
became of every sample (painted, dropped by the flood gate, lost at the queue).
Issue 25 item 3: the memory must level off, whatever the flood's length.

    python tools/flood_rss.py --seconds 20 --devices 8
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from station.bus import Publisher
from station.events import PenSample, Tool


def rss_mib(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return 0.0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--devices", type=int, default=8)
    args = ap.parse_args()
    if not (1 <= args.seconds <= 120 and 1 <= args.devices <= 64):
        sys.stderr.write("flood_rss: --seconds 1..120, --devices 1..64\n")
        return 2
    with tempfile.TemporaryDirectory(prefix="flood-") as tmp:
        bus = f"ipc://{tmp}/bus"
        pub = Publisher("@" + bus, replay=False)
        sim = subprocess.Popen(
            [sys.executable, "-m", "station", "sim", "--bus", bus, "--size", "64x48",
             "--backend", "numpy", "--log", f"{tmp}/s.jsonl", "--status", "none",
             "--autosave", "0", "--cmd", "none"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            if not pub.wait_for_subscribers(1, timeout=60):
                sys.stderr.write("flood_rss: the sim did not connect\n")
                return 1
            time.sleep(1.0)
            rss = [round(rss_mib(sim.pid), 1)]
            sent, t0 = 0, time.monotonic()
            next_mark = t0 + 1.0
            while (now := time.monotonic()) < t0 + args.seconds:
                for _ in range(200):
                    k = sent % args.devices
                    pub.publish_pen(PenSample(
                        t=now - t0, device=f"flood{k}", tool=Tool.PEN,
                        x=0.2 + 0.6 * ((sent // args.devices) % 101) / 101, y=0.5,
                        pressure=0.5, proximity=True, touching=True, seq=0))
                    sent += 1
                if now >= next_mark:
                    rss.append(round(rss_mib(sim.pid), 1))
                    next_mark += 1.0
            elapsed = time.monotonic() - t0
            time.sleep(2.0)  # let the sim drain what is queued
            rss.append(round(rss_mib(sim.pid), 1))
        finally:
            sim.send_signal(signal.SIGTERM)
            _out, err = sim.communicate(timeout=120)
            pub.close()
    last: dict[str, object] = {}
    for line in err.splitlines():  # its last line: "station sim: stopped {…}"
        if line.startswith("station sim: stopped "):
            last = json.loads(line[len("station sim: stopped "):])
    load = os.getloadavg()[0]
    print(json.dumps({"sent": sent, "seconds": round(elapsed, 1),
                      "rate_per_s": round(sent / elapsed), "rss_mib": rss,
                      "load_1min": round(load, 2), "sim_final": {
                          k: last.get(k) for k in ("samples", "flood_dropped", "lost_samples",
                                                   "bad_samples", "undo", "bus")},
                      "sim_exit": sim.returncode, "sim_stderr_tail": err[-600:]}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
