"""``station driver --device SPEC --bus ENDPOINT``: the long-running driver process.

Reads one pen device, publishes its pen samples on ``pen.<name>`` and a status
record (counts of reports, bad reports dropped, samples, forced proximity-out)
on ``status`` every ``--status-interval`` seconds.  SIGINT/SIGTERM end it
cleanly (exit 0).  When the device is unplugged it publishes ``state: gone``
and keeps watching for it to come back (``--no-reconnect`` ends instead).
A recording or a finite mock script ends the driver when it ends.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import time
from collections.abc import Callable
from pathlib import Path

from station.bus import HEARTBEAT_S, Publisher
from station.cli.buskeys import check_keys
from station.drivers.calibrated import choose_calibration, settle_pressure
from station.drivers.devicedata import SourceInfo
from station.drivers.normalise import NormaliserConfig
from station.drivers.pipeline import PenDriver, PenSource, open_device
from station.drivers.transport.base import DeviceGone, EndOfStream, TransportError
from station.drivers.transport.evdev import find_evdev_node
from station.errors import BadInput
from station.sessionlog import SessionHeader, SessionLogWriter
from station.sizes import parse_size
from station.stopsignal import StopSignal

SUBSCRIBER_WAIT_S = 5.0  # --wait-subscribers: then the driver reads the device anyway


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("driver", help="run a pen driver publishing on the bus")
    p.add_argument("--device", required=True, metavar="SPEC", help="device SPEC (docs/drivers.md)")
    p.add_argument("--bus", metavar="ENDPOINT", help="bus endpoint (default: the local ipc bus)")
    p.add_argument("--name", help="device name in the samples (default: from the model)")
    p.add_argument("--jsonl", metavar="FILE", help="also write the samples as session-log JSONL")
    p.add_argument("--status-interval", type=float, default=1.0, metavar="S")
    p.add_argument("--wait", action="store_true",
                   help="if the device is not there yet, wait for it instead of failing")
    p.add_argument("--no-reconnect", action="store_true",
                   help="end when the device is unplugged instead of waiting for it")
    p.add_argument("--max-reconnects", type=int, default=None, metavar="N",
                   help="give up after N reconnections (default: never)")
    p.add_argument("--area", metavar="X0,Y0,X1,Y1",
                   help="active area in device units (default: the whole tablet)")
    p.add_argument("--smoothing", type=float, default=0.0, metavar="MS",
                   help="position smoothing time constant in ms (0 = off)")
    p.add_argument("--tip-down", type=float, default=0.05, help="contact threshold (fraction)")
    p.add_argument("--tip-up", type=float, default=0.01, help="release threshold (fraction)")
    p.add_argument("--pressure-curve", metavar="X1,Y1,X2,Y2",
                   help="cubic Bézier pressure curve control points in [0, 1]")
    p.add_argument("--proximity-timeout", type=float, default=0.05, metavar="S",
                   help="forced proximity-out after S seconds without reports")
    p.add_argument("--no-init", action="store_true", help="do not send init feature reports")
    p.add_argument("--calibration", default="auto", metavar="auto|none|FILE",
                   help="device -> canvas calibration: the device's file from the config dir "
                   "(auto, the default), none (the tablet mapped by --mapping), or a "
                   "calibration file")
    p.add_argument("--mapping", choices=("fit", "stretch"), default="fit",
                   help="without a calibration: fit keeps the tablet's aspect ratio on the "
                        "canvas (letterboxed, centred; the default), stretch fills it")
    p.add_argument("--canvas", default="800x600", metavar="WxH",
                   help="size (or just the shape) of the canvas the samples are for "
                        "(default 800x600, the sim's default)")
    p.add_argument("--raw-jsonl", metavar="FILE",
                   help="also write the device-normalised (uncalibrated) samples as JSONL")
    p.add_argument("--wait-subscribers", type=int, default=0, metavar="N",
                   help="wait (up to 5 s) for N subscribers before reading the device")
    p.add_argument("--keys", type=Path, default=None, metavar="DIR",
                   help="CURVE key directory for tcp endpoints (default ~/.config/station/keys)")
    p.add_argument("--client-key", metavar="NAME",
                   help="connect over tcp with this driver's own key pair (made by "
                        "`station keys --client NAME`) instead of the shared client key")
    p.add_argument("--haptic-bus", action="append", default=None, metavar="ENDPOINT",
                   help="a haptic device's forces (haptic.<device>) come from here: the "
                        "endpoint station sim publishes its status on (repeatable; "
                        "default: --bus)")
    p.add_argument("--heartbeat", type=float, default=None, metavar="S",
                   help="seconds between heartbeats on hb.<device> (default 0.2; the sim "
                        "names a silent device after 3 missed ones)")
    p.set_defaults(func=run)


def normaliser_config(args: argparse.Namespace) -> NormaliserConfig:
    curve = None
    if args.pressure_curve:
        try:
            parts = tuple(float(v) for v in args.pressure_curve.split(","))
        except ValueError:
            raise BadInput("needs four numbers x1,y1,x2,y2", "--pressure-curve") from None
        if len(parts) != 4:
            raise BadInput("needs four numbers x1,y1,x2,y2", "--pressure-curve")
        curve = parts
    area = None
    if args.area:
        try:
            corners = tuple(float(v) for v in args.area.split(","))
        except ValueError:
            raise BadInput("needs four numbers x0,y0,x1,y1", "--area") from None
        if len(corners) != 4:
            raise BadInput("needs four numbers x0,y0,x1,y1", "--area")
        area = (corners[0], corners[1], corners[2], corners[3])

    return NormaliserConfig(area=area, tip_down=args.tip_down, tip_up=args.tip_up,
                            smoothing_ms=args.smoothing, pressure_curve=curve,
                            proximity_timeout=args.proximity_timeout or None,
                            mapping=args.mapping, canvas=parse_size(args.canvas, "--canvas"))


def run(args: argparse.Namespace) -> int:
    config = normaliser_config(args)
    check_keys(args.keys, args.client_key,
               [("--bus", args.bus, True)] + [("--haptic-bus", ep, False)
                                               for ep in args.haptic_bus or ()])
    if args.status_interval <= 0:
        raise BadInput("must be > 0 seconds", "--status-interval")
    stop = StopSignal()
    old = {sig: signal.signal(sig, stop.handler)
           for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        return _serve(args, config, stop)
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


def _serve(args: argparse.Namespace, config: NormaliserConfig, stop: StopSignal) -> int:
    publisher = Publisher(args.bus, keys=args.keys, client_key=args.client_key,
                          heartbeat=args.heartbeat or HEARTBEAT_S)
    writer = None
    raw_writer = None
    reconnects = 0
    totals = {"total_samples": 0, "reconnects": 0}
    last: dict[str, object] = {}
    in_force: dict[str, object] = {}  # the calibration and pressure shaping of this connection

    def status(state: str, driver: PenDriver | None = None, **extra: object) -> None:
        nonlocal last
        rec: dict[str, object] = {"kind": "driver", "state": state, "device_spec": args.device,
                               **totals, **in_force, **extra}
        if driver is not None:
            rec.update(driver.status())
        if publisher.endpoint.is_tcp and publisher.endpoint.bind:
            rec["curve_rejected"] = publisher.curve_rejected  # clients with a key not authorised
        last = rec
        publisher.publish_status(rec)

    try:
        if args.wait_subscribers:
            _wait_for_subscribers(publisher, args.wait_subscribers, stop)
            if stop.is_set():  # stopped before anyone listened: the device is never read
                status("stopped")
                return 0
        try:
            source = open_device(args.device, name=args.name, send_init=not args.no_init)
        except TransportError as exc:
            if not args.wait:
                status("failed", error=str(exc))
                raise
            waited = _wait_for_device(args, stop, status)
            if waited is None:  # stopped while waiting, or a finite source ended meanwhile
                return 0
            source = waited
        t_offset = 0.0
        while not stop.is_set():
            attach_bus = getattr(source, "attach_bus", None)
            if attach_bus is not None:  # a haptic device: forces from haptic.<device>
                attach_bus(args.haptic_bus or args.bus, keys=args.keys,
                           client_key=args.client_key)
            ident = source.describe()
            calibration = choose_calibration(args.calibration, int(ident.get("vid") or 0),
                                             int(ident.get("pid") or 0))
            norm_config, pressure = settle_pressure(calibration, config)
            if args.jsonl and writer is None:  # the header names the curve in force
                writer = SessionLogWriter(args.jsonl, SessionHeader(
                    extra={"source": args.device, "pressure": pressure.record()}))
            if args.raw_jsonl and raw_writer is None:
                raw_writer = SessionLogWriter(args.raw_jsonl, SessionHeader(
                    extra={"source": args.device, "calibrated": False,
                           "pressure": pressure.before_transform().record()}))
            # After a reconnection the session time goes on from where it was.
            driver = PenDriver(source, norm_config, live=True, t_offset=t_offset,
                               transform=calibration.transform,
                               on_device_sample=raw_writer.write if raw_writer else None)
            in_force.update(calibration=calibration.description, pressure=pressure.record())
            status("running", driver)
            next_status = time.monotonic() + args.status_interval
            gone = False
            try:
                while not stop.is_set():
                    for sample in driver.poll(0.02):
                        publisher.publish_pen(sample)
                        if writer is not None:
                            writer.write(sample)
                        totals["total_samples"] += 1
                    publisher.tick()  # alive, even while the pen is away
                    if time.monotonic() >= next_status:
                        status("running", driver)
                        next_status = time.monotonic() + args.status_interval
            except EndOfStream:
                _flush(driver, publisher, writer, totals)
                status("done", driver)
                break
            except DeviceGone as exc:
                _flush(driver, publisher, writer, totals)
                status("gone", driver, error=str(exc))
                sys.stderr.write(f"station driver: {exc}\n")
                gone = True
            finally:
                source.close()
                t_offset = driver.normaliser.last_t + 0.001
            if stop.is_set():
                status("stopped", driver)
                break
            if not gone or args.no_reconnect or (
                    args.max_reconnects is not None and reconnects >= args.max_reconnects):
                break
            again = _wait_for_device(args, stop, status, identity=driver.source.describe())
            if again is None:
                break
            source = again
            reconnects += 1
            totals["reconnects"] = reconnects
    finally:
        for w in (writer, raw_writer):
            if w is not None:
                w.close()
        publisher.close()
    keys = ("state", "total_samples", "reports", "bad_reports", "skipped_reports", "reconnects",
            *(("curve_rejected",) if "curve_rejected" in last else ()))
    sys.stderr.write("station driver: " + json.dumps({k: last.get(k) for k in keys}) + "\n")
    return 0


def _wait_for_subscribers(publisher: Publisher, count: int, stop: StopSignal) -> None:
    """Up to :data:`SUBSCRIBER_WAIT_S` for ``count`` subscriptions, in short slices so a
    SIGTERM/SIGINT meanwhile ends the wait at once (a supervisor stopping a run must not
    wait out a driver that nobody has subscribed to yet)."""
    deadline = time.monotonic() + SUBSCRIBER_WAIT_S
    while not stop.is_set() and time.monotonic() < deadline:
        if publisher.wait_for_subscribers(count, timeout=0.1) or publisher.refusals:
            return


def _flush(driver: PenDriver, publisher: Publisher, writer: SessionLogWriter | None,
           totals: dict[str, int]) -> None:
    for sample in driver.normaliser.flush():
        publisher.publish_pen(sample)
        if writer is not None:
            writer.write(sample)
        totals["total_samples"] += 1


def _replugged_spec(spec: str, identity: SourceInfo | None) -> str:
    """An evdev device that came back on another ``eventN``: the SPEC of its new node."""
    if identity is None or not spec.startswith("evdev:"):
        return spec
    target, sep, query = spec[len("evdev:"):].partition("?")
    if os.path.exists(target):
        return spec
    try:
        found = find_evdev_node(identity["product"], identity["vid"], identity["pid"])
    except Exception:  # python-evdev missing or /dev/input unreadable: keep trying the path
        return spec
    return f"evdev:{found}{sep}{query}" if found else spec


def _wait_for_device(args: argparse.Namespace, stop: StopSignal,
                     status: Callable[..., None],
                     identity: SourceInfo | None = None) -> PenSource | None:
    """Try to reopen the device every 0.5 s until it is back (or we are stopped, or it has
    ended: a finite source that reports EndOfStream; None then).

    An evdev device is also looked for by name and ids, as a replug may give it
    another event node."""
    next_note = 0.0
    while not stop.is_set():
        try:
            return open_device(_replugged_spec(args.device, identity),
                               name=args.name, send_init=not args.no_init)
        except EndOfStream as exc:
            # A finite script that ended while we were away will never come back: waiting
            # for it (EndOfStream is a TransportError too) would hang the driver for good.
            status("done", error=str(exc))
            return None
        except TransportError as exc:
            if time.monotonic() >= next_note:
                status("waiting", error=str(exc))
                next_note = time.monotonic() + 5.0
        stop.wait(0.5)
    return None
