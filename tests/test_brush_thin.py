"""The deformable brush's thin strokes (session 3): a half-loaded tuft of a few cells
draws a continuous line on rough paper, and a 1 kHz pen costs a solve every few samples
while its stroke keeps the pen's path."""

from __future__ import annotations

import json

import numpy as np
import pytest

from station.brush.deformable import DeformableBrush, TuftModel
from station.brush.stamp import BrushModel, BrushSettings
from station.canvas.paper import make_paper
from station.canvas.profiles import get_profile
from station.cli import main
from station.events import PenSample

W, H = 96, 48


def thin_stroke(kind: str, size: float, rate: float, tuft: TuftModel | None = None,
                seed: int = 3) -> tuple[np.ndarray, DeformableBrush]:
    """A steady horizontal stroke, half-loaded ink, on the ink profile's rough paper;
    the pigment it deposits (H, W)."""
    paper = make_paper(get_profile("ink").paper, H, W, seed)
    settings = BrushSettings(kind=kind, size=size, water=0.5, pigment={"Sumi Ink": 0.5})
    b = DeformableBrush(W, H, settings, BrushModel(), paper, tuft=tuft)
    # this is about the contact, not the depletion (a half-loaded 3-cell tuft lays ~30
    # widths before it breaks up): the brush holds enough to stay about half-loaded
    b.reservoir.capacity *= 4
    b.reservoir.load(0.5, {"Sumi Ink": 0.5}, b.model.water_scale, b.model.pigment_scale)
    n = int(rate * 0.25)
    for i in range(n + 1):
        # rotation 0 (a barrel sensor at rest): the flat stays edge-on, a thin line; on
        # a pen without one it would turn broadside to the pull (test_brush_flat_pull)
        b.feed(PenSample(t=i / rate, device="d", tool="pen", x=0.1 + 0.5 * i / n, y=0.5,  # type: ignore[arg-type]
                         pressure=0.5, touching=True, rotation=0.0))
    src = b.take()
    assert src is not None
    return src.full(W, H).dp["Sumi Ink"], b


def centreline(dp: np.ndarray) -> tuple[float, float]:
    """Along the row the stroke deposits most in, away from its ends: the fraction of
    cells with more than a tenth of the mean pigment, and the coefficient of variation."""
    row = dp[int(np.argmax(dp.sum(axis=1))), int(0.15 * W):int(0.55 * W)]
    mean = float(row.mean())
    return float((row > 0.1 * mean).mean()), float(row.std() / mean)


@pytest.mark.parametrize("rate", [120.0, 1000.0])
@pytest.mark.parametrize(("kind", "size"), [("round3d", 3), ("rigger", 3), ("calligraphy", 3),
                                            ("flat", 4)])
def test_half_loaded_thin_stroke_is_continuous(kind: str, size: float, rate: float) -> None:
    dp, b = thin_stroke(kind, size, rate)
    covered, cv = centreline(dp)
    assert covered >= 0.95 and cv < 0.5, (covered, cv)
    assert b.reservoir.fill > 0.3  # still about half-loaded
    # the tuft's bristles alone reach ~0.4 cells below the plane: on a 1.5-cell tooth
    # they touch only the hills, and the same stroke is a row of dots
    dots, _ = thin_stroke(kind, size, rate, TuftModel(ink_reach=0.0))
    assert centreline(dots)[0] < 0.6


def test_a_thin_stroke_breaks_up_only_when_the_brush_runs_dry() -> None:
    paper = make_paper(get_profile("ink").paper, H, 4 * W, 5)
    settings = BrushSettings(kind="round3d", size=3, water=0.5, pigment={"Sumi Ink": 0.5})
    b = DeformableBrush(4 * W, H, settings, BrushModel(), paper)
    b.reservoir.capacity *= 0.75  # run dry within the canvas' 120 widths
    b.reservoir.load(0.5, {"Sumi Ink": 0.5}, b.model.water_scale, b.model.pigment_scale)
    fills, n = [], 480
    for i in range(n + 1):
        b.feed(PenSample(t=i / 120, device="d", tool="pen", x=0.05 + 0.9 * i / n, y=0.5,  # type: ignore[arg-type]
                         pressure=0.5, touching=True))
        fills.append(b.reservoir.fill)
    src = b.take()
    assert src is not None
    dp = src.full(4 * W, H).dp["Sumi Ink"]
    row = dp[int(np.argmax(dp.sum(axis=1)))]
    xs = 0.05 * 4 * W + 0.9 * 4 * W * np.arange(n + 1) / n
    fill_at = np.interp(np.arange(4 * W) + 0.5, xs, fills)
    along = (np.arange(4 * W) > xs[0] + 4) & (np.arange(4 * W) < xs[-1] - 4)
    # connected ink down to the tip (fill above film_fill 0.4 at the start) vs the
    # tuft that has painted itself down towards pendular_fill 0.2
    wet, dry = along & (fill_at > 0.36), along & (fill_at < 0.28)
    assert wet.sum() >= 30 and dry.sum() > 100

    def covered(cells: np.ndarray) -> float:  # above a tenth of the local mean, 20 cells
        idx = np.flatnonzero(cells)
        parts = [row[idx[k:k + 20]] for k in range(0, idx.size - 9, 20)]
        return float(np.mean([(p > 0.1 * p.mean()).mean() for p in parts]))

    assert covered(wet) >= 0.9
    assert covered(dry) < 0.5  # run dry: broken


def test_a_1khz_pen_solves_every_fourth_sample() -> None:
    flat = np.ones((H, W), np.float32)
    settings = BrushSettings(kind="round3d", size=6, water=1.0, pigment={"Sumi Ink": 0.5})
    b = DeformableBrush(W, H, settings, BrushModel(), flat)
    b.reservoir.capacity *= 50  # the path, not the depletion
    b.reservoir.load(1.0, {"Sumi Ink": 0.5}, b.model.water_scale, b.model.pigment_scale)
    n = 1000
    for i in range(n + 1):  # a half circle in one second at 1 kHz
        a = np.pi * i / n
        x, y = 0.5 + 0.3 * np.cos(a), 0.2 + 0.55 * np.sin(a)
        b.feed(PenSample(t=i / 1000, device="d", tool="pen", x=x, y=y, pressure=0.5,  # type: ignore[arg-type]
                         touching=True))
    assert b.samples == n + 1
    assert b.frames <= 0.26 * n + 2  # a solve each 4 ms of session time
    # ... and a 120 Hz pen solves every sample (the results of a solve per sample)
    b2 = DeformableBrush(W, H, settings, BrushModel(), flat)
    for i in range(61):
        b2.feed(PenSample(t=i / 120, device="d", tool="pen", x=0.2 + 0.01 * i, y=0.5,  # type: ignore[arg-type]
                          pressure=0.5, touching=True))
    # (one more: a round tuft solved where it touched is solved there again, buckling
    # behind the pen, at its first move)
    assert b2.frames == b2.samples + 1 == 62


def test_coalesced_frames_match_a_solve_per_sample() -> None:
    """A curved 1 kHz stroke with a solve every 4 ms lays down the trail the same
    samples with a solve each lay down, within a few per cent of the water: the samples
    between solves move the last tuft along their own path."""
    flat = np.ones((H, W), np.float32)
    out = []
    for interval in (0.004, 0.0):
        settings = BrushSettings(kind="round3d", size=8, water=1.0, pigment={"Sumi Ink": 0.5})
        b = DeformableBrush(W, H, settings, BrushModel(), flat,
                            tuft=TuftModel(frame_interval=interval))
        for i in range(501):  # a quarter circle in half a second, pressing in
            a = 0.5 * np.pi * i / 500
            b.feed(PenSample(t=i / 1000, device="d", tool="pen", x=0.3 + 0.4 * np.sin(a),  # type: ignore[arg-type]
                             y=0.1 + 0.8 * (1.0 - np.cos(a)), pressure=0.3 + 0.4 * i / 500,
                             touching=True))
        src = b.take()
        assert src is not None
        out.append((src.full(W, H).dw, b.frames))
    (coalesced, f1), (every, f2) = out
    # a solve per sample, and the touch-down's again at the pen's first move (the round
    # tuft then buckles behind the motion)
    assert f2 == 502 and f1 <= 130
    assert abs(coalesced.sum() - every.sum()) <= 0.05 * every.sum()
    a, b = coalesced > 0, every > 0
    assert (a & b).sum() / (a | b).sum() > 0.85  # the same trail


def test_bench_brush_reports_the_1khz_pen(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "brush", "--json", "--kinds", "round3d", "--frames", "10",
                 "--sim-seconds", "0", "--pen-samples", "200"]) == 0
    pen = json.loads(capsys.readouterr().out)["pen_1khz"]
    assert {(r["kind"], r["size"]) for r in pen} >= {("round3d", 3.0), ("flat", 4.0)}
    for r in pen:
        assert r["solves_per_sample"] <= 0.27 and r["samples"] == 200
        for key in ("samples_per_s", "samples_per_cpu_s", "peer_round_samples_per_cpu_s",
                    "ratio_to_peer_cpu", "solve_each_sample_per_cpu_s", "goal_samples_per_s"):
            assert r[key] > 0
    assert main(["bench", "brush", "--pen-samples", "-1", "--sim-seconds", "0"]) == 2
