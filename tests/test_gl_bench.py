"""``station bench sim``: the JSON shape and honest figures on tiny canvases (not timed)."""

from __future__ import annotations

import json

import pytest

from station.bench import sim
from station.canvas.profiles import get_profile
from station.cli import main
from station.errors import BadInput


def _needs_gl() -> None:
    """Skip without the GL backend or an OpenGL 4.3 context (the bench's GL rows need one)."""
    gl = pytest.importorskip("station.backends.gl")
    try:
        gl.create_context().release()
    except gl.GLUnavailable as exc:
        pytest.skip(f"no OpenGL 4.3 context: {exc}")


def test_bench_sim_json_shape(capsys) -> None:
    _needs_gl()
    rc = main(["bench", "sim", "--json", "--sizes", "64x48", "--seconds", "0.05",
               "--backends", "gl,numpy"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["renderer"] and out["memory_bandwidth_gb_s"] > 0
    got = {(r["backend"], r["scenario"]) for r in out["results"]}
    assert got == {("gl", "wash"), ("gl", "stroke"), ("numpy", "wash"), ("numpy", "stroke")}
    for r in out["results"]:
        assert r["size"] == "64x48"
        assert r["steps_per_s"] > 0 and r["bytes_per_cell_step"] > 0
        assert r["cell_steps_per_s"] == pytest.approx(r["steps_per_s"] * r["active_cells"],
                                                      rel=1e-3)
        if r["scenario"] == "wash":
            assert r["active_cells"] == 64 * 48  # the whole canvas every step
        else:
            assert 0 < r["active_cells"] <= 64 * 48
        traffic = r["cell_steps_per_s"] * r["bytes_per_cell_step"] / 1e9
        # each backend against its own device's copy bandwidth (GL: the GL device's)
        assert r["bandwidth_fraction"] == pytest.approx(traffic / r["bandwidth_gb_s"],
                                                        rel=1e-2)


def test_bad_bench_arguments_are_bad_input() -> None:
    with pytest.raises(BadInput):
        sim.parse_size("800by600")
    with pytest.raises(BadInput):
        sim.parse_size("2x2")
    assert sim.parse_size("800x600") == (800, 600)
    assert main(["bench", "sim", "--backends", "cuda", "--seconds", "0.01"]) == 2


def test_bench_sim_gl_passes_profile_and_bound(capsys) -> None:
    """``--passes``: where a GL step's time goes, per program, with each program's own
    bytes (the traffic model's) and the step's distance from its bound (issue 26 item 4)."""
    _needs_gl()
    from station.backends.gl.traffic import floats_per_program, front_mode

    rc = main(["bench", "sim", "--json", "--sizes", "64x48", "--seconds", "0.05",
               "--backends", "gl", "--scenarios", "wash", "--passes"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    (r,) = out["results"]
    prof = r["passes"]
    assert prof["steps"] == sim.PROFILE_STEPS and prof["active_cells"] == 64 * 48
    programs = prof["programs"]
    # watercolor: the wet-area memory, a 17-tap flow-outward blur (blur_x, then down the
    # columns in the first Jacobi iteration) and the standing gate's front factor over
    # dry paper (front.comp, blur_x's second blur)
    front = front_mode(*get_profile("watercolor").params.standing_front())
    # and the damp exposure's pass (shelter.comp) after blur_x
    model = floats_per_program(4, 1, wet_memory=True, front=front, shelter=True)
    assert set(programs) == set(model) and "blur_x" in programs and "pressure" not in model
    assert front == 1 and "front" in programs
    assert sum(4 * model[k] for k in model) == r["bytes_per_cell_step"]
    assert sum(p["share"] for p in programs.values()) == pytest.approx(1.0, abs=1e-3)
    for name, p in programs.items():
        assert p["ms"] > 0 and p["bytes_per_cell"] == 4 * model[name]
        assert p["gb_s"] == pytest.approx(p["bytes_per_cell"] * 64 * 48 / (p["ms"] * 1e6),
                                          rel=1e-2)
    # the profiled step is no faster than its passes
    assert prof["step_ms"] >= 0.99 * sum(p["ms"] for p in programs.values())
    image = out["bandwidth"]["gl_probes_gb_s"]["image"]
    assert r["shader_copy_fraction"] == pytest.approx(r["memory_traffic_gb_s"] / image,
                                                      rel=1e-2)
    assert r["bound_factor"] == pytest.approx(1.0 / r["shader_copy_fraction"], rel=1e-2)
    # by CPU time on a CPU rasterizer: the copy's GB per CPU-second over the step's
    cpu_rate = out["bandwidth"]["gl_probes_gb_s"]["image_cpu"]
    assert r["cpu_seconds"] > 0 and cpu_rate > 0
    if "llvmpipe" in r["renderer"]:
        step_rate = (r["steps"] * r["active_cells"] * r["bytes_per_cell_step"]
                     / r["cpu_seconds"] / 1e9)
        assert r["bound_factor_cpu"] == pytest.approx(cpu_rate / step_rate, rel=2e-2)
