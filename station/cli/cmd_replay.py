"""``station replay TRACE``: play a device trace through the real driver path.

The trace's pen devices go through the same parser and normaliser as a live
device; the device-normalised pen samples are published on the bus
(``--bus``) and/or written as session-log JSONL (``--jsonl FILE`` or ``-``).
Interfaces that are not pens are skipped and listed on stderr.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
from typing import IO, Any

from station.bus import HEARTBEAT_S, Publisher
from station.cli.buskeys import add_key_flags, check_keys
from station.drivers.pipeline import TraceReplay, run_paced
from station.drivers.traces import read_trace
from station.errors import BadInput
from station.events import PenSample
from station.progress import Progress
from station.sessionlog import SessionHeader, SessionLogWriter


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("replay", help="play a device trace (.hid, .evemu, .yaml) as pen samples")
    p.add_argument("trace", help="hid-recorder, evemu-record or libinput-record file")
    p.add_argument("--speed", default="max",
                   help="1.0 = as recorded, 2 = twice as fast, max = no waiting (default)")
    p.add_argument("--bus", metavar="ENDPOINT", help="publish pen samples on this bus endpoint")
    p.add_argument("--jsonl", metavar="FILE",
                   help="write pen samples as session-log JSONL ('-' = stdout)")
    p.add_argument("--name", help="device name in the samples (default: from the model)")
    p.add_argument("--wait-subscribers", type=int, default=0, metavar="N",
                   help="with --bus: wait (up to 5 s) for N subscribers before playing")
    p.add_argument("--heartbeat", type=float, default=None, metavar="S",
                   help="with --bus: seconds between heartbeats on hb.<device> (default "
                        "0.2, as `station driver`: the sim notices a replay that stopped)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    add_key_flags(p)
    p.set_defaults(func=run)


def parse_speed(text: str) -> float | None:
    if text == "max":
        return None
    try:
        speed = float(text)
    except ValueError:
        raise BadInput(f"speed {text!r} must be a number or max", "--speed") from None
    if not 0.01 <= speed <= 1000:
        raise BadInput(f"speed {speed} must be 0.01..1000 or max", "--speed")
    return speed


def run(args: argparse.Namespace) -> int:
    speed = parse_speed(args.speed)
    check_keys(args.keys, args.client_key, (("--bus", args.bus, True),))
    trace = read_trace(args.trace)
    replay = TraceReplay(trace, device_name=args.name)
    if not replay.pen_devices:  # one line: the skipped devices are in the message
        raise BadInput(f"no pen device in this trace ({replay.skipped_text()})", args.trace)
    for s in replay.skipped:
        sys.stderr.write(f"station replay: skipped device {s['device']} {s['name']!r}: "
                         f"{s['reason']} ({s['reports']} reports)\n")
    writer = None
    publisher: Publisher | None = None
    if args.jsonl:
        header = SessionHeader(extra={"source": str(args.trace), "coordinates": "device"})
        target: str | IO[str] = sys.stdout if args.jsonl == "-" else args.jsonl
        writer = SessionLogWriter(target, header)
    if args.bus:
        publisher = Publisher(args.bus, heartbeat=args.heartbeat or HEARTBEAT_S,
                              keys=args.keys, client_key=args.client_key)
        if args.wait_subscribers:
            publisher.wait_for_subscribers(args.wait_subscribers, timeout=5.0)
    stop = threading.Event()
    count = {"samples": 0}
    bar = Progress(replay.duration(), "replay", unit="s")

    def emit(sample: PenSample) -> None:
        count["samples"] += 1
        bar.set(sample.t)
        if writer is not None:
            writer.write(sample)
        if publisher is not None:
            publisher.publish_pen(sample)

    old = {sig: signal.signal(sig, lambda *_: stop.set())
           for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        if speed is None:
            # Full speed: hand samples to the bus in batches (wire kind 5).
            batch: list[PenSample] = []
            for sample in replay.samples():
                count["samples"] += 1
                bar.set(sample.t)
                if writer is not None:
                    writer.write(sample)
                if publisher is not None:
                    batch.append(sample)
                    if len(batch) >= 64:
                        publisher.publish_pens(batch)
                        batch = []
                    else:
                        publisher.tick()  # parsing a long trace: still alive
                if stop.is_set():
                    break
            if batch and publisher is not None:  # a batch only fills with a publisher
                publisher.publish_pens(batch)
        else:
            drivers = replay.open_drivers(speed)
            if publisher is not None:
                for drv in drivers:  # heartbeats from the start, before the first sample
                    publisher.announce(drv.normaliser.device)
            run_paced(drivers, emit, stop,
                      idle=publisher.tick if publisher is not None else None)
        summary = replay.status()
        summary["samples"] = count["samples"]
        if publisher is not None:
            # A last heartbeat carries the last pen seq: samples lost at the very end
            # of the replay are counted by the subscriber, not silently missing.
            publisher.tick(force=True)
            publisher.publish_status({"kind": "replay", "state": "done", **summary})
    finally:
        bar.close()
        for sig, handler in old.items():
            signal.signal(sig, handler)
        if writer is not None:
            writer.close()
        if publisher is not None:
            publisher.close()
    out = sys.stderr if args.jsonl == "-" else sys.stdout
    if args.json:
        out.write(json.dumps(summary) + "\n")
    else:
        for d in summary["devices"]:
            out.write(f"{d['name']}: {d['reports']} reports -> {d['samples']} samples "
                      f"({d['parser']}; {d['bad_reports']} bad reports dropped, "
                      f"{d['skipped_reports']} non-pen skipped{_by_id(d)}, "
                      f"{d['forced_proximity_out']} forced proximity-out)\n")
    return 0


def _by_id(device: dict[str, Any]) -> str:
    """The skipped reports by ID, e.g. " (ID 99: 117)"."""
    ids = device.get("skipped_by_id") or {}
    return f" (ID {', ID '.join(f'{k}: {v}' for k, v in ids.items())})" if ids else ""
