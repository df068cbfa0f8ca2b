"""``station record --device SPEC -o FILE.hid``: record a device as a trace;
``station record --bus ENDPOINT -o FILE.jsonl``: record the pen samples and commands
on the bus as a session log (the blueprint's ``<recorder>``).

HID devices (hidraw, hidapi, usb, mock …) are written as hid-recorder text as
reports arrive (flushed per report, so Ctrl-C loses nothing); evdev devices as
an evemu-record file, or libinput-record YAML when FILE ends in .yaml/.yml
(written when recording stops).  The parser's init feature reports (the Wacom ``02 02``
mode switch) are sent first unless ``--no-init``.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from typing import IO

from station.bus import Subscriber
from station.cli.argtypes import positive_seconds
from station.cli.buskeys import add_key_flags, check_keys
from station.drivers.decode import ReportDecoder, event_line
from station.drivers.evdev.frames import InputEvent
from station.drivers.pipeline import open_transport
from station.drivers.registry import parser_for
from station.drivers.traces.evemu import format_evemu
from station.drivers.traces.hidrecorder import HidRecorderWriter
from station.drivers.traces.libinput_record import format_libinput_record
from station.drivers.transport.base import (
    DeviceGone,
    EndOfStream,
    EvdevTransport,
    HidDeviceInfo,
    HidTransport,
)
from station.errors import BadInput
from station.sessionlog import SessionHeader, SessionLogWriter
from station.stopsignal import StopSignal


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("record", help="record a pen device to a trace (.hid or .evemu)")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--device", metavar="SPEC", help="device SPEC (docs/drivers.md)")
    src.add_argument("--bus", metavar="ENDPOINT",
                     help="record what the bus carries (pen samples, commands) as a session "
                          "log instead of a device's reports")
    p.add_argument("-o", "--output", required=True, metavar="FILE",
                   help="trace file to write (a session log .jsonl with --bus)")
    p.add_argument("--duration", type=positive_seconds, metavar="S",
                   help="stop after S seconds")
    p.add_argument("--no-init", action="store_true",
                   help="do not send the init feature reports (records mouse mode on a Wacom)")
    p.add_argument("-q", "--quiet", dest="quiet_events", action="store_true",
                   help="do not print each report or event as it arrives (on stdout)")
    add_key_flags(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.bus is not None:
        return _record_bus(args)
    opened = open_transport(args.device)
    try:  # before recording anything: a path that cannot be written is bad input
        out = open(args.output, "w", encoding="utf-8")  # noqa: SIM115 (closed below)
    except OSError as exc:
        opened.transport.close()
        raise BadInput(f"cannot write {args.output!r} ({exc.strerror})", "-o") from None
    stop = StopSignal()
    old = {sig: signal.signal(sig, stop.handler)
           for sig in (signal.SIGINT, signal.SIGTERM)}
    deadline = time.monotonic() + args.duration if args.duration else None
    count = 0
    try:
        with out:
            show = None if args.quiet_events else sys.stdout
            if opened.kind == "evdev":
                count = _record_evdev(opened.transport, out, args.output, stop, deadline,
                                      args.duration, show)
            else:
                count = _record_hid(opened.transport, out, stop, deadline, args.duration,
                                    not args.no_init, show)
    except DeviceGone as exc:
        sys.stderr.write(f"station record: {exc}\n")
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
        opened.transport.close()
    sys.stderr.write(f"station record: {count} reports written to {args.output}\n")
    return 0


def _init_features(info: HidDeviceInfo) -> list[bytes]:
    try:
        return list(parser_for(info.vid, info.pid, info.descriptor, info.bus).init_features)
    except BadInput:
        return []


def _record_hid(transport: HidTransport, fh: IO[str], stop: StopSignal,
                deadline: float | None, duration: float | None, send_init: bool,
                show: IO[str] | None) -> int:
    info = transport.info
    decoder = ReportDecoder(info.descriptor, info.vid, info.pid, info.bus) if show else None
    if show is not None:
        show.write(f"# {info.name} ({info.vid:04x}:{info.pid:04x}) -> {fh.name}: each "
                   "report as it arrives (-q: quiet)\n")
        show.flush()
    fh.write(f"# recorded by station record from {info.path}\n")
    writer = HidRecorderWriter(fh)
    writer.add_device(info.name, info.vid, info.pid, info.bus, info.descriptor, info.phys)
    if send_init:
        for feature in _init_features(info):
            transport.send_feature(feature)
    first: float | None = None
    try:
        while not stop.is_set():
            if deadline is not None and time.monotonic() >= deadline:
                break
            report = transport.read(0.05)
            if report is None:
                continue
            first = report.time if first is None else first
            if duration is not None and report.time - first > duration:
                break  # recording clock (a fast replayed mock) past the duration
            writer.write_report(report.time, report.data)
            if show is not None and decoder is not None:
                show.write(decoder.line(report.time - first, report.data) + "\n")
                show.flush()  # live, also into a pipe
    except EndOfStream:
        pass
    return writer.reports


def _record_evdev(transport: EvdevTransport, fh: IO[str], path: str, stop: StopSignal,
                  deadline: float | None, duration: float | None,
                  show: IO[str] | None) -> int:
    events: list[InputEvent] = []
    try:
        while not stop.is_set():
            if deadline is not None and time.monotonic() >= deadline:
                break
            new = transport.read(0.05)
            events.extend(new)
            if show is not None and new:
                t0 = events[0].time
                show.write("".join(event_line(e.time - t0, e.type, e.code, e.value) + "\n"
                                   for e in new))
                show.flush()
            if duration is not None and events and events[-1].time - events[0].time > duration:
                break
    except EndOfStream:
        pass
    finally:
        t0 = events[0].time if events else 0.0
        rel = [InputEvent(e.time - t0, e.type, e.code, e.value) for e in events]
        if path.endswith((".yaml", ".yml")):
            text = format_libinput_record([(transport.caps, rel)])
        else:
            text = format_evemu(transport.caps, rel)
        fh.write(text)
    return len(events)


def _record_bus(args: argparse.Namespace) -> int:
    """Subscribe to the bus and write every pen sample and command as a session log.

    Samples keep their driver time; one that would go back in time (two devices with
    their own clocks) is written at the last time and counted as ``retimed``."""
    import dataclasses

    if args.bus.startswith("@"):
        raise BadInput("the recorder connects to the bus (a driver or 'station bus' binds it); "
                       "drop the '@'", "--bus")
    check_keys(args.keys, args.client_key, (("--bus", args.bus, False),))
    stop = StopSignal()
    old = {sig: signal.signal(sig, stop.handler)
           for sig in (signal.SIGINT, signal.SIGTERM)}
    deadline = time.monotonic() + args.duration if args.duration else None
    counts = {"samples": 0, "commands": 0, "retimed": 0}
    sub = Subscriber(args.bus, topics=("pen.", "cmd"), keys=args.keys,
                     client_key=args.client_key)
    try:
        header = SessionHeader(extra={"source": sub.endpoints[0].url,
                                      "recorded_by": "station record"})
        writer = SessionLogWriter(args.output, header)
    except OSError as exc:
        sub.close()
        raise BadInput(f"cannot write ({exc.strerror})", args.output) from None
    last_t = 0.0
    try:
        while not stop.is_set() and (deadline is None or time.monotonic() < deadline):
            msg = sub.recv(100)
            if msg is None or msg.kind not in ("pen", "cmd"):
                continue
            rec = msg.value
            if rec.t < last_t:
                rec = dataclasses.replace(rec, t=last_t)
                counts["retimed"] += 1
            last_t = rec.t
            writer.write(rec)
            counts["samples" if msg.kind == "pen" else "commands"] += 1
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
        writer.close()
        lost = sub.stats.lost
        sub.close()
    sys.stderr.write(f"station record: {counts['samples']} samples, {counts['commands']} "
                     f"commands written to {args.output} (retimed {counts['retimed']}, "
                     f"lost on the bus {lost})\n")
    return 0
