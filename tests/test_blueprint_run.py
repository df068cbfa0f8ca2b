"""``station run`` with real processes and mock devices: the bundled blueprints paint,
record and mix two pens; a component killed with SIGKILL is restarted and the painting
continues (the recovered sim's picture is the one its whole log paints); rules fire."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import needs_pty
from livesim import log_records
from xvfb_server import xvfb

import station as station_pkg

SMALL = ["--set", "sim.backend=numpy", "--set", "sim.width=64", "--set", "sim.height=48",
         "--set", "sim.rate=40"]


def _sim_help() -> str:
    return subprocess.run([sys.executable, "-m", "station", "sim", "--help"],
                          capture_output=True, text=True, timeout=60).stdout


needs_live_sim = pytest.mark.skipif(
    "--recover" not in _sim_help(),
    reason="station sim has no --recover/--cmd yet (the faults branch is not merged)")


def station(*args: str, cwd: Path, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "station", *args], cwd=cwd, text=True,
                          capture_output=True, timeout=timeout)


def start(*args: str, cwd: Path) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "station", *args], cwd=cwd, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def state(run: Path) -> dict[str, Any]:
    try:
        return dict(json.loads((run / "supervisor.json").read_text()))
    except (OSError, ValueError):
        return {}


def wait_for(pred: Any, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if pred():
            return True
        time.sleep(0.1)
    return False


def records(log: Path) -> list[dict[str, Any]]:
    return log_records(log)  # a line still being written is not a record yet


def pens(log: Path) -> list[dict[str, Any]]:
    return [r for r in records(log) if r["type"] == "pen"]


def device_pens(log: Path) -> list[dict[str, Any]]:
    """The pen samples a device sent (each has its publisher's ``seq``), not the pen-ups
    the sim logs itself when a device falls silent mid-stroke (no ``seq``): a source
    stalled for 3 heartbeats on a loaded machine gets one, and it is no sample of the
    device's (counting it made 2001 logged for 2000 sent)."""
    got = pens(log)
    synthetic = [r for r in got if "seq" not in r]
    assert all(not r["touching"] and not r["proximity"] for r in synthetic), synthetic
    return [r for r in got if "seq" in r]


def pixels(png: Path) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(png), dtype=np.int32)


def painted(png: Path) -> int:
    """Cells noticeably darker than the paper (the brightest level in the picture)."""
    px = pixels(png)[..., :3].sum(axis=2)
    return int((px < np.percentile(px, 99) - 24).sum())


def paint(log: Path, out: Path) -> None:
    proc = station("paint", str(log), "-o", str(out), "--backend", "numpy", cwd=out.parent)
    assert proc.returncode == 0, proc.stderr


def driver_total(run: Path, ident: str) -> int:
    line = [ln for ln in (run / "logs" / f"{ident}.log").read_text().splitlines()
            if ln.startswith("station driver: {")][-1]
    return int(json.loads(line.split(": ", 1)[1])["total_samples"])


@needs_live_sim
def test_headless_demo_paints(tmp_path: Path) -> None:
    run = tmp_path / "r"
    proc = station("run", "headless-demo", "--once", "--run-dir", str(run), *SMALL,
                   "--set", "pen.device=mock:intuos-pro-m?script=line", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "--once: the sources are done" in proc.stderr
    png = tmp_path / "painting.png"
    assert f"station run: sim: picture: {png.resolve()}" in proc.stderr
    assert pixels(png).shape[:2] == (48, 64)
    assert painted(png) > 40  # the stroke is there
    log = Path(state(run)["components"]["sim"]["log"])
    assert len(device_pens(log)) == driver_total(run, "pen") > 100  # every sample painted
    paint(log, tmp_path / "replay.png")
    assert np.array_equal(pixels(png), pixels(tmp_path / "replay.png"))
    assert (tmp_path / "painting.npz").exists()
    st = state(run)["components"]
    assert st["pen"]["state"] == "finished" and st["sim"]["state"] == "stopped"
    assert st["sim"]["exit"] == 0 and st["sim"]["restarts"] == 0


def test_record_only_records_every_sample(tmp_path: Path) -> None:
    run = tmp_path / "r"
    proc = station("run", "record-only", "--once", "--run-dir", str(run),
                   "--set", "pen.device=mock:intuos-pro-m?script=arc", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    out = tmp_path / "recording.jsonl"
    header = json.loads(out.read_text().splitlines()[0])
    assert header["format"] == "station-session"
    got = pens(out)
    assert len(got) == driver_total(run, "pen") > 100
    assert {r["device"] for r in got} == {"pen"}
    assert any(r["touching"] for r in got)
    ts = [r["t"] for r in got]
    assert ts == sorted(ts)


@needs_live_sim
def test_two_tablets_paint_one_canvas(tmp_path: Path) -> None:
    run = tmp_path / "r"
    proc = station("run", "two-tablets", "--once", "--run-dir", str(run), *SMALL, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    log = Path(state(run)["components"]["sim"]["log"])
    samples = device_pens(log)
    by_device = {d: sum(1 for r in samples if r["device"] == d) for d in ("left", "right")}
    assert by_device == {"left": driver_total(run, "left"), "right": driver_total(run, "right")}
    assert min(by_device.values()) > 100
    png = tmp_path / "two-tablets.png"
    assert painted(png) > 80
    paint(log, tmp_path / "replay.png")
    assert np.array_equal(pixels(png), pixels(tmp_path / "replay.png"))


def _stop(proc: subprocess.Popen[str], timeout: float = 60) -> tuple[int, str]:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
    try:
        _out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        _out, err = proc.communicate()
    return proc.returncode, err


@needs_live_sim
def test_sigkill_restarts_and_the_painting_continues(tmp_path: Path) -> None:
    """kill -9 the sim mid-painting, then the driver: both come back (logged, with
    back-off); the sim recovers its painting from autosave + log, so the picture it
    ends with is what its whole log paints uninterrupted (`station paint`), and the log
    before the crash is kept as it was."""
    run = tmp_path / "r"
    sup = start("run", "headless-demo", "--run-dir", str(run), *SMALL,
                "--set", "sim.autosave=300ms",
                "--set", "pen.device=mock:intuos-pro-m?script=spiral&repeat=0&reports=150",
                cwd=tmp_path)
    try:
        assert wait_for(lambda: state(run).get("components", {}).get("pen", {}).get("pid"), 60)
        log = Path(state(run)["components"]["sim"]["log"])
        assert wait_for(lambda: log.exists() and len(pens(log)) > 200, 60)
        autosave = log.with_name(log.stem + ".autosave.npz")
        assert wait_for(autosave.exists, 20)
        sim_pid = state(run)["components"]["sim"]["pid"]
        os.kill(sim_pid, signal.SIGKILL)
        before = records(log)
        assert wait_for(lambda: state(run)["components"]["sim"]["restarts"] == 1
                        and state(run)["components"]["sim"]["pid"] not in (None, sim_pid), 30)
        assert wait_for(lambda: len(pens(log)) > len(before) + 150, 60)  # painting goes on
        pen_pid = state(run)["components"]["pen"]["pid"]
        os.kill(pen_pid, signal.SIGKILL)
        assert wait_for(lambda: state(run)["components"]["pen"]["restarts"] == 1
                        and state(run)["components"]["pen"]["pid"] not in (None, pen_pid), 30)
        n = len(pens(log))
        assert wait_for(lambda: len(pens(log)) > n + 100, 60)
    finally:
        code, err = _stop(sup)
    assert code == 0, err
    assert "sim died (signal 9 (SIGKILL))" in err and "restart 1 in 0.5 s" in err
    assert "sim started" in err and "(recovering its painting)" in err
    assert "pen died (signal 9 (SIGKILL))" in err
    # Stopped in reverse start order: the pen before the sim.
    assert err.index("pen stopped") < err.index("sim stopped")
    after = records(log)
    assert after[: len(before)] == before  # continued, never rewritten
    png = tmp_path / "painting.png"
    paint(log, tmp_path / "replay.png")
    assert np.array_equal(pixels(png), pixels(tmp_path / "replay.png"))
    assert painted(png) > 100


@needs_live_sim
def test_idle_rule_saves_to_gallery_and_clears(tmp_path: Path) -> None:
    bp = tmp_path / "idle.xml"
    bp.write_text("""<?xml version="1.0"?>
<station name="idle" version="1">
  <driver id="pen" device="mock:intuos-pro-m?script=line" calibration="none"/>
  <gallery id="gallery" dir="gallery"/>
  <sim id="sim" width="64" height="48" backend="numpy" rate="40" png="end.png">
    <requires interface="pen" from="pen"/>
  </sim>
  <on event="idle" after="1s"><save-to-gallery/><clear/></on>
</station>
""")
    run = tmp_path / "r"
    sup = start("run", str(bp), "--run-dir", str(run), cwd=tmp_path)
    try:
        assert wait_for(lambda: state(run).get("saved_to_gallery"), 60)
        time.sleep(1.0)  # the clear reaches the sim
    finally:
        code, err = _stop(sup)
    assert code == 0, err
    assert "rule on idle (line 8)" in err and "save-to-gallery, clear" in err
    saved = [Path(p) for p in state(run)["saved_to_gallery"]]
    assert len(saved) == 1 and saved[0].parent == tmp_path / "gallery"
    assert painted(saved[0]) > 40  # the stroke went to the gallery
    assert painted(tmp_path / "end.png") == 0  # and the canvas was cleared
    log = Path(state(run)["components"]["sim"]["log"])
    assert [r["cmd"] for r in records(log) if r["type"] == "cmd"].count("clear") == 1


def _have_kiosk() -> bool:
    return "kiosk" in subprocess.run([sys.executable, "-m", "station", "--help"],
                                     capture_output=True, text=True, timeout=60).stdout


UNPLUG_TEXT = "The pen has been unplugged: please ask the staff."


def _kiosk_unplug_line() -> int:
    """Where the bundled kiosk blueprint has its device-unplugged rule."""
    text = (Path(station_pkg.__file__).parent / "data" / "blueprints" / "kiosk.xml").read_text()
    return 1 + next(i for i, ln in enumerate(text.splitlines())
                    if '<on event="device-unplugged"' in ln)


def _unplugged(run: Path) -> bool:
    """The unplug message is up and the tablet has exited (a driver stopped on its way out,
    its handlers gone, would die of the SIGTERM and the run count it failed)."""
    st = state(run)
    tablet = st.get("components", {}).get("tablet", {})
    return UNPLUG_TEXT in st.get("messages", []) and tablet.get("state") == "finished"


@pytest.mark.skipif(shutil.which("Xvfb") is None, reason="no Xvfb here")
@pytest.mark.skipif(not _have_kiosk(), reason="station kiosk is not merged here")
def test_kiosk_blueprint_under_xvfb(tmp_path: Path) -> None:
    """The bundled kiosk blueprint with its tablet swapped for a mock (a spiral from the
    middle of the tablet, which the window maps right of the panel): the pen stream
    reaches the window through the bus proxy and paints (the part of the spiral that
    leaves the letterboxed canvas is not painted), the unplug rule puts its message on the
    panel, and the kiosk stops cleanly under the supervisor, saving the painting.

    No fixed window: the run goes on until the mock tablet has played its script and
    exited and the unplug rule has fired (the kiosk heard the whole stroke, then the
    tablet fell silent: only a kiosk that took the pen's samples reports it silent),
    however long a loaded machine takes to get there, then the test
    stops it the way an operator does, with SIGTERM to ``station run``."""
    run = tmp_path / "r"
    err_path = tmp_path / "run.err"
    with xvfb() as display, open(err_path, "w") as err_file:
        # stderr to a file, not a pipe: nobody reads a pipe while the test polls
        sup = subprocess.Popen(
            [sys.executable, "-m", "station", "run", "kiosk", "--run-dir", str(run),
             "--set", "tablet.vid=", "--set", "tablet.pid=", "--set", "tablet.calibration=none",
             "--set", "tablet.device=mock:intuos-pro-m?script=spiral",
             "--set", "kiosk.windowed=800x600", "--set", "kiosk.width=64",
             "--set", "kiosk.height=48", "--set", "kiosk.backend=numpy",
             "--set", "kiosk.serve=none"],
            cwd=tmp_path, env={**os.environ, "DISPLAY": display}, text=True,
            stdout=subprocess.DEVNULL, stderr=err_file)
        try:
            unplugged = wait_for(lambda: sup.poll() is not None or _unplugged(run), 120)
            running = sup.poll() is None
        finally:
            if sup.poll() is None:
                sup.send_signal(signal.SIGTERM)
            try:
                sup.wait(timeout=90)
            except subprocess.TimeoutExpired:
                sup.kill()
                sup.wait()
    stderr = err_path.read_text()
    assert unplugged and running, stderr[-3000:]
    assert sup.returncode == 0, stderr[-3000:]
    st = state(run)["components"]
    assert st["kiosk"]["exit"] == 0 and st["kiosk"]["restarts"] == 0
    assert st["tablet"]["state"] == "finished", st  # the mock played its whole script
    assert "kiosk: 3 components up" in stderr
    final = json.loads(stderr.split("station kiosk: stopped ", 1)[1].splitlines()[0])
    assert final["samples"] > 50, stderr[-3000:]  # the pen reached the window
    # and painted: the spiral's samples over the canvas made brush stamps, and the
    # painting the stop saved to the gallery shows them
    assert final["stamps"] > 50, stderr[-3000:]
    line = _kiosk_unplug_line()
    assert f"rule on device-unplugged (line {line}), device tablet: show-message" in stderr
    assert "'message' is unknown" not in stderr  # the kiosk took it
    (pid,) = final["saved"]
    meta = json.loads((tmp_path / "gallery" / pid / "meta.json").read_text())
    assert meta["reason"] == "stopped" and meta["stamps"] == final["stamps"]
    assert painted(tmp_path / "gallery" / pid / "painting.png") > 500  # 2021 of 3072 cells here


@needs_pty
def test_trace_and_haptic_device_through_the_bus(tmp_path: Path) -> None:
    """A <replay> of a recorded trace and a <haptic> mock device on one canvas."""
    rec = station("record", "--device", "mock:intuos-pro-m?script=arc&speed=max",
                  "-o", "arc.hid", cwd=tmp_path)
    assert rec.returncode == 0, rec.stderr
    (tmp_path / "bp.xml").write_text("""<station name="rep" version="1">
  <replay id="trace" trace="arc.hid" speed="max"/>
  <haptic id="hand" device="serial-mock:?script=stroke"/>
  <bus id="hub"><requires interface="pen" from="trace"/><requires interface="pen" from="hand"/>
  </bus>
  <sim id="sim" width="64" height="48" backend="numpy" png="out.png">
    <requires interface="pen" from="hub"/></sim>
</station>
""")
    run = tmp_path / "r"
    proc = station("run", "bp.xml", "--once", "--run-dir", str(run), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    log = Path(state(run)["components"]["sim"]["log"])
    counts = {d: sum(1 for r in device_pens(log) if r["device"] == d) for d in ("trace", "hand")}
    replayed = int(proc.stderr.split("reports -> ")[1].split(" samples")[0])
    assert counts == {"trace": replayed, "hand": driver_total(run, "hand")}
    assert min(counts.values()) > 100
    assert painted(tmp_path / "out.png") > 40


def test_a_crashing_component_backs_off_exponentially(tmp_path: Path) -> None:
    """A driver whose device is not there exits 1 each time: restarted after 0.1, 0.2,
    0.4 … s, each restart logged."""
    (tmp_path / "bp.xml").write_text("""<station name="crash" version="1">
  <driver id="pen" device="hidraw:/dev/hidraw-not-here" restart-delay="100ms"/>
  <recorder id="rec" output="rec.jsonl"><requires interface="pen" from="pen"/></recorder>
</station>
""")
    run = tmp_path / "r"
    sup = start("run", "bp.xml", "--run-dir", str(run), cwd=tmp_path)
    try:
        assert wait_for(lambda: state(run).get("components", {}).get("pen", {})
                        .get("restarts", 0) >= 3, 90)
    finally:
        code, err = _stop(sup)
    assert code in (0, 1), err  # 1 when the stop caught the driver before its handlers
    delays = [float(ln.rsplit(" in ", 1)[1].split()[0]) for ln in err.splitlines()
              if ln.startswith("station run: pen died (exit 1)")]
    assert delays[:3] == [0.1, 0.2, 0.4], err


def test_run_refuses_a_broken_blueprint_before_starting(tmp_path: Path) -> None:
    (tmp_path / "bp.xml").write_text("""<station name="broken" version="1">
  <driver id="pen" device="mock:intuos-pro-m"/>
  <driver id="pen" device="mock:cintiq-22hd"/>
</station>
""")
    run = tmp_path / "r"
    proc = station("run", "bp.xml", "--run-dir", str(run), cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        "station run: bp.xml:3: <driver id=\"pen\">: duplicate id 'pen' "
        "(first at line 2)"]
    assert not run.exists()  # nothing started, nothing made
