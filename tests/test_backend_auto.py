"""One meaning of ``auto`` (issue 8 item 8): one function decides it, every entry point
goes through it, and ``station bench sim`` measures every backend available."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import station.backends.factory as backend_mod
from station.cli import main
from station.sim.paint import make_backend, paint
from station.sim.script import Script


def _gl_works() -> bool:
    try:
        backend_mod._gl_renderer()
    except Exception:
        return False
    return True


def test_available_backends_are_the_ones_that_run_here() -> None:
    names = backend_mod.available_backends()
    assert names[0] == "numpy"
    assert ("cpu" in names) == backend_mod.numba_available()
    assert ("gl" in names) == _gl_works()
    assert backend_mod.resolve_auto()[0] in names


@pytest.mark.parametrize("pick", ["numpy", "cpu"])
def test_every_auto_goes_through_resolve_auto(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                                              pick: str) -> None:
    if pick == "cpu" and not backend_mod.numba_available():
        pytest.skip("numba is not installed")
    monkeypatch.setattr(backend_mod, "resolve_auto", lambda: (pick, "test"))
    cls = {"numpy": "NumpyCanvas", "cpu": "CpuCanvas"}[pick]
    assert type(backend_mod.create_backend("auto", 16, 12)).__name__ == cls
    canvas, name = make_backend("auto", 16, 12, "watercolor", 0)
    assert name == pick and type(canvas).__name__ == cls
    s = Script(24, 16, seed=1)
    s.brush(size=4, water=0.6, pigment={"Burnt Umber": 0.5})
    s.line((0.2, 0.5), (0.8, 0.5), 0.1, pressure=0.8)
    log = tmp_path / "s.jsonl"
    log.write_text(s.text(), encoding="utf-8")
    assert paint(str(log), None, backend="auto", progress=False).backend == pick


def test_bench_sim_measures_every_available_backend_by_default(
        capsys: pytest.CaptureFixture[str]) -> None:
    auto = backend_mod.resolve_auto()[0]  # measured (or cached) first: the bench only reads it
    rc = main(["bench", "sim", "--sizes", "24x16", "--seconds", "0.01", "--scenarios",
               "stroke"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    measured = [r["backend"] for r in out["results"] if "error" not in r]
    assert measured == backend_mod.available_backends()
    assert out["auto"] == auto and out["auto"] in measured
