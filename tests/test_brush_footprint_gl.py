"""The GL footprint's bristle tags against the numba reference (session 4): the same
cells tagged with the same (lowest) bristle, and a stroke that runs dry with the GL
rasteriser breaks up like the numba-rasterised one."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np
import pytest

from station.brush.deformable import DeformableBrush
from station.brush.footprint import FootprintMaps, rasterise, segments
from station.brush.footprint_gl import GLFootprint
from station.brush.stamp import BrushModel, BrushSettings
from station.canvas.paper import make_paper
from station.canvas.profiles import get_profile
from station.events import PenSample
from station.glkit.context import GLUnavailable

INK = "Sumi Ink"


@pytest.fixture(scope="module")
def gl() -> Iterator[GLFootprint]:
    try:
        g = GLFootprint()
    except GLUnavailable as exc:
        pytest.skip(f"no OpenGL context: {exc}")
    yield g
    g.close()


def bristle_set(rng: np.random.Generator, count: int = 30, joints: int = 5) -> np.ndarray:
    """Random bent bristles (count, joints, 3) in cells, sinking below the plane."""
    pts = np.zeros((count, joints, 3))
    pts[:, 0, :2] = rng.uniform(5.0, 35.0, (count, 2))
    pts[:, 0, 2] = rng.uniform(0.0, 8.0, count)
    for s in range(1, joints):
        pts[:, s] = pts[:, s - 1] + rng.normal(0.0, 1.5, (count, 3)) - [0.0, 0.0, 1.5]
    # the GL path draws float32 ends; give the reference the same ends
    return pts.astype(np.float32).astype(np.float64)


def test_gl_tags_the_same_cells_with_the_same_bristle(gl: GLFootprint) -> None:
    rng = np.random.default_rng(7)
    tagged = wrong = joint_ties = 0
    for _ in range(20):
        pts = bristle_set(rng)
        segs = segments(pts)
        per = pts.shape[1] - 1
        tags = np.repeat(rng.uniform(0.2, 1.0, pts.shape[0]), per)  # one per bristle
        cpu = rasterise(segs, 1.3, tags=tags)
        gpu = gl.rasterise(segs, 1.3, (cpu.y0, cpu.x0, *cpu.cover.shape), tags=tags)
        assert cpu.tag is not None and gpu.tag is not None
        has_c, has_g = ~np.isnan(cpu.tag), ~np.isnan(gpu.tag)
        # tagged exactly where the tubes reach below the clip plane
        assert np.array_equal(has_c, cpu.depth > -1e5)
        both = has_c & has_g
        tagged += int(has_c.sum())
        wrong += int((has_c != has_g).sum() + (cpu.tag[both] != gpu.tag[both]).sum())
        # one tag per segment: the two disagree only at a bristle's own joints, where
        # both of its segments reach the same depth (float32 against float64)
        ids = np.arange(segs.shape[0], dtype=np.float64)
        ci = rasterise(segs, 1.3, tags=ids).tag
        gi = gl.rasterise(segs, 1.3, (cpu.y0, cpu.x0, *cpu.cover.shape), tags=ids).tag
        assert ci is not None and gi is not None
        differ = both & (ci != gi)
        assert np.array_equal(ci[differ] // per, gi[differ] // per)
        assert np.abs(cpu.depth - gpu.depth)[differ].max(initial=0.0) < 1e-5
        joint_ties += int(differ.sum())
    # measured: 0 of 8,220 tagged cells differ per bristle; per segment 5.7 % of the
    # cells are joint ties, all within one bristle
    assert tagged > 5000
    assert wrong <= 0.001 * tagged, (wrong, tagged)
    assert joint_ties < 0.1 * tagged, (joint_ties, tagged)


@pytest.mark.parametrize("kind", ["round3d", "flat"])
def test_the_brush_hands_its_bristle_tags_to_the_gl_rasteriser(gl: GLFootprint,
                                                              kind: str) -> None:
    paper = np.ones((64, 96), np.float32)
    b = DeformableBrush(96, 64, BrushSettings(kind=kind, size=16.0), BrushModel(), paper)
    for k in range(8):
        bristles = b.frame(30.0 + k, 30.0, 0.7 * (k + 1) / 8, tilt_y=-20.0)
    cpu = b.footprint(bristles)
    b.rasterise = gl.rasterise
    gpu = b.footprint(bristles)
    assert cpu.tag is not None and gpu.tag is not None
    has = ~np.isnan(cpu.tag)
    assert has.sum() > 50 and np.array_equal(has, ~np.isnan(gpu.tag))
    assert len(np.unique(cpu.tag[has])) > 3  # several bristles, several retentions
    # measured: 0 of 77 (round3d) and 53 (flat) tagged cells differ
    assert (cpu.tag[has] != gpu.tag[has]).sum() <= 0.002 * has.sum()


def dry_stroke(rasteriser: Callable[..., FootprintMaps] | None) -> np.ndarray:
    """A size-10 round3d stroke, pressed hard with a small load on rough paper, that
    runs dry on its canvas; its pigment (H, W)."""
    size, w, h = 10.0, 240, 48
    paper = make_paper(get_profile("ink").paper, h, w, 3)
    b = DeformableBrush(w, h, BrushSettings(kind="round3d", size=size, water=0.5,
                                            pigment={INK: 0.5}), BrushModel(), paper,
                        rasteriser=rasteriser)
    b.reservoir.capacity *= 0.12
    b.reservoir.load(0.5, {INK: 0.5}, b.model.water_scale, b.model.pigment_scale)
    x0, x1 = 24.0, w - 24.0
    n = int((x1 - x0) / 150.0 * 120.0)
    for i in range(n + 1):
        b.feed(PenSample(t=i / 120, device="d", tool="pen",  # type: ignore[arg-type]
                         x=(x0 + (x1 - x0) * i / n) / w, y=0.5, pressure=0.9, touching=True))
    src = b.take()
    assert src is not None
    return src.full(w, h).dp[INK]


def test_a_stroke_runs_dry_the_same_with_the_gl_rasteriser(gl: GLFootprint) -> None:
    cpu = dry_stroke(None)
    gpu = dry_stroke(gl.rasterise)
    tuft_wide = dry_stroke(lambda segs, radius: gl.rasterise(segs, radius))  # no tags
    level = 0.1 * BrushModel().pigment_scale * 0.5
    painted = cpu > level
    row = int(np.argmax(cpu.sum(axis=1)))

    def along(dp: np.ndarray) -> np.ndarray:
        line = (dp > level)[row - 2:row + 3].mean(axis=0)
        return np.convolve(line, np.ones(20) / 20, mode="valid")

    # it runs dry on its canvas: full near the start, broken up at the end
    assert along(cpu).max() > 0.8 and along(cpu)[-40:].max() < 0.4
    # measured: the same 990 cells painted, pigment within 6e-7 (of 0.079)
    assert (painted != (gpu > level)).sum() <= 0.005 * painted.sum()
    assert np.abs(cpu - gpu).max() <= 1e-4 * cpu.max()
    assert np.abs(along(cpu) - along(gpu)).max() <= 0.02
    # without the tags the tuft dries as one body: 108 cells (11 %) differ, coverage
    # along the stroke by up to 0.11
    assert (painted != (tuft_wide > level)).sum() >= 0.05 * painted.sum()
    assert np.abs(along(cpu) - along(tuft_wide)).max() >= 0.05
