"""``station calibrate``: interactive, scripted and file calibration of a pen device.

Modes (exactly one):

* ``--device SPEC``: the fullscreen calibration window (targets, live cursor,
  residuals, misclick rejection); writes the calibration file.
* ``--fit POINTS.csv``: fit calibration points (interfaces.md); ``--json``
  prints ``{"model", "matrix", "rms", "max", "outliers", …}``.
* ``--from-trace TRACE --targets TARGETS.csv``: find the taps in a recorded
  calibration session, match them to the targets in order, fit.
* ``--export libinput|tslib --calibration FILE``: print a foreign line.
* ``--import libinput|tslib LINEFILE``: turn a foreign line into a calibration file.
* ``--check FILE``: validate a calibration file (exit 2 with the reason if bad).
* ``--edit FILE``: change area, pressure and tilt settings (validated, atomic).

See docs/calibration.md.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from station import boundedio
from station.calibrate.samples import iter_samples
from station.calibrate.window import run_interactive
from station.calibration.area import Area, DeviceGeometry, Rect
from station.calibration.errors import CalibrationError
from station.calibration.export import libinput_line, parse_libinput, parse_tslib, tslib_line
from station.calibration.files import dumps, read_file, write_file
from station.calibration.fit import MIN_TILT_SPREAD, FitReport, PointSet, fit_points
from station.calibration.geometry import scaling
from station.calibration.model import Calibration, DeviceId, FitInfo
from station.calibration.points import read_points
from station.calibration.pressure import PressureSettings, TiltSettings, fit_curve
from station.calibration.taps import detect_taps, match_taps, read_targets
from station.errors import BadInput


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "calibrate",
        help="calibrate a pen device (interactive window, points CSV, trace, file formats)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    mode = p.add_mutually_exclusive_group(required=True)
    mode.add_argument("--device", metavar="SPEC",
                      help="interactive: mock-user:OPTS, mock-taps:FILE.csv or a drivers device")
    mode.add_argument("--fit", metavar="POINTS.csv", help="fit calibration points")
    mode.add_argument("--from-trace", metavar="TRACE", help="fit from a recorded session")
    mode.add_argument("--export", choices=("libinput", "tslib"), help="print a foreign format")
    mode.add_argument("--import", dest="import_", choices=("libinput", "tslib"),
                      metavar="{libinput,tslib}", help="import a foreign line (from --input)")
    mode.add_argument("--check", metavar="FILE", help="validate a calibration file")
    mode.add_argument("--edit", metavar="FILE",
                      help="change area, pressure or tilt settings of a calibration file")
    e = p.add_argument_group("settings for --edit")
    e.add_argument("--area", metavar="CX,CY,W,H[,ROT]",
                   help="active area: centre, size, rotation in degrees ('full': whole tablet)")
    e.add_argument("--area-units", choices=("normalised", "device", "mm"), default="normalised")
    e.add_argument("--left-handed", action=argparse.BooleanOptionalAction, default=None)
    e.add_argument("--lock-aspect", action=argparse.BooleanOptionalAction, default=None)
    e.add_argument("--outside", choices=("clip", "drop"))
    e.add_argument("--output-rect", metavar="X,Y,W,H", help="canvas sub-rectangle, normalised")
    e.add_argument("--pressure-range", metavar="THRESHOLD,MAXIMUM",
                   help="raw pressure fractions for no touch and full pressure")
    e.add_argument("--pressure-curve", metavar="X1,Y1,X2,Y2", help="Bézier control points")
    e.add_argument("--pressure-targets", metavar="IN:OUT,…",
                   help="fit the curve to wanted responses, e.g. 0.25:0.1,0.5:0.35,0.75:0.7")
    e.add_argument("--tilt-offset", metavar="TX,TY", help="degrees subtracted from the tilt")
    p.add_argument("--model", choices=("affine", "homography", "auto"), default=None,
                   help="mapping model (default: affine for --fit, auto interactively)")
    p.add_argument("--parallax", choices=("auto", "on", "off"), default="auto",
                   help="fit screen-tablet parallax (auto: when the tilt varies enough)")
    p.add_argument("--no-robust", action="store_true", help="do not look for misclicks")
    p.add_argument("--noise", type=float, default=None, metavar="SIGMA",
                   help="known tap noise per axis, canvas units: misclicks are taps beyond "
                        "3.7 sigma (otherwise the noise is estimated from the points)")
    p.add_argument("--resolution", metavar="RX[,RY]",
                   help="device units per mm (for residuals in mm)")
    p.add_argument("--device-size", metavar="W,H",
                   help="the device's active size in mm (residuals in mm without --resolution)")
    p.add_argument("--device-max", metavar="XMAX,YMAX",
                   help="device coordinates are device units 0..max (else normalised)")
    p.add_argument("--json", action="store_true", help="machine output")
    p.add_argument("--targets", metavar="TARGETS.csv", help="targets for --from-trace")
    p.add_argument("--calibration", metavar="FILE", help="calibration file for --export")
    p.add_argument("--units", choices=("normalised", "px"), default="normalised",
                   help="--fit: the points' canvas coordinates are canvas-normalised [0, 1] "
                        "(the default; anything outside is refused) or pixels of --canvas")
    p.add_argument("--canvas", metavar="WxH",
                   help="--fit --units px: the canvas (screen) size the pixels are of")
    p.add_argument("--input", metavar="FILE", help="file holding the line for --import")
    p.add_argument("--screen", metavar="WxH", help="screen pixels for tslib")
    p.add_argument("--id", dest="device_id", metavar="VID:PID[:SERIAL]",
                   help="device id for the written calibration file")
    p.add_argument("-o", "--output", metavar="FILE", help="write the calibration file here")
    p.add_argument("--points", type=int, choices=(4, 5, 9), default=9,
                   help="interactive: number of targets")
    p.add_argument("--tilt-pass", action="store_true",
                   help="interactive: a second pass at several tilts (screen tablets)")
    p.add_argument("--pressure-pass", action="store_true",
                   help="interactive: a light and a hard press set the tip threshold and maximum")
    p.add_argument("--misclick-px", type=float, default=15.0,
                   help="interactive: misclick threshold in screen pixels (xinput_calibrator: 15)")
    p.add_argument("--screenshot", metavar="PNG", help="interactive: save the last frame")
    p.add_argument("--result-seconds", type=float, default=8.0, metavar="S",
                   help="interactive: how long the result stays on screen (Esc ends it)")
    p.add_argument("--timeout", type=float, default=120.0,
                   help="interactive: give up after this many seconds")
    p.add_argument("--windowed", action="store_true", help="interactive: not fullscreen")
    p.set_defaults(func=run)


# ---------------------------------------------------------------------------


def _pair(text: str | None, flag: str) -> tuple[float, float] | None:
    if text is None:
        return None
    parts = text.replace("x", ",").split(",")
    try:
        vals = [float(v) for v in parts]
    except ValueError:
        raise BadInput(f"{text!r} is not a number or a pair of numbers", flag) from None
    if len(vals) == 1:
        vals = vals * 2
    if len(vals) != 2 or not all(np.isfinite(vals)) or min(vals) <= 0:
        raise BadInput(f"{text!r} must be one or two positive numbers", flag)
    return (vals[0], vals[1])


def parse_device_id(text: str | None) -> DeviceId | None:
    if text is None:
        return None
    parts = text.split(":", 2)
    if len(parts) < 2:
        raise BadInput(f"{text!r} is not VID:PID[:SERIAL] (hex)", "--id")
    try:
        vid, pid = int(parts[0], 16), int(parts[1], 16)
    except ValueError:
        raise BadInput(f"{text!r}: vid and pid are hexadecimal", "--id") from None
    return DeviceId(vid, pid, parts[2] if len(parts) == 3 and parts[2] else None)


def _parallax_choice(args: argparse.Namespace, points: PointSet) -> bool:
    if args.parallax == "on":
        return True
    if args.parallax == "off" or points.tilt is None:
        return False
    tt = points.tan_tilt
    return bool((np.ptp(tt, axis=0) >= MIN_TILT_SPREAD).all())


def _report_text(rep: FitReport, labels: tuple[str, ...]) -> str:
    lines = [f"model: {rep.model}"]
    m = rep.mapping.matrix
    lines += ["matrix:"] + [f"  {r[0]: .9g} {r[1]: .9g} {r[2]: .9g}" for r in m]
    lines.append(f"rms {rep.rms:.6g}  max {rep.max:.6g}  (canvas units, {len(rep.inliers)} points)")
    if rep.loo_rms is not None:
        lines.append(f"leave-one-out rms {rep.loo_rms:.6g}  max {rep.loo_max:.6g}")
    if rep.residuals_mm is not None:
        mm = np.linalg.norm(rep.residuals_mm[rep.inliers], axis=1)
        lines.append(f"rms {np.sqrt(np.mean(mm**2)):.3f} mm  max {mm.max():.3f} mm on the tablet")
    if rep.mapping.parallax != (0.0, 0.0):
        px, py = rep.mapping.parallax
        extra = ""
        if rep.parallax_mm is not None:
            extra = f" ({rep.parallax_mm[0]:.3f}, {rep.parallax_mm[1]:.3f}) mm"
        lines.append(f"parallax per tan(tilt): ({px:.6g}, {py:.6g}) device units{extra}")
    if rep.outliers:
        lines.append("misclicks (excluded): " + ", ".join(
            f"row {i} ({labels[i]})" if labels else f"row {i}" for i in rep.outliers))
    lines += [f"note: {n}" for n in rep.notes]
    return "\n".join(lines)


def _units_per_mm(args: argparse.Namespace) -> tuple[float, float] | None:
    """Device units per mm of the points' device coordinates, where it can be known."""
    upm = _pair(args.resolution, "--resolution")
    if upm is not None:
        return upm
    size = _pair(args.device_size, "--device-size")
    if size is None:
        return None
    span = _pair(args.device_max, "--device-max") or (1.0, 1.0)  # normalised: 0..1
    return (span[0] / size[0], span[1] / size[1])


def _fit_and_print(args: argparse.Namespace, points: PointSet, extra: dict[str, object]) -> int:
    model = args.model or "affine"
    parallax = _parallax_choice(args, points)
    upm = _units_per_mm(args)
    if args.noise is not None and not args.noise > 0:
        raise BadInput(f"{args.noise} must be a positive number (canvas units)", "--noise")
    rep = fit_points(points, model, parallax, robust=not args.no_robust,
                     units_per_mm=upm, noise=args.noise)
    if args.output:
        _write_fit_file(args, rep, points)
    if args.json:
        out = rep.to_json(points.labels)
        out.update(extra)
        json.dump(out, sys.stdout, indent=2, allow_nan=False)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(_report_text(rep, points.labels) + "\n")
        for k, v in extra.items():
            sys.stdout.write(f"{k}: {v}\n")
    return 0


def _write_fit_file(args: argparse.Namespace, rep: FitReport, points: PointSet) -> None:
    dev = parse_device_id(args.device_id)
    if dev is None:
        raise BadInput("writing a calibration file needs the device id", "--id")
    upm = _units_per_mm(args) if args.device_max else _pair(args.resolution, "--resolution")
    dmax = _pair(args.device_max, "--device-max")
    matrix = rep.mapping.matrix
    parallax = rep.mapping.parallax
    if dmax is not None:
        geometry = DeviceGeometry(0.0, dmax[0], 0.0, dmax[1],
                                  upm[0] if upm else None, upm[1] if upm else None)
        matrix = matrix @ scaling(dmax[0], dmax[1])  # normalised → units, then the fit
        parallax = (parallax[0] / dmax[0], parallax[1] / dmax[1])
    else:
        geometry = DeviceGeometry()
    fit = FitInfo(rep.model, tuple(map(tuple, matrix)), parallax, rep.rms, rep.max,
                  rep.loo_rms, len(rep.inliers))
    write_file(Calibration(dev, geometry, fit), args.output)


def run_fit(args: argparse.Namespace) -> int:
    return _fit_and_print(args, _canvas_normalised(args, read_points(args.fit)), {})


def _canvas_normalised(args: argparse.Namespace, points: PointSet) -> PointSet:
    """The points with canvas coordinates in [0, 1]: pixels of ``--canvas`` divided
    out (``--units px``), else checked (the docs say 0-1; pixels taken silently made
    a libinput matrix with 815.7 in it)."""
    canvas = points.canvas
    if args.units == "px":
        if not args.canvas:
            raise BadInput("--units px needs --canvas WxH (the size the pixels are of)",
                           "--canvas")
        w, h = _pair(args.canvas, "--canvas") or (0.0, 0.0)
        if not (w >= 1 and h >= 1):
            raise BadInput(f"{args.canvas}: width and height must be at least 1 pixel",
                           "--canvas")
        canvas = canvas / np.array([w, h])
    elif args.canvas:
        raise BadInput("--canvas goes with --units px", "--canvas")
    for i, (u, v) in enumerate(canvas):
        for name, value in (("canvas_x", u), ("canvas_y", v)):
            if not 0.0 <= value <= 1.0:
                hint = ("outside the --canvas" if args.units == "px" else
                        "canvas-normalised [0, 1]; pixels? give --units px --canvas WxH")
                raise BadInput(f"{name} {points.canvas[i][0 if name == 'canvas_x' else 1]:g}"
                               f" is outside [0, 1] ({hint})", points.labels[i])
    return PointSet(points.device, canvas, points.tilt, points.labels)


def run_from_trace(args: argparse.Namespace) -> int:
    if not args.targets:
        raise BadInput("--from-trace needs --targets TARGETS.csv", "--targets")
    targets = read_targets(args.targets)
    taps, strokes = detect_taps(iter_samples(args.from_trace))
    points, used = match_taps(taps, targets, args.model or "affine")
    skipped = [i for i in range(len(taps)) if i not in used]
    labels = tuple(f"tap {i} (t={taps[i].t0:.3f}s)" for i in used)

    points = PointSet(points.device, points.canvas, points.tilt, labels)
    extra = {"taps": len(taps), "strokes_skipped": strokes, "taps_unmatched": skipped}
    return _fit_and_print(args, points, extra)


def run_export(args: argparse.Namespace) -> int:
    if not args.calibration:
        raise BadInput("--export needs --calibration FILE", "--calibration")
    cal = read_file(args.calibration)
    if args.export == "libinput":
        sys.stdout.write(libinput_line(cal) + "\n")
        return 0
    screen = _pair(args.screen, "--screen") if args.screen else None
    if screen is None:
        if cal.area.output_pixels is None:
            raise BadInput("tslib needs the screen size in pixels", "--screen")
        screen = (float(cal.area.output_pixels[0]), float(cal.area.output_pixels[1]))
    sys.stdout.write(tslib_line(cal, int(screen[0]), int(screen[1])) + "\n")
    return 0


def run_import(args: argparse.Namespace) -> int:
    if not args.input:
        raise BadInput("--import needs --input FILE (the line to import)", "--input")
    dev = parse_device_id(args.device_id)
    if dev is None:
        raise BadInput("--import needs the device id", "--id")
    try:
        text = boundedio.read_text(args.input, boundedio.CAP_POINTS, "--input")
    except (OSError, UnicodeDecodeError) as exc:
        raise BadInput(f"cannot read ({exc})", args.input) from None
    if args.import_ == "libinput":
        cal = parse_libinput(text, dev, args.input)
    else:
        dmax = _pair(args.device_max, "--device-max")
        if dmax is None:
            raise BadInput("tslib coefficients are in device units: give --device-max",
                           "--device-max")
        screen = _pair(args.screen, "--screen")
        upm = _pair(args.resolution, "--resolution")
        geometry = DeviceGeometry(0.0, dmax[0], 0.0, dmax[1],
                                  upm[0] if upm else None, upm[1] if upm else None)
        cal = parse_tslib(text, dev, geometry, args.input,
                          int(screen[0]) if screen else None,
                          int(screen[1]) if screen else None)
    if args.output:
        write_file(cal, args.output)
    else:
        sys.stdout.write(dumps(cal))
    return 0


def run_check(args: argparse.Namespace) -> int:
    cal = read_file(args.check, parse_device_id(args.device_id))
    f = cal.fit
    sys.stdout.write(
        f"{args.check}: ok: device {cal.device.describe()}, model {f.model}, "
        f"rms {f.rms if f.rms is not None else '-'}, parallax {f.parallax}\n"
    )
    return 0


def _numbers(text: str, n: int | tuple[int, ...], flag: str) -> list[float]:
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        raise BadInput(f"{text!r} must be comma-separated numbers", flag) from None
    counts = (n,) if isinstance(n, int) else n
    if len(vals) not in counts or not all(np.isfinite(vals)):
        raise BadInput(f"{text!r} needs {' or '.join(map(str, counts))} finite numbers", flag)
    return vals


def run_edit(args: argparse.Namespace) -> int:
    cal = read_file(args.edit, parse_device_id(args.device_id))
    area = cal.area
    try:
        if args.area == "full":
            area = area.with_(area=None)
        elif args.area:
            v = _numbers(args.area, (4, 5), "--area")
            area = area.with_(area=Area(v[0], v[1], v[2], v[3], v[4] if len(v) == 5 else 0.0,
                                        args.area_units))
        if args.left_handed is not None:
            area = area.with_(left_handed=args.left_handed)
        if args.outside:
            area = area.with_(outside=args.outside)
        if args.output_rect:
            area = area.with_(output=Rect(*_numbers(args.output_rect, 4, "--output-rect")))
        if args.screen:
            px = _pair(args.screen, "--screen")
            if px is not None:
                area = area.with_(output_pixels=(int(px[0]), int(px[1])))
        if args.lock_aspect is not None:
            area = area.with_(lock_aspect=args.lock_aspect)
        pressure = cal.pressure
        if args.pressure_range:
            thr, top = _numbers(args.pressure_range, 2, "--pressure-range")
            pressure = PressureSettings(thr, top, pressure.curve)
        if args.pressure_curve:
            curve = _numbers(args.pressure_curve, 4, "--pressure-curve")
            pressure = PressureSettings(pressure.threshold, pressure.maximum,
                                        (curve[0], curve[1], curve[2], curve[3]))
        if args.pressure_targets:
            pairs = [pt.split(":") for pt in args.pressure_targets.split(",")]
            if any(len(pt) != 2 for pt in pairs):
                raise BadInput("targets are IN:OUT pairs", "--pressure-targets")
            ins = [float(a) for a, _ in pairs]
            outs = [float(b) for _, b in pairs]
            pressure = PressureSettings(pressure.threshold, pressure.maximum,
                                        fit_curve(ins, outs))
        tilt = cal.tilt
        if args.tilt_offset:
            tx, ty = _numbers(args.tilt_offset, 2, "--tilt-offset")
            tilt = TiltSettings(tx, ty)
        new = cal.with_(area=area, pressure=pressure, tilt=tilt)
        _ = new.matrix  # compose now: a setting that cannot be composed is refused here
    except ValueError as exc:
        raise BadInput(str(exc), args.edit) from None
    except CalibrationError as exc:
        raise BadInput(str(exc), args.edit) from None
    write_file(new, args.output or args.edit)
    sys.stdout.write(f"wrote {args.output or args.edit}\n")
    return 0


def run(args: argparse.Namespace) -> int:
    if args.fit:
        return run_fit(args)
    if args.from_trace:
        return run_from_trace(args)
    if args.export:
        return run_export(args)
    if args.import_:
        return run_import(args)
    if args.check:
        return run_check(args)
    if args.edit:
        return run_edit(args)

    return run_interactive(args)
