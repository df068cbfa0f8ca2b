"""``station record --device SPEC -o FILE.hid``: record a device as a trace.

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
import threading
import time
from typing import IO, Any

from station.cli.argtypes import positive_seconds
from station.errors import BadInput


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("record", help="record a pen device to a trace (.hid or .evemu)")
    p.add_argument("--device", required=True, metavar="SPEC", help="device SPEC (docs/drivers.md)")
    p.add_argument("-o", "--output", required=True, metavar="FILE", help="trace file to write")
    p.add_argument("--duration", type=positive_seconds, metavar="S",
                   help="stop after S seconds")
    p.add_argument("--no-init", action="store_true",
                   help="do not send the init feature reports (records mouse mode on a Wacom)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from station.drivers.pipeline import open_transport
    from station.drivers.transport.base import DeviceGone

    opened = open_transport(args.device)
    try:  # before recording anything: a path that cannot be written is bad input
        out = open(args.output, "w", encoding="utf-8")  # noqa: SIM115 (closed below)
    except OSError as exc:
        opened.transport.close()
        raise BadInput(f"cannot write {args.output!r} ({exc.strerror})", "-o") from None
    stop = threading.Event()
    old = {sig: signal.signal(sig, lambda *_: stop.set())
           for sig in (signal.SIGINT, signal.SIGTERM)}
    deadline = time.monotonic() + args.duration if args.duration else None
    count = 0
    try:
        with out:
            if opened.kind == "evdev":
                count = _record_evdev(opened.transport, out, args.output, stop, deadline,
                                      args.duration)
            else:
                count = _record_hid(opened.transport, out, stop, deadline, args.duration,
                                    not args.no_init)
    except DeviceGone as exc:
        sys.stderr.write(f"station record: {exc}\n")
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
        opened.transport.close()
    sys.stderr.write(f"station record: {count} reports written to {args.output}\n")
    return 0


def _init_features(info: Any) -> list[bytes]:
    from station.drivers.registry import parser_for

    try:
        return list(parser_for(info.vid, info.pid, info.descriptor, info.bus).init_features)
    except BadInput:
        return []


def _record_hid(transport: Any, fh: IO[str], stop: threading.Event, deadline: float | None,
                duration: float | None, send_init: bool) -> int:
    from station.drivers.traces.hidrecorder import HidRecorderWriter
    from station.drivers.transport.base import EndOfStream

    info = transport.info
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
    except EndOfStream:
        pass
    return writer.reports


def _record_evdev(transport: Any, fh: IO[str], path: str, stop: threading.Event,
                  deadline: float | None, duration: float | None) -> int:
    from station.drivers.evdev.frames import InputEvent
    from station.drivers.traces.evemu import format_evemu
    from station.drivers.traces.libinput_record import format_libinput_record
    from station.drivers.transport.base import EndOfStream

    events: list[InputEvent] = []
    try:
        while not stop.is_set():
            if deadline is not None and time.monotonic() >= deadline:
                break
            events.extend(transport.read(0.05))
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
