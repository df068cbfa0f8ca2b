"""Row-strip decomposition of the canvas and the painting-aware split (no MPI here).

Each rank *owns* a contiguous range of canvas rows and *holds* those rows
plus a halo of ``radius`` rows on each side (clipped to the canvas). Strips, not
blocks: a halo as wide as one step's stencil is exchanged once per step, and with
the 2-8 ranks of a station a strip's two borders cost less than a block's four.

The split follows the *work*, not the area (the weakness measured in chapter 5 of
the dissertation: a painted corner falls on one process): :func:`balanced_split`
weighs every 8 rows by the cells the dirty-tile boxes simulate in them, so ranks
share the painted rows evenly wherever they are.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

IDLE_ROW_WEIGHT = 1e-4
"""Weight of a row nobody paints, relative to a fully simulated one. A step costs such a
row next to nothing (the tile bookkeeping is per box), so the weight only decides the
split of a canvas nobody paints (even) and must not push painted rows off the rank
that holds the quiet rest of the canvas (0.002 moved the corner stroke's cut ~25 rows)."""

GRANULE = 8
"""Rows per unit of the painting-aware split [rows]: finer than a tile row (32), so a
small painted region is cut within a row or two of the even share of its work."""


@dataclass(frozen=True)
class Strip:
    """One rank's rows: owned ``[lo, hi)`` and held ``[pad_lo, pad_hi)`` [canvas rows]."""

    lo: int
    hi: int
    pad_lo: int
    pad_hi: int

    @property
    def rows(self) -> int:
        """Rows held (owned plus halo)."""
        return self.pad_hi - self.pad_lo


def strips(bounds: Sequence[int], height: int, radius: int) -> list[Strip]:
    """Strips for ``bounds`` (``n + 1`` increasing row numbers from 0 to ``height``)."""
    out = []
    for lo, hi in itertools.pairwise(bounds):
        out.append(Strip(int(lo), int(hi), max(int(lo) - radius, 0),
                         min(int(hi) + radius, height)))
    return out


def even_split(height: int, tile_size: int, n: int) -> list[int]:
    """Tile-aligned bounds giving every rank about the same number of tile rows."""
    n_tiles = -(-height // tile_size)
    return _bounds_from_tiles([round(i * n_tiles / n) for i in range(n + 1)], height, tile_size)


def _bounds_from_tiles(tile_bounds: list[int], height: int, tile_size: int) -> list[int]:
    return [min(t * tile_size, height) for t in tile_bounds]


def row_work(regions: Sequence[tuple[slice, slice]], height: int, width: int,
             tile_size: int) -> np.ndarray:
    """Work per group of ``tile_size`` rows (a tile row, or :data:`GRANULE` rows): cells
    the given boxes simulate in it, plus the idle weight."""
    n_tiles = -(-height // tile_size)
    per_row = np.full(n_tiles * tile_size, IDLE_ROW_WEIGHT * width, np.float64)
    per_row[height:] = 0.0
    for ys, xs in regions:
        per_row[ys.start:ys.stop] += xs.stop - xs.start
    out: np.ndarray = per_row.reshape(n_tiles, tile_size).sum(axis=1)
    return out


def balanced_split(work: np.ndarray, height: int, tile_size: int, n: int) -> list[int]:
    """Bounds at multiples of ``tile_size`` rows (a tile row or :data:`GRANULE`) with
    about equal ``work`` (per such group of rows) for each of ``n`` ranks.

    Every rank keeps at least one tile row while there are enough; the cut after a
    prefix sum passes ``k/n`` of the total (ties to the lower row, deterministic).
    """
    n_tiles = len(work)
    if n >= n_tiles:
        return _bounds_from_tiles([min(i, n_tiles) for i in range(n + 1)], height, tile_size)
    cum = np.concatenate([[0.0], np.cumsum(work)])
    total = cum[-1]
    cuts = [0]
    for k in range(1, n):
        t = int(np.searchsorted(cum, total * k / n, side="left"))
        # at least one tile row per rank on both sides of the cut
        t = max(t, cuts[-1] + 1)
        t = min(t, n_tiles - (n - k))
        cuts.append(t)
    cuts.append(n_tiles)
    return _bounds_from_tiles(cuts, height, tile_size)


def imbalance(work: np.ndarray, bounds: Sequence[int], tile_size: int) -> float:
    """Largest rank's share of ``work`` over the mean share (1.0 = perfect)."""
    shares = []
    for lo, hi in itertools.pairwise(bounds):
        shares.append(float(work[lo // tile_size:-(-hi // tile_size)].sum()))
    mean = sum(shares) / len(shares)
    return max(shares) / mean if mean > 0 else 1.0
