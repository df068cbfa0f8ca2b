"""The interactive ``station calibrate --device`` window under Xvfb, driven by mock devices.

Starts ``Xvfb -displayfd`` (installed by ``make test``; see xvfb_server), runs the
command in a subprocess against a simulated installer with a known distortion,
a misclick and screen-tablet parallax, then checks the written calibration
file against the distortion and the screenshot for the drawn targets.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from station.calibration.files import read_file
from station.calibration.geometry import project
from station.calibration.session import CalibrationSession, target_grid
from xvfb_server import xvfb

from station.calibrate.sources import MockUserSource
from station.events import PenSample, Tool

SCREEN = (1024, 768)
DISTORTION = "rot=2,scale=1.04:0.97,offset=0.01:-0.015,persp=0.01:0.005"
GREEN = np.array([26, 217, 51])
RED = np.array([242, 38, 26])
BACKGROUND = np.array([20, 20, 26])
# Generous deadlines, not windows: a session ends as soon as its mock user is done (a
# few seconds); on a loaded machine its frames come slowly and it must not give up.
SESSION_S = "240"  # calibrate --timeout: the window gives up after this
COMMAND_S = 300  # the test gives up on the command after this


@pytest.fixture(scope="module")
def display() -> Iterator[str]:
    with xvfb() as name:
        yield name


def calibrate(display: str, *argv: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "DISPLAY": display}
    return subprocess.run([sys.executable, "-m", "station", "calibrate", *argv,
                           "--result-seconds", "0"], env=env,
                          capture_output=True, text=True, timeout=COMMAND_S)


def test_interactive_with_mock_user_recovers_the_distortion(display: str, tmp_path: Path) -> None:
    out, shot = tmp_path / "cal.json", tmp_path / "shot.png"
    spec = (f"mock-user:{DISTORTION},misclick=6,noise=0.0005,parallax=0.004:-0.003,seed=1,"
            "tiltbias=3:-2,light=0.08,hard=0.7")
    proc = calibrate(display, "--device", spec, "--points", "9", "--tilt-pass",
                     "--pressure-pass", "-o", str(out), "--screenshot", str(shot),
                     "--timeout", SESSION_S)
    assert proc.returncode == 0, proc.stderr + proc.stdout
    assert "REJECTED (misclick" in proc.stdout  # rejected on the spot …
    assert proc.stdout.count("target 6/22: ok") == 1  # … and the target asked again
    cal = read_file(out)
    truth = MockUserSource(DISTORTION).truth()
    probe = np.random.default_rng(0).uniform(0.1, 0.9, (300, 2))
    err = np.abs(project(cal.matrix, probe) - project(truth, probe)).max()
    assert err < 0.0015  # ≈ 1.5 px on 1024 px: within the tap noise (0.5 px sigma)
    assert cal.fit.parallax == pytest.approx((0.004, -0.003), abs=0.0008)
    # the upright press measured the tilt bias; light and hard presses the pressure range
    assert (cal.tilt.offset_x, cal.tilt.offset_y) == pytest.approx((3.0, -2.0), abs=1e-9)
    assert cal.pressure.threshold == pytest.approx(0.04, abs=0.005)  # half the light press
    assert cal.pressure.maximum == pytest.approx(0.7 * (1 + 0.08 * 1.28), abs=0.04)  # p90
    assert cal.area.output_pixels == SCREEN

    from PIL import Image

    img = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    assert img.shape == (SCREEN[1], SCREEN[0], 3)
    for x, y in target_grid(9):  # a green dot on every target
        px = img[int(round(y * SCREEN[1])) - 4:int(round(y * SCREEN[1])) + 5,
                 int(round(x * SCREEN[0])) - 4:int(round(x * SCREEN[0])) + 5]
        assert (np.abs(px - GREEN).sum(axis=2) < 30).mean() > 0.5, (x, y)
    assert (np.abs(img - RED).sum(axis=2) < 30).sum() > 20  # the rejected misclick's cross
    # the rest is background (the words' panel top left aside)
    rest = img.copy()
    rest[110:300, :1000] = BACKGROUND
    assert (np.abs(rest - BACKGROUND).sum(axis=2) < 6).mean() > 0.95


def test_interactive_with_recorded_taps(display: str, tmp_path: Path) -> None:
    # taps of a 5-point calibration under a known affine map, as a mock-taps file
    truth = np.array([[0.95, 0.03, 0.02], [-0.02, 1.03, -0.01], [0, 0, 1.0]])
    dev = project(np.linalg.inv(truth), np.array(target_grid(5)))
    taps = tmp_path / "taps.csv"
    taps.write_text("device_x,device_y\n" + "".join(f"{float(x)!r},{float(y)!r}\n" for x, y in dev))
    out = tmp_path / "cal.json"
    proc = calibrate(display, "--device", f"mock-taps:{taps}", "--points", "5",
                     "--model", "affine", "-o", str(out), "--timeout", SESSION_S)
    assert proc.returncode == 0, proc.stderr + proc.stdout
    cal = read_file(out)
    assert np.allclose(cal.matrix, truth, atol=1e-9)
    # too few taps for the targets: a clear failure, not a hang
    short = tmp_path / "short.csv"
    short.write_text("device_x,device_y\n0.1,0.1\n0.9,0.1\n")
    proc = calibrate(display, "--device", f"mock-taps:{short}", "--points", "5", "-o",
                     str(tmp_path / "x.json"), "--timeout", SESSION_S)
    assert proc.returncode == 2 and "ran out of taps at target 3/5" in proc.stderr


# -- the session logic without a window -------------------------------------------------------


def feed_tap(session: CalibrationSession, x: float, y: float, t0: float) -> object:
    result = None
    for k in range(12):
        s = PenSample(t=t0 + 0.005 * k, device="m", tool=Tool.PEN, x=x, y=y, pressure=0.5,
                      touching=True)
        session.feed(s)
    result = session.feed(PenSample(t=t0 + 0.07, device="m", tool=Tool.PEN, x=x, y=y))
    return result


def test_session_detects_swapped_axes_and_rejects_misaligned_taps() -> None:
    session = CalibrationSession(screen=SCREEN, points=4, model="affine")
    # device axes swapped: screen x follows device y
    swap = [(y, x) for x, y in target_grid(4)]
    r1 = feed_tap(session, *swap[0], 0.0)
    r2 = feed_tap(session, *swap[1], 1.0)
    assert r1.accepted and r2.accepted  # type: ignore[attr-defined]
    assert session.swapped_axes is True
    # target 3 shares its screen column with target 2, so the tap must share target 2's
    # device *y* (axes swapped): 0.1 off in device y is ~77 px off the column
    bad = feed_tap(session, swap[2][0], swap[2][1] - 0.1, 2.0)
    assert not bad.accepted and "misclick" in bad.reason  # type: ignore[attr-defined]
    assert session.current == 2
    good = feed_tap(session, *swap[2], 3.0)
    assert good.accepted  # type: ignore[attr-defined]
    feed_tap(session, *swap[3], 4.0)
    assert session.done
    rep = session.fit()
    assert np.allclose(rep.mapping.matrix, [[0, 1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-9)


# -- a real device path: a recorded Cintiq trace through the drivers' pipeline --------------


def cintiq_tap_trace(path: Path, truth: np.ndarray, targets: list[tuple[float, float]]) -> None:
    """A hid-recorder trace of a Cintiq 22HD (Intuos protocol) tapping each target once."""
    synth = pytest.importorskip("station.drivers.synth")
    dev = project(np.linalg.inv(truth), np.array(targets))
    events: list[tuple[float, bytes]] = []
    t = 0.0
    for x, y in dev:
        ux, uy = int(round(x * 95840)), int(round(y * 54260))
        events.append((t, synth.intuos_prox_in(0x802, 0x1234)))
        t += 0.008
        for k in range(16):  # 3 hover, 10 contact, 3 hover reports at 128 Hz
            pressure = 900 if 3 <= k < 13 else 0
            events.append((t, synth.intuos_pen(ux, uy, pressure, 10, -5, distance=0)))
            t += 0.008
        events.append((t, synth.intuos_prox_out()))
        t += 0.3
    dev_info = synth.synth_devices()["cintiq-22hd"]
    rec = synth.RecordedDevice(dev_info.name, dev_info.vid, dev_info.pid, dev_info.descriptor,
                               events)
    synth.write_hid_recorder([rec], path)


def test_interactive_through_the_drivers_pipeline(display: str, tmp_path: Path) -> None:
    pytest.importorskip("station.drivers.pipeline")
    truth = np.array([[1.02, -0.01, -0.012], [0.015, 0.97, 0.02], [0, 0, 1.0]])
    trace = tmp_path / "taps.hid"
    cintiq_tap_trace(trace, truth, target_grid(9))
    out = tmp_path / "cal.json"
    proc = calibrate(display, "--device", f"trace:{trace}", "--points", "9", "--model",
                     "affine", "-o", str(out), "--timeout", SESSION_S)
    assert proc.returncode == 0, proc.stderr + proc.stdout
    cal = read_file(out)
    assert (cal.device.vid, cal.device.pid) == (0x056A, 0x00FA)  # the id from the trace
    assert cal.geometry.x_max == 95840 and cal.geometry.y_max == 54260
    probe = np.random.default_rng(0).uniform(0.1, 0.9, (100, 2))
    # device units are integers: 1/95840 of rounding is all that is lost
    assert np.abs(project(cal.matrix, probe) - project(truth, probe)).max() < 1e-4


def test_from_trace_reads_device_traces(tmp_path: Path) -> None:
    pytest.importorskip("station.drivers.traces")
    truth = np.array([[0.98, 0.02, 0.01], [-0.01, 1.01, -0.005], [0, 0, 1.0]])
    trace = tmp_path / "taps.hid"
    cintiq_tap_trace(trace, truth, target_grid(5))
    targets = tmp_path / "targets.csv"
    targets.write_text("canvas_x,canvas_y\n" + "".join(f"{x},{y}\n" for x, y in target_grid(5)))
    proc = subprocess.run([sys.executable, "-m", "station", "calibrate", "--from-trace",
                           str(trace), "--targets", str(targets), "--json"],
                          capture_output=True, text=True, timeout=COMMAND_S)
    assert proc.returncode == 0, proc.stderr
    rep = json.loads(proc.stdout)
    assert rep["taps"] == 5
    m = np.array(rep["matrix"])
    probe = np.random.default_rng(0).uniform(0.1, 0.9, (100, 2))
    assert np.abs(project(m, probe) - project(truth, probe)).max() < 1e-4


def test_session_asks_again_for_taps_the_final_fit_excludes() -> None:
    truth = np.array([[0.97, 0.02, 0.01], [-0.02, 1.01, 0.0], [0, 0, 1.0]])
    inverse = np.linalg.inv(truth)
    # on-the-spot rejection off (a huge threshold): only the final fit can catch the slip
    session = CalibrationSession(screen=SCREEN, points=9, model="affine", misclick_px=1e6)
    rng = np.random.default_rng(0)
    t = 0.0
    while not session.done:
        xy = np.array([session.targets[session.current]])
        dev = project(inverse, xy)[0] + rng.normal(0, 0.0005, 2)
        if session.current == 4 and not session.rejected:
            dev = dev + np.array([0.06, 0.05])  # the misclick
        feed_tap(session, float(dev[0]), float(dev[1]), t)
        t += 1.0
    assert session.finish() is False  # the centre target is asked again
    assert session.targets[session.current] == (0.5, 0.5) and len(session.targets) == 10
    assert [r.target for r in session.rejected] == [4]
    dev = project(inverse, np.array([[0.5, 0.5]]))[0]
    feed_tap(session, float(dev[0]), float(dev[1]), t)
    assert session.done and session.finish() is True
    assert session.report is not None and session.report.outliers == []
    probe = np.random.default_rng(1).uniform(0.1, 0.9, (50, 2))
    assert np.abs(project(session.report.mapping.matrix, project(inverse, probe)) - probe).max() \
        < 0.0015


def test_the_window_says_what_to_do_and_the_result_in_words(display: str,
                                                            tmp_path: Path) -> None:
    """Issue 24.5: an installer at the kiosk screen sees the instructions, a rejected
    tap's reason and the final residuals on screen, not only in the terminal."""
    from PIL import Image, ImageFont

    from station.calibrate.window import (
        PANEL_ALPHA,
        TEXT_PX,
        WHITE,
        panel_origin,
        render_words,
    )

    out, shot = tmp_path / "cal.json", tmp_path / "shot.png"
    proc = calibrate(display, "--device", f"mock-user:{DISTORTION},misclick=2,seed=3",
                     "--points", "5", "--model", "affine", "-o", str(out), "--screenshot",
                     str(shot), "--timeout", SESSION_S)
    assert proc.returncode == 0, proc.stderr + proc.stdout
    assert "REJECTED (misclick" in proc.stdout
    cal = read_file(out)
    rejected = proc.stdout.count("REJECTED")
    px = max(SCREEN)
    lines = [line for line in proc.stdout.splitlines() if line.startswith("fit: ")]
    excluded = int(lines[0].rsplit("excluded by the fit: ", 1)[1].split(";")[0])
    words = (
        (f"calibration done: affine fit of {cal.fit.points} taps", WHITE),
        (f"residuals: rms {cal.fit.rms * px:.2f} px, max {cal.fit.max * px:.2f} px, "
         f"leave-one-out rms {(cal.fit.loo_rms or 0) * px:.2f} px", None),
        (f"misclicks rejected on the spot: {rejected}, excluded by the fit: {excluded}",
         WHITE),
    )
    img = np.asarray(Image.open(shot).convert("RGB")).astype(float)
    font = ImageFont.load_default(size=TEXT_PX)
    best = None
    for colour in ((0.1, 0.85, 0.2, 1.0), (1.0, 0.85, 0.1, 1.0)):  # a good or a large max
        for last in ("saved; Esc closes this window",
                     "saved; the max residual is large: calibrate again if the pen feels off"):
            want = (*((t, c or colour) for t, c in words), (last, WHITE))
            panel = np.asarray(render_words(want, font, SCREEN[0] - 40)).astype(float)
            h, w = panel.shape[:2]
            a = panel[..., 3:] / 255.0
            expect = panel[..., :3] * a + BACKGROUND * (1 - a)
            x0, y0 = (int(v) for v in panel_origin(SCREEN))
            diff = np.abs(img[y0:y0 + h, x0:x0 + w] - expect).mean()
            best = diff if best is None else min(best, diff)
    assert best is not None and best < 2.0  # the words drawn, pixel for pixel (± blending)
    assert PANEL_ALPHA > 128
