"""``auto`` by measurement (issue 26 item 4): a bounded probe, a per-machine cache that
a new version, machine or GL renderer invalidates, and a corrupt cache never crashes."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest

import station
import station.bench.sim as bench_sim
from station.backends import choice
from station.backends.factory import available_backends
from station.blueprint import doctor
from station.cli import main
from station.errors import StationError

STEP_S = {"numpy": 0.004, "cpu": 0.001, "gl": 0.002}


class _Fake:
    """A canvas whose step takes a known time."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.sources = 0

    def add_sources(self, **_: Any) -> None:
        self.sources += 1

    def step(self) -> None:
        time.sleep(STEP_S[self.name])


class _Maker:
    def __init__(self, broken: tuple[str, ...] = ()) -> None:
        self.made: list[str] = []
        self.broken = broken

    def __call__(self, name: str, w: int, h: int, *_: Any, **__: Any) -> _Fake:
        self.made.append(name)
        if name in self.broken:
            raise StationError(f"{name} cannot start here")
        return _Fake(name)


@pytest.fixture(autouse=True)
def _short_probe(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(choice, "PROBE_SECONDS", 0.03)


def test_the_fastest_measured_backend_is_chosen_and_cached(tmp_path: Path) -> None:
    path = tmp_path / "c.json"
    make = _Maker()
    c = choice.resolve(["numpy", "cpu", "gl"], "Some GPU", "m1", make, "numpy", path)
    assert c.backend == "cpu" and not c.cached and make.made == ["numpy", "cpu", "gl"]
    figures = c.steps_per_s
    assert figures["cpu"] > figures["gl"] > figures["numpy"] > 0  # type: ignore[operator]
    assert "cpu" in c.why and json.loads(path.read_text())["backend"] == "cpu"
    # the second use reads the cache: no probe at all
    again = choice.resolve(["numpy", "cpu", "gl"], "Some GPU", "m1", _Maker(("numpy", "cpu",
                                                                             "gl")),
                           "numpy", path)
    assert again.cached and again.backend == "cpu" and again.steps_per_s == figures


@pytest.mark.parametrize("change", ["renderer", "machine", "version", "backends"])
def test_a_new_renderer_machine_version_or_backend_set_measures_again(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, change: str) -> None:
    path = tmp_path / "c.json"
    choice.resolve(["numpy", "cpu", "gl"], "GPU A", "m1", _Maker(), "numpy", path)
    renderer, machine, names = "GPU A", "m1", ["numpy", "cpu", "gl"]
    if change == "renderer":
        renderer = "GPU B"
    elif change == "machine":
        machine = "m2"
    elif change == "version":
        monkeypatch.setattr(station, "__version__", "9.9.9")
    else:
        names = ["numpy", "cpu"]
    make = _Maker()
    c = choice.resolve(names, renderer, machine, make, "numpy", path)
    assert not c.cached and make.made == names
    assert json.loads(path.read_text())["renderer"] == renderer


@pytest.mark.parametrize("content", [b"", b"{not json", b"\xff\xfe\x00", b"[1, 2]",
                                     b'{"schema": 1, "backend": "gl", "steps_per_s": {}}',
                                     b'{"schema": 1, "backend": "cpu", "steps_per_s": '
                                     b'{"cpu": "fast"}}',
                                     b'{"schema": 7, "backend": "cpu", "steps_per_s": '
                                     b'{"cpu": 1}}'])
def test_a_corrupt_cache_is_measured_over(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "c.json"
    path.write_bytes(content)
    make = _Maker()
    c = choice.resolve(["numpy", "cpu"], None, "m1", make, "numpy", path)
    assert c.backend == "cpu" and make.made == ["numpy", "cpu"]
    assert choice.load(path) is not None  # rewritten whole


def test_an_unwritable_cache_and_broken_backends_do_not_crash(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    path = blocker / "c.json"  # its directory is a file: cannot be written
    c = choice.resolve(["numpy", "cpu", "gl"], "GPU", "m1", _Maker(("cpu",)), "numpy", path)
    assert c.backend == "gl" and c.steps_per_s["cpu"] is None
    assert "cannot start" in c.errors["cpu"]
    # nothing runs: the fixed rule's pick
    c = choice.resolve(["numpy", "cpu"], None, "m1", _Maker(("numpy", "cpu")), "cpu", path)
    assert c.backend == "cpu" and "fixed rule" in c.why


def test_doctor_shows_the_choice_and_its_figures(monkeypatch: pytest.MonkeyPatch,
                                                 tmp_path: Path) -> None:
    monkeypatch.setenv("STATION_CACHE_DIR", str(tmp_path))
    assert "not measured" in doctor.check_backend(measure=False).detail
    c = choice.measure(["numpy", "cpu"], None, "m1", _Maker(), "numpy")
    assert choice.save(c)
    check = doctor.check_backend(measure=False)
    assert check.status == "ok" and "--backend auto = cpu" in check.detail
    assert f"cpu {c.steps_per_s['cpu']:g}" in check.detail
    assert f"numpy {c.steps_per_s['numpy']:g}" in check.detail
    assert "no GL" in check.detail and "cached" in check.detail


def test_bench_sim_takes_each_backend_s_fraction_of_its_own_device(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    if "gl" not in available_backends():
        pytest.skip("no GL context here")
    monkeypatch.setattr(bench_sim, "memory_bandwidth_gb_s", lambda: 10.0)
    monkeypatch.setattr(bench_sim, "gl_copy_probes", lambda: {"buffer": 1000.0, "image": 250.0})
    rc = main(["bench", "sim", "--sizes", "24x16", "--seconds", "0.01", "--scenarios",
               "wash", "--backends", "numpy,gl"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["bandwidth"] == {"cpu_gb_s": 10.0, "gl_gb_s": 1000.0,
                                "gl_probes_gb_s": {"buffer": 1000.0, "image": 250.0}}
    rows = {r["backend"]: r for r in out["results"]}
    for name, bw in (("numpy", 10.0), ("gl", 1000.0)):
        r = rows[name]
        assert r["bandwidth_gb_s"] == bw
        assert r["bandwidth_fraction"] == pytest.approx(r["memory_traffic_gb_s"] / bw, abs=1e-4)
        assert out["bytes_per_cell_step"][name] == r["bytes_per_cell_step"] > 0
    gl = rows["gl"]
    assert gl["shader_copy_fraction"] == pytest.approx(gl["memory_traffic_gb_s"] / 250.0,
                                                       abs=1e-4)

    def no_gl() -> dict[str, float]:
        raise StationError("no EGL context")

    monkeypatch.setattr(bench_sim, "gl_copy_probes", no_gl)
    main(["bench", "sim", "--sizes", "24x16", "--seconds", "0.01", "--scenarios", "wash",
          "--backends", "gl"])
    out = json.loads(capsys.readouterr().out)
    assert out["bandwidth"]["gl_gb_s"] is None and "no EGL" in out["bandwidth"]["gl_error"]
    assert out["results"][0]["bandwidth_fraction"] is None


def test_the_real_probe_runs_in_a_child_and_a_dead_child_gives_the_fixed_rule(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "c.json"
    c = choice.resolve(["numpy"], None, "m1", None, "cpu", path)  # a real child, numpy only
    assert c.backend == "numpy" and c.steps_per_s["numpy"] > 0  # type: ignore[operator]
    assert choice.load(path) is not None
    monkeypatch.setattr(choice, "_CHILD", "import sys; sys.exit('driver crashed')")
    c = choice.resolve(["numpy", "gl"], "GPU", "m1", None, "gl", path)
    assert c.backend == "gl" and "driver crashed" in c.why and "fixed rule" in c.why
    assert c.steps_per_s == {"numpy": None, "gl": None} and "probe" in c.errors
    again = choice.resolve(["numpy", "gl"], "GPU", "m1", _Maker(), "gl", path)
    assert again.backend == "gl" and not again.pending and "probe" not in again.errors


def test_the_gl_copy_probes_measure_both_ways() -> None:
    """Both probes run on the real GL device and move bytes at a positive rate; the
    device's bound is the better of them."""
    if "gl" not in available_backends():
        pytest.skip("no GL context here")
    probes = bench_sim.gl_copy_probes(nbytes=8 << 20, repeats=2)
    assert set(probes) == {"buffer", "image", "image_cpu"} and min(probes.values()) > 0.01


_SLOW_CHILD = """
import json, sys, time
names = json.loads(sys.argv[1])["candidates"]
print(json.dumps({"start": names[0]}), flush=True)
print(json.dumps({"name": names[0], "steps_per_s": 12.5, "error": ""}), flush=True)
print(json.dumps({"start": names[1]}), flush=True)
time.sleep(120)  # the cpu backend compiling on a busy machine
"""


def test_a_probe_out_of_time_keeps_what_it_measured_and_measures_the_rest_next_time(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A first probe that runs out of time inside the cpu backend's compile: numpy's
    figure counts, cpu is pending and the fixed rule keeps cpu for now; the cache says
    so, and the next use measures cpu only (gl10's finding: before, the whole probe was
    lost and the next use waited the whole deadline again)."""
    path = tmp_path / "c.json"
    monkeypatch.setattr(choice, "_CHILD", _SLOW_CHILD)
    monkeypatch.setattr(choice, "CHILD_TIMEOUT_S", 10.0)  # the path under test, not a timing
    c = choice.resolve(["numpy", "cpu", "gl"], "llvmpipe", "m1", None, "cpu", path)
    assert c.backend == "cpu" and c.steps_per_s == {"numpy": 12.5, "cpu": None, "gl": None}
    assert set(c.pending) == {"cpu", "gl"} and "still running after 10 s" in c.pending["cpu"]
    assert "fixed rule" in c.why and "numpy 12.5" in c.why and not c.errors
    kept = choice.load(path)
    assert kept is not None and kept.pending == c.pending
    assert not choice.still_valid(kept, "llvmpipe", "m1", ["numpy", "cpu", "gl"])
    # the next use measures only what is pending, and the merged figures decide
    make = _Maker()
    again = choice.resolve(["numpy", "cpu", "gl"], "llvmpipe", "m1", make, "cpu", path)
    assert make.made == ["cpu", "gl"] and not again.pending
    assert again.steps_per_s["numpy"] == 12.5 and again.backend == "cpu"
    assert "measured: cpu" in again.why
    third = choice.resolve(["numpy", "cpu", "gl"], "llvmpipe", "m1", _Maker(("numpy", "cpu",
                                                                            "gl")), "cpu", path)
    assert third.cached and third.steps_per_s == again.steps_per_s


def test_a_child_that_dies_measuring_one_backend_fails_it_and_keeps_the_others() -> None:
    out = "\n".join(json.dumps(m) for m in (
        {"start": "numpy"}, {"name": "numpy", "steps_per_s": 4.0, "error": ""},
        {"start": "gl"}))
    figures, errors, pending = choice.read_child(["numpy", "gl", "cpu"], out + "\nnoise\n[1]",
                                                 died="Segmentation fault")
    assert figures == {"numpy": 4.0, "gl": None} and "Segmentation fault" in errors["gl"]
    assert list(pending) == ["cpu"]
    c = choice.decide(figures, errors, "cpu", "GPU", "m1", pending)
    assert c.backend == "cpu" and "fixed rule" in c.why  # cpu pending: the rule's pick stands
    c = choice.decide(figures, errors, "gl", "GPU", "m1", pending)
    assert c.backend == "numpy" and "not measured yet: cpu" in c.why
    # a figure that is not a positive finite number is not a measurement
    bad = json.dumps({"name": "numpy", "steps_per_s": float("nan"), "error": ""})
    assert choice.read_child(["numpy"], bad, died="x")[2] == {"numpy": "not reached: x"}
