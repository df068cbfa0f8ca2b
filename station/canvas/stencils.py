"""Stencils shared by the reference passes (``reference.py`` is the contract): the wet
mask, the capillary capacity, faces, fluxes, the implicit diffusion, the flow-outward
pressure."""

from __future__ import annotations

import numpy as np

from station.canvas.params import SimParams

F32 = np.float32
_ZERO = F32(0.0)
_ONE = F32(1.0)


# ---------------------------------------------------------------- helpers
def own_wet(w: np.ndarray, wc: np.ndarray, mask: np.ndarray, prm: SimParams) -> np.ndarray:
    """Cells wet by their own water: fluid water, or capillary water above the moist
    threshold, and not masked (bool (H, W)); the wet area the flow-outward term blurs."""
    return ((w > 0) | (wc > F32(prm.moist_threshold))) & (mask == 0)


def wet_memory(own: np.ndarray, area: np.ndarray, prm: SimParams) -> np.ndarray:
    """The wet-area mask ``M`` the flow-outward term blurs: with ``wet_hold > 0``
    ``max(wet_area, own)`` (float32; the cells wet in this wet phase, Curtis 1997), else
    ``own`` itself."""
    if prm.wet_hold > 0:
        return np.maximum(area, own.astype(F32))
    return own


def wet_area_update(area_m: np.ndarray, w: np.ndarray, wc: np.ndarray, mask: np.ndarray,
                    prm: SimParams, dt: float) -> np.ndarray:
    """``wet_area`` after a step (the end of pass 10), from ``area_m`` = :func:`wet_memory`
    at the start of the step: 1 where the cell is wet by its own water now, else
    ``max(area_m - dt / wet_hold, 0)`` while the paper is damp (``wc > 0``), else 0."""
    fade = F32(dt / prm.wet_hold)
    own = own_wet(w, wc, mask, prm)
    kept = np.where(wc > _ZERO, np.maximum(area_m - fade, _ZERO), _ZERO)
    return np.where(own, _ONE, kept).astype(F32)


def axis_neighbours(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The larger of each cell's two x neighbours' ``w`` and of its two y neighbours'
    (float32; cells outside count as 0)."""
    nx = np.zeros(w.shape, F32)
    nx[:, :-1] = w[:, 1:]
    nx[:, 1:] = np.maximum(nx[:, 1:], w[:, :-1])
    ny = np.zeros(w.shape, F32)
    ny[:-1, :] = w[1:, :]
    ny[1:, :] = np.maximum(ny[1:, :], w[:-1, :])
    return nx, ny


def wet_mask(w: np.ndarray, wc: np.ndarray, mask: np.ndarray, prm: SimParams,
             h: np.ndarray, fibre: np.ndarray | None = None,
             area: np.ndarray | None = None) -> np.ndarray:
    """Cells taking part in the fluid and surface layers this step (bool (H, W)).

    With ``advance_height > 0`` an unmasked dry cell also joins when
    a 4-neighbour's fluid water stands above the cell's advancing height
    ``advance_height * (1.5 - h)``: the contact line creeps on where the paper lets it. On
    paper damper than ``damp_sat`` the height is ``advance_height * (1 + g/2 - g h)``
    (:func:`advance_term`, ``g`` = ``advance_grain``).
    With ``fibre_wick > 0`` and the fibre texture ``fibre`` (2, H, W), that height is
    lowered by ``1 - fibre_wick * fibre[axis]`` for the neighbours on each axis: along a
    fibre the water is not pinned.

    With ``advance_curvature > 0`` the reach on paper no damper than ``damp_sat`` is
    :func:`front_curvature`'s.

    On paper no damper than ``damp_sat`` (``min(wc / c, 1)``) the front advances into a
    cell only with a neighbour beside it: at least two of its 4-neighbours are wet or
    advancing with it (:func:`pinned`).

    With ``damp_exposure`` and the wet-area mask ``area`` (:func:`wet_memory` at the start
    of the step) the cells :func:`sheltered` names do not join, after the pinning.
    """
    out = _wet_mask(w, wc, mask, prm, h, fibre)
    if area is None or prm.damp_exposure <= 0:
        return out
    shut = sheltered(area, own_wet(w, wc, mask, prm), wc, h, prm)
    return out if shut is None else out & ~shut


def sheltered(area: np.ndarray, own: np.ndarray, wc: np.ndarray, h: np.ndarray,
              prm: SimParams) -> np.ndarray | None:
    """The damp cells (``min(wc / c, 1) > damp_sat``, not ``own``) whose exposure ``1 -
    M'`` is below ``damp_exposure``, ``M'`` = :func:`blurred_wet` of the wet-area mask
    ``area`` with the flow-outward term's taps (bool; None when the rule is off: no
    ``damp_exposure``, ``flow_outward`` or ``wet_blur``). Fresh water in a damp wash must
    push the wash's paint on through the damp paper; it gives way where there is paper
    around to take it, at the front's bulges, and holds in its bays."""
    taps = gaussian_taps(prm.wet_blur)
    if prm.damp_exposure <= 0 or prm.flow_outward <= 0 or len(taps) == 0:
        return None
    damp = np.minimum(wc / capacity(h, prm), _ONE) > F32(prm.damp_sat)
    exposure = _ONE - blurred_wet(area, taps)
    out: np.ndarray = damp & ~own & (exposure < F32(prm.damp_exposure))
    return out


def _wet_mask(w: np.ndarray, wc: np.ndarray, mask: np.ndarray, prm: SimParams,
              h: np.ndarray, fibre: np.ndarray | None) -> np.ndarray:
    """:func:`wet_mask` without the damp exposure."""
    own = own_wet(w, wc, mask, prm)
    if prm.advance_height > 0:
        thr = F32(prm.advance_height) * advance_term(wc, h, prm)
        if prm.damp_ease > 0:
            thr = thr * damp_factor(wc, h, prm)
        if prm.fibre_wick > 0 and fibre is not None:
            # a fibre along the face axis wicks the front on: lower pinning height
            thx = thr * (_ONE - F32(prm.fibre_wick) * fibre[0])
            thy = thr * (_ONE - F32(prm.fibre_wick) * fibre[1])
            nx, ny = axis_neighbours(w)
            line = front_curvature(w, wc, h, prm, thr, (nx > thx) | (ny > thy))
            return own | pinned(own, line & (mask == 0), wc, h, prm)
        nb = np.zeros(w.shape, F32)
        nb[:, :-1] = w[:, 1:]
        nb[:, 1:] = np.maximum(nb[:, 1:], w[:, :-1])
        nb[:-1, :] = np.maximum(nb[:-1, :], w[1:, :])
        nb[1:, :] = np.maximum(nb[1:, :], w[:-1, :])
        line = front_curvature(w, wc, h, prm, thr, nb > thr)
        own = own | pinned(own, line & (mask == 0), wc, h, prm)
    return own


def front_curvature(w: np.ndarray, wc: np.ndarray, h: np.ndarray, prm: SimParams,
                    thr: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Where the contact line reaches (bool (H, W)): ``line`` (a neighbour's water above
    the advancing height ``thr``), but with ``advance_curvature`` ``a > 0`` on paper no
    damper than ``damp_sat`` (``min(wc / c, 1)``) where the neighbourhood's water
    ``((w_E + w_W) + w_S) + w_N + a (((w_SE + w_SW) + w_NE) + w_NW)`` (cells outside 0)
    exceeds ``float32(1 + 2a) * thr``: the meniscus's curvature (surface tension). A
    straight edge standing ``w`` deep meets the same height as before; a cell ahead of
    the front (the tip of a tab two cells wide: ``(1 + a) w``) needs more water, a notch
    behind it less. Read cell by cell from the paper height, the old reach let single
    columns run ahead into dry paper, and :func:`pinned` grew them into rectangular tabs
    2-3 cells across: the front dried as battlements."""
    if prm.advance_curvature <= 0:
        return line
    a = F32(prm.advance_curvature)
    p = np.pad(w, 1)
    s4 = ((p[1:-1, 2:] + p[1:-1, :-2]) + p[2:, 1:-1]) + p[:-2, 1:-1]
    sd = ((p[2:, 2:] + p[2:, :-2]) + p[:-2, 2:]) + p[:-2, :-2]
    reach = (s4 + a * sd) > F32(1.0 + 2.0 * prm.advance_curvature) * thr
    damp = np.minimum(wc / capacity(h, prm), _ONE) > F32(prm.damp_sat)
    out: np.ndarray = np.where(damp, line, reach)
    return out


def pinned(own: np.ndarray, crept: np.ndarray, wc: np.ndarray, h: np.ndarray,
           prm: SimParams) -> np.ndarray:
    """The cells of ``crept`` (dry cells the contact line reaches) it advances into: on
    paper damper than ``damp_sat`` all of them (the front runs on in the capillary film: a
    bloom's fingers), on drier paper those with at least two 4-neighbours wet (``own``) or
    advancing with them (cells outside count as dry). Surface tension pins a front on dry
    paper: a one-cell finger's meniscus would bend over a cell. Without this, a lone cell
    of high paper past a straight wet edge took the water, and the outward flow filled
    that dead end with pigment to the brim (q 1.0 dried): 2.6 one-cell whiskers per 100
    edge cells along a dried flat stroke; a tongue two cells wide still creeps on."""
    a = (own | crept).astype(np.int8)
    n4 = np.zeros(a.shape, np.int8)
    n4[:, :-1] += a[:, 1:]
    n4[:, 1:] += a[:, :-1]
    n4[:-1, :] += a[1:, :]
    n4[1:, :] += a[:-1, :]
    damp = np.minimum(wc / capacity(h, prm), _ONE) > F32(prm.damp_sat)
    out: np.ndarray = crept & ((n4 >= 2) | damp)
    return out


def advance_base(prm: SimParams) -> np.float32:
    """``1 + advance_grain / 2`` (float32), see :func:`advance_term`."""
    return F32(1.0 + 0.5 * prm.advance_grain)


def advance_term(wc: np.ndarray, h: np.ndarray, prm: SimParams) -> np.ndarray:
    """The paper's share of the advancing height (float32): ``1.5 - h`` on paper no damper
    than ``damp_sat`` (``min(wc / c, 1)``: the meniscus pins on the fibres' relief, so a
    wet-on-dry edge follows the tooth), ``advance_base - advance_grain * h`` on damper
    paper, where the capillary film levels the relief. With the default grain 1 both are
    ``1.5 - h`` exactly (``1 * h`` is ``h``). Read cell by cell on damp paper, the paper's
    height blobs (several cells across) made a creeping front stop and run on in blocks
    and notches of whole cells."""
    dry = F32(1.5) - h
    if prm.advance_grain == 1.0:
        return dry
    damp = np.minimum(wc / capacity(h, prm), _ONE) > F32(prm.damp_sat)
    out: np.ndarray = np.where(damp, advance_base(prm) - F32(prm.advance_grain) * h, dry)
    return out.astype(F32)


def capacity(h: np.ndarray, prm: SimParams) -> np.ndarray:
    """Capillary capacity ``c = c_min + h (c_max - c_min)`` [height], float32."""
    return F32(prm.c_min) + h * F32(prm.c_max - prm.c_min)


def damp_factor(wc: np.ndarray, h: np.ndarray, prm: SimParams) -> np.ndarray:
    """``max(1 - damp_ease * ((4 s') (1 - s')), 0)`` with ``s' = max(s - damp_sat, 0) /
    (1 - damp_sat)``, ``s = min(wc / c, 1)``: the share of the advancing height left to
    overcome (float32). Paper drier than ``damp_sat`` pins the front (1), a full capillary
    layer has no suction (1), damp paper in between draws fresh water in."""
    s = np.minimum(wc / capacity(h, prm), _ONE)
    sp = np.maximum(s - F32(prm.damp_sat), _ZERO) / F32(1.0 - prm.damp_sat)
    f = _ONE - F32(prm.damp_ease) * ((F32(4.0) * sp) * (_ONE - sp))
    return np.maximum(f, _ZERO).astype(F32)


def water_speed(vx: np.ndarray, vy: np.ndarray, prm: SimParams) -> np.ndarray:
    """The fibre dispersion's water speed ``min(sqrt(vx*vx + vy*vy), fibre_flow_max)``
    [cell/s], float32: water moves through the paper's channels no faster than that."""
    return np.minimum(np.sqrt(vx * vx + vy * vy), F32(prm.fibre_flow_max)).astype(F32)


def open_faces(wet: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Open faces (both cells wet): x faces (H, W-1) and y faces (H-1, W), bool."""
    return wet[:, :-1] & wet[:, 1:], wet[:-1, :] & wet[1:, :]


def neighbour_sum(x: np.ndarray, bx: np.ndarray, by: np.ndarray) -> np.ndarray:
    """sum over the 4 faces of ``b_face * x_neighbour`` (x may have leading axes)."""
    s = np.empty_like(x)
    np.multiply(bx, x[..., :, 1:], out=s[..., :, :-1])  # east neighbours
    s[..., :, -1] = 0
    s[..., :, 1:] += bx * x[..., :, :-1]  # west
    s[..., :-1, :] += by * x[..., 1:, :]  # south
    s[..., 1:, :] += by * x[..., :-1, :]  # north
    return s


def apply_fluxes(u: np.ndarray, fx: np.ndarray, fy: np.ndarray) -> np.ndarray:
    """``u`` after face fluxes (positive: lower-index cell -> higher-index cell)."""
    out = u.copy()
    out[..., :, :-1] -= fx
    out[..., :, 1:] += fx
    out[..., :-1, :] -= fy
    out[..., 1:, :] += fy
    return out


def implicit_diffusion(u: np.ndarray, bx: np.ndarray, by: np.ndarray, k: float,
                       iters: int) -> np.ndarray:
    """Conservative implicit diffusion (pass 4/5 maths, see module docstring).

    ``u`` (..., H, W) >= 0; ``bx`` (H, W-1) and ``by`` (H-1, W) face conductances in [0, 1];
    ``k = nu * dt`` [cell^2]. Returns the new field, float32.
    """
    if k <= 0:
        return u.copy()
    kk = F32(k)
    denom = _ONE + kk * neighbour_sum(np.ones(u.shape[-2:], F32), bx, by)
    x = u
    for _ in range(int(iters)):
        acc = neighbour_sum(x, bx, by)
        acc *= kk
        acc += u
        acc /= denom
        x = acc
    fx = kk * bx * (x[..., :, :-1] - x[..., :, 1:])
    fy = kk * by * (x[..., :-1, :] - x[..., 1:, :])
    fxp, fxn = np.maximum(fx, _ZERO), np.minimum(fx, _ZERO)
    fyp, fyn = np.maximum(fy, _ZERO), np.minimum(fy, _ZERO)
    out = np.zeros(u.shape, F32)
    out[..., :, :-1] += fxp
    out[..., :, 1:] -= fxn
    out[..., :-1, :] += fyp
    out[..., 1:, :] -= fyn
    # donor limiter: never move more than a cell holds. A cell the limiter itself left a
    # rounding error below zero holds nothing: clamped to 0 it gives nothing (s = 0)
    # instead of a division by a zero outflow (-inf, then NaN fluxes that wipe a wash).
    held = np.maximum(u, _ZERO)
    short = out > held
    if short.any():
        s = np.where(short, held / np.where(short, out, _ONE), _ONE).astype(F32)
        fx = fxp * s[..., :, :-1] + fxn * s[..., :, 1:]
        fy = fyp * s[..., :-1, :] + fyn * s[..., 1:, :]
    return apply_fluxes(u, fx, fy)


def gaussian_taps(sigma: float) -> np.ndarray:
    """Normalised float32 Gaussian taps ``g[0..2R]``, ``R = ceil(2 sigma)`` (empty: sigma 0)."""
    if sigma <= 0:
        return np.zeros(0, F32)
    r = int(np.ceil(2.0 * sigma))
    d = np.arange(-r, r + 1, dtype=np.float64)
    g = np.exp(-0.5 * (d / sigma) ** 2)
    return (g / g.sum()).astype(F32)


def blurred_wet(wet: np.ndarray, taps: np.ndarray) -> np.ndarray:
    """``M'``: the wet mask blurred separably (x, then y) with ``taps``; cells outside the
    region count as non-wet. Each sum runs over the taps in order, offset -R first."""
    hh, ww = wet.shape
    r = (len(taps) - 1) // 2
    m = np.pad(wet.astype(F32), r)
    mx = np.zeros((hh + 2 * r, ww), F32)
    for k in range(2 * r + 1):
        mx = mx + taps[k] * m[:, k:k + ww]
    out = np.zeros((hh, ww), F32)
    for k in range(2 * r + 1):
        out = out + taps[k] * mx[k:k + hh, :]
    return out


def flow_pressure(w: np.ndarray, own: np.ndarray, wet: np.ndarray, h: np.ndarray,
                  prm: SimParams) -> np.ndarray:
    """The height the water-height term levels, on wet cells: the free surface over the
    paper, ``w + paper_relief * h``, lowered by ``flow_outward * (1 - M')`` near the edge
    of the wet area ``own`` (Curtis 1997: flow outward, and water runs downhill over the
    paper's relief); ``w`` elsewhere, and ``w`` itself when both terms are off. ``own``:
    the cells wet by their own water (bool), or the wet-area mask of :func:`wet_memory`
    (float32 in [0, 1]) when ``wet_hold > 0``."""
    taps = gaussian_taps(prm.wet_blur)
    outward = prm.flow_outward > 0 and len(taps) > 0
    if not outward and prm.paper_relief <= 0:
        return w
    pr = w
    if prm.paper_relief > 0:
        pr = w + F32(prm.paper_relief) * h
    if outward:
        mb = blurred_wet(own, taps)
        pr = pr - F32(prm.flow_outward) * outward_pull(_ONE - mb, prm)
    return np.where(wet, pr, w).astype(F32)


def outward_pull(u: np.ndarray, prm: SimParams) -> np.ndarray:
    """The flow outward's pull per unit ``flow_outward`` for the dry share ``u = 1 - M'``
    of each cell's blurred neighbourhood: ``u`` itself, or with ``rim_sharpness`` k
    ``(1 - k) u + k s``, ``s = min(max((u - rim_onset) inv, 0), 1)``
    (:meth:`SimParams.rim_profile`), in that order in float32.

    ``u`` falls off with the distance from the wet area's edge over the blur's reach: on a
    stroke narrower than about four blur widths it never reaches 0, so the pull differs
    little from the edge to the middle and the whole stroke drains to a soft gradient
    (the narrow stroke without a rim, the pale blotch a tapered touch-down leaves at its
    head). ``s`` is the same pull cut to the cells next to the contact line: full on the
    outermost ring or two, 0 a few cells in, whatever the stroke's width, so the water,
    and with it the pigment, gathers in a band at the pinned edge, as it does where the
    evaporating film's flow diverges at the contact line (Deegan et al. 1997)."""
    k, ci, a, inv = prm.rim_profile()
    if k <= 0:
        return u
    s = np.minimum(np.maximum((u - F32(a)) * F32(inv), _ZERO), _ONE)
    return (F32(ci) * u + F32(k) * s).astype(F32)


# ---------------------------------------------------------------- passes
