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
CHANGED (API): ``stencil_radius`` adds the flow-outward blur's reach beyond 4 cells
  (``ceil(2 wet_blur) - BLUR_REACH_IN_EXTRA``; watercolor's 3.5-cell blur: 7 -> 10).
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

CHANGED: backruns (issue 21 item 4). Wet mask on damp paper: with ``damp_ease > 0`` the
  advancing height is multiplied by ``min(damp_ease * (1 - wc / c), 1)`` (``c`` the capillary
  capacity ``c_min + h (c_max - c_min)``; stencils.damp_factor), both axes, before the fibre
  factor. Pass 10: with ``suspend_sat > 0`` a cell with ``w == 0`` deposits only when NOT
  ``wc > suspend_sat * c`` (wc after pass 9): damp paper keeps its pigment suspended, so
  water flowing back into a damp wash carries it to the front (Curtis et al. 1997, 4.7).
  The watercolor profile sets both and ``moist_threshold`` 1.0 (no cell is wet by its
  capillary water alone: fresh water has a front to advance into a damp wash).
CHANGED: pass 8 lifts with ``beta / lift_gain`` in place of the staining ``beta`` (eq. 4.12
  times ``lift_gain``; eq. 4.11 unchanged): settled pigment goes back into suspension faster
  than it settles (watercolor 5: a bloom's returning water carries the damp wash's pigment to
  its front, issue 21 item 4). ``slot_properties`` rounds ``beta / lift_gain`` to float32 once;
  the cpu backend takes that array, GL's ``u_dob`` is ``delta / it`` (the removal tools keep
  the pigments' own staining: ``slot_properties(state, lift=False)``).
CHANGED: Curtis 1997's wet-area mask with a memory (issue 21 item 8: rows laid over
  half-dry rows). New field ``CanvasState.wet_area`` (float32 (H, W) in [0, 1]) and SimParams
  ``wet_hold`` [s] (0: off, the field stays 0 and everything is as before). With
  ``wet_hold > 0``: at the wet mask (once per step, after the sources)
  ``M = max(wet_area, own)`` (``wet_memory``; ``own`` as 1/0) and ``wet_area <- M``;
  pass 3's flow-outward term blurs ``M`` instead of ``own``; at the end of pass 10
  (``wet_area_update``, with w and wc after pass 10) ``wet_area = 1`` where the cell is
  ``own``-wet, else ``max(M - float32(dt / wet_hold), 0)`` where ``wc > 0``, else 0. A strip
  that dries inside a still-wet wash stays in the wet area, so the flow outward no longer
  pulls water and pigment to its receding edge (the dark line between zig-zag rows); a
  wash whose water has been gone for ``wet_hold`` leaves the area, so water put back into
  it still makes a bloom with a crust. Tools that dry paper out (hair dryer, eraser of
  ``wc``) set ``wet_area = 0`` where ``wc`` becomes 0, as pass 10 would.
CHANGED: pass 3 along the paper's fibres (issue 21 item 4: a drop of colour into a fully wet
  wash feathers). New SimParams ``fibre_permeability`` ``a`` (0: off, as before): the
  height term's difference along each axis is multiplied by ``base + gain * fibre[axis]``
  with ``(base, gain) = prm.fibre_channel()`` = float32 ``(1 - a, FIBRE_CHANNEL * a)``
  (``FIBRE_CHANNEL`` 4), i.e. ``vh = -height_gain * ((wE - wW)/2 * kx, (wS - wN)/2 * ky)``
  computed as ``g * ((wE - wW) * kx)``, ``g = float32(-0.5 height_gain)``. Water driven
  through wet paper runs along its fibres (Darcy flow through a permeability uneven at the
  fibre scale) and the paint the brush pushes into a wash goes out in fingers. No built-in
  profile sets it yet (with ``a = 1``, ``nu_p`` 0.02 and ``fibre_dispersivity`` 9 the
  wet-wash drop feathers, but rims, damp-wash blooms and hot-press washes regress).
CHANGED: the fibre channel gated (new SimParams ``fibre_gate_depth``, 0: ungated as above):
  ``kx = (1 - g a) + (g gain) fibre[0]`` (``ky`` alike), ``g = standing_gate(w)`` =
  smoothstep ``t t (3 - 2 t)``, ``t = min(w / fibre_gate_depth, 1)`` of the cell's water at
  the step's start (:func:`fibre_gate`); ``g = 0`` everywhere on a paper without any fibre
  (hot-press: its factor is exactly 1, with or without the gate).
CHANGED: the pigment's own diffusion in standing water (new SimParams ``standing_depth``,
  0: off, and ``standing_nu_p``): beta_c's ``1`` (of the fibre dispersion's factor, or
  beta_c itself) is ``1 - drop * standing_gate(w)`` with ``drop = float32(1 -
  standing_nu_p / nu_p)`` and ``t = min(w / standing_depth, 1)``: ``nu_p`` on damp paper,
  ``standing_nu_p`` in standing water, the fibre dispersion unchanged.
CHANGED: the standing gate's front factor (new SimParams ``standing_front_pull``, 0: off,
  and ``standing_front_dry``): ``standing_gate(w)`` times ``1 - F`` (:func:`standing_front`),
  ``F = smoothstep(min(flow_outward (1 - M') / standing_front_pull, 1))``, with
  ``standing_front_dry`` T > 0 times ``min(2 (1 - blurred_wet(wc >= T c)), 1)``: near the
  edge of a wet area over dry paper the pigment keeps ``nu_p`` (the brush rim's band).
CHANGED: pass 3's pull cut to the contact line (issue 21 item 3: narrow strokes without a
  rim, the soft gradient, the pale head). New SimParams ``rim_sharpness`` k (0: off, as
  before), ``rim_onset`` a, ``rim_full`` b: the flow-outward term is ``flow_outward *
  outward_pull(1 - M')`` with ``outward_pull(u) = u`` when k is 0, else ``(1 - k) u + k s``,
  ``s = min(max((u - a) inv, 0), 1)``, ``(k, 1 - k, a, inv) = prm.rim_profile()`` (float32,
  ``inv = 1 / (b - a)``), in that order. ``u`` falls with the distance from the wet area's
  edge; ``s`` is full on the outermost cells and 0 a few cells in on a stroke of any
  width, so the film pools in a band at the pinned edge instead of sloping across the whole
  width the blur spans. Everything reading pass 3's levelled height (the fibre gate's
  pull) sees the same pull; the standing gate's front factor keeps ``flow_outward (1 -
  M')``.
CHANGED: the damp paper's exposure (issue 21 item 4: blooms branch). New SimParams
  ``damp_exposure`` (0: off; needs ``flow_outward`` and ``wet_blur``): after the pinning,
  a cell of the wet mask that is not ``own``, on paper damper than ``damp_sat``, is taken
  out where ``1 - M' < damp_exposure``, ``M'`` = ``blurred_wet(area_m, gaussian_taps(
  wet_blur))`` of the wet-area mask at the start of the step (the flow-outward term's
  blur; ``stencils.sheltered``; ``wet_mask(..., area)``). GL: ``shelter.comp`` after
  ``blur_x`` (wb -1 and v1 0 for such a cell); cpu: ``_pin`` (``_blur_y_at``).
NOTE (no maths change): the helpers live in ``stencils.py``, the passes in ``passes.py``;
  this module re-exports them and runs the step.

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
   ``P = (w + paper_relief * h) - flow_outward * outward_pull(1 - M')`` on wet cells
   (``P = w`` elsewhere; the free surface over the paper's relief, lowered near the edge by Curtis
   1997's flow outward; a term whose parameter is 0 is left out), ``M'`` = ``blurred_wet``:
   the own wet mask (1/0; with ``wet_hold > 0`` the wet-area mask ``M``, see CHANGED)
   blurred with the float32 Gaussian ``gaussian_taps(wet_blur)`` along x, then along y,
   each sum over the taps in order (offset -R first), cells outside the region 0. For
   each wet cell, neighbour heights (of P) ``wE = P[y,x+1]`` if face E is open else
   ``w[y,x]`` (same for W, N, S);
   ``vh = -height_gain * ((wE - wW)/2, (wS - wN)/2)`` (each times the fibre channel with
   ``fibre_permeability``, see CHANGED);
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
   ``up = surface_rate*dt * q f (1 - (1 - h)*gamma) delta / beta``, with
   ``beta = float32(staining / lift_gain)`` (``slot_properties``);
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
    ``t = min(p[k], 1 - q[k])``: ``q += t``, ``p -= t``, and gets ``v = 0``; then (with
    ``wet_hold > 0``) the wet-area memory fades (``wet_area_update``, see CHANGED).

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
from station.canvas.passes import (
    advect_velocity,
    advect_water_and_pigment,
    blocking,
    capillary,
    diffuse_pigment,
    diffuse_velocity,
    diffuse_water,
    dry_cells,
    evaporate,
    slot_properties,
    standing_gate,
    surface_exchange,
    tilt_kick,
    water_height_and_boundary,
)
from station.canvas.state import CanvasState
from station.canvas.stencils import (
    F32,
    apply_fluxes,
    blurred_wet,
    capacity,
    damp_factor,
    flow_pressure,
    gaussian_taps,
    implicit_diffusion,
    neighbour_sum,
    open_faces,
    outward_pull,
    own_wet,
    water_speed,
    wet_area_update,
    wet_mask,
    wet_memory,
)

__all__ = ["F32", "PASS_ORDER", "STENCIL_RADIUS_EXTRA", "advect_velocity",
           "advect_water_and_pigment", "apply_fluxes", "blocking", "blurred_wet", "capacity",
           "capillary", "damp_factor", "diffuse_pigment", "diffuse_velocity", "diffuse_water",
           "dry_cells", "evaporate", "flow_pressure", "gaussian_taps", "implicit_diffusion",
           "neighbour_sum", "open_faces", "outward_pull", "own_wet", "slot_properties",
           "standing_front", "standing_gate", "stencil_radius",
           "step", "step_region", "surface_exchange", "tilt_kick", "water_height_and_boundary",
           "water_speed", "wet_area_update", "wet_mask", "wet_memory"]


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


BLUR_REACH_IN_EXTRA = 4
"""The flow-outward blur's reach ``ceil(2 wet_blur)`` [cells] that ``STENCIL_RADIUS_EXTRA``
already covers (a 2-cell blur: the cross-border sessions of ``tests/test_distributed.py``
paint the same as one process with it)."""


def stencil_radius(prm: SimParams) -> int:
    """Halo one step needs: ``jacobi_iters + STENCIL_RADIUS_EXTRA`` [cells], plus what the
    flow-outward blur reaches beyond :data:`BLUR_REACH_IN_EXTRA`.

    The blur reads the wet-area mask ``ceil(2 wet_blur)`` cells away: a change of wetness
    that far moves pass 3's pressure and so everything after it. The point probe of
    ``tests/test_stencil_radius.py`` halves values without drying a cell, so it cannot see
    that chain; the cross-border sessions of ``tests/test_distributed.py`` do."""
    blur = len(gaussian_taps(prm.wet_blur)) // 2 if prm.flow_outward > 0 else 0
    return (int(prm.jacobi_iters) + STENCIL_RADIUS_EXTRA
            + max(blur - BLUR_REACH_IN_EXTRA, 0))


_ZERO32 = F32(0.0)
_ONE32 = F32(1.0)


def fibre_gate(state: CanvasState, w: np.ndarray, h: np.ndarray,
               pr: np.ndarray) -> np.ndarray | None:
    """Pass 3's fibre channel gate per cell (``water_height_and_boundary``'s ``gate``):
    None without a gate (``fibre_gate_depth`` 0: the channel everywhere), zeros on paper
    without any fibre (hot-press: nothing channels the flow, its factor stays 1), else
    :func:`standing_gate` of the cells' water at the start of the step, with
    ``fibre_gate_pull`` times ``1 - standing_gate(pull)``, ``pull = max((w + paper_relief
    h) - pr, 0)`` (``pr`` pass 3's levelled height: the flow-outward pull near the edge of
    the wet area)."""
    prm = state.params
    if prm.fibre_permeability <= 0:
        return None
    if not state.fibre.any():
        return np.zeros_like(w)
    inv = prm.fibre_gate()
    if inv <= 0:
        return None
    g = standing_gate(w, inv)
    inv_pull = prm.fibre_gate_front()
    if inv_pull > 0:
        top = w + F32(prm.paper_relief) * h if prm.paper_relief > 0 else w
        pull = np.maximum(top - pr, _ZERO32)
        g = g * (_ONE32 - standing_gate(pull, inv_pull))
    return g


def standing_front(standing: np.ndarray, area_m: np.ndarray, wc: np.ndarray,
                   h: np.ndarray, prm: SimParams) -> np.ndarray:
    """The standing gate ``standing`` times ``1 - F`` (``standing_front_pull``; unchanged
    when off): ``F = standing_gate(flow_outward (1 - M'), 1 / standing_front_pull)``,
    ``M'`` = :func:`blurred_wet` of the wet-area mask ``area_m`` (the flow-outward term's),
    with ``standing_front_dry`` T times ``min(2 D, 1)``, ``D = 1 - blurred_wet(wc >= T c)``
    (the paper's share nearby that is dry; cells outside the region count as dry: they
    are at rest, without capillary water). All at the start of the step."""
    inv, dry = prm.standing_front()
    if inv <= 0:
        return standing
    taps = gaussian_taps(prm.wet_blur)
    pull = F32(prm.flow_outward) * (_ONE32 - blurred_wet(area_m, taps))
    front = standing_gate(pull, inv)
    if dry > 0:
        d = _ONE32 - blurred_wet(wc >= F32(dry) * capacity(h, prm), taps)
        front = front * np.minimum(F32(2.0) * d, _ONE32)
    return (standing * (_ONE32 - front)).astype(F32)


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
    holding = prm.wet_hold > 0
    area_m = wet_memory(own_wet(w, wc, mask, prm), state.wet_area[ys, xs], prm)
    if holding:  # the wet-area mask grows where the cell holds its own water
        state.wet_area[ys, xs] = area_m
    wet = wet_mask(w, wc, mask, prm, h, fib, area_m)
    inv_still = prm.standing_diffusion()[0]
    standing = standing_gate(w, inv_still) if inv_still > 0 else None
    if standing is not None:
        standing = standing_front(standing, area_m, wc, h, prm)
    for name in PASS_ORDER:
        if name == "advect_velocity":
            vx, vy = advect_velocity(vx, vy, wet, dt)
        elif name == "diffuse_velocity":
            vx, vy = diffuse_velocity(vx, vy, wet, prm, dt)
        elif name == "water_height_and_boundary":
            pr = flow_pressure(w, area_m, wet, h, prm)
            gate = fibre_gate(state, w, h, pr)
            vx, vy = water_height_and_boundary(vx, vy, pr, wet, prm, dt, fib, gate)
        elif name == "diffuse_water":
            w = diffuse_water(w, wet, prm, dt)
        elif name == "diffuse_pigment":
            beta_c = blocking(h, state.block[ys, xs], state.block_time[ys, xs],
                              state.sim_time, prm, fib, speed0, standing)
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
            if holding:
                state.wet_area[ys, xs] = wet_area_update(area_m, w, wc, mask, prm, dt)
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
