"""The round brush: footprint geometry, masking, pressure, velocity, settings."""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
import pytest

from station.brush.stamp import (
    BrushError,
    BrushModel,
    BrushSettings,
    RoundBrush,
    footprint,
)
from station.events import PenSample

W, H = 200, 120


def pen(t: float, x: float, y: float, p: float = 1.0, touching: bool = True,
        tool: str = "pen", device: str = "d0", tilt: tuple[float, float] = (0.0, 0.0)
        ) -> PenSample:
    return PenSample(t=t, device=device, tool=tool, x=x, y=y,  # type: ignore[arg-type]
                     pressure=p if touching else 0.0, touching=touching,
                     tilt_x=tilt[0], tilt_y=tilt[1])


def stroke(n: int, brush: RoundBrush, x0: float = 0.1, x1: float = 0.9, y: float = 0.5,
           duration: float = 1.0, p: float = 1.0):
    for i in range(n + 1):
        u = i / n
        brush.feed(pen(duration * u, x0 + (x1 - x0) * u, y, p))
    return brush.take()


def test_footprint_is_a_disc_of_the_radius() -> None:
    for r in (6.0, 10.5, 20.0):
        hard = footprint(100.0, 60.0, r, W, H)
        soft = footprint(100.0, 60.0, r, W, H, soft=True)
        assert abs(hard.cells - math.pi * r * r) / (math.pi * r * r) < 0.05
        assert abs(soft.area - math.pi * r * r) / (math.pi * r * r) < 0.01  # anti-aliased
        assert set(np.unique(hard.cover)) <= {0.0, 1.0}
        for fp in (hard, soft):
            ys, xs = np.nonzero(fp.mask)
            w = fp.cover[ys, xs]
            # centred: the coverage's centroid is the pen position within a tenth of a cell
            assert abs(((xs + fp.x0 + 0.5) * w).sum() / w.sum() - 100.0) < 0.1
            assert abs(((ys + fp.y0 + 0.5) * w).sum() / w.sum() - 60.0) < 0.1
            # every cell within r - 1 of the centre is fully in, none beyond r + 1
            cy, cx = np.mgrid[fp.y0:fp.y1, fp.x0:fp.x1] + 0.5
            d = np.hypot(cx - 100.0, cy - 60.0)
            assert (fp.cover[d <= r - 1] == 1.0).all() and not fp.mask[d > r + 1].any()
        # the soft rim ramps with the distance: half covered on the circle itself
        cy, cx = np.mgrid[soft.y0:soft.y1, soft.x0:soft.x1] + 0.5
        d = np.hypot(cx - 100.0, cy - 60.0)
        np.testing.assert_allclose(soft.cover, np.clip(r - d + 0.5, 0.0, 1.0), atol=1e-12)


def test_footprint_clips_at_the_canvas_edge() -> None:
    fp = footprint(2.0, 2.0, 10.0, W, H)
    assert fp.x0 == 0 and fp.y0 == 0
    assert fp.cells < math.pi * 100 / 2  # about a quarter disc survives
    assert fp.cells > math.pi * 100 / 4 * 0.8
    outside = footprint(-50.0, -50.0, 10.0, W, H)
    assert outside.cells == 0


def test_tilt_stretches_the_footprint_along_the_tilt() -> None:
    round_ = footprint(100.0, 60.0, 8.0, W, H)
    tilted = footprint(100.0, 60.0, 8.0, W, H, stretch=1.5, angle=0.0)
    assert abs(tilted.cells / round_.cells - 1.5) < 0.08
    assert tilted.mask.any(axis=0).sum() > round_.mask.any(axis=0).sum() + 6  # wider in x
    assert tilted.mask.any(axis=1).sum() == round_.mask.any(axis=1).sum()  # same in y
    # through the brush: 60° of x tilt stretches by 1 + 0.5 sin 60°
    m = BrushModel()
    b = RoundBrush(W, H, BrushSettings(size=16, water=1.0), m)
    b.feed(pen(0.0, 0.5, 0.5, tilt=(60.0, 0.0)))
    src = b.take()
    assert src is not None
    area = src.dw.sum() / (m.load(1.0) * m.water_scale)
    assert abs(area / (math.pi * 64) - (1 + 0.5 * math.sin(math.radians(60)))) < 0.03
    cols = (src.dw > 0).any(axis=0).sum()
    rows = (src.dw > 0).any(axis=1).sum()
    assert cols >= rows + 6  # elongated along x (16·1.43 ≈ 23 cells against 16)


@pytest.mark.parametrize("soft", [False, True])
def test_fast_stroke_does_not_overfill_water_follows_covered_area(soft: bool) -> None:
    settings = BrushSettings(size=16, water=1.0, pigment={"French Ultramarine": 1.0})
    model = BrushModel(soft_edge=soft)
    per_cell = 1.0 * model.load(1.0) * model.water_scale
    totals = []
    for n in (1, 3, 20, 400):  # 2 samples … 401 samples over the same line
        b = RoundBrush(W, H, settings, model)
        src = stroke(n, b)
        assert src is not None
        covered = int((src.dw > 0).sum())
        totals.append(float(src.dw.sum(dtype=np.float64)))
        # no cell gets more than one stamp's water; the stroke's body gets exactly that
        assert src.dw.max() <= per_cell * (1 + 1e-6)
        body = src.dw >= per_cell * (1 - 1e-6)
        assert body.sum() > 0.8 * covered
        np.testing.assert_allclose(src.dp["French Ultramarine"][body],
                                   model.load(1.0) * model.pigment_scale, rtol=1e-6)
        if not soft:  # the seed's cell map: every covered cell filled exactly once
            np.testing.assert_allclose(src.dw[src.dw > 0], per_cell, rtol=1e-6)
        # the stamps overlap heavily: without masking the cells would be filled many times
        assert b.stamps * math.pi * 8.0**2 > 3.0 * covered
    assert max(totals) - min(totals) < 1e-6 * max(totals)  # independent of sample count
    # water = one fill of the stroke's capsule: length 160 cells × 16 + a disc of radius 8
    expected = (0.8 * W * 16 + math.pi * 8.0**2) * per_cell
    assert abs(totals[0] - expected) / expected < (0.01 if soft else 0.05)


def test_water_scales_with_area_not_time() -> None:
    """Twice the stroke length → twice the water (minus the round caps), whatever the speed."""
    b1 = RoundBrush(W, H, BrushSettings(size=10, water=1.0))
    short = stroke(10, b1, 0.2, 0.5, duration=0.1).dw.sum()
    b2 = RoundBrush(W, H, BrushSettings(size=10, water=1.0))
    long_ = stroke(10, b2, 0.2, 0.8, duration=3.0).dw.sum()
    cap = math.pi * 25 * BrushModel().water_scale
    assert abs((long_ - cap) / (short - cap) - 2.0) < 0.05


def test_pressure_sets_radius_and_load() -> None:
    m = BrushModel()
    assert m.radius(20, 1.0) == pytest.approx(10.0)
    assert m.radius(20, 0.0) == pytest.approx(10.0 * m.r_min)
    assert m.radius(20, 0.5) == pytest.approx(10.0 * (m.r_min + (1 - m.r_min) * 0.5))
    radii = [m.radius(20, p / 10) for p in range(11)]
    assert all(a < b for a, b in itertools.pairwise(radii))
    assert m.radius(0.2, 0.0) == 0.5  # never below half a cell
    areas = {}
    for p in (0.2, 1.0):
        b = RoundBrush(W, H, BrushSettings(size=30, water=1.0))
        b.feed(pen(0.0, 0.5, 0.5, p))
        src = b.take()
        assert src is not None
        areas[p] = int((src.dw > 0).sum())
        assert src.dw.max() == pytest.approx(m.load(p) * m.water_scale, rel=1e-6)
    expect = (m.r_min + (1 - m.r_min) * 0.2) ** 2
    assert abs(areas[0.2] / areas[1.0] - expect) < 0.05


def test_velocity_source_follows_pen_speed_and_direction() -> None:
    m = BrushModel(velocity_gain=0.5, v_max=30.0)
    b = RoundBrush(W, H, BrushSettings(size=10, water=1.0), m, time_scale=1.0)
    # 0.2 of 200 cells in 2 s = 20 cells/s to the right
    b.feed(pen(0.0, 0.3, 0.5))
    b.take()
    b.feed(pen(2.0, 0.5, 0.5))
    src = b.take()
    assert src is not None
    body = src.dw >= src.dw.max() * (1 - 1e-6)  # cells under the brush, not its rim
    np.testing.assert_allclose(src.dvx[body], 10.0, rtol=1e-5)
    np.testing.assert_allclose(src.dvy[body], 0.0, atol=1e-6)
    # rim cells get the velocity in proportion to their coverage, never more
    assert np.all(src.dvx <= 10.0 * (1 + 1e-5))
    np.testing.assert_allclose(src.dvx[src.dw > 0] / src.dw[src.dw > 0],
                               10.0 / src.dw.max(), rtol=1e-4)
    # upwards (y down): negative vy; a fast flick is clamped to v_max
    b.feed(pen(2.01, 0.5, 0.1))
    src = b.take()
    assert src is not None
    body = src.dw >= src.dw.max() * (1 - 1e-6)
    assert np.all(src.dvy[body] == pytest.approx(-30.0, rel=1e-5))
    # time_scale converts session seconds to simulation time
    b2 = RoundBrush(W, H, BrushSettings(size=10), m, time_scale=2.0)
    b2.feed(pen(0.0, 0.3, 0.5))
    b2.feed(pen(2.0, 0.5, 0.5))
    src = b2.take()
    assert src is not None
    assert src.dvx[src.dw > 0].max() == pytest.approx(5.0, rel=1e-5)


def test_eraser_and_hover_paint_nothing_and_are_counted() -> None:
    b = RoundBrush(W, H, BrushSettings(size=10, water=1.0))
    for i in range(5):
        b.feed(pen(i * 0.01, 0.2 + i * 0.1, 0.5, tool="eraser"))
    b.feed(pen(0.1, 0.5, 0.5, touching=False))
    assert b.take() is None
    assert b.eraser_samples == 5 and b.samples == 0 and b.stamps == 0
    # a lift ends the stroke: the next touch stamps a full footprint again
    b.feed(pen(0.2, 0.5, 0.5))
    b.feed(pen(0.3, 0.5, 0.5, touching=False))
    b.feed(pen(0.4, 0.5, 0.5))
    src = b.take()
    assert src is not None and b.strokes == 2
    assert src.dw.max() == pytest.approx(2 * BrushModel().water_scale * BrushModel().load(1.0))


def test_devices_keep_separate_strokes() -> None:
    b = RoundBrush(W, H, BrushSettings(size=10, water=1.0))
    for i in range(11):
        b.feed(pen(i * 0.1, 0.1 + 0.03 * i, 0.3, device="a"))
        b.feed(pen(i * 0.1, 0.1 + 0.03 * i, 0.7, device="b"))
    src = b.take()
    assert src is not None
    top, bottom = src.dw[: src.dw.shape[0] // 2], src.dw[src.dw.shape[0] // 2:]
    assert abs(top.sum() - bottom.sum()) < 1e-3 * top.sum()
    assert b.strokes == 2


def test_stroke_is_deterministic() -> None:
    def run() -> np.ndarray:
        b = RoundBrush(W, H, BrushSettings(size=13, water=0.7, pigment={"Black": 0.3}))
        for i in range(50):
            u = i / 49
            b.feed(pen(u, 0.2 + 0.6 * u, 0.5 + 0.3 * math.sin(5 * u), 0.3 + 0.6 * u))
        src = b.take()
        assert src is not None
        return np.concatenate([src.dw.ravel(), src.dvx.ravel(), src.dp["Black"].ravel()])

    a, c = run(), run()
    assert a.tobytes() == c.tobytes()


def test_sources_expand_to_the_full_canvas() -> None:
    b = RoundBrush(W, H, BrushSettings(size=10, water=1.0, pigment={"Black": 1.0}))
    b.feed(pen(0.0, 0.9, 0.1))
    src = b.take()
    assert src is not None
    full = src.full(W, H)
    assert full.dw.shape == (H, W)
    assert full.dw.sum() == pytest.approx(src.dw.sum())
    ys, xs = np.nonzero(full.dw)
    assert abs(xs.mean() + 0.5 - 180.0) < 0.2 and abs(ys.mean() + 0.5 - 12.0) < 0.2


def test_brush_settings_validation() -> None:
    names = {"French Ultramarine", "Black"}
    s = BrushSettings.from_args({"kind": "round", "size": 24, "water": 0.8,
                                 "pigment": {"French Ultramarine": 0.6}}, "x:3", names)
    assert s.size == 24 and s.water == 0.8 and dict(s.pigment) == {"French Ultramarine": 0.6}
    partial = BrushSettings.from_args({"size": 5}, None, names, base=s)
    assert partial.size == 5 and partial.water == 0.8 and dict(partial.pigment) == dict(s.pigment)
    bad: list[tuple[dict[str, Any], str]] = [
        ({"pigment": {"Unobtainium": 0.5}}, "unknown pigment 'Unobtainium'"),
        ({"size": 0}, "must be > 0"),
        ({"size": "big"}, "must be a number"),
        ({"water": 1.5}, "outside [0, 1]"),
        ({"pigment": {"Black": float("nan")}}, "outside"),
        ({"kind": "sponge"}, "unknown brush kind"),
        ({"pigment": ["Black"]}, "must be an object"),
    ]
    for args, text in bad:
        with pytest.raises(BrushError) as err:
            BrushSettings.from_args(args, "log.jsonl:7", names)
        assert text in str(err.value) and str(err.value).startswith("log.jsonl:7: ")


def test_brush_velocity_pushes_the_paint_along_the_stroke() -> None:
    """On the canvas (numpy backend): with the velocity source the pigment of a
    fast stroke ends up further along the stroke's direction than without."""
    from station.backends.factory import create_backend
    from station.sim.player import add_sources

    def centroid(gain: float, direction: int) -> float:
        w, h = 96, 48
        canvas = create_backend("numpy", w, h, "watercolor", 1)
        brush = RoundBrush(w, h, BrushSettings(size=12, water=1.0, pigment={"Black": 0.5}),
                           BrushModel(velocity_gain=gain, v_max=30.0, pigment_scale=0.3))
        n = 20
        for i in range(n + 1):
            u = i / n if direction > 0 else 1 - i / n
            brush.feed(pen(i * 0.01, 0.2 + 0.6 * u, 0.5, 0.9))
            if i % 3 == 0:
                src = brush.take()
                if src is not None:
                    add_sources(canvas, src)
                canvas.step()
        for _ in range(30):
            canvas.step()
        st = canvas.state()
        amount = (st.p.sum(axis=0) + st.q.sum(axis=0)).sum(axis=0)
        return float((amount * np.arange(w)).sum() / amount.sum())

    still_right, still_left = centroid(0.0, +1), centroid(0.0, -1)
    moved_right, moved_left = centroid(0.1, +1), centroid(0.1, -1)
    assert moved_right > still_right + 1.0
    assert moved_left < still_left - 1.0
