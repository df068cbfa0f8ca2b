"""Running dry (session 4): a half-loaded tuft lays a stroke of dozens of its widths, a
full one goes further, and the end breaks into streaks along the stroke, not dashes."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import uniform_filter1d

from station.brush.deformable import DeformableBrush, TuftModel
from station.brush.footprint import rasterise, weight
from station.brush.stamp import BrushModel, BrushSettings
from station.canvas.paper import make_paper
from station.canvas.profiles import get_profile
from station.events import PenSample

INK = "Sumi Ink"


def straight(size: float, water: float, diameters: float, tuft: TuftModel | None = None,
             capacity: float = 1.0, seed: int = 3, pressure: float = 0.5
             ) -> tuple[np.ndarray, float]:
    """A steady stroke of round3d at 150 cells/s, 120 Hz, half pressure, on the ink
    profile's rough dry paper; the pigment (H, W) and the x where it starts."""
    w, h = int(size * (diameters + 6) + 20), int(4 * size + 16)
    paper = make_paper(get_profile("ink").paper, h, w, seed)
    b = DeformableBrush(w, h, BrushSettings(kind="round3d", size=size, water=water,
                                            pigment={INK: 0.5}), BrushModel(), paper, tuft=tuft)
    b.reservoir.capacity *= capacity
    b.reservoir.load(water, {INK: 0.5}, b.model.water_scale, b.model.pigment_scale)
    x0, x1 = 2 * size + 4, w - 2 * size - 4
    n = int((x1 - x0) / 150.0 * 120.0)
    for i in range(n + 1):
        b.feed(PenSample(t=i / 120, device="d", tool="pen", x=(x0 + (x1 - x0) * i / n) / w,  # type: ignore[arg-type]
                         y=0.5, pressure=pressure, touching=True))
    src = b.take()
    assert src is not None
    return src.full(w, h).dp[INK], float(x0)


def covered(dp: np.ndarray, x0: float, size: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Cells with visible paint (a tenth of what a full brush lays: ``pigment_scale ·
    amount``), the coverage of the centreline's rows in windows of two widths, and that
    level."""
    row = int(np.argmax(dp.sum(axis=1)))
    level = 0.1 * BrushModel().pigment_scale * 0.5
    cov = dp > level
    core = max(1, int(size) // 4)  # the centreline's rows: a thin line wanders by a cell
    line = cov[row - core:row + core + 1].mean(axis=0)
    win = max(8, int(2 * size))
    along = np.convolve(line, np.ones(win) / win, mode="valid")
    return cov, along, level


def reach(dp: np.ndarray, x0: float, size: float) -> float:
    """Brush widths painted before the centreline's coverage falls below half."""
    _, along, _ = covered(dp, x0, size)
    low = np.flatnonzero(along[int(x0):] < 0.5)
    assert low.size, "the stroke did not run dry on its canvas"
    return float(low[0]) / size


@pytest.mark.parametrize("size", [3, 6])
def test_a_half_loaded_tuft_paints_dozens_of_widths(size: float) -> None:
    # before session 4 (a reservoir of ten footprints' worth, the ink's connection to
    # the tip lost at 0.4 of a full load by every bristle at once) this was 6-9 widths;
    # 25 on the first two-octave rough paper, 21 on the broadband one (issue 21 item 7)
    assert reach(*straight(size, 0.5, 90), size) >= 20


def test_a_bigger_tuft_paints_more_of_its_widths() -> None:
    # the tuft holds ink by its volume (size³), a stroke takes it by its width (size):
    # twice the size, about twice the widths
    assert reach(*straight(6, 0.5, 90), 6) >= 1.6 * reach(*straight(3, 0.5, 90), 3)


def test_a_full_tuft_goes_further_than_a_half_loaded_one() -> None:
    half = reach(*straight(3, 0.5, 90), 3)
    full = reach(*straight(3, 1.0, 90), 3)
    assert full > 1.4 * half, (half, full)


def correlation_length(mask: np.ndarray, axis: int, most: int = 12) -> float:
    """Lag (cells, interpolated) at which the autocorrelation of ``mask`` along ``axis``
    falls below 1/e, the fade along the stroke taken out (a running mean over four
    widths of the band)."""
    m = mask.astype(float)
    m = m - uniform_filter1d(m.mean(axis=0, keepdims=True), 4 * m.shape[0], axis=1,
                             mode="nearest")
    var = float((m * m).mean())
    n = m.shape[axis]
    last = 1.0
    for lag in range(1, min(n, most)):
        a = np.take(m, range(n - lag), axis=axis)
        b = np.take(m, range(lag, n), axis=axis)
        ac = float((a * b).mean()) / var
        if ac < 1.0 / np.e:
            return lag - 1 + (last - 1.0 / np.e) / (last - ac)
        last = ac
    return float(most)


def runs(mask: np.ndarray) -> float:
    """Mean length of the runs of True along the rows of ``mask``."""
    out = []
    for r in mask:
        edges = np.diff(np.concatenate([[0], r.astype(np.int8), [0]]))
        out.extend(np.flatnonzero(edges < 0) - np.flatnonzero(edges > 0))
    return float(np.mean(out))


def dry_end(tuft: TuftModel | None = None) -> tuple[np.ndarray, float, float]:
    """Where a size-12 tuft, pressed hard, runs dry (from the centreline's coverage below
    0.9 to below 0.2): the coverage of the stroke's band (the rows at least 30 %
    covered) and its correlation lengths along and across the stroke."""
    size = 12
    dp, x0 = straight(size, 0.5, 40, tuft, capacity=0.12, pressure=0.9)
    cov, along, _ = covered(dp, x0, size)
    a = int(x0) + int(np.flatnonzero(along[int(x0):] < 0.9)[0])
    z = int(x0) + int(np.flatnonzero(along[int(x0):] < 0.2)[0])
    rows = np.flatnonzero(cov[:, a:z].mean(axis=1) > 0.3)
    band = cov[rows.min():rows.max() + 1, a:z]
    # (0.70 on the broadband rough paper of issue 21 item 7, 0.6 on the first one)
    assert band.shape[1] > 10 * size and 0.3 < band.mean() < 0.75, (band.shape, band.mean())
    return band, correlation_length(band, 1), correlation_length(band, 0)


def test_the_running_dry_end_breaks_into_streaks_along_the_stroke() -> None:
    band, along, across = dry_end()
    # measured: 1.9 cells along, 0.71 across; paint runs 7.2 / 3.1, gaps 4.9 / 1.8
    assert along >= 2.0 * across, (along, across)
    # the paint and the paper left white both come in streaks along the stroke
    assert runs(band) >= 1.6 * runs(band.T), (runs(band), runs(band.T))
    assert runs(~band) >= 1.5 * runs(~band.T), (runs(~band), runs(~band.T))
    # the dragged hairs skim from hill to hill: touching only where the paper itself is
    # high (skim 0), the marks are the tooth's own round dots (0.99 along, 0.77 across)
    _, along0, across0 = dry_end(TuftModel(skim=0))
    assert along0 < 0.7 * along and along0 < 1.5 * across0, (along0, across0)


def test_the_tuft_holds_by_its_volume() -> None:
    paper = np.ones((64, 64), np.float32)
    held = []
    for size in (4.0, 8.0):
        b = DeformableBrush(64, 64, BrushSettings(kind="round3d", size=size), BrushModel(), paper)
        held.append(b.reservoir.capacity)
        assert b.reservoir.capacity == pytest.approx(
            b.shape.capacity * b.model.water_scale * np.pi * (size / 2) ** 2 * b.tuft_length)
    assert held[1] == pytest.approx(8.0 * held[0])


def test_each_cell_knows_the_bristle_that_touches_it() -> None:
    # two crossing bristles; the lower one's tag wins where both cover a cell
    segs = np.array([[[4.0, 8.0, -0.2], [14.0, 8.0, -0.2]],
                     [[9.0, 3.0, 0.0], [9.0, 13.0, 0.0]]])
    maps = rasterise(segs, 0.6, tags=np.array([2.0, 0.5]))
    assert maps.tag is not None and maps.tag.shape == maps.cover.shape
    at = (8 - maps.y0, 9 - maps.x0)  # the crossing
    assert maps.tag[at] == pytest.approx(2.0)
    assert maps.tag[(4 - maps.y0, 9 - maps.x0)] == pytest.approx(0.5)
    assert np.isnan(maps.tag[maps.cover == 0]).all()
    assert rasterise(segs, 0.6).tag is None
    # per-cell lift: raising the contact where the tag is low takes its paint away
    paper = np.full((24, 24), 0.5, np.float32)
    _, _, flat = weight(maps, paper, 1.5, 0.6)
    lift = np.where(np.nan_to_num(maps.tag) < 1.0, 5.0, 0.0).astype(np.float32)
    _, _, lifted = weight(maps, paper, 1.5, 0.6, lift=lift)
    low = np.nan_to_num(maps.tag) < 1.0
    assert lifted[low & (maps.cover > 0)].max() == 0.0
    assert np.array_equal(lifted[~low], flat[~low])


def test_a_flick_lays_a_thinner_film_than_a_slow_stroke() -> None:
    """Transfer ∝ √(contact time) up to ``contact_time``: a stroke 4× faster than the
    tuft's length per ``contact_time`` lays about half the water per cell."""
    paper = np.ones((40, 400), np.float32)
    per_cell = []
    for speed in (100.0, 3000.0):  # cells per session second
        b = DeformableBrush(400, 40, BrushSettings(kind="round3d", size=6, water=1.0,
                                                   pigment={INK: 0.5}), BrushModel(), paper)
        b.reservoir.capacity *= 100  # the transfer, not the depletion
        b.reservoir.load(1.0, {INK: 0.5}, b.model.water_scale, b.model.pigment_scale)
        n = 60
        for i in range(n + 1):
            b.feed(PenSample(t=i * 300.0 / n / speed, device="d", tool="pen",  # type: ignore[arg-type]
                             x=(50 + 300.0 * i / n) / 400, y=0.5, pressure=0.6, touching=True))
        src = b.take()
        assert src is not None
        dw = src.full(400, 40).dw[:, 100:300]
        per_cell.append(float(dw.sum()) / float((dw > 0).sum()))
    slow, fast = per_cell
    assert 0.3 * slow < fast < 0.7 * slow, (slow, fast)
