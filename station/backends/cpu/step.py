"""One canvas step with the fused numba sweeps (same passes and maths as ``reference``).

:func:`step` mirrors ``reference.step``: the dirty tiles decide the boxes (the same
``tiles.active_regions``), each box is simulated on its own (cells outside it are
non-wet zeros), then ``tiles.update_tiles``, ``sim_time`` and ``step_count`` advance.
:func:`step_region` takes ``stop_after`` (a name of ``reference.PASS_ORDER``) and
writes the fields back right after that pass, for pass-by-pass comparisons.
"""

from __future__ import annotations

import numba
import numpy as np

from station.backends.cpu import fused as F
from station.backends.cpu import kernels as K
from station.canvas import reference, stencils, tiles
from station.canvas.params import CanvasInputError, SimParams
from station.canvas.state import CanvasState

F32 = np.float32
_THREADS = int(getattr(numba.config, "NUMBA_NUM_THREADS", 1))


def work_grow(n_taps: int) -> int:
    """Cells around the active tiles that a tiled step computes: the reference changes
    cells up to ``tiles.HALO`` away; a wet cell (at most one cell off an active tile) reads
    the x-blurred wet area up to R = n_taps // 2 rows away; one more cell beyond both, so
    every cell at the edge of the computed area is at rest and reads only cells at rest
    (zero in the scratch, as the reference's quiet values act on it)."""
    return max(tiles.HALO, 1 + n_taps // 2) + 1

_FIELDS_2D = ("w0", "bc", "v1x", "v1y", "xvax", "xvay",
              "xwa", "xwb", "v3x", "v3y", "w2", "w3",
              "sat", "mbx", "pr", "dbx")
_FLAGS_2D = ("wet", "opn")
"""0/1 flags (the wet mask, the open flag), one byte a cell: every sweep reads the wet
mask, so its bytes count five times a step (issue 26 item 1)."""
_FIELDS_3D = ("p0", "xpa", "xpb", "p2")


def constants(prm: SimParams, dt: float, sim_time: float) -> np.ndarray:
    """The float32 constant vector of the kernels, rounded exactly like the reference's."""
    c = np.zeros(K.N_CONST, F32)
    c[K.C_DT] = F32(dt)
    c[K.C_KV] = F32(prm.viscosity * dt)
    c[K.C_KW] = F32(prm.nu_w * dt)
    c[K.C_KP] = F32(prm.nu_p * dt)
    c[K.C_G] = F32(-0.5 * prm.height_gain)
    c[K.C_OH] = F32(prm.omega_h)
    c[K.C_OI] = F32(1.0 - prm.omega_h)
    c[K.C_VMAX] = F32(prm.v_max)
    c[K.C_Q4] = F32(0.25 * dt)
    c[K.C_WMIN] = F32(prm.w_min)
    c[K.C_WMAX] = F32(prm.w_max)
    c[K.C_EVAP] = F32(prm.evap_shallow() * dt)
    c[K.C_EDGE] = F32(prm.edge_evap)
    c[K.C_RATE] = F32(prm.surface_rate * dt)
    c[K.C_CMIN] = F32(prm.c_min)
    c[K.C_CSPAN] = F32(prm.c_max - prm.c_min)
    c[K.C_ALPHA] = F32(prm.alpha * dt)
    c[K.C_KC] = F32(prm.cap_diffusion * dt)
    c[K.C_ECAP] = F32(prm.evap_cap() * dt)
    c[K.C_WDRY] = F32(prm.w_dry_eps)
    c[K.C_MOIST] = F32(prm.moist_threshold)
    c[K.C_TIME] = F32(sim_time)
    c[K.C_FADE] = F32(prm.block_fade)
    c[K.C_BPAPER] = F32(prm.block_paper)
    c[K.C_ADV] = F32(prm.advance_height)
    c[K.C_ETA] = F32(prm.flow_outward)
    c[K.C_RELIEF] = F32(prm.paper_relief)
    c[K.C_WICK] = F32(prm.fibre_wick)
    c[K.C_DISP] = F32(prm.fibre_dispersion_gain())
    c[K.C_VFIB] = F32(prm.fibre_flow_max)
    c[K.C_EASE] = F32(prm.damp_ease)
    c[K.C_SUSP] = F32(prm.suspend_sat)
    c[K.C_DSAT] = F32(prm.damp_sat)
    # stencils.sheltered: off without the flow outward's blur of the wet area
    c[K.C_DEXP] = F32(prm.damp_exposure if prm.flow_outward > 0 and prm.wet_blur > 0
                      else 0.0)
    c[K.C_DSPAN] = F32(1.0 - prm.damp_sat)
    c[K.C_ABASE] = stencils.advance_base(prm)
    c[K.C_AGRAIN] = F32(prm.advance_grain)
    c[K.C_CURV] = F32(prm.advance_curvature)
    c[K.C_CURVN] = F32(1.0 + 2.0 * prm.advance_curvature)
    c[K.C_PBASE], c[K.C_PGAIN] = (F32(v) for v in prm.fibre_channel())
    c[K.C_PA] = F32(prm.fibre_permeability)
    c[K.C_PGATE] = F32(prm.fibre_gate())
    c[K.C_PPULL] = F32(prm.fibre_gate_front())
    c[K.C_SINV], c[K.C_SDROP] = (F32(v) for v in prm.standing_diffusion())
    c[K.C_FINV], c[K.C_FDRY] = (F32(v) for v in prm.standing_front())
    c[K.C_RIMK], c[K.C_RIMI], c[K.C_RIMA], c[K.C_RIMINV] = (F32(v) for v in prm.rim_profile())
    c[K.C_TILTX], c[K.C_TILTY] = reference.tilt_kick(prm, dt)
    return c


def _touched(a: np.ndarray) -> np.ndarray:
    """``a`` with every page written: ``np.zeros`` only maps its pages, so the first
    step wrote each one for the first time (a page fault per 4 KiB, ~20-30 us each in
    this machine's VM: ~180 ms for a 512x512 canvas's 25 MB of scratch, a third of the
    peer bench's 50 timed wash steps)."""
    a.fill(0)
    return a


class Scratch:
    """Padded float32 (flags: uint8) scratch fields ``(H + 2, W + 2)`` (pigment:
    ``(S, H + 2, W + 2)``),
    allocated once per canvas size and slot count and reused every step, with the work
    spans of the box being simulated and those of the last one (:func:`K.clear_stale`
    keeps every cell outside the current spans at zero), and the per-thread buffers of the
    temporally blocked Jacobi sweep."""

    def __init__(self, height: int, width: int, slots: int) -> None:
        self.height, self.width, self.slots = height, width, slots
        shape = (height + 2, width + 2)
        floats = {name: _touched(np.zeros(shape, F32)) for name in _FIELDS_2D}
        self.f2 = tuple(floats.values())
        self.f2u = tuple(_touched(np.zeros(shape, np.uint8)) for _ in _FLAGS_2D)
        self.a2: dict[str, np.ndarray] = {**floats,
                                          **dict(zip(_FLAGS_2D, self.f2u, strict=True))}
        self.a3 = {name: _touched(np.zeros((slots, *shape), F32)) for name in _FIELDS_3D}
        self.f3 = tuple(self.a3.values())
        most = width // 2 + 2  # spans per row: tiles are >= 4 cells, a gap >= 1
        self.spans = _touched(np.zeros((height + 2, most, 2), np.int32))
        self.nsp = np.zeros(height + 2, np.int32)
        self.pspans = _touched(np.zeros((height + 2, most, 2), np.int32))
        self.pnsp = np.zeros(height + 2, np.int32)
        self.hsp = _touched(np.zeros((height + 2, most, 2), np.int32))
        self.hn = np.zeros(height + 2, np.int32)
        # each row's run of one x-blurred value in mbx ([0]) and dbx ([1]), written by
        # K.prep (K._blur_x_run) and read by the y halves of the blurs (K._blur_y_run)
        self.runs = np.zeros((2, height + 2, 2), np.int64)
        self.rvals = np.zeros((2, height + 2), F32)
        self._jbuf = np.zeros((0, 0, 0, 0, 0), F32)
        self._cst: tuple[SimParams, float, np.ndarray, np.ndarray] | None = None
        self._regions: tuple[tuple[tuple[int, ...], bytes], list[tuple[slice, slice]]] | None = None
        self._full_bounds: tuple[tuple[int, int, int], np.ndarray] | None = None

    def fits(self, height: int, width: int, slots: int) -> bool:
        return self.height == height and self.width == width and self.slots >= slots

    def jbuf(self, levels: int) -> np.ndarray:
        """Zeroed (threads, 3 + slots, 2, rows, W + 2) buffers of :func:`K.jacobi_blocked`."""
        rows = K.BLOCK_ROWS + 2 * levels
        shape = (_THREADS, 3 + self.slots, 2, rows, self.width + 2)
        if self._jbuf.shape != shape:
            self._jbuf = np.zeros(shape, F32)
        return self._jbuf

    def constants(self, prm: SimParams, dt: float, sim_time: float
                  ) -> tuple[np.ndarray, np.ndarray]:
        """:func:`constants` and the flow-outward taps, rebuilt only when the parameters
        (a frozen object) or ``dt`` change; the step's time is set each call (building
        them took ~45 us a step, 2-3 % of a 512x512 stroke's step)."""
        c = self._cst
        if c is None or c[0] is not prm or c[1] != dt:
            c = (prm, dt, constants(prm, dt, sim_time), reference.gaussian_taps(prm.wet_blur))
            self._cst = c
        c[2][K.C_TIME] = F32(sim_time)
        return c[2], c[3]

    def regions(self, state: CanvasState, active: np.ndarray) -> list[tuple[slice, slice]]:
        """``tiles.active_regions(state)``, recomputed only when the active tiles change
        (``active``: ``tile_ttl > 0`` as uint8)."""
        key = active.shape, active.tobytes()
        if self._regions is None or self._regions[0] != key:
            self._regions = (key, tiles.active_regions(state))
        return self._regions[1]

    def bounds(self, bh: int, bw: int, full: bool) -> np.ndarray:
        """:func:`row_bounds` of the spans :meth:`select` set, kept while every cell of
        the box is computed (``full``: the spans then depend on the box's size only; the
        split cost ~0.1-0.2 ms a step, ~2 % of a 512x512 wash's)."""
        parts = F.ring_chunks()
        if not full:
            return row_bounds(self.spans, self.nsp, bh, parts)
        key = (bh, bw, parts)
        if self._full_bounds is None or self._full_bounds[0] != key:
            self._full_bounds = (key, row_bounds(self.spans, self.nsp, bh, parts))
        return self._full_bounds[1]

    def select(self, y0: int, x0: int, bh: int, bw: int, active: np.ndarray | None,
               ts: int, grow: int, state: CanvasState | None = None, ns: int = 1) -> None:
        """Set the work spans of a box (every cell; the cells within ``grow`` of a live
        cell of ``state``, see :func:`K.live_spans`; without ``state`` the cells within
        ``grow`` of an active tile) and zero what the last box computed outside them."""
        if active is None:
            K.full_spans(bh, bw, self.spans, self.nsp)
        elif state is not None:
            K.live_spans(active, ts, grow, y0, x0, bh, bw, state.w, state.wc, state.vx,
                         state.vy, state.p, ns, self.hsp, self.hn, self.spans, self.nsp)
        else:
            K.work_spans(active, ts, grow, y0, x0, bh, bw, self.spans, self.nsp)
        K.clear_stale(self.pspans, self.pnsp, self.spans, self.nsp, self.f2, self.f3,
                      self.f2u)


ROW_COST = 32
"""A row's own cost in the row split of :func:`row_bounds`, in cells (the ring rows, the
span loop's set-up)."""


def row_bounds(spans: np.ndarray, nsp: np.ndarray, bh: int, parts: int) -> np.ndarray:
    """Rows ``1..bh`` split into ``min(parts, bh)`` contiguous chunks of about equal work
    (the cells of their spans, plus :data:`ROW_COST` a row): ``bounds[c]..bounds[c+1]-1``
    are chunk c's rows (int64, ``bounds[0] = 1``, ``bounds[-1] = bh + 1``, every chunk
    non-empty). prange hands each thread an equal run of rows, so a live stroke whose
    wet rows lie mostly in one half of its box kept one thread busy while the other
    waited (512x512 peer stroke: 15 456 against 22 890 cells)."""
    parts = max(1, min(parts, bh))
    out = np.empty(parts + 1, np.int64)
    out[0], out[parts] = 1, bh + 1
    if parts == 1:
        return out
    nj = nsp[1:bh + 1]
    m = int(nj.max()) if bh > 0 else 0
    sp = spans[1:bh + 1, :m].astype(np.int64)
    cells = np.where(np.arange(m) < nj[:, None], sp[..., 1] - sp[..., 0] + 1, 0).sum(axis=1)
    work = np.cumsum(cells + ROW_COST)
    cut = np.searchsorted(work, work[-1] * np.arange(1, parts) / parts, side="right") + 1
    for c in range(1, parts):  # strictly increasing, room for the chunks after it
        out[c] = min(max(int(cut[c - 1]), int(out[c - 1]) + 1), bh + 1 - (parts - c))
    return out


def _win(a: np.ndarray, bh: int, bw: int) -> np.ndarray:
    """Interior of the box window of a padded scratch field (a view)."""
    return a[..., 1:bh + 1, 1:bw + 1]


def step_region(state: CanvasState, sl: tuple[slice, slice], dt: float,
                scratch: Scratch, stop_after: str | None = None,
                active: np.ndarray | None = None) -> None:
    """Passes 1-10 on the cells ``sl`` of ``state`` in place (see ``reference.step_region``).

    ``active`` (uint8 per tile, ``tile_ttl > 0``): compute only the box's cells within
    ``grow`` cells of an active tile (:func:`work_grow`); the others are at rest and the
    reference's passes leave them as they are. None: every cell of the box."""
    if stop_after is not None and stop_after not in reference.PASS_ORDER:
        raise CanvasInputError(f"unknown pass {stop_after!r}", "step_region")
    last = reference.PASS_ORDER.index(stop_after) if stop_after else len(reference.PASS_ORDER)

    def runs(name: str) -> bool:
        return reference.PASS_ORDER.index(name) <= last

    prm = state.params
    ys, xs = sl
    y0, x0 = int(ys.start), int(xs.start)
    bh, bw = int(ys.stop) - y0, int(xs.stop) - x0
    ns = max(len(state.slots), 1)
    cst, taps = scratch.constants(prm, dt, state.sim_time)
    if cst[K.C_PGAIN] != 0 and not K.any_nonzero(state.fibre.reshape(-1).view(np.uint32)):
        # paper without any fibre: nothing channels pass 3's flow (reference fibre_gate)
        cst = cst.copy()
        cst[K.C_PGAIN] = F32(0.0)
    beta, gamma, delta = (a[:ns].copy() for a in reference.slot_properties(state))
    s2, s3 = scratch.a2, scratch.a3
    n_it = int(prm.jacobi_iters)
    do_v = prm.viscosity * dt > 0 and n_it >= 1 and runs("diffuse_velocity")
    do_w = prm.nu_w * dt > 0 and runs("diffuse_water")
    do_p = prm.nu_p * dt > 0 and runs("diffuse_pigment")

    outward = prm.flow_outward > 0 and len(taps) > 0
    full = stop_after is not None or active is None
    scratch.select(y0, x0, bh, bw, None if full else active,
                   int(prm.tile_size), work_grow(len(taps)), state, ns)
    spans, nsp = scratch.spans, scratch.nsp
    bounds = scratch.bounds(bh, bw, full)
    do_pr = (outward or prm.paper_relief > 0) and runs("water_height_and_boundary")
    # the standing gate's front factor needs M' (the y half of the blur) before beta_c:
    # prep writes the x halves of both blurs (the wet area into mbx, with the dry-paper
    # term the not-dry paper into dbx) and leaves beta_c out; K._front_row writes pass 3's
    # levelled height and beta_c with the factor (its y half of the blur is M'). With one
    # Jacobi iteration advect_jacobi1 does that row by row (fold); with more, its
    # pigment iteration reads beta_c of the next rows, so K.standing_front runs first
    front = cst[K.C_FINV] > 0 and outward and do_pr
    jac1 = n_it == 1
    fold = front and jac1
    drying = front and cst[K.C_FDRY] > 0
    # prep copies w and p into the padded w0/p0 only for the sweeps that read them as
    # fields: the temporally blocked Jacobi iterations, pass 3 levelling w itself (pr is
    # w0); otherwise the stencils read the state (issue 26 item 1: 24 B a cell-step)
    copy = not (jac1 and do_pr)
    cprep = cst
    if front:
        cprep = cst.copy()
        cprep[K.C_SINV] = cprep[K.C_DISP] = F32(0.0)
    K.prep(state.w, state.wc, state.mask, state.vx, state.vy, state.p, state.h,
           state.block, state.block_time, state.fibre, taps, y0, x0, bh, bw, ns, cprep,
           outward and (do_pr or cst[K.C_DEXP] > 0), spans, nsp, s2["wet"], s2["w0"],
           s3["p0"], s2["bc"],
           s2["opn"], s2["mbx"], state.wet_area, prm.wet_hold > 0, bounds, not front, drying,
           s2["dbx"], scratch.runs, scratch.rvals, copy)
    if front and not fold:
        K.standing_front(state.w, state.h, state.block, state.block_time, state.vx,
                         state.vy, state.fibre, s2["mbx"], s2["wet"], taps, y0, x0, bh, bw,
                         cst, spans, nsp, bounds, s2["dbx"], s2["bc"], s2["pr"], scratch.runs,
                         scratch.rvals)
    wet, bc, w0, p0 = s2["wet"], s2["bc"], s2["w0"], s3["p0"]
    # pass 3 levels w itself unless the flow-outward or the relief term is on
    pr = s2["pr"] if do_pr else w0
    # pass 1 (+ pass 3's levelled height) + iteration 1 of the water/pigment solves (x0 = u)
    jw = do_w and n_it >= 1
    jp = do_p and n_it >= 1
    xw, xw_next = (s2["xwa"], s2["xwb"])
    xp, xp_next = (s3["xpa"], s3["xpb"])
    # with one iteration, limit_diffuse_fused computes it in its row ring (no xw/xp fields)
    K.advect_jacobi1(wet, state.vx, state.vy, bc, w0, p0, s2["mbx"], state.h, taps, y0, x0,
                     bh, bw, ns, cst, jw and not jac1, jp and not jac1, do_pr and not front,
                     outward, spans,
                     nsp, s2["v1x"], s2["v1y"], xw, xp, s2["pr"], bounds, fold, state.block,
                     state.block_time, state.fibre, s2["dbx"], scratch.runs, scratch.rvals,
                     state.w)
    if not jw:
        xw = w0
    if not jp:
        xp = p0
    if stop_after == "advect_velocity":
        state.vx[ys, xs] = _win(s2["v1x"], bh, bw)
        state.vy[ys, xs] = _win(s2["v1y"], bh, bw)
        return
    # iterations 2..n of water/pigment, 1..n-1 of velocity (one iteration behind)
    xvx, xvy = s2["v1x"], s2["v1y"]
    pong = ((s2["xvax"], s2["xvay"]),)
    if n_it >= 2:  # all of them in one temporally blocked sweep
        ovx, ovy = pong[0]
        K.jacobi_blocked(wet, bc, s2["v1x"], s2["v1y"], xvx, xvy, ovx, ovy, w0, xw, xw_next,
                         p0, xp, xp_next, bh, bw, ns, cst, do_v, jw, jp, n_it - 1, spans, nsp,
                         scratch.jbuf(n_it - 1))
        if do_v:
            xvx, xvy = ovx, ovy
        if jw:
            xw, xw_next = xw_next, xw
        if jp:
            xp, xp_next = xp_next, xp
    # last velocity iteration, pass 3, donor limiters and fluxes of passes 4/5: one sweep
    # (fused.limit_diffuse_fused: height_limit + diffuse_apply, bitwise the same)
    F.limit_diffuse_fused(wet, bc, s2["v1x"], s2["v1y"], xvx, xvy, state.w, xw, state.p, xp,
                          pr, bh, bw,
                          ns, cst, do_v, runs("water_height_and_boundary"), do_w, do_p,
                          jac1, s2["v3x"], s2["v3y"], s2["w2"], s3["p2"], spans, nsp, bounds,
                          state.fibre, y0, x0, state.h)
    v3x, v3y = s2["v3x"], s2["v3y"]
    if last <= reference.PASS_ORDER.index("water_height_and_boundary"):
        state.vx[ys, xs] = _win(v3x, bh, bw)
        state.vy[ys, xs] = _win(v3y, bh, bw)
        return
    if last <= reference.PASS_ORDER.index("diffuse_pigment"):
        state.vx[ys, xs] = _win(v3x, bh, bw)
        state.vy[ys, xs] = _win(v3y, bh, bw)
        state.w[ys, xs] = _win(s2["w2"], bh, bw)
        state.p[:ns, ys, xs] = _win(s3["p2"][:ns], bh, bw)
        return
    if runs("advect_water_and_pigment"):  # pass 6's limiters and fluxes in one sweep
        F.advect_fused(wet, v3x, v3y, s2["w2"], s3["p2"], y0, x0, bh, bw, ns, cst, s2["w3"],
                       state.p, spans, nsp, bounds)
    else:  # the copy of advect_apply's switched-off pass
        K.advect_apply(wet, v3x, v3y, s2["w2"], s2["w2"], s2["w2"], s3["p2"], y0, x0, bh, bw,
                       ns, cst, False, s2["w3"], state.p, spans, nsp)
    if runs("capillary"):  # passes 7-10 in one sweep (fused.evap_cap_fused)
        F.evap_cap_fused(wet, s2["w3"], s2["opn"], state.h, state.wc,
                         state.evaporated, state.w, state.p, state.q, beta, gamma, delta,
                         v3x, v3y, state.vx, state.vy, y0, x0, bh, bw, ns, cst,
                         runs("evaporate"), runs("surface_exchange"), True,
                         prm.cap_diffusion * dt > 0, runs("dry_cells"), spans, nsp, bounds,
                         state.wet_area, F32(dt / prm.wet_hold) if prm.wet_hold > 0 else F32(0),
                         prm.wet_hold > 0)  # with dry_cells, the memory's fade (pass 10's end)
    else:  # a pass-by-pass comparison that stops before the capillary passes
        K.evap_surface_absorb(wet, s2["w3"], s2["opn"], state.h, state.wc,
                              state.evaporated, state.w, state.p, state.q, beta, gamma, delta,
                              y0, x0, bh, bw, ns, cst, runs("evaporate"),
                              runs("surface_exchange"), False, s2["sat"], spans, nsp)
    if not runs("dry_cells"):
        state.vx[ys, xs] = _win(v3x, bh, bw)
        state.vy[ys, xs] = _win(v3y, bh, bw)


def step(state: CanvasState, scratch: Scratch, dt: float | None = None) -> int:
    """One simulation step of ``state`` in place; returns the number of cells simulated."""
    dt = state.params.dt if dt is None else float(dt)
    if not dt > 0 or dt * state.params.v_max > 1.0 + 1e-9:
        raise CanvasInputError("dt must be > 0 and move at most one cell per step", "step")
    if state.tiling:
        active = (state.tile_ttl > 0).astype(np.uint8)
        regions = scratch.regions(state, active)
        for region in regions:
            step_region(state, region, dt, scratch, active=active)
        boxes = np.array([(r[0].start, r[0].stop, r[1].start, r[1].stop) for r in regions],
                         np.int64).reshape(-1, 4)
        K.update_tiles(state.tile_ttl, active, boxes, state.w, state.wc,
                       int(state.params.tile_size), int(state.params.tile_ttl_steps()),
                       tiles.HALO)
        cells = sum((r[0].stop - r[0].start) * (r[1].stop - r[1].start) for r in regions)
    else:
        step_region(state, (slice(0, state.height), slice(0, state.width)), dt, scratch)
        cells = state.height * state.width
    state.sim_time += dt
    state.step_count += 1
    out: int = cells
    return out
