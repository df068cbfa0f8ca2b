"""Canvas operations on a :class:`CanvasState`: sources, dry, new layer, clear, profile.

All functions mutate the state in place and keep the bookkeeping honest: every
amount that enters or leaves is booked where it happens.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from station.canvas import tiles
from station.canvas.paper import make_paper
from station.canvas.params import CanvasInputError
from station.canvas.profiles import get_profile, profile_palette
from station.canvas.state import CanvasState

F32 = np.float32


def _placed(state: CanvasState, a: np.ndarray, y0: int, x0: int, what: str
            ) -> tuple[tuple[slice, slice], np.ndarray] | None:
    """Clip array ``a`` placed at (y0, x0) to the canvas: canvas slices + clipped array."""
    arr = np.asarray(a, dtype=F32)
    if arr.ndim != 2:
        raise CanvasInputError(f"source {what} must be a 2-D array", "add_sources")
    if not np.isfinite(arr).all():
        raise CanvasInputError(f"source {what} holds non-finite values", "add_sources")
    hh, ww = arr.shape
    cy0, cx0 = max(y0, 0), max(x0, 0)
    cy1, cx1 = min(y0 + hh, state.height), min(x0 + ww, state.width)
    if cy1 <= cy0 or cx1 <= cx0:
        return None
    sub = arr[cy0 - y0:cy1 - y0, cx0 - x0:cx1 - x0]
    return (slice(cy0, cy1), slice(cx0, cx1)), sub


def add_sources(state: CanvasState, dw: np.ndarray | None = None,
                dp: Mapping[str, np.ndarray] | None = None, dvx: np.ndarray | None = None,
                dvy: np.ndarray | None = None, *, y0: int = 0, x0: int = 0) -> None:
    """Spec step 1: add water, pigment and velocity sources; masked cells get none.

    Water is capped at ``w_max`` and pigment at 1; what is actually added is booked.
    Pigment names are validated (and slots assigned) before anything changes.
    """
    prm = state.params
    dp = dict(dp or {})
    # validate everything first so a bad pigment changes nothing
    placed_p = {}
    for name, arr in dp.items():
        state.palette.get(name)
        pl = _placed(state, arr, y0, x0, f"dp[{name!r}]")
        if pl is not None:
            if (pl[1] < 0).any():
                raise CanvasInputError("pigment sources must be >= 0", "add_sources")
            if pl[1].any():  # an all-zero source takes no slot
                placed_p[name] = pl
    placed_w = _placed(state, dw, y0, x0, "dw") if dw is not None else None
    if placed_w is not None and (placed_w[1] < 0).any():
        raise CanvasInputError("water sources must be >= 0", "add_sources")
    placed_v = [(_placed(state, a, y0, x0, n) if a is not None else None)
                for a, n in ((dvx, "dvx"), (dvy, "dvy"))]
    new = [n for n in placed_p if state.palette.get(n).name not in state.slots]
    free = state.n_slots - len(state.slots)
    if len({state.palette.get(n).name for n in new}) > free:
        raise CanvasInputError(
            f"the active layer holds {len(state.slots)} of {state.n_slots} pigments; "
            "start a new layer for more", "pigment")

    touched: list[tuple[tuple[slice, slice], np.ndarray]] = []
    if placed_w is not None:
        sl, a = placed_w
        before = state.w[sl]
        after = np.where(state.mask[sl] == 0, np.minimum(before + a, F32(prm.w_max)), before)
        after = np.maximum(after, before)  # a full cell stays as it is
        state.water_added += float((after - before).sum(dtype=np.float64))
        state.w[sl] = after
        touched.append((sl, a))
    for name, (sl, a) in placed_p.items():
        k = state.slot_of(name)
        pname = state.slots[k]
        before = state.p[k][sl]
        after = np.where(state.mask[sl] == 0, np.minimum(before + a, F32(1.0)), before)
        after = np.maximum(after, before)
        state.pigment_added[pname] = state.pigment_added.get(pname, 0.0) + float(
            (after - before).sum(dtype=np.float64))
        state.p[k][sl] = after
        touched.append((sl, a))
    vm = F32(prm.v_max)
    for field, pl in zip((state.vx, state.vy), placed_v, strict=True):
        if pl is None:
            continue
        sl, a = pl
        field[sl] = np.where(state.mask[sl] == 0, np.clip(field[sl] + a, -vm, vm), field[sl])
        touched.append((sl, a))
    for sl, a in touched:
        tiles.mark_nonzero(state, sl[0], sl[1], a)


FOLD_EVERY = 512
"""Steps between folds of the per-cell evaporation accumulator into the float64 total."""


def fold_accumulators(state: CanvasState) -> None:
    """Move the per-cell evaporated water into the float64 total (exact bookkeeping).

    A float32 accumulator that has grown large rounds each small increment; folding it
    regularly keeps the bookkeeping within 1e-5 over sessions of any length.
    """
    state.evaporated_folded += float(state.evaporated.sum(dtype=np.float64))
    state.evaporated[...] = 0


def dry(state: CanvasState) -> None:
    """UI "dry": all suspended pigment settles (``q += p``), all water evaporates (booked)."""
    evap = state.w.astype(np.float64) + state.wc
    state.evaporated += evap.astype(F32)
    state.w[...] = 0
    state.wc[...] = 0
    state.wet_area[...] = 0  # dry paper: no wet phase left
    state.vx[...] = 0
    state.vy[...] = 0
    t = np.minimum(state.p, F32(1.0) - state.q)
    state.q += t
    state.p -= t
    # what cannot settle (q already 1) is booked as removed so nothing is lost unseen
    if state.p.any():
        state.removed_p += state.p
        state.p[...] = 0
    state.tile_ttl[...] = 0


def fold_pigment_totals(state: CanvasState) -> dict[str, float]:
    """Per pigment name: surface amount of the active layer (float64 totals)."""
    return {name: float(state.q[k].sum(dtype=np.float64)) for k, name in enumerate(state.slots)}


def new_layer(state: CanvasState, composed: np.ndarray) -> None:
    """Dry, set ``r_composed = composed`` (the render of the dried canvas), free the slots.

    ``composed`` is float32 (H, W, 3), computed by the caller's renderer. Masked cells
    never receive anything, so nothing lies above them; what was under the mask when it
    was applied stays (protected), and the mask itself stays until ``remove_mask``.
    """
    dry(state)
    state.r_composed[...] = composed
    layer = fold_pigment_totals(state)
    state.layers.append(layer)
    for k, name in enumerate(state.slots):
        state.pigment_dried[name] = state.pigment_dried.get(name, 0.0) + layer[name]
        state.pigment_removed_past[name] = state.pigment_removed_past.get(name, 0.0) + float(
            state.removed_p[k].sum(dtype=np.float64))
    state.p[...] = 0
    state.q[...] = 0
    state.removed_p[...] = 0
    state.slots = []


def apply_mask(state: CanvasState, region: np.ndarray, *, y0: int = 0, x0: int = 0) -> None:
    """Masking fluid: cells where ``region > 0`` (placed at y0, x0) get ``mask = 1``."""
    pl = _placed(state, region, y0, x0, "mask")
    if pl is None:
        return
    sl, a = pl
    state.mask[sl] = np.where(a > 0, F32(1.0), state.mask[sl])


def remove_mask(state: CanvasState) -> None:
    """Lift the masking fluid: fluid water and suspended pigment on masked cells go with it.

    What is removed is booked (``removed_w``, ``removed_p``); deposits under the mask stay.
    """
    masked = state.mask > 0
    if not masked.any():
        return
    state.removed_w += np.where(masked, state.w, F32(0.0))
    state.w[masked] = 0
    state.removed_p += np.where(masked, state.p, F32(0.0))
    state.p[:, masked] = 0
    state.vx[masked] = 0
    state.vy[masked] = 0
    state.mask[...] = 0
    tiles.activate_all_live(state)


def clear(state: CanvasState) -> None:
    """Blank paper again: every field but the paper height reset, bookkeeping reset."""
    for name in ("vx", "vy", "w", "wc", "mask", "block_time", "evaporated", "removed_w",
                 "p", "q", "removed_p", "wet_area"):
        getattr(state, name)[...] = 0
    state.evaporated_folded = 0.0
    state.block[...] = 1
    state.tile_ttl[...] = 0
    state.r_composed[...] = state.paper_reflectance()[..., None]
    state.slots = []
    state.water_added = 0.0
    state.pigment_added = {}
    state.pigment_removed_past = {}
    state.pigment_dried = {}
    state.layers = []


def set_profile(state: CanvasState, name: str) -> None:
    """Switch parameters and profile name; the paper stays (it is the physical sheet)."""
    prof = get_profile(name)
    if prof.params.tile_size != state.params.tile_size:
        raise CanvasInputError("profiles must share the tile size", "profile")
    # the render bands are the sheet's (r_composed holds them), not the medium's
    state.params = prof.params.replace(render_bands=state.r_composed.shape[-1])
    state.profile = prof.name
    state.palette = profile_palette(prof, state.palette)


def new_paper(name: str, width: int, height: int, seed: int) -> np.ndarray:
    """The paper of profile ``name`` (helper for backends)."""
    return make_paper(get_profile(name).paper, height, width, seed)
