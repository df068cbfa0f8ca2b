"""``station tablet-test --device SPEC``: watch what a pen sends, raw and normalised.

A window (glfw + Dear ImGui, as the kiosk) with the pen's trail (pressure as
width), the raw report's fields beside the normalised sample, and the pressure
curve with the live point and the tip threshold, editable, with "save to my device
settings"; or, with ``--terminal`` (or without a display), one line per raw sample:
its fields, then the normalised sample.  Any SPEC: evdev, hidraw, hidapi, usb (a
UC-Logic tablet), a mock, or a trace played in real time (``trace:FILE?speed=1``).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from station.calibrate.tablettest import TabletTester, TesterSettings
from station.drivers.pipeline import open_device
from station.drivers.transport.base import DeviceGone
from station.errors import BadInput


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "tablet-test", help="watch a pen live: raw fields, normalised sample, pressure curve",
        description="Watch what a pen sends as it moves: the raw report's fields beside the "
                    "normalised sample, the trail with pressure as width, the pressure curve "
                    "with the live point and the tip threshold (editable), and save them to "
                    "your device settings (the tablet's calibration file). A window, or "
                    "--terminal for one line per raw sample.",
        epilog="examples:\n"
               "  station tablet-test --device evdev:/dev/input/event7\n"
               "  station tablet-test --device 'mock:intuos-pro-m?script=spiral&speed=1'\n"
               "  station tablet-test --device trace:pen.hid?speed=1 --terminal\n"
               "  station tablet-test --device hidapi:256c:006d --pressure-curve "
               "0.3,0,0.7,1 --save",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--device", required=True, metavar="SPEC",
                   help="the pen (docs/drivers.md): evdev:, hidraw:, hidapi:, usb:, mock:, "
                        "trace:FILE?speed=1, auto:pen")
    p.add_argument("--terminal", action="store_true",
                   help="no window: one line per raw sample on stdout")
    p.add_argument("--pressure-curve", metavar="X1,Y1,X2,Y2",
                   help="the Bezier curve to try (default linear 0,0,1,1)")
    p.add_argument("--tip-threshold", type=float, default=0.0, metavar="F",
                   help="normalised pressure below which the pen does not paint (default 0: "
                        "the device's own contact)")
    p.add_argument("--duration", type=float, metavar="S", help="stop after S seconds")
    p.add_argument("--save", action="store_true",
                   help="--terminal: save the curve and threshold to your device settings "
                        "at the end")
    p.add_argument("--screenshot", metavar="PNG",
                   help="window: save the last frame (when the source ends or --duration)")
    p.add_argument("--linger", type=float, default=3600.0, metavar="S",
                   help="window: stay open this long after a mock or trace has ended")
    p.set_defaults(func=run)


def _curve(text: str | None) -> tuple[float, float, float, float]:
    if text is None:
        return (0.0, 0.0, 1.0, 1.0)
    try:
        vals = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise BadInput(f"{text!r}: needs four numbers x1,y1,x2,y2", "--pressure-curve") from None
    if len(vals) != 4:
        raise BadInput(f"{text!r}: needs four numbers x1,y1,x2,y2", "--pressure-curve")
    return (vals[0], vals[1], vals[2], vals[3])


def run(args: argparse.Namespace) -> int:
    settings = TesterSettings(_curve(args.pressure_curve), args.tip_threshold)
    if args.duration is not None and not args.duration > 0:
        raise BadInput("must be > 0 seconds", "--duration")
    terminal = args.terminal or not (os.environ.get("DISPLAY") or
                                     os.environ.get("WAYLAND_DISPLAY"))
    if terminal and not args.terminal:
        sys.stderr.write("station tablet-test: no display: terminal mode\n")
    source = open_device(args.device, name="tablet-test")
    tester = TabletTester(source, settings)
    try:
        if not terminal:
            # the window's modules (glfw, imgui) load only for the window: --terminal and
            # machines without them still work
            from station.calibrate.tablettest_window import TesterWindow

            TesterWindow(tester).run(args.duration, args.linger,
                                     Path(args.screenshot) if args.screenshot else None)
        else:
            d = source.describe()
            sys.stdout.write(f"# {d.get('product', '')} ({d.get('usb_id', '')}, "
                             f"{d.get('parser', '')}): raw fields | normalised sample\n")
            start = time.monotonic()
            try:
                while args.duration is None or time.monotonic() - start < args.duration:
                    for raw, samples in tester.poll(0.05):
                        sys.stdout.write(tester.line(raw, samples) + "\n")
                    sys.stdout.flush()
            except DeviceGone:
                pass  # a mock or trace that ended, or the tablet unplugged: say what we saw
            except KeyboardInterrupt:
                pass
            sys.stderr.write(f"station tablet-test: {tester.raw_count} raw samples, "
                             f"{tester.sample_count} normalised\n")
        if args.save:
            sys.stderr.write(f"station tablet-test: saved to {tester.save()}\n")
    finally:
        source.close()
    return 0
