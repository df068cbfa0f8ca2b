"""The distributed canvas under ``mpiexec -n 2`` and ``-n 4`` (oversubscribed is fine).

Every MPI run paints a tiny canvas (96 x 128 cells, 16-cell tiles: strip borders at
rows 32/64/96) and is compared with one process, bitwise, field by field, tiles and
their time-to-live and the float64 books included.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import mpi_session as ms
import numpy as np
import pytest

from station.backends.cpu import CpuCanvas
from station.backends.distributed import boxes, decomp
from station.backends.numpy_canvas import NumpyCanvas
from station.bus import Publisher
from station.canvas import reference, tiles
from station.canvas.profiles import get_profile
from station.canvas.state import CanvasState
from station.events import Command, PenSample
from station.sessionlog import read_session
from station.sim.script import Script

pytest.importorskip("mpi4py")
BIN = Path(sys.executable).parent
MPIEXEC = shutil.which("mpiexec", path=str(BIN)) or shutil.which("mpiexec")
pytestmark = pytest.mark.skipif(MPIEXEC is None, reason="no mpiexec (pip install mpich)")
DRIVER = Path(__file__).with_name("mpi_session.py")
FIELDS = ("vx", "vy", "w", "wc", "h", "mask", "block", "block_time", "p", "q", "r_composed",
          "evaporated", "removed_w", "removed_p", "tile_ttl")
META = ("slots", "step_count", "sim_time", "water_added", "evaporated_folded",
        "pigment_added", "pigment_removed_past", "pigment_dried", "layers", "profile")


def mpirun(n: int, args: list[str], timeout: float = 90.0,
           env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    assert MPIEXEC is not None
    return subprocess.run([MPIEXEC, "-n", str(n), *args], capture_output=True, text=True,
                          timeout=timeout, env={**os.environ, **(env or {})})


def run_session(tmp_path: Path, n: int, base: str, script: str,
                timeout: float = 90.0) -> Path:
    out = tmp_path / f"{script}-{n}-{base}.npz"
    res = mpirun(n, [sys.executable, str(DRIVER), str(out), base, script], timeout)
    assert res.returncode == 0, res.stdout + res.stderr
    return out


def single(script: str, tmp_path: Path, cls: type = NumpyCanvas) -> NumpyCanvas:
    cv = cls(ms.WIDTH, ms.HEIGHT, seed=3, params=ms.PARAMS)
    ms.play(cv, ms.SESSIONS[script], str(tmp_path))
    return cv


def assert_same_state(a: CanvasState, b: CanvasState) -> None:
    for name in FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        assert x.shape == y.shape and x.dtype == y.dtype, name
        bad = np.argwhere(x != y)
        assert bad.size == 0, f"{name}: {len(bad)} cells differ, first {bad[:3].tolist()}"
    for name in META:
        assert getattr(a, name) == getattr(b, name), name


@pytest.mark.parametrize("n", [2, 4])
def test_session_across_borders_dry_layer_saveload_is_bitwise_one_process(
        tmp_path: Path, n: int) -> None:
    out = run_session(tmp_path, n, "numpy", "full")
    one = single("full", tmp_path)
    assert_same_state(one.state(), CanvasState.load(out))
    rgb = np.load(str(out) + ".rgb.npy")
    assert np.array_equal(rgb, one.render())  # changed tiles gathered = the whole picture
    stats = json.loads(Path(str(out) + ".stats.json").read_text())
    ref = one.stats()
    for k in ("water", "pigments", "steps", "sim_seconds", "layers", "dried_layers"):
        assert stats[k] == ref[k], k
    # the session painted several pigments over two layers, and something is still wet
    assert len(ref["dried_layers"]) == 1 and ref["water"]["fluid"] > 0


@pytest.mark.parametrize("n", [2, 4])
def test_a_stroke_across_every_border(tmp_path: Path, n: int) -> None:
    out = run_session(tmp_path, n, "numpy", "stroke")
    one = single("stroke", tmp_path).state()
    got = CanvasState.load(out)
    assert_same_state(one, got)
    # the stroke really spans the strips: pigment on both sides of every border
    ink = (got.p[0] + got.q[0]).sum(axis=1)
    for border in (32, 64, 96):
        assert ink[border - 8:border].sum() > 0.5 and ink[border:border + 8].sum() > 0.5


def test_rebalancing_in_the_middle_of_a_wet_stroke_changes_nothing(tmp_path: Path) -> None:
    out = run_session(tmp_path, 4, "numpy", "wet-rebalance")
    assert_same_state(single("stroke", tmp_path).state(), CanvasState.load(out))


@pytest.mark.parametrize("n", [2, 4])
def test_overlapped_halo_schedule_equals_blocking_and_one_process(tmp_path: Path,
                                                                  n: int) -> None:
    # overlapped: border bands stepped on copies after the exchange, the interior
    # while the halo travels; blocking: every box waits for its halo first
    one = single("stroke", tmp_path).state()
    scheds = {}
    for name in ("stroke", "stroke:blocking", "stroke:auto"):
        out = run_session(tmp_path, n, "numpy", name)
        assert_same_state(one, CanvasState.load(out))
        scheds[name] = json.loads(Path(str(out) + ".sched.json").read_text())
    # both schedules really ran: bands only when overlapped (a box owning fewer than
    # 2 radius rows next to a border still waits), every box waits when blocking
    assert scheds["stroke"]["bands"] >= 10
    assert scheds["stroke"]["late"] < scheds["stroke"]["bands"] / 4
    assert scheds["stroke:blocking"]["bands"] == 0 and scheds["stroke:blocking"]["late"] >= 10
    # auto: all ranks share this machine, so nothing is worth the bands' extra work
    assert scheds["stroke:auto"] == scheds["stroke:blocking"]


TCP_ENV = {"MPIR_CVAR_NOLOCAL": "1", "MPIR_CVAR_CH4_NETMOD": "ofi", "FI_PROVIDER": "tcp",
           "MPIR_CVAR_DEBUG_SUMMARY": "1"}
"""MPICH over libfabric's tcp provider with shared memory off: the cross-machine path."""


def test_two_hosts_over_tcp_overlap_across_the_host_border(tmp_path: Path) -> None:
    # hydra's fork launcher, two "hosts" (localhost and 127.0.0.1, two ranks each) and
    # TCP sockets between every pair of ranks: the cluster set-up of docs/distributed.md
    # minus ssh. auto overlaps only the border between ranks 1 and 2 (other hosts).
    assert MPIEXEC is not None
    out = tmp_path / "tcp.npz"
    res = subprocess.run([MPIEXEC, "-launcher", "fork", "-hosts", "localhost:2,127.0.0.1:2",
                          "-n", "4", sys.executable, str(DRIVER), str(out), "numpy",
                          "stroke:auto"], capture_output=True, text=True, timeout=120,
                         env={**os.environ, **TCP_ENV})
    assert res.returncode == 0, res.stdout + res.stderr
    assert "libfabric provider: tcp" in res.stdout + res.stderr  # MPICH's own summary
    assert_same_state(single("stroke", tmp_path).state(), CanvasState.load(out))
    sched = json.loads(Path(str(out) + ".sched.json").read_text())
    assert sched["bands"] >= 5 and sched["late"] >= 5


def test_ink_on_fibred_paper_is_bitwise_one_process(tmp_path: Path) -> None:
    # each strip holds its rows of the whole sheet's fibres (not a strip-sized sheet's),
    # and they travel with the rows when the bounds move
    out = run_session(tmp_path, 4, "numpy", "wet-rebalance-ink")
    one = NumpyCanvas(ms.WIDTH, ms.HEIGHT, "ink", seed=3, params=ms.INK_PARAMS)
    ms.play(one, ms.SESSIONS["stroke"], str(tmp_path))
    got = CanvasState.load(out)
    assert_same_state(one.state(), got)
    assert got.fibre.any() and np.array_equal(got.fibre, one.state().fibre)


def test_cpu_base_is_bitwise_the_cpu_backend(tmp_path: Path) -> None:
    # numba compiles per process (cached on disk after the first run): longer timeout
    out = run_session(tmp_path, 2, "cpu", "stroke", timeout=280.0)
    assert_same_state(single("stroke", tmp_path, CpuCanvas).state(), CanvasState.load(out))


def test_a_rank_that_dies_aborts_the_job(tmp_path: Path) -> None:
    out = tmp_path / "dead.npz"
    t0 = time.monotonic()
    res = mpirun(4, [sys.executable, str(DRIVER), str(out), "numpy", "stroke",
                     json.dumps({"rank": 2, "step": 5})], timeout=60.0)
    assert time.monotonic() - t0 < 60.0
    assert res.returncode != 0
    text = res.stdout + res.stderr
    assert "BAD TERMINATION" in text and "signal 9" in text, text
    assert not out.exists()  # nothing half-gathered was written


def test_an_exception_on_one_rank_aborts_the_job_instead_of_hanging(tmp_path: Path) -> None:
    out = tmp_path / "bug.npz"
    res = mpirun(2, [sys.executable, str(DRIVER), str(out), "numpy", "stroke",
                     json.dumps({"rank": 1, "step": -4})], timeout=60.0)
    assert res.returncode != 0
    assert "rank 1 failed (RuntimeError: a bug on one rank only); aborting the MPI job" \
        in res.stderr, res.stderr
    assert not out.exists()


def test_paint_cli_distributed_equals_one_process(tmp_path: Path) -> None:
    s = Script(96, 128, seed=5, rate_hz=60.0)
    s.brush(size=14, water=0.9, pigment={"French Ultramarine": 0.8})
    s.line((0.2, 0.1), (0.6, 0.9), 0.5, pressure=0.8)  # down across every border
    s.dry()
    s.brush(size=10, water=0.8, pigment={"Hansa Yellow": 0.7})
    s.curve([(0.1, 0.4), (0.5, 0.55), (0.9, 0.45)], 0.4, pressure=0.7)
    s.new_layer()
    s.brush(size=12, water=0.9, pigment={"Burnt Umber": 0.5})
    s.line((0.8, 0.2), (0.3, 0.7), 0.4, pressure=0.9)
    s.wait(0.3)
    log = tmp_path / "s.jsonl"
    s.save(log)
    before = log.read_bytes()
    station = str(BIN / "station")
    outs = {}
    for tag, cmd in (("one", [station]), ("mpi", [MPIEXEC, "-n", "2", station])):
        png, st = tmp_path / f"{tag}.png", tmp_path / f"{tag}.npz"
        args = [*cmd, "paint", str(log), "-o", str(png), "--state", str(st), "--backend",
                "numpy", "--json"] + (["--distributed"] if tag == "mpi" else [])
        res = subprocess.run(args, capture_output=True, text=True, timeout=120)
        assert res.returncode == 0, res.stderr
        summary = json.loads(res.stdout)  # one summary: only rank 0 prints
        outs[tag] = (png.read_bytes(), CanvasState.load(st), summary)
    assert outs["one"][0] == outs["mpi"][0]
    assert_same_state(outs["one"][1], outs["mpi"][1])
    assert outs["mpi"][2]["backend"] == "distributed-numpy"
    assert log.read_bytes() == before


# -- the split, without MPI ---------------------------------------------------------------
def test_balanced_split_follows_the_painted_corner() -> None:
    ts, height, width = 32, 2048, 2048
    corner = [(slice(0, 385), slice(0, 385))]  # a 12 x 12 tile box in the top-left corner
    work = decomp.row_work(corner, height, width, ts)
    even = decomp.even_split(height, ts, 2)
    bal = decomp.balanced_split(work, height, ts, 2)
    assert even == [0, 1024, 2048]
    assert decomp.imbalance(work, even, ts) > 1.8  # one rank does almost everything
    assert bal[1] < 385 and decomp.imbalance(work, bal, ts) < 1.2
    assert all(b % ts == 0 for b in bal)
    four = decomp.balanced_split(work, height, ts, 4)
    assert len(four) == 5 and four == sorted(four) and len(set(four)) == 5


def test_fast_boxes_are_the_tiles_boxes() -> None:
    # the replicated per-step box finding is scipy's labelling, the same boxes as tiles'
    st = NumpyCanvas(1024, 768, params=ms.PARAMS).state()
    rng = np.random.default_rng(5)
    for _ in range(150):
        density = rng.choice([0.005, 0.03, 0.1, 0.3, 0.6])
        st.tile_ttl[...] = (rng.random(st.tile_ttl.shape) < density) * rng.integers(
            1, 4, st.tile_ttl.shape)
        assert boxes.active_regions(st) == tiles.active_regions(st)
    st.tile_ttl[...] = 0
    assert boxes.active_regions(st) == []
    st.tile_ttl[2:5, 40:48] = 1
    st.tile_ttl[30:32, 0:2] = 1
    assert boxes.active_regions(st) == [(slice(30, 82), slice(638, 770)),
                                        (slice(478, 514), slice(0, 34))]


# -- station sim --distributed: rank 0 on the bus, the others follow ----------------------
def _sim(tmp_path: Path, marker: str) -> tuple[subprocess.Popen[str], Publisher, Path, Path]:
    bus = f"ipc://{tmp_path}/bus"
    log, state = tmp_path / "live.jsonl", tmp_path / "live.npz"
    pub = Publisher(bus, bind=True)
    assert MPIEXEC is not None
    proc = subprocess.Popen(
        [MPIEXEC, "-n", "2", sys.executable, "-m", "station", "sim", "--distributed",
         "--bus", bus, "--size", "64x96", "--backend", "numpy", "--log", str(log),
         "--state", str(state), "--status", "none", "--rate", "30"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "STATION_TEST_MARKER": marker})
    assert pub.wait_for_subscribers(1, timeout=60.0), "rank 0 never subscribed"
    return proc, pub, log, state


def _stroke(pub: Publisher, n: int) -> None:
    pub.publish_cmd(Command(t=0.0, cmd="brush", args={
        "size": 12, "water": 1.0, "pigment": {"Burnt Umber": 1.0}}))
    for i in range(n):  # down across the strip border at row 64
        pub.publish_pen(PenSample(t=i * 0.02, device="p", tool="pen",  # type: ignore[arg-type]
                                  x=0.3 + 0.01 * i, y=0.4 + 0.4 * i / n, pressure=0.9,
                                  touching=True))
        time.sleep(0.02)


def test_sim_distributed_paints_what_its_log_replays(tmp_path: Path) -> None:
    proc, pub, log, state = _sim(tmp_path, "sim-ok")
    try:
        _stroke(pub, 30)
        time.sleep(0.3)
        pub.publish_cmd(Command(t=0.0, cmd="stop", args={}))
        _out, err = proc.communicate(timeout=60)
        assert proc.returncode == 0, err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        pub.close()
    replay = tmp_path / "replay.npz"
    res = subprocess.run([str(BIN / "station"), "paint", str(log), "-o", str(tmp_path / "r.png"),
                          "--backend", "numpy", "--state", str(replay)],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    live = CanvasState.load(state)
    assert live.step_count > 10 and float((live.p + live.q).sum()) > 1.0
    assert_same_state(CanvasState.load(replay), live)


def _rank_pid(marker: str, rank: int) -> int | None:
    for d in Path("/proc").iterdir():
        try:
            env = (d / "environ").read_bytes().split(b"\0")
        except OSError:
            continue
        if (f"STATION_TEST_MARKER={marker}".encode() in env
                and f"PMI_RANK={rank}".encode() in env):
            return int(d.name)
    return None


def test_sim_distributed_rank_death_aborts_and_keeps_the_log(tmp_path: Path) -> None:
    marker = f"sim-death-{os.getpid()}"
    proc, pub, log, _state = _sim(tmp_path, marker)
    try:
        _stroke(pub, 20)
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and log.read_text().count('"pen"') < 20:
            time.sleep(0.1)
        pid = _rank_pid(marker, 1)
        assert pid is not None
        os.kill(pid, signal.SIGKILL)
        t0 = time.monotonic()
        out, err = proc.communicate(timeout=60)
        assert time.monotonic() - t0 < 60
        assert proc.returncode != 0
        text = out + err  # mpiexec names the rank that died and how
        assert "BAD TERMINATION" in text and "signal 9" in text, text
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        pub.close()
    header, records = read_session(log)  # whole lines only: it parses
    assert (header.width, header.height) == (64, 96)
    assert sum(isinstance(r, PenSample) for r in records) == 20


def test_render_gathers_only_the_changed_tiles(tmp_path: Path) -> None:
    out = tmp_path / "delta.npz"
    res = mpirun(4, [sys.executable, str(DRIVER), str(out), "numpy", "render-delta"])
    assert res.returncode == 0, res.stdout + res.stderr
    one = NumpyCanvas(ms.WIDTH, ms.HEIGHT, seed=3, params=ms.PARAMS)
    first_ops, second_ops = ms.delta_ops()
    ms.play(one, first_ops, str(tmp_path))
    assert np.array_equal(np.load(str(out) + ".first.npy"), one.render())
    ms.play(one, second_ops, str(tmp_path))
    assert np.array_equal(np.load(str(out) + ".second.npy"), one.render())
    sent = json.loads(Path(str(out) + ".sent.json").read_text())
    assert sent[0] == ms.WIDTH * ms.HEIGHT  # the first picture: everything
    # the dab's tiles (and their neighbours reached by the step's boxes) only
    assert 0 < sent[1] <= 3 * 16 * 3 * 16


# -- station bench distributed ------------------------------------------------------------
def test_bench_reports_both_schedules_per_rank(tmp_path: Path) -> None:
    res = subprocess.run([str(BIN / "station"), "bench", "distributed", "--quick",
                          "--scenarios", "wash", "--schedules", "overlap,blocking"],
                         capture_output=True, text=True, timeout=240)
    assert res.returncode == 0, res.stderr
    runs = {(r["ranks"], r["schedule"]): r for r in json.loads(res.stdout)["runs"]}
    assert set(runs) == {(n, k) for n in (1, 2) for k in ("overlap", "blocking")}
    for (n, _k), r in runs.items():
        assert len(r["comm_share_per_rank"]) == n and len(r["halo_wait_share_per_rank"]) == n
        assert r["speedup"] > 0 and r["steps"] >= 3 and r["cpu_speedup"] > 0
    # two ranks move halos; only the overlapped schedule steps interiors meanwhile
    assert runs[(2, "overlap")]["halo_bytes_per_step"] > 0
    assert min(runs[(2, "overlap")]["overlapped_work_share_per_rank"]) > 0
    assert max(runs[(2, "blocking")]["overlapped_work_share_per_rank"]) == 0
    # the overlapped wash simulates the border bands too: 2 x 2 radius rows more
    extra = sum(runs[(2, "overlap")]["cells_per_rank_step"]) - sum(
        runs[(2, "blocking")]["cells_per_rank_step"])
    radius = reference.stencil_radius(get_profile("watercolor").params)  # 10: 1 + 6 + 3 (the blur)
    assert extra == 2 * 2 * radius * 512
    bad = subprocess.run([str(BIN / "station"), "bench", "distributed", "--schedules", "fast"],
                         capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and "--schedules" in bad.stderr
