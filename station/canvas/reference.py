"""NumPy reference of one canvas time step: the pass list is the contract.

The GL backend implements the same passes with the same maths; tests compare
them pass by pass. Everything is float32, arrays are indexed ``[y, x]`` (row,
column), "E/W" neighbours are ``x +/- 1`` and "S/N" neighbours ``y +/- 1``.
Cells outside the array (canvas border, or the edge of the simulated tile
region) are *non-wet with zero water, zero capillary water, zero velocity and
zero pigment*: every stencil treats them exactly like that, which is what makes
tiling on/off give the same result.

CHANGED: render.py gouache (not a step pass): the body colour is now R_inf = a - b of the
  KM mix of the cell's pigments WITH an implicit white filler of share
  ``gouache_white`` (new SimParams field, 0.25) using Titanium White's K and S:
  ``K = (1-g) sum s_k K_k + g K_w``, ``S = (1-g) sum s_k S_k + g S_w``; opacity unchanged.
CHANGED: add_sources activates only the tiles in which a source array is nonzero
  (``tiles.mark_nonzero``), not the whole source rectangle (results do not depend on it).
CHANGED: add_sources ignores a pigment whose source array is all zero (it takes no slot).
CHANGED: bookkeeping: ``CanvasState.evaporated_folded`` (float64 metadata, default 0) holds
  evaporated water folded out of the per-cell ``evaporated`` accumulator; NumpyCanvas.step
  calls ``operations.fold_accumulators`` every ``operations.FOLD_EVERY`` (512) steps and
  stats report ``evaporated_folded + sum(evaporated)``. Backends must carry the field
  through state()/load_state() (a float32 accumulator that grows large rounds small
  increments: 6e-5 relative error after 18k steps without folding, 2e-6 with).
CHANGED: wet mask: a dry unmasked cell is wet when a 4-neighbour's w exceeds
  ``advance_height * (1.5 - h)`` (new SimParams field; cells outside the region have w 0).
CHANGED: wet mask along the paper's fibres: with ``fibre_wick > 0`` the advancing height
  is ``advance_height * (1.5 - h) * (1 - fibre_wick * fibre[0])`` for the two x
  neighbours and ``... * fibre[1]`` for the two y neighbours (``CanvasState.fibre``, the
  paper's fibre texture): the front runs on along fibres (ink bleed).
CHANGED: passes 7 and 9c use ``prm.evap_shallow()`` / ``prm.evap_cap()``: eps_shallow and
  eps_cap scaled by the drying power of the air (temperature, humidity, airflow); exactly
  eps_* at the reference conditions 20 C, 50 %, airflow 1.
CHANGED: pass 3 levels ``P = (w + paper_relief h) - flow_outward (1 - M')`` instead of w
  (Curtis 1997's flow-outward term; new SimParams ``flow_outward``, ``wet_blur``,
  ``paper_relief``); ``edge_evap`` default 4 -> 1 (the spec's value); surface_rate
  0.5 -> 0.1 (Stokes settling of micron pigment through a film takes tens of seconds).
CHANGED: tiles.HALO = 2 (was 1): a dry cell next to a wet one can join the wet area,
  absorb, and pass capillary water one cell further within the step.
NOTE (API): ``stencil_radius(params) = jacobi_iters + STENCIL_RADIUS_EXTRA`` bounds how far
  one step reaches (the distributed canvas's halo); a term that reaches farther must raise
  ``STENCIL_RADIUS_EXTRA`` (``tests/test_stencil_radius.py`` measures it).
CHANGED: pass 3 adds the tilt's gravity ``(ax dt, ay dt)`` after the blend, before the
  boundary (new SimParams ``tilt``, ``tilt_direction``, ``gravity``; flat by default).
CHANGED: pass 5's beta_c is multiplied by ``1 + gd * (max(fibre[0], fibre[1]) * |v0|)``,
  ``gd = float32(SimParams.fibre_dispersion_gain()) = fibre_dispersivity / nu_p``, ``|v0| =
  min(sqrt(vx*vx + vy*vy), fibre_flow_max)`` of the velocity at the START of the step
  (before pass 1; new SimParams ``fibre_flow_max``, 2 cell/s): hydrodynamic
  dispersion ``D = alpha |v|`` along the paper's fibre channels (new SimParams
  ``fibre_dispersivity``, 0 = off; the watercolor profile sets it, and cold-press paper now
  has a fibre texture). Face conductances may exceed 1.
NOTE (API): ``PASS_ORDER`` names the passes; ``step_region(state, box, dt, stop_after=name)``
  writes the fields back right after pass ``name`` (pass-by-pass comparisons).
NOTE (no maths change): pass 1 computes the bilinear weight from the displacement,
  ``f = (-v dt) - floor(-v dt)``, with ``i0 = i + floor(-v dt)`` and the clamps of the
  formula below (i0 < 0 -> i0 = 0, f = 0; i0 >= n-1 -> i0 = n-2, f = 1); it equals
  ``X - floor(X)`` in exact arithmetic and does not depend on the region origin.
NOTE (no maths change): pass 6 evaluates ``r' = (r * s_out[donor]) * s_in[receiver]`` in
  that order; pass 4/5 skip the donor limiter when no cell is short (bitwise the same).

Notation: ``dt`` step [s]; ``own = ((w > 0) | (wc > moist_threshold)) & (mask == 0)``;
``wet = own | (unmasked and max_4-neighbours(w) > advance_height * (1.5 - h))`` (the
contact line advances where the paper lets it; off when ``advance_height == 0``)
is computed ONCE per step, after the sources were added, and used by passes 1-6
and 8. A *face* is the side shared by two 4-neighbours; a face is *open* when
both of its cells are wet (``fx[y, x]`` joins (y, x) and (y, x+1), shape (H, W-1);
``fy[y, x]`` joins (y, x) and (y+1, x), shape (H-1, W)). A face flux F > 0 flows
from the lower-index cell to the higher-index cell; applying fluxes means
``u[cell] -= F`` for the donor and ``u[other] += F`` for the receiver (exactly
the same float32 value on both sides).

0. sources (``add_sources``, before the step): for every unmasked cell
   ``w <- min(w + dw, w_max)``, ``p[k] <- min(p[k] + dp[k], 1)``,
   ``v <- clamp(v + dv, -v_max, v_max)``; the amounts actually added are booked.

1. ``advect_velocity`` (semi-Lagrangian, Stam 1999). Source field
   ``vs = v * wet``. For each wet cell: back-trace ``X = x - vx*dt``,
   ``Y = y - vy*dt``, clamp X to [0, W-1] and Y to [0, H-1]; ``x0 = min(floor(X),
   W-2)`` (0 when W == 1), ``fx = X - x0`` (same for y); bilinear
   ``(1-fy)((1-fx) vs[y0,x0] + fx vs[y0,x0+1]) + fy((1-fx) vs[y0+1,x0] + fx vs[y0+1,x0+1])``.
   Non-wet cells get 0.

2. ``diffuse_velocity`` (implicit, Jacobi): ``k = viscosity*dt``; per component u,
   ``x0 = u``; ``jacobi_iters`` times ``x <- (u + k * sum_{open faces} x_n) /
   (1 + k * n_open)`` (n_open = number of open faces of the cell; all old x, i.e.
   Jacobi not Gauss-Seidel); non-wet cells 0.

3. ``water_height_and_boundary``: the levelled height is the pressure
   ``P = (w + paper_relief * h) - flow_outward * (1 - M')`` on wet cells (``P = w``
   elsewhere; the free surface over the paper's relief, lowered near the edge by Curtis
   1997's flow outward; a term whose parameter is 0 is left out), ``M'`` = ``blurred_wet``:
   the wet mask (1/0) blurred with the float32
   Gaussian ``gaussian_taps(wet_blur)`` along x, then along y, each sum over the taps in
   order (offset -R first), cells outside the region 0. For each wet cell, neighbour
   heights (of P) ``wE = P[y,x+1]`` if face E is open else ``w[y,x]`` (same for W, N, S);
   ``vh = -height_gain * ((wE - wW)/2, (wS - wN)/2)``;
   ``v <- (1 - omega_h) v + omega_h vh``; then the tilt (``tilt_kick``: float32
   ``(ax dt, ay dt)`` of ``SimParams.tilt_acceleration``) is added to each component
   where it is nonzero (a flat canvas adds nothing); boundary (no flow into non-wet cells or
   the border): face E closed -> ``vx = min(vx, 0)``, face W closed -> ``vx = max(vx, 0)``,
   face S closed -> ``vy = min(vy, 0)``, face N closed -> ``vy = max(vy, 0)``;
   then clamp each component to [-v_max, v_max]; non-wet cells 0.

4. ``diffuse_water`` (conservative implicit diffusion, ``k = nu_w*dt``, conductance
   ``b = 1`` on open faces, 0 on closed): see ``implicit_diffusion`` below.

5. ``diffuse_pigment``: the same with ``k = nu_p*dt`` and the diffusion controller:
   cell value ``beta_c = min(1 - block_paper*(1 - h), block_eff)``, times
   ``(1 + gd * (max(fibre[0], fibre[1]) * min(sqrt(vx0*vx0 + vy0*vy0), fibre_flow_max)))`` when
   ``gd = fibre_dispersivity / nu_p > 0`` (v0: the velocity at the start of the step;
   hydrodynamic dispersion along the paper's fibre channels),
   ``block_eff = block + (1 - block) * clamp((sim_time - block_time)/block_fade, 0, 1)``
   (``block_fade == 0`` -> 1), face conductance ``b = min(beta_c[i], beta_c[j])`` on
   open faces. All slots at once.

   ``implicit_diffusion(u, b, k)``: ``B = sum_faces b``; ``x0 = u``; ``jacobi_iters``
   times ``x <- (u + k * sum_faces b * x_n) / (1 + k*B)`` (the seed's
   ``(a u + sum b x_n) / (a + sum b)`` with ``a = 1/k``); then face fluxes
   ``F = k * b * (x_i - x_j)`` (i the lower-index cell); donor limiter: per cell
   ``out = sum of F leaving it``, ``s = u/out if out > u else 1``; each face flux is
   multiplied by ``s`` of its donor; ``u_new = u - sum F_out + sum F_in``. Exactly
   mass-conserving for any iteration count, equal to the implicit solution when
   converged, never negative.

6. ``advect_water_and_pigment`` (conservative face fluxes, seed 4.5.2/4.5.4):
   face velocity ``uf = (vx_i + vx_j)/2`` (x faces) / ``(vy_i + vy_j)/2`` (y faces) on
   open faces, 0 on closed; rate ``r = |uf| * dt / 4`` (the four faces' contributions
   are summed and divided by four); donor = upwind cell (i if uf > 0, else j).
   Per cell: ``Rout = sum of r over faces where it donates``; ``lo = min(w, w_min)``;
   ``s_out = (w - lo)/(w*Rout) if w*Rout > w - lo else 1``.
   ``Iw = sum over faces where it receives of w_donor*r`` and per pigment
   ``Ip[k] = sum p_donor[k]*r``; ``hi = max(w, w_max)``;
   ``s_in = min(1, (hi - w)/Iw, min_k (1 - p[k])/Ip[k])`` (terms with a zero
   denominator are skipped; negative numerators count as 0).
   Limited rate ``r' = r * s_out[donor] * s_in[receiver]``; water flux ``w_donor*r'``,
   pigment flux ``p_donor[k]*r'`` (pigment moves with the water that carries it:
   ``p * flux / w_upwind``). Then apply. Guarantees: no cell leaves
   ``[min(w, w_min), max(w, w_max)]`` or p leaves [0, 1]; closed faces carry nothing.

7. ``evaporate`` (fluid layer, seed 4.5.3): for each cell with ``w > 0``:
   ``n = number of 4-neighbours with w == 0`` (border counts as w == 0),
   ``loss = min(w, eps_shallow*dt + edge_evap*n*w*eps_shallow*dt)``;
   ``w -= loss``; ``evaporated += loss``.

8. ``surface_exchange`` (seed 4.6), per slot k, wet cells only, ``f = clamp(w/w_max, 0, 1)``:
   ``down = surface_rate*dt * p (1 - f)(1 - h*gamma) delta``,
   ``up = surface_rate*dt * q f (1 - (1 - h)*gamma) delta / beta``;
   ``down = min(down, p, 1 - q)``; ``up = min(up, q, 1 - p)``;
   ``p += up - down``; ``q += down - up``. Free slots have delta = 0.

9. ``capillary`` (seed 4.7.2), ALL cells (not only wet), ``c = c_min + h (c_max - c_min)``,
   ``open = (mask == 0)``:
   a. absorb: where ``w > 0`` and open: ``d = min(alpha*dt, w, max(c - wc, 0))``;
      ``w -= d``; ``wc += d``;
   b. diffuse (explicit, one step): saturation ``s = wc / c``; face flux
      ``F = cap_diffusion*dt * min(c_i, c_j) * (s_i - s_j)`` on faces with both cells
      open (0 otherwise); apply (``cap_diffusion*dt <= 1/8`` keeps wc in [0, c]), then
      ``wc = max(wc, 0)`` (guards float rounding only);
   c. evaporate: where ``w == 0``: ``e = min(eps_cap*dt, wc)``; ``wc -= e``;
      ``evaporated += e``.

10. ``dry_cells`` (seed 4.7, spec step 8): cells with ``0 < w < w_dry_eps`` lose the
    rest to evaporation (booked); then every cell with ``w == 0`` deposits
    ``t = min(p[k], 1 - q[k])``: ``q += t``, ``p -= t``, and gets ``v = 0``.

Then ``sim_time += dt``, ``step_count += 1`` and the dirty tiles are updated
(``tiles.py``). With tiling on, passes run on the bounding box of each 8-connected
group of active tiles plus a one-cell halo (overlapping boxes merged, so boxes are
disjoint); all other cells are inactive (w == 0, wc == 0, v == 0) and no pass changes
them, so the result is the same as with tiling off.
"""

from __future__ import annotations

import numpy as np

from station.canvas import tiles
from station.canvas.params import CanvasInputError, SimParams
from station.canvas.state import CanvasState

F32 = np.float32
_ZERO = F32(0.0)
_ONE = F32(1.0)


# ---------------------------------------------------------------- helpers
def own_wet(w: np.ndarray, wc: np.ndarray, mask: np.ndarray, prm: SimParams) -> np.ndarray:
    """Cells wet by their own water: fluid water, or capillary water above the moist
    threshold, and not masked (bool (H, W)); the wet area the flow-outward term blurs."""
    return ((w > 0) | (wc > F32(prm.moist_threshold))) & (mask == 0)


def wet_mask(w: np.ndarray, wc: np.ndarray, mask: np.ndarray, prm: SimParams,
             h: np.ndarray, fibre: np.ndarray | None = None) -> np.ndarray:
    """Cells taking part in the fluid and surface layers this step (bool (H, W)).

    With ``advance_height > 0`` an unmasked dry cell also joins when
    a 4-neighbour's fluid water stands above the cell's advancing height
    ``advance_height * (1.5 - h)``: the contact line creeps on where the paper lets it.
    With ``fibre_wick > 0`` and the fibre texture ``fibre`` (2, H, W), that height is
    lowered by ``1 - fibre_wick * fibre[axis]`` for the neighbours on each axis: along a
    fibre the water is not pinned.
    """
    own = own_wet(w, wc, mask, prm)
    if prm.advance_height > 0:
        thr = F32(prm.advance_height) * (F32(1.5) - h)
        if prm.damp_ease > 0:
            thr = thr * damp_factor(wc, h, prm)
        if prm.fibre_wick > 0 and fibre is not None:
            # a fibre along the face axis wicks the front on: lower pinning height
            thx = thr * (_ONE - F32(prm.fibre_wick) * fibre[0])
            thy = thr * (_ONE - F32(prm.fibre_wick) * fibre[1])
            nx = np.zeros(w.shape, F32)
            nx[:, :-1] = w[:, 1:]
            nx[:, 1:] = np.maximum(nx[:, 1:], w[:, :-1])
            ny = np.zeros(w.shape, F32)
            ny[:-1, :] = w[1:, :]
            ny[1:, :] = np.maximum(ny[1:, :], w[:-1, :])
            return own | (((nx > thx) | (ny > thy)) & (mask == 0))
        nb = np.zeros(w.shape, F32)
        nb[:, :-1] = w[:, 1:]
        nb[:, 1:] = np.maximum(nb[:, 1:], w[:, :-1])
        nb[:-1, :] = np.maximum(nb[:-1, :], w[1:, :])
        nb[1:, :] = np.maximum(nb[1:, :], w[:-1, :])
        own = own | ((nb > thr) & (mask == 0))
    return own


def capacity(h: np.ndarray, prm: SimParams) -> np.ndarray:
    """Capillary capacity ``c = c_min + h (c_max - c_min)`` [height], float32."""
    return F32(prm.c_min) + h * F32(prm.c_max - prm.c_min)


def damp_factor(wc: np.ndarray, h: np.ndarray, prm: SimParams) -> np.ndarray:
    """``min(damp_ease * (1 - wc / c), 1)``: the share of the advancing height left to
    overcome on paper whose capillary layer is already this saturated (float32); 0 on a
    full capillary layer, 1 below the saturation ``1 - 1 / damp_ease``."""
    f = F32(prm.damp_ease) * (_ONE - wc / capacity(h, prm))
    return np.minimum(f, _ONE).astype(F32)


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
    of the ``own`` wet area (Curtis 1997: flow outward, and water runs downhill over the
    paper's relief); ``w`` elsewhere, and ``w`` itself when both terms are off."""
    taps = gaussian_taps(prm.wet_blur)
    outward = prm.flow_outward > 0 and len(taps) > 0
    if not outward and prm.paper_relief <= 0:
        return w
    pr = w
    if prm.paper_relief > 0:
        pr = w + F32(prm.paper_relief) * h
    if outward:
        mb = blurred_wet(own, taps)
        pr = pr - F32(prm.flow_outward) * (_ONE - mb)
    return np.where(wet, pr, w).astype(F32)


# ---------------------------------------------------------------- passes
def _backtrace_axis(disp: np.ndarray, n: int, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """Left sample index (intp) and weight of the back-trace ``X = i - disp`` on one axis.

    Same maths as ``X = clamp(i - disp, 0, n-1)``, ``i0 = min(floor(X), n-2)``,
    ``f = X - i0``, but the fraction is computed from the displacement alone
    (``|disp| <= 1``), so the result does not depend on where the simulated region
    starts: tiling cannot change the rounding.
    """
    off = -disp
    fl = np.floor(off)
    frac = (off - fl).astype(F32)
    shape = [1, 1]
    shape[axis] = n
    idx = np.arange(n, dtype=np.intp).reshape(shape) + fl.astype(np.intp)
    if n < 2:
        return np.zeros(disp.shape, np.intp), np.zeros(disp.shape, F32)
    low = idx < 0
    high = idx >= n - 1
    idx = np.where(low, 0, np.where(high, n - 2, idx))
    frac = np.where(low, _ZERO, np.where(high, _ONE, frac))
    return idx, frac


def advect_velocity(vx: np.ndarray, vy: np.ndarray, wet: np.ndarray,
                    dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Pass 1: semi-Lagrangian self-advection of v (bilinear back-trace)."""
    hh, ww = wet.shape
    svx = np.where(wet, vx, _ZERO)
    svy = np.where(wet, vy, _ZERO)
    fdt = F32(dt)
    x0, fx = _backtrace_axis(svx * fdt, ww, 1)
    y0, fy = _backtrace_axis(svy * fdt, hh, 0)
    i00 = y0 * ww + x0
    dx = 1 if ww > 1 else 0  # x1 = min(x0 + 1, W - 1)
    dy = ww if hh > 1 else 0
    gx = _ONE - fx
    gy = _ONE - fy
    out = []
    for src in (svx, svy):
        flat = src.ravel()
        top = gx * flat.take(i00) + fx * flat.take(i00 + dx)
        bot = gx * flat.take(i00 + dy) + fx * flat.take(i00 + dy + dx)
        out.append(np.where(wet, gy * top + fy * bot, _ZERO).astype(F32))
    return out[0], out[1]


def diffuse_velocity(vx: np.ndarray, vy: np.ndarray, wet: np.ndarray, prm: SimParams,
                     dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Pass 2: implicit viscosity by Jacobi iterations over open faces."""
    k = F32(prm.viscosity * dt)
    ox, oy = open_faces(wet)
    bx, by = ox.astype(F32), oy.astype(F32)
    denom = _ONE + k * neighbour_sum(np.ones(wet.shape, F32), bx, by)
    res = []
    for u in (vx, vy):
        x = u
        if k > 0:
            for _ in range(int(prm.jacobi_iters)):
                x = (u + k * neighbour_sum(x, bx, by)) / denom
        res.append(np.where(wet, x, _ZERO).astype(F32))
    return res[0], res[1]


def tilt_kick(prm: SimParams, dt: float) -> tuple[np.float32, np.float32]:
    """The velocity a tilted canvas adds to wet cells in one step, float32 (x, y) [cell/s]."""
    ax, ay = prm.tilt_acceleration()
    return F32(ax * dt), F32(ay * dt)


def water_height_and_boundary(vx: np.ndarray, vy: np.ndarray, w: np.ndarray, wet: np.ndarray,
                              prm: SimParams, dt: float | None = None
                              ) -> tuple[np.ndarray, np.ndarray]:
    """Pass 3: blend in the water-height velocity and the tilt's gravity, then the
    no-penetration boundary (``dt`` defaults to ``prm.dt``)."""
    ox, oy = open_faces(wet)
    w_e = w.copy()
    w_e[:, :-1] = np.where(ox, w[:, 1:], w[:, :-1])
    w_w = w.copy()
    w_w[:, 1:] = np.where(ox, w[:, :-1], w[:, 1:])
    w_s = w.copy()
    w_s[:-1, :] = np.where(oy, w[1:, :], w[:-1, :])
    w_n = w.copy()
    w_n[1:, :] = np.where(oy, w[:-1, :], w[1:, :])
    g = F32(-0.5 * prm.height_gain)
    oh = F32(prm.omega_h)
    oi = F32(1.0 - prm.omega_h)
    nvx = oi * vx + oh * (g * (w_e - w_w))
    nvy = oi * vy + oh * (g * (w_s - w_n))
    gx, gy = tilt_kick(prm, prm.dt if dt is None else dt)
    if gx != 0:  # flat canvas: no addition at all (x + 0 would turn -0.0 into +0.0)
        nvx = nvx + gx
    if gy != 0:
        nvy = nvy + gy
    e_open = np.zeros(wet.shape, bool)
    e_open[:, :-1] = ox
    w_open = np.zeros(wet.shape, bool)
    w_open[:, 1:] = ox
    s_open = np.zeros(wet.shape, bool)
    s_open[:-1, :] = oy
    n_open = np.zeros(wet.shape, bool)
    n_open[1:, :] = oy
    nvx = np.where(e_open, nvx, np.minimum(nvx, _ZERO))
    nvx = np.where(w_open, nvx, np.maximum(nvx, _ZERO))
    nvy = np.where(s_open, nvy, np.minimum(nvy, _ZERO))
    nvy = np.where(n_open, nvy, np.maximum(nvy, _ZERO))
    vm = F32(prm.v_max)
    nvx = np.where(wet, np.clip(nvx, -vm, vm), _ZERO).astype(F32)
    nvy = np.where(wet, np.clip(nvy, -vm, vm), _ZERO).astype(F32)
    return nvx, nvy


def diffuse_water(w: np.ndarray, wet: np.ndarray, prm: SimParams, dt: float) -> np.ndarray:
    """Pass 4: conservative implicit water diffusion over open faces."""
    ox, oy = open_faces(wet)
    return implicit_diffusion(w, ox.astype(F32), oy.astype(F32), prm.nu_w * dt,
                              prm.jacobi_iters)


def blocking(h: np.ndarray, block: np.ndarray, block_time: np.ndarray, sim_time: float,
             prm: SimParams, fibre: np.ndarray | None = None,
             speed: np.ndarray | None = None) -> np.ndarray:
    """Diffusion-controller cell value beta_c (1 free, 0 blocked), in [0, 1] without
    fibre dispersion. With ``fibre_dispersivity > 0``, the fibre texture ``fibre`` (2, H, W)
    and the water's speed ``speed`` (H, W) [cell/s] it is multiplied by
    ``1 + gd * (max(fibre[0], fibre[1]) * speed)``, ``gd = fibre_dispersivity / nu_p``:
    where water moves through fibre channels the pigment it carries disperses along them
    (``D = alpha |v|``, Bear's hydrodynamic dispersion); still water is untouched."""
    if prm.block_fade > 0:
        age = np.clip((F32(sim_time) - block_time) / F32(prm.block_fade), _ZERO, _ONE)
    else:
        age = np.ones_like(block)
    eff = block + (_ONE - block) * age
    paper = _ONE - F32(prm.block_paper) * (_ONE - h)
    beta = np.minimum(paper, eff).astype(F32)
    gd = F32(prm.fibre_dispersion_gain())
    if gd > 0 and fibre is not None and speed is not None:
        beta = beta * (_ONE + gd * (np.maximum(fibre[0], fibre[1]) * speed))
    return beta.astype(F32)


def diffuse_pigment(p: np.ndarray, wet: np.ndarray, beta_c: np.ndarray, prm: SimParams,
                    dt: float) -> np.ndarray:
    """Pass 5: conservative implicit pigment diffusion with the diffusion controller."""
    ox, oy = open_faces(wet)
    bx = np.where(ox, np.minimum(beta_c[:, :-1], beta_c[:, 1:]), _ZERO)
    by = np.where(oy, np.minimum(beta_c[:-1, :], beta_c[1:, :]), _ZERO)
    return implicit_diffusion(p, bx, by, prm.nu_p * dt, prm.jacobi_iters)


def advect_water_and_pigment(w: np.ndarray, p: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                             wet: np.ndarray, prm: SimParams,
                             dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Pass 6: conservative, clamped face-flux advection of water and pigment.

    Directional rates: ``rxp`` carries from (y, x) to (y, x+1), ``rxn`` from (y, x+1) to
    (y, x); ``ryp`` from (y, x) to (y+1, x), ``ryn`` back. One of each pair is 0.
    """
    ox, oy = open_faces(wet)
    q4 = F32(0.25 * dt)
    ufx = np.where(ox, F32(0.5) * (vx[:, :-1] + vx[:, 1:]), _ZERO)
    ufy = np.where(oy, F32(0.5) * (vy[:-1, :] + vy[1:, :]), _ZERO)
    rx = np.abs(ufx) * q4
    ry = np.abs(ufy) * q4
    rxp = np.where(ufx > 0, rx, _ZERO)
    rxn = rx - rxp
    ryp = np.where(ufy > 0, ry, _ZERO)
    ryn = ry - ryp
    # donor-side total rate and lower limiter
    r_out = np.zeros(w.shape, F32)
    r_out[:, :-1] += rxp
    r_out[:, 1:] += rxn
    r_out[:-1, :] += ryp
    r_out[1:, :] += ryn
    lo = np.minimum(w, F32(prm.w_min))
    want = w * r_out
    room = w - lo
    s_out = np.where(want > room, room / np.where(want > room, want, _ONE), _ONE).astype(F32)
    # receiver-side unscaled inflows and upper limiter (water and every pigment)
    i_w = np.zeros(w.shape, F32)
    i_w[:, 1:] += w[:, :-1] * rxp
    i_w[:, :-1] += w[:, 1:] * rxn
    i_w[1:, :] += w[:-1, :] * ryp
    i_w[:-1, :] += w[1:, :] * ryn
    i_p = np.zeros(p.shape, F32)
    i_p[:, :, 1:] += p[:, :, :-1] * rxp
    i_p[:, :, :-1] += p[:, :, 1:] * rxn
    i_p[:, 1:, :] += p[:, :-1, :] * ryp
    i_p[:, :-1, :] += p[:, 1:, :] * ryn
    room_w = np.maximum(np.maximum(w, F32(prm.w_max)) - w, _ZERO)
    s_in = np.where(i_w > room_w, room_w / np.where(i_w > room_w, i_w, _ONE), _ONE)
    room_p = np.maximum(_ONE - p, _ZERO)
    s_in_p = np.where(i_p > room_p, room_p / np.where(i_p > room_p, i_p, _ONE), _ONE).min(axis=0)
    s_in = np.minimum(np.minimum(s_in, s_in_p), _ONE).astype(F32)
    # limited rates r' = r * s_out[donor] * s_in[receiver]
    axp = rxp * s_out[:, :-1] * s_in[:, 1:]
    axn = rxn * s_out[:, 1:] * s_in[:, :-1]
    ayp = ryp * s_out[:-1, :] * s_in[1:, :]
    ayn = ryn * s_out[1:, :] * s_in[:-1, :]
    w_new = apply_fluxes(w, w[:, :-1] * axp - w[:, 1:] * axn, w[:-1, :] * ayp - w[1:, :] * ayn)
    p_new = apply_fluxes(p, p[:, :, :-1] * axp - p[:, :, 1:] * axn,
                         p[:, :-1, :] * ayp - p[:, 1:, :] * ayn)
    return w_new, p_new


def evaporate(w: np.ndarray, evaporated: np.ndarray, prm: SimParams,
              dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Pass 7: fluid evaporation, faster at faces towards cells without fluid water."""
    has = w > 0
    n_dry = np.zeros(w.shape, F32)
    n_dry[:, :-1] += ~has[:, 1:]
    n_dry[:, 1:] += ~has[:, :-1]
    n_dry[:-1, :] += ~has[1:, :]
    n_dry[1:, :] += ~has[:-1, :]
    n_dry[:, -1] += 1
    n_dry[:, 0] += 1
    n_dry[-1, :] += 1
    n_dry[0, :] += 1
    e = F32(prm.evap_shallow() * dt)
    loss = e + F32(prm.edge_evap) * n_dry * w * e
    loss = np.where(has, np.minimum(loss, w), _ZERO).astype(F32)
    return w - loss, evaporated + loss


def surface_exchange(p: np.ndarray, q: np.ndarray, w: np.ndarray, h: np.ndarray,
                     wet: np.ndarray, beta: np.ndarray, gamma: np.ndarray, delta: np.ndarray,
                     prm: SimParams, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Pass 8: deposition and lifting between fluid and surface layer (eqs. 4.11/4.12).

    ``beta``, ``gamma``, ``delta``: float32 (S,) per slot (free slots: delta = 0).
    """
    f = np.clip(w / F32(prm.w_max), _ZERO, _ONE)
    rate = F32(prm.surface_rate * dt)
    g = gamma[:, None, None]
    d = delta[:, None, None]
    b = beta[:, None, None]
    down = rate * p * (_ONE - f) * (_ONE - h * g) * d
    up = rate * q * f * (_ONE - (_ONE - h) * g) * (d / b)
    down = np.minimum(np.minimum(down, p), _ONE - q)
    up = np.minimum(np.minimum(up, q), _ONE - p)
    net = np.where(wet, down - up, _ZERO).astype(F32)
    return p - net, q + net


def capillary(w: np.ndarray, wc: np.ndarray, h: np.ndarray, mask: np.ndarray,
              evaporated: np.ndarray, prm: SimParams,
              dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pass 9: absorption, capillary diffusion, capillary evaporation (all cells)."""
    c = F32(prm.c_min) + h * F32(prm.c_max - prm.c_min)
    opn = mask == 0
    d = np.minimum(np.minimum(F32(prm.alpha * dt), w), np.maximum(c - wc, _ZERO))
    d = np.where((w > 0) & opn, d, _ZERO)
    w = w - d
    wc = wc + d
    k = F32(prm.cap_diffusion * dt)
    if k > 0:
        s = wc / c
        fx = np.where(opn[:, :-1] & opn[:, 1:],
                      k * np.minimum(c[:, :-1], c[:, 1:]) * (s[:, :-1] - s[:, 1:]), _ZERO)
        fy = np.where(opn[:-1, :] & opn[1:, :],
                      k * np.minimum(c[:-1, :], c[1:, :]) * (s[:-1, :] - s[1:, :]), _ZERO)
        wc = apply_fluxes(wc, fx, fy)
        wc = np.maximum(wc, _ZERO)  # guards -0.0/rounding only; the flux bound keeps wc >= 0
    e = np.where(w == 0, np.minimum(F32(prm.evap_cap() * dt), wc), _ZERO).astype(F32)
    return w, wc - e, evaporated + e


def dry_cells(w: np.ndarray, p: np.ndarray, q: np.ndarray, vx: np.ndarray, vy: np.ndarray,
              evaporated: np.ndarray, prm: SimParams, wc: np.ndarray | None = None,
              h: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
    """Pass 10: tiny water evaporates; cells without fluid water deposit their pigment,
    unless (``suspend_sat > 0``) their capillary layer is still saturated above
    ``suspend_sat``: the pigment stays suspended in the damp paper until it dries."""
    tiny = (w > 0) & (w < F32(prm.w_dry_eps))
    evaporated = evaporated + np.where(tiny, w, _ZERO)
    w = np.where(tiny, _ZERO, w)
    dry = w == 0
    if prm.suspend_sat > 0 and wc is not None and h is not None:
        settle = dry & ~(wc > F32(prm.suspend_sat) * capacity(h, prm))
        t = np.where(settle, np.minimum(p, _ONE - q), _ZERO)
    else:
        t = np.where(dry, np.minimum(p, _ONE - q), _ZERO)
    return (w, p - t, q + t, np.where(dry, _ZERO, vx), np.where(dry, _ZERO, vy), evaporated)


# ---------------------------------------------------------------- the step
def slot_properties(state: CanvasState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """beta, gamma, delta per slot (float32 (S,)); free slots: beta 1, gamma 0, delta 0."""
    n = state.n_slots
    beta = np.ones(n, F32)
    gamma = np.zeros(n, F32)
    delta = np.zeros(n, F32)
    for k, pig in enumerate(state.slot_pigments()):
        beta[k], gamma[k], delta[k] = pig.beta, pig.gamma, pig.delta
    return beta, gamma, delta


PASS_ORDER = (
    "advect_velocity", "diffuse_velocity", "water_height_and_boundary", "diffuse_water",
    "diffuse_pigment", "advect_water_and_pigment", "evaporate", "surface_exchange",
    "capillary", "dry_cells",
)
"""The passes of one step, in order (the contract the GL backend follows)."""

STENCIL_RADIUS_EXTRA = 6
"""How far one step reaches beyond its Jacobi iterations [cells, Chebyshev distance].

A cell's new value depends on old values at most ``stencil_radius(params)`` cells away:
pass 1 reaches 1 cell (bilinear back-trace, ``|v dt| <= 1``); pass 2 adds one per
Jacobi iteration (velocity: ``1 + n``); passes 4/5 reach ``n`` (iterations) ``+ 1``
(face fluxes) ``+ 1`` (the donor limiter of the neighbour); pass 6 adds 2 (face rates
and the limiters ``s_out``/``s_in`` of the neighbour) on top of ``n + 2``; pass 7 and
the capillary diffusion of pass 9 add one each: ``n + 6``. The distributed canvas uses
it as its halo width; ``tests/test_stencil_radius.py`` measures it, so a new term that
reaches farther must raise this constant.
"""


def stencil_radius(prm: SimParams) -> int:
    """Halo one step needs: ``jacobi_iters + STENCIL_RADIUS_EXTRA`` [cells]."""
    return int(prm.jacobi_iters) + STENCIL_RADIUS_EXTRA


def step_region(state: CanvasState, sl: tuple[slice, slice], dt: float,
                stop_after: str | None = None) -> None:
    """Run passes 1-10 on the cells ``sl`` of ``state`` (in place).

    ``stop_after``: the name of a pass in :data:`PASS_ORDER`; the fields are written
    back right after it (for pass-by-pass comparisons with another backend).
    """
    if stop_after is not None and stop_after not in PASS_ORDER:
        raise CanvasInputError(f"unknown pass {stop_after!r}", "step_region")
    prm = state.params
    ys, xs = sl
    w = state.w[ys, xs]
    wc = state.wc[ys, xs]
    h = state.h[ys, xs]
    mask = state.mask[ys, xs]
    p = state.p[:, ys, xs]
    q = state.q[:, ys, xs]
    vx = state.vx[ys, xs]
    vy = state.vy[ys, xs]
    evap = state.evaporated[ys, xs]
    beta, gamma, delta = slot_properties(state)
    # slots never used in this layer stay zero: skip them for speed
    n_used = max(len(state.slots), 1)
    pp = p[:n_used]
    qq = q[:n_used]

    fib = state.fibre[:, ys, xs]
    speed0 = water_speed(vx, vy, prm) if prm.fibre_dispersion_gain() > 0 else None
    wet = wet_mask(w, wc, mask, prm, h, fib)
    for name in PASS_ORDER:
        if name == "advect_velocity":
            vx, vy = advect_velocity(vx, vy, wet, dt)
        elif name == "diffuse_velocity":
            vx, vy = diffuse_velocity(vx, vy, wet, prm, dt)
        elif name == "water_height_and_boundary":
            pr = flow_pressure(w, own_wet(w, wc, mask, prm), wet, h, prm)
            vx, vy = water_height_and_boundary(vx, vy, pr, wet, prm, dt)
        elif name == "diffuse_water":
            w = diffuse_water(w, wet, prm, dt)
        elif name == "diffuse_pigment":
            beta_c = blocking(h, state.block[ys, xs], state.block_time[ys, xs],
                              state.sim_time, prm, fib, speed0)
            pp = diffuse_pigment(pp, wet, beta_c, prm, dt)
        elif name == "advect_water_and_pigment":
            w, pp = advect_water_and_pigment(w, pp, vx, vy, wet, prm, dt)
        elif name == "evaporate":
            w, evap = evaporate(w, evap, prm, dt)
        elif name == "surface_exchange":
            pp, qq = surface_exchange(pp, qq, w, h, wet, beta[:n_used], gamma[:n_used],
                                      delta[:n_used], prm, dt)
        elif name == "capillary":
            w, wc, evap = capillary(w, wc, h, mask, evap, prm, dt)
        else:  # dry_cells
            w, pp, qq, vx, vy, evap = dry_cells(w, pp, qq, vx, vy, evap, prm, wc, h)
        if name == stop_after:
            break

    state.w[ys, xs] = w
    state.wc[ys, xs] = wc
    state.vx[ys, xs] = vx
    state.vy[ys, xs] = vy
    state.p[:n_used, ys, xs] = pp
    state.q[:n_used, ys, xs] = qq
    state.evaporated[ys, xs] = evap


def step(state: CanvasState, dt: float | None = None) -> int:
    """One simulation step of ``state`` in place (tiles decide the region).

    Returns the number of cells simulated (the area of the boxes run).
    """
    dt = state.params.dt if dt is None else float(dt)
    if not dt > 0 or dt * state.params.v_max > 1.0 + 1e-9:
        raise CanvasInputError("dt must be > 0 and move at most one cell per step", "step")
    if state.tiling:
        regions = tiles.active_regions(state)
        for region in regions:
            step_region(state, region, dt)
        tiles.update_tiles(state, regions)
        cells = sum((r[0].stop - r[0].start) * (r[1].stop - r[1].start) for r in regions)
    else:
        step_region(state, (slice(0, state.height), slice(0, state.width)), dt)
        cells = state.height * state.width
    state.sim_time += dt
    state.step_count += 1
    return cells
