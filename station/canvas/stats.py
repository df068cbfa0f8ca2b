"""The ``--stats`` JSON (interfaces.md): water and pigment bookkeeping of a canvas.

Every amount is a float64 sum of per-cell float32 amounts [cell units]. The
evaporated and removed amounts come from per-cell accumulators that the passes
and tools update where the water or pigment leaves (never "added minus present").
Pigment ``surface`` counts the active layer's deposits plus the dried layers;
``layers`` counts the dried layers and ``dried_layers`` lists each one's deposits
by pigment.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TypedDict

import numpy as np

from station.canvas.state import CanvasState


class WaterBooks(TypedDict):
    """Water [cell water-height x cells]: what came in and where it is or went."""

    added: float
    fluid: float
    capillary: float
    evaporated: float
    removed: float


class PigmentBooks(TypedDict):
    """One pigment [area fraction x cells]."""

    added: float
    fluid: float
    surface: float
    removed: float
    surface_active_layer: float


class Balance(TypedDict):
    """Relative bookkeeping errors (0 when nothing was added)."""

    water_rel_error: float
    pigment_rel_error: float


class CanvasStats(TypedDict):
    """The ``--stats`` JSON object of interfaces.md."""

    width: int
    height: int
    steps: int
    sim_seconds: float
    renderer: str
    profile: str
    layers: int
    dried_layers: list[dict[str, float]]
    water: WaterBooks
    pigments: dict[str, PigmentBooks]
    balance: Balance


def _sum(a: np.ndarray) -> float:
    return float(a.sum(dtype=np.float64))


def canvas_stats(state: CanvasState, renderer: str) -> CanvasStats:
    """Bookkeeping of ``state`` as the interfaces.md JSON object."""
    water: WaterBooks = {
        "added": state.water_added,
        "fluid": _sum(state.w),
        "capillary": _sum(state.wc),
        "evaporated": state.evaporated_folded + _sum(state.evaporated),
        "removed": _sum(state.removed_w),
    }
    names: list[str] = []
    for n in (*state.pigment_added, *state.slots, *state.pigment_dried):
        if n not in names:
            names.append(n)
    pigments: dict[str, PigmentBooks] = {}
    for n in names:
        k = state.slots.index(n) if n in state.slots else None
        fluid = _sum(state.p[k]) if k is not None else 0.0
        surf_active = _sum(state.q[k]) if k is not None else 0.0
        removed = state.pigment_removed_past.get(n, 0.0) + (
            _sum(state.removed_p[k]) if k is not None else 0.0)
        pigments[n] = {
            "added": state.pigment_added.get(n, 0.0),
            "fluid": fluid,
            "surface": surf_active + state.pigment_dried.get(n, 0.0),
            "removed": removed,
            "surface_active_layer": surf_active,
        }
    return {
        "width": state.width, "height": state.height, "steps": state.step_count,
        "sim_seconds": state.sim_time, "renderer": renderer, "profile": state.profile,
        "layers": len(state.layers), "dried_layers": [dict(d) for d in state.layers],
        "water": water, "pigments": pigments,
        "balance": balance(water, pigments),
    }


def balance(water: WaterBooks, pigments: Mapping[str, PigmentBooks]) -> Balance:
    """Relative bookkeeping errors: water and the worst pigment (0 when nothing added)."""
    def rel(lhs: float, rhs: float, scale: float) -> float:
        return abs(lhs - rhs) / scale if scale > 0 else 0.0

    w_err = rel(water["added"] - water["evaporated"] - water["removed"],
                water["fluid"] + water["capillary"], water["added"])
    p_err = max((rel(v["added"] - v["removed"], v["fluid"] + v["surface"], v["added"])
                 for v in pigments.values()), default=0.0)
    return {"water_rel_error": w_err, "pigment_rel_error": p_err}
