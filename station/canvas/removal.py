"""Canvas-side tools that take water and paint away: the hair dryer and brush pickup.

Both act on a :class:`CanvasState` between simulation steps and book everything they
remove (``evaporated`` for the dryer, ``removed_w`` / ``removed_p`` for the pickup),
so the balance in the stats still closes. The caller runs one of them on any backend
with :func:`station.backends.protocol.edit_state` (in place on the NumPy and cpu
backends, through a state round trip elsewhere).

Hair dryer: hot moving air raises the local drying power of the air exactly as the
canvas's ``temperature`` / ``airflow`` settings do (``SimParams.drying_power``), on a
Gaussian footprint. Pickup (the canvas side of two-way paint transfer, seed future
work): a brush touching wet paint scrubs deposited pigment back into suspension (less
the more the pigment stains, ``beta``) and drinks fluid water with the pigment it
carries.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import TypeVar

import numpy as np

from station.canvas.params import CanvasInputError, SimParams
from station.canvas.reference import slot_properties
from station.canvas.state import CanvasState

F32 = np.float32
T = TypeVar("T")


@lru_cache(maxsize=8)
def gaussian_footprint(radius: float) -> np.ndarray:
    """Weights in [0, 1] of a Gaussian spot, ``sigma = radius / 2``, cut at ``radius``
    (float32, square of side ``2 ceil(radius) + 1``)."""
    r = max(int(math.ceil(radius)), 0)
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1].astype(np.float64)
    d2 = yy * yy + xx * xx
    sig = max(radius / 2.0, 0.5)
    wgt = np.exp(-0.5 * d2 / (sig * sig))
    wgt[d2 > radius * radius] = 0.0
    out = wgt.astype(F32)
    out.flags.writeable = False  # cached and shared between calls
    result: np.ndarray = out
    return result


def _window(state: CanvasState, shape: tuple[int, int], y0: int, x0: int
            ) -> tuple[tuple[slice, slice], tuple[slice, slice]] | None:
    """Canvas slices and array slices of an array of ``shape`` placed at (y0, x0)."""
    hh, ww = shape
    cy0, cx0 = max(y0, 0), max(x0, 0)
    cy1, cx1 = min(y0 + hh, state.height), min(x0 + ww, state.width)
    if cy1 <= cy0 or cx1 <= cx0:
        return None
    return ((slice(cy0, cy1), slice(cx0, cx1)),
            (slice(cy0 - y0, cy1 - y0), slice(cx0 - x0, cx1 - x0)))


def _weights(weight: np.ndarray) -> np.ndarray:
    a = np.asarray(weight, dtype=F32)
    if a.ndim != 2 or not np.isfinite(a).all() or (a < 0).any() or (a > 1).any():
        raise CanvasInputError("tool weights must be a 2-D array of numbers in [0, 1]", "tool")
    return a


# ------------------------------------------------------------------ hair dryer
@dataclass(frozen=True)
class HairDryer:
    """A hair dryer held over the canvas.

    cx, cy: centre [cells]; radius: where its air still dries [cells]; temperature: of the
    air at the sheet [C]; airflow: mass-transfer factor of its jet relative to the room's
    reference draught [1]. The defaults (40 C, twice the draught) dry about six times
    faster than the room, as a hand dryer held at arm's length does.
    """

    cx: float
    cy: float
    radius: float = 60.0
    temperature: float = 40.0
    airflow: float = 2.0

    def __post_init__(self) -> None:
        for name in ("cx", "cy", "radius", "temperature", "airflow"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise CanvasInputError(f"hair dryer {name} must be a finite number", "hairdryer")
        if not 1.0 <= self.radius <= 2048.0:
            raise CanvasInputError("hair dryer radius must lie in [1, 2048] cells", "hairdryer")
        if not 0.0 <= self.airflow <= 200.0:
            raise CanvasInputError("hair dryer airflow must lie in [0, 200]", "hairdryer")
        if not -10.0 <= self.temperature <= 60.0:
            raise CanvasInputError("hair dryer temperature must lie in [-10, 60] C", "hairdryer")

    def extra_power(self, prm: SimParams) -> float:
        """Drying power under the jet's centre minus the room's (relative units) [1]."""
        jet = prm.replace(temperature=self.temperature, airflow=self.airflow)
        return max(jet.drying_power() - prm.drying_power(), 0.0)


def blow(state: CanvasState, dryer: HairDryer, dt: float) -> float:
    """Evaporate for ``dt`` seconds what the dryer's air takes beyond the room's.

    Fluid water goes first at ``eps_shallow * extra * weight``; where none is left the
    capillary water dries at ``eps_cap * extra * weight``. Booked in ``evaporated``.
    Returns the water evaporated [height * cells].
    """
    prm = state.params
    extra = dryer.extra_power(prm)
    if extra <= 0 or dt <= 0:
        return 0.0
    fp = gaussian_footprint(dryer.radius)
    r = (fp.shape[0] - 1) // 2
    win = _window(state, fp.shape, int(round(dryer.cy)) - r, int(round(dryer.cx)) - r)
    if win is None:
        return 0.0
    (ys, xs), (ay, ax) = win
    wgt = fp[ay, ax]
    w = state.w[ys, xs]
    wc = state.wc[ys, xs]
    lw = np.minimum(w, F32(prm.eps_shallow * extra * dt) * wgt)
    w_new = w - lw
    lc = np.where(w_new == 0, np.minimum(wc, F32(prm.eps_cap * extra * dt) * wgt), F32(0))
    state.w[ys, xs] = w_new
    state.wc[ys, xs] = wc - lc
    # paper dried out: no wet phase left there (pass 10's rule for wet_area)
    state.wet_area[ys, xs] = np.where(wc - lc > 0, state.wet_area[ys, xs], F32(0))
    state.evaporated[ys, xs] += lw + lc
    return float(lw.sum(dtype=np.float64) + lc.sum(dtype=np.float64))


# ------------------------------------------------------------------ pickup
@dataclass(frozen=True)
class Pickup:
    """What a pickup took from the canvas: water [height * cells], pigment per name
    [area fraction * cells]."""

    water: float
    pigment: dict[str, float]


def pickup(state: CanvasState, weight: np.ndarray, *, y0: int = 0, x0: int = 0,
           thirst: float = 0.8, scrub: float = 0.25, wet_depth: float = 0.0,
           room: float = float("inf")) -> Pickup:
    """A brush footprint ``weight`` (contact in [0, 1], top-left at row ``y0``, column
    ``x0``) touching the canvas takes paint into the brush.

    Where fluid water stands under the brush, bristles scrub deposited pigment back into
    suspension: ``q * (1 - exp(-scrub * weight / beta_k))`` (``beta_k`` the pigment's
    staining: staining pigments stay put), capped so ``p <= 1``; then the brush drinks
    ``thirst * weight`` of the fluid water and the same share of the suspended pigment
    (pigment leaves with the water that carries it). Everything taken is booked in
    ``removed_w`` / ``removed_p`` and returned. A dry canvas gives nothing: a brush
    only lifts paint it has wetted first. ``thirst`` in [0, 1], ``scrub`` >= 0 [1].

    Two limits for a brush that is already loaded (the deformable brush's dirty-brush
    pickup calls this function): ``wet_depth`` > 0 [height] makes the drink follow the
    standing water, ``share * clip(w / wet_depth, 0, 1)`` (bristles reach a puddle, not a
    damp film); ``room`` [height * cells] is the water the brush can still hold: a fuller
    take is scaled down as a whole (water and the pigment it carries).
    """
    if (not (0.0 <= thirst <= 1.0) or not (0.0 <= scrub <= 50.0) or not wet_depth >= 0.0
            or not room >= 0.0):
        raise CanvasInputError("pickup needs thirst in [0, 1], scrub in [0, 50], "
                               "wet_depth >= 0 and room >= 0", "pickup")
    wgt_all = _weights(weight)
    win = _window(state, wgt_all.shape, y0, x0)
    names = state.slot_pigments()
    if win is None:
        return Pickup(0.0, {})
    (ys, xs), (ay, ax) = win
    wgt = wgt_all[ay, ax]
    ns = max(len(state.slots), 1)
    beta, _gamma, _delta = slot_properties(state, lift=False)
    w = state.w[ys, xs]
    wet = (w > 0) & (state.mask[ys, xs] == 0)
    p = state.p[:ns, ys, xs]
    q = state.q[:ns, ys, xs]
    loose = np.where(wet, F32(1) - np.exp(-F32(scrub) * wgt / beta[:ns, None, None]), F32(0))
    lift = np.minimum(q * loose.astype(F32), np.maximum(F32(1) - p, F32(0)))
    p = p + lift
    q = q - lift
    share = np.where(wet, F32(thirst) * wgt, F32(0)).astype(F32)
    if wet_depth > 0.0:
        share = (share * np.clip(w / F32(wet_depth), F32(0), F32(1))).astype(F32)
    tw = w * share
    total = float(tw.sum(dtype=np.float64))
    if total > room:  # a full brush takes no more
        share = (share * F32(room / total)).astype(F32)
        tw = w * share
    tp = p * share
    state.w[ys, xs] = w - tw
    state.p[:ns, ys, xs] = p - tp
    state.q[:ns, ys, xs] = q
    state.removed_w[ys, xs] += tw
    state.removed_p[:ns, ys, xs] += tp
    taken = {pig.name: float(tp[k].sum(dtype=np.float64)) for k, pig in enumerate(names)
             if k < ns}
    return Pickup(float(tw.sum(dtype=np.float64)), taken)


@dataclass(frozen=True, slots=True)
class StateSurface:
    """A canvas state as the brush's reservoir sees it (``station.brush.reservoir.WetSurface``):
    a loaded brush gliding over paint lifts the suspended pigment only (no scrubbing)."""

    state: CanvasState

    def lift(self, weight: np.ndarray, y0: int, x0: int, thirst: float, wet_depth: float,
             room: float) -> Pickup:
        return pickup(self.state, weight, y0=y0, x0=x0, thirst=thirst, scrub=0.0,
                      wet_depth=wet_depth, room=room)
