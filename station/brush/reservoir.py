"""The brush's reservoir: water and a pigment mix that go both ways (issue 11 §6).

Units are the canvas's, summed over cells: water in cell water-heights × cells,
pigment in area fraction × cells.  So what leaves the brush is exactly what a
``add_sources`` call gets, and what :func:`pickup` lifts off the canvas
arrays is exactly what the brush gains: reservoir + canvas is conserved.

* Loading (a ``brush`` command dips the brush): ``V = max(water, 0.02)·V_cap``,
  ``m_k = amount_k · pigment_scale / water_scale · V_cap``, so a full brush
  deposits what the round brush does per stamp.
* Deposit per cell: ``dw = water_scale · fill · cover``, ``dp_k = dw · m_k/V``
  with ``fill = V/V_cap``: the stroke fades as the brush empties, and the mix
  it lays down is the mix it holds — including what it picked up.
* Pick-up (dirty brush): under the footprint, a share
  ``pickup · weight · wet`` of the canvas's *fluid* pigment ``p`` and water
  ``w`` moves into the reservoir (``wet = clip(w / w_wet, 0, 1)``: only wet
  paint comes along).  The canvas books the pigment and water it loses in its
  ``removed_p`` / ``removed_w`` fields like every tool that takes paint.

:func:`pickup` moves what a :class:`WetSurface` gives up into the reservoir.  The
brush does not know the canvas: the session player hands it the surface (over the
canvas state: :class:`station.canvas.removal.StateSurface`), so the brush's mechanics
(which the haptic driver uses for its force) carry no canvas state with them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

W_WET = 0.1
"""Fluid water height at which a cell's paint comes along fully."""


class Lifted(Protocol):
    """What a surface gave up: water [height * cells], pigment per name
    [area fraction * cells]."""

    @property
    def water(self) -> float: ...

    @property
    def pigment(self) -> Mapping[str, float]: ...


class WetSurface(Protocol):
    """The wet paint a loaded brush glides over, as the reservoir sees it."""

    def lift(self, weight: np.ndarray, y0: int, x0: int, thirst: float, wet_depth: float,
             room: float) -> Lifted:
        """Take the fluid water and suspended pigment under ``weight`` (contact in
        [0, 1], top-left at row ``y0``, column ``x0``): a share ``thirst`` in [0, 1],
        following the standing water up to ``wet_depth`` [height], at most ``room``
        [height * cells] of water in all; book it as removed and return it."""
        ...


def _book(ledger: dict[str, float], name: str, amount: float) -> None:
    ledger[name] = ledger.get(name, 0.0) + amount


@dataclass(slots=True)
class Reservoir:
    """Water ``volume`` and pigment ``mass`` per name held by the brush.

    The ledgers book every pigment movement, so that per name
    ``mass = loaded - washed - deposited + picked`` (the session's bookkeeping:
    with the canvas's own books, brush + canvas is conserved).
    """

    capacity: float
    volume: float = 0.0
    mass: dict[str, float] = field(default_factory=dict)
    loaded: dict[str, float] = field(default_factory=dict)
    washed: dict[str, float] = field(default_factory=dict)
    deposited: dict[str, float] = field(default_factory=dict)
    picked: dict[str, float] = field(default_factory=dict)

    def ledger(self) -> dict[str, dict[str, float]]:
        """The reservoir's books (JSON-able)."""
        return {"volume": {"now": self.volume, "capacity": self.capacity},
                "mass": dict(self.mass), "loaded": dict(self.loaded),
                "washed": dict(self.washed), "deposited": dict(self.deposited),
                "picked": dict(self.picked)}

    @property
    def fill(self) -> float:
        return 0.0 if self.capacity <= 0.0 else min(1.0, self.volume / self.capacity)

    def load(self, water: float, pigment: Mapping[str, float], water_scale: float,
             pigment_scale: float) -> None:
        """Dip the brush: rinse what it held, refill to ``water`` and the command's mix."""
        for name, m in self.mass.items():
            _book(self.washed, name, m)
        self.volume = max(water, 0.02) * self.capacity
        ratio = pigment_scale / water_scale if water_scale > 0 else 0.0
        self.mass = {k: a * ratio * self.capacity for k, a in pigment.items() if a > 0.0}
        for name, m in self.mass.items():
            _book(self.loaded, name, m)

    def total_pigment(self) -> float:
        return float(sum(self.mass.values()))

    def deposit(self, cover: np.ndarray, water_scale: float
                ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Per-cell water and pigment for ``cover``; the reservoir pays for them."""
        fill = self.fill
        dw = (water_scale * fill) * cover.astype(np.float64)
        total = float(dw.sum())
        if total > self.volume and total > 0.0:
            dw *= self.volume / total
            total = self.volume
        dp: dict[str, np.ndarray] = {}
        if self.volume > 0.0 and total > 0.0:
            share = total / self.volume
            for name, m in self.mass.items():
                if m > 0.0:
                    dp[name] = dw * (m / self.volume)
                    self.mass[name] = m * (1.0 - share)
                    _book(self.deposited, name, m * share)
        self.volume -= total
        return dw, dp


def pickup(surface: WetSurface, res: Reservoir, weight: np.ndarray, y0: int, x0: int,
           rate: float) -> dict[str, float]:
    """Lift wet paint under ``weight`` (placed at ``y0, x0``) into ``res``.

    The canvas side is ``surface`` (over a canvas state :func:`station.canvas.removal.pickup`
    with no scrubbing: a loaded brush
    gliding over paint lifts the suspended pigment only, deposited pigment ``q`` stays;
    the drink follows the standing water up to ``W_WET`` and stops when the brush is
    full).  Returns the pigment lifted per name.
    """
    if rate <= 0.0:
        return {}
    got = surface.lift(weight, y0, x0, thirst=min(float(rate), 1.0), wet_depth=W_WET,
                       room=max(0.0, res.capacity - res.volume))
    res.volume += got.water
    out: dict[str, float] = {}
    for name, m in got.pigment.items():
        if m <= 0.0:
            continue
        res.mass[name] = res.mass.get(name, 0.0) + m
        _book(res.picked, name, m)
        out[name] = m
    return out
