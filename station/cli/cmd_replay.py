"""``station replay TRACE``: play a device trace through the real driver path.

The trace's pen devices go through the same parser and normaliser as a live
device; the device-normalised pen samples are published on the bus
(``--bus``) and/or written as session-log JSONL (``--jsonl FILE`` or ``-``).
Interfaces that are not pens are skipped and listed on stderr.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import time
from typing import IO, Any

from station.bus import HEARTBEAT_S, Publisher
from station.cli.buskeys import add_key_flags, check_keys
from station.drivers.decode import ReportDecoder, event_line
from station.drivers.pipeline import TraceReplay, run_paced
from station.drivers.traces import read_trace
from station.drivers.traces.model import Trace
from station.errors import BadInput, StationError
from station.events import PenSample
from station.progress import Progress
from station.sessionlog import SessionHeader, SessionLogWriter
from station.stopsignal import StopSignal


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
    p.add_argument("--decode", action="store_true",
                   help="print each report's fields by name (as hid-decode; evdev events by "
                        "name) and stop: nothing is replayed")
    p.add_argument("--uhid", action="store_true",
                   help="play the HID devices of the trace into the kernel through /dev/uhid "
                        "(hid-tools), so other programs see a tablet; needs /dev/uhid")
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
    if args.decode:
        return _decode(read_trace(args.trace))
    if args.uhid:
        return _uhid(read_trace(args.trace), speed)
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
    stop = StopSignal()
    count = {"samples": 0}
    bar = Progress(replay.duration(), "replay", unit="s")

    def emit(sample: PenSample) -> None:
        count["samples"] += 1
        bar.set(sample.t)
        if writer is not None:
            writer.write(sample)
        if publisher is not None:
            publisher.publish_pen(sample)

    old = {sig: signal.signal(sig, stop.handler)
           for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        if speed is None:
            count["samples"] = _play_full_speed(replay, writer, publisher, bar, stop)
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
    _print_summary(summary, sys.stderr if args.jsonl == "-" else sys.stdout, args.json)
    return 0


def _play_full_speed(replay: TraceReplay, writer: SessionLogWriter | None,
                     publisher: Publisher | None, bar: Progress, stop: StopSignal) -> int:
    """Every sample as fast as the trace parses, to the bus in batches (wire kind 5);
    returns the number of samples."""
    samples = 0
    batch: list[PenSample] = []
    for sample in replay.samples():
        samples += 1
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
    return samples


def _print_summary(summary: dict[str, Any], out: IO[str], as_json: bool) -> None:
    if as_json:
        out.write(json.dumps(summary) + "\n")
        return
    for d in summary["devices"]:
        out.write(f"{d['name']}: {d['reports']} reports -> {d['samples']} samples "
                  f"({d['parser']}; {d['bad_reports']} bad reports dropped, "
                  f"{d['skipped_reports']} non-pen skipped{_by_id(d)}, "
                  f"{d['forced_proximity_out']} forced proximity-out)\n")


def _by_id(device: dict[str, Any]) -> str:
    """The skipped reports by ID, e.g. " (ID 99: 117)"."""
    ids = device.get("skipped_by_id") or {}
    return f" (ID {', ID '.join(f'{k}: {v}' for k, v in ids.items())})" if ids else ""


def _decode(trace: Trace) -> int:
    """``--decode``: every report (or event) of every device, one line each."""

    w = sys.stdout.write
    for dev in trace.devices:
        w(f"# device {dev.index}: {dev.name} ({dev.vid:04x}:{dev.pid:04x}), "
          f"{len(dev.reports)} reports, {len(dev.events)} events ({dev.where})\n")
        if dev.reports:
            decoder = ReportDecoder(dev.descriptor, dev.vid, dev.pid, dev.bus)
            if decoder.note:
                w(f"# {decoder.note}\n")
            t0 = dev.reports[0].time
            for r in dev.reports:
                w(decoder.line(r.time - t0, r.data) + "\n")
        if dev.events:
            t0 = dev.events[0].time
            for e in dev.events:
                w(event_line(e.time - t0, e.type, e.code, e.value) + "\n")
    return 0


UHID = "/dev/uhid"


def _uhid(trace: Trace, speed: float | None) -> int:
    """``--uhid``: the trace's HID devices become kernel devices (hid-tools' UHIDDevice)
    and their reports are played at ``speed`` (as recorded by default)."""
    if not os.path.exists(UHID):
        raise StationError(f"no {UHID} on this machine (a container, or the uhid module is "
                           "not loaded: sudo modprobe uhid); nothing was played")
    if not os.access(UHID, os.R_OK | os.W_OK):
        raise StationError(f"{UHID} is not readable and writable for this user (root, or a "
                           "udev rule giving it to your group)")
    from hidtools.uhid import UHIDDevice  # optional at run time: only this mode needs it

    hid = [d for d in trace.devices if d.reports and d.descriptor]
    if not hid:
        raise BadInput("no HID device with a report descriptor in this trace (evdev traces "
                       "cannot go through uhid)", trace.path)
    devices = []
    try:
        for d in hid:
            u = UHIDDevice()
            u.name, u.info, u.rdesc = d.name, (d.bus, d.vid, d.pid), bytes(d.descriptor or b"")
            u.phys = d.phys or "station-replay"
            u.create_kernel_device()
            devices.append((u, d))
        for u, _ in devices:
            u.dispatch(1000)  # until the kernel has started it
        events = sorted((r.time, i, r.data) for i, (_, d) in enumerate(devices)
                        for r in d.reports)
        start, t0 = time.monotonic(), events[0][0] if events else 0.0
        for t, i, data in events:
            if speed is not None:
                wait = start + (t - t0) / speed - time.monotonic()
                if wait > 0:
                    time.sleep(wait)
            devices[i][0].call_input_event(list(data))
        sys.stderr.write(f"station replay: {len(events)} reports played through {UHID} "
                         f"into {len(devices)} device(s)\n")
    finally:
        for u, _ in devices:
            u.destroy()
    return 0
