"""Paper height from seedable Worley (cellular) noise (Worley 1996, seed 4.7.1), and
the paper's fibre texture.

The height ``h`` in ``[0, 1]`` drives granulation, the capillary capacity
``c = c_min + h (c_max - c_min)`` and the diffusion controller.

The fibre texture (:func:`make_fibres`, MoXi's fibre feathering; the seed's ch. 4
capillary layer) is a set of straight fibres laid at random positions and orientations
with a preset's coverage and mean length. Per cell it holds how much fibre runs along x
and along y: ``fibre[0] = min(1, sum cos^2 theta)``, ``fibre[1] = min(1, sum sin^2 theta)``
over the fibres crossing the cell (each counted by its length inside the cell). Water
runs along a fibre where it would stay pinned on the felt between fibres: the wet mask
lowers a dry cell's advancing height by ``1 - fibre_wick * fibre`` for the neighbours on
the fibre's axis (``SimParams.fibre_wick``), so the front, and the ink it carries, feathers
out along the fibres.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib import resources

import numpy as np

from station.canvas.params import CanvasInputError


@dataclass(frozen=True)
class PaperPreset:
    """Worley octaves (feature spacing in cells, weight) and the height range used."""

    name: str
    octaves: tuple[tuple[float, float], ...]
    low: float  # h range after rescaling: [low, high]
    high: float
    # fibre texture: coverage (fibre length per cell area, ~ fibres crossing a cell) and
    # mean fibre length [cells]; (0, 0): no fibre texture
    fibres: tuple[float, float] = (0.0, 0.0)


def _load_presets() -> dict[str, PaperPreset]:
    """The packaged papers (``station/data/papers.json``), validated."""
    data = json.loads(resources.files("station").joinpath("data", "papers.json")
                      .read_text(encoding="utf-8"))
    out = {}
    for d in data["papers"]:
        octaves = tuple((float(a), float(b)) for a, b in d["octaves"])
        fib = (float(d["fibres"][0]), float(d["fibres"][1]))
        low, high = float(d["low"]), float(d["high"])
        if not octaves or any(a <= 0 or b < 0 for a, b in octaves) or not 0 <= low < high <= 1:
            raise CanvasInputError(f"papers.json: malformed paper {d.get('name')!r}")
        out[str(d["name"])] = PaperPreset(str(d["name"]), octaves, low, high, fib)
    return out


PAPER_PRESETS: dict[str, PaperPreset] = _load_presets()
"""Papers by name: hot-press, cold-press, rough (data: ``station/data/papers.json``)."""


def worley_f1(height: int, width: int, spacing: float, rng: np.random.Generator) -> np.ndarray:
    """Distance to the nearest feature point, one random point per ``spacing`` grid cell.

    Vectorised: every pixel looks at the 3x3 feature cells around its own.
    Returns float32 (height, width), not normalised.
    """
    gh = int(np.ceil(height / spacing)) + 2
    gw = int(np.ceil(width / spacing)) + 2
    # feature point of grid cell (gy, gx), in pixel units; grid cell 0 starts at -spacing
    pts = ((rng.random((gh, gw, 2)) + np.stack(np.meshgrid(
        np.arange(gh), np.arange(gw), indexing="ij"), axis=-1) - 1.0) * spacing).astype(np.float32)
    ys = np.arange(height, dtype=np.float32) + np.float32(0.5)
    xs = np.arange(width, dtype=np.float32) + np.float32(0.5)
    cy = ((np.arange(height) + 0.5) // spacing).astype(np.int64) + 1
    cx = ((np.arange(width) + 0.5) // spacing).astype(np.int64) + 1
    best = np.full((height, width), np.inf, np.float32)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            gy = np.clip(cy + dy, 0, gh - 1)
            gx = np.clip(cx + dx, 0, gw - 1)
            py = pts[gy[:, None], gx[None, :], 0]
            px = pts[gy[:, None], gx[None, :], 1]
            d = (py - ys[:, None]) ** 2 + (px - xs[None, :]) ** 2
            np.minimum(best, d, out=best)
    return np.sqrt(best).astype(np.float32)


def make_paper(preset: str, height: int, width: int, seed: int) -> np.ndarray:
    """Paper height field in ``[low, high]`` of ``preset``, deterministic in ``seed``."""
    try:
        p = PAPER_PRESETS[preset]
    except KeyError:
        raise CanvasInputError(
            f"unknown paper preset {preset!r} (known: {', '.join(PAPER_PRESETS)})", "paper"
        ) from None
    rng = np.random.default_rng(seed)
    total = np.zeros((height, width), np.float32)
    for spacing, weight in p.octaves:
        f1 = worley_f1(height, width, spacing, rng)
        # F1 is 0 at feature points: invert so features are peaks (fibre crossings)
        total += np.float32(weight) * (1.0 - f1 / np.float32(spacing))
    lo, hi = float(total.min()), float(total.max())
    norm = (total - lo) / (hi - lo) if hi > lo else np.zeros_like(total)
    h = np.float32(p.low) + norm * np.float32(p.high - p.low)
    out: np.ndarray = np.clip(h, 0.0, 1.0).astype(np.float32)
    return out


def make_fibres(preset: str, height: int, width: int, seed: int) -> np.ndarray:
    """The fibre texture of ``preset`` (float32 (2, H, W) in [0, 1]: fibre along x, along
    y), deterministic in ``seed``; zeros for a preset without fibres."""
    try:
        p = PAPER_PRESETS[preset]
    except KeyError:
        raise CanvasInputError(
            f"unknown paper preset {preset!r} (known: {', '.join(PAPER_PRESETS)})", "paper"
        ) from None
    out = np.zeros((2, height, width), np.float32)
    coverage, length = p.fibres
    if coverage <= 0 or length <= 0:
        return out
    rng = np.random.default_rng(seed + 104729)  # own stream: h is unchanged by fibres
    n = max(1, int(round(coverage * height * width / length)))
    cy = rng.random(n) * height
    cx = rng.random(n) * width
    theta = rng.random(n) * np.pi
    lens = length * (0.5 + rng.random(n))  # lengths uniform in [L/2, 3L/2]
    # sample each fibre every half cell; each sample stands for half a cell of fibre
    m = int(np.ceil(lens.max() / 0.5)) + 1
    t = (np.arange(m)[None, :] / (m - 1) - 0.5) * lens[:, None]
    keep = np.abs(t) <= lens[:, None] / 2
    ys = np.floor(cy[:, None] + t * np.sin(theta)[:, None]).astype(np.int64)
    xs = np.floor(cx[:, None] + t * np.cos(theta)[:, None]).astype(np.int64)
    keep &= (ys >= 0) & (ys < height) & (xs >= 0) & (xs < width)
    seg = (lens / (m - 1))[:, None] * np.ones((1, m))  # fibre length per sample
    flat = (ys * width + xs)[keep]
    for axis, share in enumerate((np.cos(theta) ** 2, np.sin(theta) ** 2)):
        acc = np.bincount(flat, weights=(seg * share[:, None])[keep],
                          minlength=height * width)
        out[axis] = np.minimum(acc, 1.0).reshape(height, width)
    return out
