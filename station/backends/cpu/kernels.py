"""The fused, parallel sweeps of the ``cpu`` backend (numba; maths of ``reference.py``).

Every sweep runs over the cells of one simulated box (a tile region, or the whole
canvas), rows in parallel (``prange``), columns in plain loops that LLVM vectorises.
Intermediate fields live in *padded* scratch arrays of shape ``(H + 2, W + 2)``: box
cell ``(y0 + j - 1, x0 + i - 1)`` is scratch ``[j, i]`` for ``j in 1..bh``, ``i in
1..bw``, and the ring around the box window is kept at zero (``zero_ring``), which is
exactly the reference's rule "cells outside the region are non-wet with zero water,
capillary water, velocity and pigment". State arrays are read and written only at the
cell itself, so updating them in place is race-free.

The maths is the reference's to the float32 operation: same operands, same order of
every sum (E, W, S, N faces; ``u - F_E + F_W - F_S + F_N``), same clamps and limiters,
the same float32 constants (built in :mod:`station.backends.cpu.step`). A face flux is
computed by both of its cells from the same operands in the same order, so both see the
same float32 value: mass is conserved exactly as in the reference.

Sweeps (``n`` Jacobi iterations, ``s`` pigment slots in use):

* ``prep``: wet mask, the copies the stencils need (w, p), the diffusion controller
  beta_c and the open (unmasked) flag (the two flags are uint8 fields; the capacity is
  recomputed from ``h`` where read, and pass 1 reads the state's velocity where the
  wet mask is set, so neither is a scratch field);
* ``advect_jacobi1``: pass 1 (semi-Lagrangian velocity) + Jacobi iteration 1 of the
  water and pigment solves (passes 4/5);
* ``jacobi_blocked`` (one sweep): velocity iterations 1..n-1 and water/pigment
  iterations 2..n (pass 2 lags one iteration behind: it needs pass 1's result at the
  neighbours), temporally blocked: chunks of rows keep the intermediate iterates in
  cache and recompute the rows they share with their neighbours;
* ``height_limit``: the last velocity iteration, pass 3, and the donor limiters of
  passes 4/5;
* ``diffuse_apply``: the limited face fluxes of passes 4/5;
* ``advect_limit``: pass 6's per-cell limiters s_out, s_in;
* ``advect_apply``: pass 6's limited fluxes;
* ``evap_surface_absorb``: pass 7, pass 8, pass 9a;
* ``capillary_dry``: pass 9b/9c and pass 10.

State arrays are indexed with an *unsigned* column ``np.uint64(x0 + i - 1)``: numba
wraps negative signed indices around, and the select that costs made LLVM give up
vectorising those loops (measured 5-10x slower); an unsigned index cannot be negative.

The constant vector ``cst`` (float32) is laid out as the ``C_*`` indices below.

Why one file over 600 lines (issue 23 item 7 allows the kernels it): the sweeps share the
``C_*`` layout, the padded-scratch convention and the unsigned-index intrinsic, and each
sweep is read against the numbered passes of ``reference.py``/``passes.py`` in this order;
split by pass, every reader would hold three files open to follow one step, and numba's
cache would key on more modules.  The fused variants live apart (``fused.py``).
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import get_thread_id, njit, prange, types
from numba.extending import intrinsic

F32 = np.float32
ZERO = np.float32(0.0)
ONE = np.float32(1.0)
HALF = np.float32(0.5)

# indices into the float32 constant vector ``cst`` (see step.constants)
FOUR = np.float32(4.0)
C_DT = 0
C_KV = 1          # viscosity * dt
C_KW = 2          # nu_w * dt
C_KP = 3          # nu_p * dt
C_G = 4           # -0.5 * height_gain
C_OH = 5          # omega_h
C_OI = 6          # 1 - omega_h
C_VMAX = 7
C_Q4 = 8          # 0.25 * dt
C_WMIN = 9
C_WMAX = 10
C_EVAP = 11       # eps_shallow * dt
C_EDGE = 12       # edge_evap
C_RATE = 13       # surface_rate * dt
C_CMIN = 14
C_CSPAN = 15      # c_max - c_min
C_ALPHA = 16      # alpha * dt
C_KC = 17         # cap_diffusion * dt
C_ECAP = 18       # eps_cap * dt
C_WDRY = 19       # w_dry_eps
C_MOIST = 20      # moist_threshold
C_TIME = 21       # sim_time
C_FADE = 22       # block_fade
C_BPAPER = 23     # block_paper
C_ADV = 24        # advance_height
C_ETA = 25        # flow_outward
C_RELIEF = 26     # paper_relief
C_WICK = 27       # fibre_wick
C_TILTX = 28      # tilt kick x: float32(ax * dt)
C_TILTY = 29      # tilt kick y
C_DISP = 30       # fibre_dispersivity / nu_p (SimParams.fibre_dispersion_gain)
C_VFIB = 31       # fibre_flow_max
C_EASE = 32       # damp_ease
C_SUSP = 33       # suspend_sat
C_DSAT = 34       # damp_sat
C_DSPAN = 35      # float32(1 - damp_sat)
C_ABASE = 36      # float32(1 + advance_grain / 2) (stencils.advance_base)
C_AGRAIN = 37     # advance_grain
C_CURV = 38       # advance_curvature
C_CURVN = 39      # float32(1 + 2 advance_curvature)
C_PBASE = 40      # float32(1 - fibre_permeability) (SimParams.fibre_channel)
C_PGAIN = 41      # float32(FIBRE_CHANNEL * fibre_permeability); 0: pass 3 reads no fibre
C_PA = 42         # fibre_permeability (the gated channel's 1 - g a)
C_PGATE = 43      # 1 / fibre_gate_depth (SimParams.fibre_gate); 0: the channel ungated
C_SINV = 44       # 1 / standing_depth (SimParams.standing_diffusion); 0: off
C_SDROP = 45      # 1 - standing_nu_p / nu_p
C_PPULL = 46      # 1 / fibre_gate_pull (SimParams.fibre_gate_front); 0: no front factor
C_FINV = 47       # 1 / standing_front_pull (SimParams.standing_front); 0: off
C_FDRY = 48       # standing_front_dry; 0: the front factor at every front
C_RIMK = 49       # rim_sharpness k (SimParams.rim_profile); 0: the blur's pull alone
C_RIMI = 50       # float32(1 - k)
C_RIMA = 51       # rim_onset
C_RIMINV = 52     # float32(1 / (rim_full - rim_onset))
C_DEXP = 53       # damp_exposure (0: off, or no flow outward to blur the wet area for)
N_CONST = 54

# the sweeps: rows in parallel; IEEE float32 maths exactly as written (no fastmath, no FMA
# contraction), numpy's error model (division without ZeroDivision checks: every division
# is guarded like the reference's), compiled once and cached on disk; they release the
# interpreter lock (the kiosk steps in a thread beside its window's)
_parallel = njit(parallel=True, fastmath=False, cache=True, error_model="numpy", nogil=True)
_serial = njit(fastmath=False, cache=True, error_model="numpy", nogil=True)
_inline = njit(inline="always", fastmath=False, cache=True, error_model="numpy")


# ------------------------------------------------------------------ work spans
@intrinsic
def _at_least_one(typingctx: object, x: types.Integer) -> tuple[object, object]:
    """``x`` (int64), telling LLVM that it is >= 1 (``llvm.assume``; the caller knows)."""
    sig = types.int64(types.int64)

    def codegen(context: object, builder: ir.IRBuilder, signature: object,
                args: list[ir.Value]) -> ir.Value:
        v = args[0]
        fn = builder.module.declare_intrinsic(
            "llvm.assume", fnty=ir.FunctionType(ir.VoidType(), [ir.IntType(1)]))
        builder.call(fn, [builder.icmp_signed(">=", v, ir.Constant(v.type, 1))])
        return v

    return sig, codegen


@_inline
def _span(spans: np.ndarray, j: int, si: int) -> tuple[int, int]:
    """Span ``si`` of row ``j`` as int64 with the start (>= 1: :func:`work_spans`) known to
    LLVM: a column loop from a start it cannot bound keeps numba's negative-index
    wraparound on ``i - 1`` and does not vectorise (measured 4-15x slower)."""
    lo: int = _at_least_one(np.int64(spans[j, si, 0]))  # type: ignore[call-arg]
    return lo, int(spans[j, si, 1])


@_inline
def _state_row(src: np.ndarray, y0: int, x0: int, r: int, bh: int, spans: np.ndarray,
               nsp: np.ndarray, o: np.ndarray) -> None:  # pragma: no cover - compiled
    """Row r of the box as a padded scratch copy of the state field ``src`` holds it: the
    state's values on the row's spans, 0 elsewhere (the box's ring, the rows outside it,
    the columns outside the spans). A per-chunk ring of these rows stands in for the
    ``w0``/``p0`` copies (issue 26: the stencils read the state, the copies are not
    written): the same values, so the same bits."""
    if r < 1 or r > bh:
        for u in range(np.uint64(o.shape[0])):
            o[u] = ZERO
        return
    row = src[y0 + r - 1]
    xo = np.uint64(x0 - 1)
    prev = np.uint64(0)
    for sx in range(nsp[r]):
        slo, shi = _span(spans, r, sx)
        for u in range(prev, np.uint64(slo)):  # unsigned: no wraparound, no scatter
            o[u] = ZERO
        for u in range(np.uint64(slo), np.uint64(shi + 1)):
            o[u] = row[xo + u]
        prev = np.uint64(shi + 1)
    for u in range(prev, np.uint64(o.shape[0])):
        o[u] = ZERO


@_serial
def any_nonzero(bits: np.ndarray) -> bool:
    """``a.any()`` of a float32 array ``a``, given as its flat uint32 view ``bits``,
    stopping at the first block of 4096 values with a non-zero one: the step asks it of
    the paper's fibres (two float32 per cell), which numpy read whole every step (0.6 ms
    of a 1920x1080 wash step, more with the fibres out of cache), and a paper with
    fibres has one in its first block. A block's test is an OR of the bits without the
    sign (-0 is zero, NaN is not, as for numpy) over unsigned indices: it vectorises, so
    a paper without fibres costs what numpy's any does."""
    n = np.uint64(bits.shape[0])
    b0 = np.uint64(0)
    while b0 < n:
        b1 = min(b0 + np.uint64(4096), n)
        hit = np.uint32(0)
        for i in range(b0, b1):
            hit |= bits[i]
        if hit & np.uint32(0x7FFFFFFF):
            return True
        b0 = b1
    return False


@_serial
def full_spans(bh: int, bw: int, spans: np.ndarray, nsp: np.ndarray) -> None:
    """Every cell of the box window: one span ``[1, bw]`` on rows ``1..bh``."""
    for j in range(nsp.shape[0]):
        nsp[j] = 0
    for j in range(1, bh + 1):
        spans[j, 0, 0] = 1
        spans[j, 0, 1] = bw
        nsp[j] = 1


@_serial
def work_spans(active: np.ndarray, ts: int, grow: int, y0: int, x0: int, bh: int, bw: int,
               spans: np.ndarray, nsp: np.ndarray) -> None:
    """The cells of the box within ``grow`` cells (chessboard) of an active tile, as sorted
    disjoint column spans ``[lo, hi]`` (scratch columns) per scratch row ``1..bh``."""
    nty, ntx = active.shape
    for j in range(nsp.shape[0]):
        nsp[j] = 0
    for j in range(1, bh + 1):
        y = y0 + j - 1
        ty_lo = max((y - grow) // ts, 0)
        ty_hi = min((y + grow) // ts, nty - 1)
        n = 0
        for tx in range(ntx):
            on = False
            for ty in range(ty_lo, ty_hi + 1):
                if active[ty, tx] != 0:
                    on = True
            if not on:
                continue
            lo = max(tx * ts - grow, x0) - x0 + 1
            hi = min((tx + 1) * ts + grow, x0 + bw) - x0
            if hi < lo:
                continue
            if n > 0 and lo <= spans[j, n - 1, 1] + 1:
                if hi > spans[j, n - 1, 1]:
                    spans[j, n - 1, 1] = hi
            else:
                spans[j, n, 0] = lo
                spans[j, n, 1] = hi
                n += 1
        nsp[j] = n


@_serial
def live_spans(active: np.ndarray, ts: int, grow: int, y0: int, x0: int, bh: int, bw: int,
               w: np.ndarray, wc: np.ndarray, vx: np.ndarray, vy: np.ndarray, p: np.ndarray,
               ns: int, hsp: np.ndarray, hn: np.ndarray, spans: np.ndarray,
               nsp: np.ndarray) -> None:
    """The cells of the box within ``grow`` cells (chessboard) of a live cell, as sorted
    disjoint column spans like :func:`work_spans`. A cell is live if its water, capillary
    water, velocity or surface pigment (slots ``< ns``) is not zero; live cells lie in
    active tiles (the tiles' invariant), so only those are scanned. ``hsp``/``hn``: work
    arrays shaped like ``spans``/``nsp`` (each row's live runs grown along x)."""
    work_spans(active, ts, 0, y0, x0, bh, bw, spans, nsp)  # the active tiles' cells
    flag = np.zeros(bw + 2, np.uint8)
    for j in range(1, bh + 1):  # each active tile's row segment: first to last live cell,
        y = y0 + j - 1  # grown by ``grow`` along x (a superset of the cells needed is exact)
        wy = w[y, x0:]
        cy = wc[y, x0:]
        uy = vx[y, x0:]
        vy_ = vy[y, x0:]
        n = 0
        for si in range(nsp[j]):
            a, b = _span(spans, j, si)
            for i in range(a, b + 1):  # branch-free, vectorises
                flag[i] = (wy[i - 1] != 0) | (cy[i - 1] != 0) | (uy[i - 1] != 0) | (
                    vy_[i - 1] != 0)
            for k in range(ns):
                pk = p[k, y, x0:]
                for i in range(a, b + 1):
                    flag[i] |= pk[i - 1] != 0
            while a <= b and flag[a] == 0:
                a += 1
            if a > b:
                continue
            while flag[b] == 0:
                b -= 1
            lo = max(a - grow, 1)
            up = min(b + grow, bw)
            if n > 0 and lo <= hsp[j, n - 1, 1] + 1:
                hsp[j, n - 1, 1] = max(up, hsp[j, n - 1, 1])
            else:
                hsp[j, n, 0] = lo
                hsp[j, n, 1] = up
                n += 1
        hn[j] = n
    # the rows within ``grow``: each run lies inside one span of the active tiles grown by
    # ``grow`` (those are disjoint); keep, per such span, first start to last end
    work_spans(active, ts, grow, y0, x0, bh, bw, spans, nsp)
    lo_k = np.empty(spans.shape[1], np.int64)
    hi_k = np.empty(spans.shape[1], np.int64)
    for j in range(1, bh + 1):
        m = nsp[j]
        for k in range(m):
            lo_k[k] = bw + 1
            hi_k[k] = 0
        for r in range(max(j - grow, 1), min(j + grow, bh) + 1):
            k = 0
            for q in range(hn[r]):
                a = hsp[r, q, 0]
                while k < m - 1 and spans[j, k, 1] < a:
                    k += 1
                lo_k[k] = min(lo_k[k], a)
                hi_k[k] = max(hi_k[k], hsp[r, q, 1])
        n = 0
        for k in range(m):
            if hi_k[k] > 0:
                spans[j, n, 0] = lo_k[k]
                spans[j, n, 1] = hi_k[k]
                n += 1
        nsp[j] = n


@_serial
def clear_stale(pspans: np.ndarray, pnsp: np.ndarray, spans: np.ndarray, nsp: np.ndarray,
                f2: tuple[np.ndarray, ...], f3: tuple[np.ndarray, ...],
                f2u: tuple[np.ndarray, ...]) -> None:
    """Zero the scratch cells the last box computed (``pspans``) that this box does not
    (``spans``), in every field, and remember this box's spans: outside its spans the
    scratch is then zero, which stands for the reference's quiet cells and the ring
    "outside the box" alike (see :mod:`station.backends.cpu.step`)."""
    for r in range(pnsp.shape[0]):  # serial: a parallel region costs more here
        k = 0
        ncur = nsp[r]
        for q in range(pnsp[r]):
            a = pspans[r, q, 0]
            b = pspans[r, q, 1]
            c = a
            while c <= b:
                while k < ncur and spans[r, k, 1] < c:
                    k += 1
                if k < ncur and spans[r, k, 0] <= c:  # inside a current span: skip it
                    c = spans[r, k, 1] + 1
                    continue
                e = b if k >= ncur else min(b, spans[r, k, 0] - 1)
                for f in f2:
                    for i in range(c, e + 1):
                        f[r, i] = ZERO
                for f in f2u:
                    for i in range(c, e + 1):
                        f[r, i] = 0
                for f in f3:
                    for m in range(f.shape[0]):
                        for i in range(c, e + 1):
                            f[m, r, i] = ZERO
                c = e + 1
        for q in range(ncur):
            pspans[r, q, 0] = spans[r, q, 0]
            pspans[r, q, 1] = spans[r, q, 1]
        pnsp[r] = ncur


# ------------------------------------------------------------------ prep
@_inline
def _fibre_dispersion(fibre: np.ndarray, vx: np.ndarray, vy: np.ndarray, y: int,
                      x: np.uint64, gd: np.float32, vfib: np.float32,
                      own: np.float32) -> np.float32:
    """``own + gd * (max(fibre[0], fibre[1]) * min(|v|, fibre_flow_max))``: the factor on
    beta_c of a cell whose fibre channels disperse the pigment moving water carries
    (reference ``blocking``, ``water_speed``; v at the start of the step); ``own`` 1, or
    :func:`_standing_own` with ``standing_depth``."""
    f0 = fibre[0, y, x]
    f1 = fibre[1, y, x]
    u = vx[y, x]
    v = vy[y, x]
    s = np.sqrt(u * u + v * v)
    s = s if s < vfib else vfib
    return own + gd * ((f0 if f0 > f1 else f1) * s)


@_inline
def _smoothstep_w(w: np.float32, inv: np.float32) -> np.float32:
    """reference ``passes.standing_gate``: ``t t (3 - 2 t)``, ``t = min(w inv, 1)``."""
    t = w * inv
    t = ONE if t > ONE else t
    return (t * t) * (np.float32(3.0) - np.float32(2.0) * t)


@_inline
def _standing_own(w: np.float32, sinv: np.float32, sdrop: np.float32) -> np.float32:
    """``1 - drop * standing_gate(w)``: the pigment's own diffusion share in standing
    water (reference ``blocking``'s ``standing``)."""
    return ONE - sdrop * _smoothstep_w(w, sinv)


@_inline
def _damp_factor(wcv: np.float32, hv: np.float32, cmin: np.float32, cspan: np.float32,
                 ease: np.float32, dsat: np.float32, dspan: np.float32) -> np.float32:
    """``max(1 - damp_ease ((4 s') (1 - s')), 0)``, ``s' = max(s - damp_sat, 0) /
    (1 - damp_sat)``, ``s = min(wc / c, 1)`` (reference.damp_factor)."""
    s = wcv / (cmin + hv * cspan)
    s = ONE if s > ONE else s
    sp = s - dsat
    sp = (sp if sp > ZERO else ZERO) / dspan
    f = ONE - ease * ((FOUR * sp) * (ONE - sp))
    return ZERO if f < ZERO else f


@_inline
def _front_curvature(wr: np.ndarray, wn: np.ndarray, ws: np.ndarray, i: int,
                     curv: np.float32, curvn: np.float32, thr: np.float32, damp: bool,
                     line: bool) -> bool:
    """The contact line's reach with the meniscus's curvature (reference
    ``stencils.front_curvature``): on paper no damper than damp_sat the neighbourhood's
    water ``((E + W) + S) + N + a (((SE + SW) + NE) + NW)`` above ``(1 + 2a) thr``, read
    from the padded rows of w (row j: ``wr``, j - 1: ``wn``, j + 1: ``ws``)."""
    s4 = ((wr[i + 1] + wr[i - 1]) + ws[i]) + wn[i]
    sd = ((ws[i + 1] + ws[i - 1]) + wn[i + 1]) + wn[i - 1]
    return line if damp else (s4 + curv * sd) > curvn * thr


@_inline
def _wet_memory_row(own: np.ndarray, area: np.ndarray, y: int, x0: int, r: int, slo: int,
                    shi: int) -> None:
    """The wet-area mask of a span of row y: ``max(wet_area, own)`` (own 1/0, area in
    [0, 1]) into the row's ``own`` buffer and back into ``area`` (reference
    ``wet_memory``)."""
    for i in range(slo, shi + 1):
        x = np.uint64(x0 + i - 1)
        m = ONE if own[i + r] != ZERO else area[y, x]
        area[y, x] = m
        own[i + r] = m


@_parallel
def prep(w: np.ndarray, wc: np.ndarray, mask: np.ndarray, vx: np.ndarray, vy: np.ndarray,
         p: np.ndarray, h: np.ndarray, block: np.ndarray, block_time: np.ndarray,
         fibre: np.ndarray, taps: np.ndarray, y0: int, x0: int, bh: int, bw: int, ns: int,
         cst: np.ndarray, outward: bool, spans: np.ndarray, nsp: np.ndarray,
         wet_o: np.ndarray, w0_o: np.ndarray, p0_o: np.ndarray, bc_o: np.ndarray,
         opn_o: np.ndarray,
         mbx_o: np.ndarray, area: np.ndarray, holding: bool, bounds: np.ndarray,
         do_bc: bool, drying: bool, dbx_o: np.ndarray, runs: np.ndarray,
         rvals: np.ndarray, copy: bool) -> None:
    """Wet mask (once per step; own water, or the advancing contact line: a neighbour's
    w above ``advance_height (1.5 - h)``, on damp paper ``(1 + g/2 - g h)`` (g
    ``advance_grain``, reference ``stencils.advance_term``), lowered along the paper's
    fibres by ``1 - fibre_wick * fibre[axis]`` for the neighbours on that axis, with
    ``advance_curvature`` on paper no damper than damp_sat :func:`_front_curvature`'s; cells
    outside the box count as w = 0), copies, beta_c (diffusion controller, times the fibre
    dispersion), open, and with ``outward`` the own wet area blurred along x (``mbx``, the
    first half of :func:`flow_pressure`'s blur). With ``holding`` (``wet_hold > 0``) the
    blurred area is the wet-area mask ``max(wet_area, own)``, written back to ``area``
    (reference ``wet_memory``). Without ``do_bc`` (the standing gate's front factor on)
    beta_c is left to :func:`_front_row`, which writes it once with its factor; with
    ``drying`` (its dry-paper term) the x half of the blur of the not-dry paper ``wc >= T
    c`` into ``dbx_o`` (a column outside the box adds +0, a column of the box outside the
    spans reads the state; the row's blur outside its spans is the scratch's 0 like
    ``mbx``'s): this sweep reads the row's ``wc`` and ``h`` anyway. ``runs``/``rvals``
    ``[0]`` (``mbx``) and ``[1]`` (``dbx``): each row's run of one blurred value
    (:func:`_blur_x_run`; empty where there is none), for the y halves.

    The contact line reads its neighbours from a per-chunk ring of padded rows of the
    state's w (:func:`_state_row`: zero "outside the box" and outside the spans) without a
    bounds test, in branch-free rows that vectorise. With ``copy`` a first sweep copies
    w and p into the padded ``w0``/``p0`` for the sweeps that still read them (several
    Jacobi iterations, or pass 3 levelling w itself); without it nothing reads them
    (issue 26 item 1: 24 B a cell-step with two slots)."""
    moist = cst[C_MOIST]
    adv = cst[C_ADV]
    wick = cst[C_WICK]
    one5 = np.float32(1.5)
    abase = cst[C_ABASE]
    agrain = cst[C_AGRAIN]
    curv = cst[C_CURV]
    curvn = cst[C_CURVN]
    curving = curv > ZERO
    t_now = cst[C_TIME]
    fade = cst[C_FADE]
    bpaper = cst[C_BPAPER]
    cmin = cst[C_CMIN]
    cspan = cst[C_CSPAN]
    disp = cst[C_DISP]
    vfib = cst[C_VFIB]
    sinv = cst[C_SINV]
    sdrop = cst[C_SDROP]
    ease = cst[C_EASE]
    dsat = cst[C_DSAT]
    dspan = cst[C_DSPAN]
    easing = ease > ZERO
    advancing = adv > ZERO
    dry = cst[C_FDRY]
    nt = taps.shape[0]
    r = (nt - 1) // 2
    ur = np.uint64(r)
    xo = np.uint64(x0 - 1)
    nch = bounds.shape[0] - 1
    if copy:
        for ch in prange(nch):
            for j in range(bounds[ch], bounds[ch + 1]):
                y = y0 + j - 1
                for si in range(nsp[j]):
                    slo, shi = _span(spans, j, si)
                    for i in range(slo, shi + 1):
                        w0_o[j, i] = w[y, np.uint64(x0 + i - 1)]
                    for k in range(ns):
                        for i in range(slo, shi + 1):
                            p0_o[k, j, i] = p[k, y, np.uint64(x0 + i - 1)]
    for ch in prange(nch):
        j0, j1 = bounds[ch], bounds[ch + 1]
        # own wet area of a row with r zero columns each side (a tap outside the box adds
        # +0 there, which leaves the sum exactly as the reference's skipped term)
        own = np.empty(bw + 2 + 2 * r, F32)
        nd = np.empty(bw + 2 + 2 * r, F32)
        acc = np.empty(bw + 2, F32)
        ring = np.empty((3, bw + 2), F32)  # padded rows of w: row j in slot j % 3
        _state_row(w, y0, x0, j0 - 1, bh, spans, nsp, ring[(j0 - 1) % 3])
        _state_row(w, y0, x0, j0, bh, spans, nsp, ring[j0 % 3])
        for j in range(j0, j1):
            y = y0 + j - 1
            _state_row(w, y0, x0, j + 1, bh, spans, nsp, ring[(j + 1) % 3])
            wr, wn, ws = ring[j % 3], ring[(j - 1) % 3], ring[(j + 1) % 3]
            for i in range(bw + 2 + 2 * r):  # columns outside the spans: not own
                own[i] = ZERO
            for q in range(2):  # no run of one value yet (_blur_x_run)
                runs[q, j, 0] = 1
                runs[q, j, 1] = 0
            for si in range(nsp[j]):
                slo, shi = _span(spans, j, si)
                if advancing and wick > ZERO:
                    for i in range(slo, shi + 1):
                        x = np.uint64(x0 + i - 1)
                        wv = wr[i]
                        un = mask[y, x] == ZERO
                        ow = ((wv > ZERO) | (wc[y, x] > moist)) & un
                        own[i + r] = ONE if ow else ZERO
                        hv = h[y, x]
                        sv = wc[y, x] / (cmin + hv * cspan)
                        sv = sv if sv < ONE else ONE
                        thr = adv * ((abase - agrain * hv) if sv > dsat else (one5 - hv))
                        if easing:
                            thr = thr * _damp_factor(wc[y, x], h[y, x], cmin, cspan, ease,
                                                        dsat, dspan)
                        nb = wr[i + 1]
                        t = wr[i - 1]
                        nb = nb if nb > t else t
                        ny = ws[i]
                        t = wn[i]
                        ny = ny if ny > t else t
                        line = (nb > thr * (ONE - wick * fibre[0, y, x])) | \
                            (ny > thr * (ONE - wick * fibre[1, y, x]))
                        if curving:
                            line = _front_curvature(wr, wn, ws, i, curv, curvn, thr, sv > dsat,
                                                    line)
                        # 3: reached by the contact line, not wet by its own water
                        # (_pin decides; every wet_o is 0 or 1 when prep returns)
                        wet_o[j, i] = 1 if ow else (3 if un & line else 0)
                        opn_o[j, i] = 1 if un else 0
                else:
                    for i in range(slo, shi + 1):
                        x = np.uint64(x0 + i - 1)
                        wv = wr[i]
                        un = mask[y, x] == ZERO
                        ow = ((wv > ZERO) | (wc[y, x] > moist)) & un
                        own[i + r] = ONE if ow else ZERO
                        hv = h[y, x]
                        sv = wc[y, x] / (cmin + hv * cspan)
                        sv = sv if sv < ONE else ONE
                        thr = adv * ((abase - agrain * hv) if sv > dsat else (one5 - hv))
                        if easing:
                            thr = thr * _damp_factor(wc[y, x], h[y, x], cmin, cspan, ease,
                                                        dsat, dspan)
                        nb = wr[i + 1]
                        t = wr[i - 1]
                        nb = nb if nb > t else t
                        t = ws[i]
                        nb = nb if nb > t else t
                        t = wn[i]
                        nb = nb if nb > t else t
                        line = nb > thr
                        if curving:
                            line = _front_curvature(wr, wn, ws, i, curv, curvn, thr, sv > dsat,
                                                    line)
                        wet_o[j, i] = 1 if ow else (3 if un & advancing & line else 0)
                        opn_o[j, i] = 1 if un else 0
                if holding:  # a loop of its own: the column loops above stay as they were
                    _wet_memory_row(own, area, y, x0, r, slo, shi)
                if not do_bc:
                    continue
                if fade > ZERO:
                    for i in range(slo, shi + 1):
                        x = np.uint64(x0 + i - 1)
                        hv = h[y, x]
                        b = block[y, x]
                        age = (t_now - block_time[y, x]) / fade
                        age = ZERO if age < ZERO else age
                        age = ONE if age > ONE else age
                        eff = b + (ONE - b) * age
                        paper = ONE - bpaper * (ONE - hv)
                        bcv = paper if paper < eff else eff
                        bc_o[j, i] = bcv
                else:
                    for i in range(slo, shi + 1):
                        x = np.uint64(x0 + i - 1)
                        hv = h[y, x]
                        b = block[y, x]
                        eff = b + (ONE - b) * ONE
                        paper = ONE - bpaper * (ONE - hv)
                        bcv = paper if paper < eff else eff
                        bc_o[j, i] = bcv
                if disp > ZERO and sinv > ZERO:  # loops of their own: no tests inside
                    for i in range(slo, shi + 1):
                        x = np.uint64(x0 + i - 1)
                        own_p = _standing_own(wr[i], sinv, sdrop)
                        bc_o[j, i] = bc_o[j, i] * _fibre_dispersion(fibre, vx, vy, y, x, disp,
                                                                    vfib, own_p)
                elif disp > ZERO:
                    for i in range(slo, shi + 1):
                        x = np.uint64(x0 + i - 1)
                        bc_o[j, i] = bc_o[j, i] * _fibre_dispersion(fibre, vx, vy, y, x, disp,
                                                                    vfib, ONE)
                elif sinv > ZERO:
                    for i in range(slo, shi + 1):
                        bc_o[j, i] = bc_o[j, i] * _standing_own(wr[i], sinv, sdrop)
            if outward:
                # x half of the blur: tap-outer, column-inner; per cell the taps add in
                # order, offset -R first
                for si in range(nsp[j]):
                    slo, shi = _span(spans, j, si)
                    _blur_x_run(own, taps, slo, shi, acc, mbx_o[j], runs[0], rvals[0], j)
            if drying:
                wcr, hr = wc[y], h[y]
                for u in range(np.uint64(bw + 2 + 2 * r)):
                    nd[u] = ZERO
                for si in range(nsp[j]):
                    slo, shi = _span(spans, j, si)
                    lo = slo - r if slo - r > 1 else 1
                    hi = shi + r if shi + r < bw else bw
                    for u in range(np.uint64(lo), np.uint64(hi + 1)):
                        nd[u + ur] = ONE if wcr[xo + u] >= dry * (cmin + hr[xo + u] * cspan) \
                            else ZERO
                for si in range(nsp[j]):
                    slo, shi = _span(spans, j, si)
                    _blur_x_run(nd, taps, slo, shi, acc, dbx_o[j], runs[1], rvals[1], j)
    if advancing:
        _pin(wet_o, wc, h, y0, x0, bounds, spans, nsp, cmin, cspan, dsat,
             cst[C_DEXP] if outward else ZERO, mbx_o, taps, bh)


@_inline
def _front_row(mbx: np.ndarray, wet: np.ndarray, w: np.ndarray, h: np.ndarray,
               block: np.ndarray, block_time: np.ndarray, vx: np.ndarray, vy: np.ndarray,
               fibre: np.ndarray, dbx: np.ndarray, taps: np.ndarray, j: int, y: int, x0: int,
               bh: int, slo: int, shi: int, cst: np.ndarray, am: np.ndarray, ad: np.ndarray,
               pr_o: np.ndarray, bc_o: np.ndarray, runs: np.ndarray,
               rvals: np.ndarray) -> None:
    """The standing gate's front factor on the span ``slo..shi`` of row j (reference
    ``standing_front``): pass 3's levelled height (:func:`_pressure_row`, ``pr_o``; its y
    half of the blur is ``M'``) and beta_c, written once: :func:`prep`'s block and paper
    expression (it leaves ``bc`` alone with the front factor on) times ``own + gd (...)``
    (or ``own``), ``own = 1 - drop g (1 - F)``, ``F = smoothstep(eta (1 - M'))``, with
    ``C_FDRY`` times ``min(2 (1 - D'), 1)``, ``D'`` the y half of the blur of ``wc >= T
    c`` whose x half prep wrote into ``dbx``. Buffers (``bw + 2``): ``am`` M', ``ad`` D'.
    After the blurs one loop does the rest (three loops, with beta_c's block part and
    the levelled height in their own, took 5 % more of advect_jacobi1's CPU time).
    Unsigned columns throughout (numba's negative-index wraparound keeps signed ones
    scalar)."""
    disp = cst[C_DISP]
    vfib = cst[C_VFIB]
    sinv = cst[C_SINV]
    sdrop = cst[C_SDROP]
    eta = cst[C_ETA]
    rk, ri, ra, rinv = cst[C_RIMK], cst[C_RIMI], cst[C_RIMA], cst[C_RIMINV]
    relief = cst[C_RELIEF]
    finv = cst[C_FINV]
    drying = cst[C_FDRY] > ZERO
    t_now = cst[C_TIME]
    fade = cst[C_FADE]
    bpaper = cst[C_BPAPER]
    xo = np.uint64(x0 - 1)
    ulo, uhi = np.uint64(slo), np.uint64(shi + 1)
    _blur_y_run(mbx, taps, j, bh, ulo, uhi, am, runs[0], rvals[0])
    if drying:
        _blur_y_run(dbx, taps, j, bh, ulo, uhi, ad, runs[1], rvals[1])
    hr, br, btr = h[y], block[y], block_time[y]
    wr, wsr, pro, bcr = wet[j], w[y], pr_o[j], bc_o[j]
    f0r, f1r, vxr, vyr = fibre[0, y], fibre[1, y], vx[y], vy[y]
    # one loop: pass 3's levelled height (_pressure_row's expression), prep's beta_c
    # before its standing/dispersion factor, the factor
    for u in range(ulo, uhi):
        wv = wsr[xo + u]
        hv = hr[xo + u]
        pv = wv
        if relief > ZERO:
            pv = wv + relief * hv
        pv = pv - eta * _outward_pull(ONE - am[u], rk, ri, ra, rinv)
        pro[u] = pv if wr[u] != ZERO else wv
        b = br[xo + u]
        if fade > ZERO:
            age = (t_now - btr[xo + u]) / fade
            age = ZERO if age < ZERO else age
            age = ONE if age > ONE else age
            eff = b + (ONE - b) * age
        else:
            eff = b + (ONE - b) * ONE
        paper = ONE - bpaper * (ONE - hv)
        bcv = paper if paper < eff else eff
        fr = _smoothstep_w(eta * (ONE - am[u]), finv)
        if drying:
            dv = np.float32(2.0) * (ONE - ad[u])
            fr = fr * (ONE if dv > ONE else dv)
        own_p = ONE - sdrop * (_smoothstep_w(wv, sinv) * (ONE - fr))
        if disp > ZERO:
            f0 = f0r[xo + u]
            f1 = f1r[xo + u]
            a = vxr[xo + u]
            bv = vyr[xo + u]
            s = np.sqrt(a * a + bv * bv)
            s = s if s < vfib else vfib
            own_p = own_p + disp * ((f0 if f0 > f1 else f1) * s)
        bcr[u] = bcv * own_p


@_parallel
def standing_front(w: np.ndarray, h: np.ndarray, block: np.ndarray, block_time: np.ndarray,
                   vx: np.ndarray, vy: np.ndarray, fibre: np.ndarray, mbx: np.ndarray,
                   wet: np.ndarray, taps: np.ndarray, y0: int, x0: int, bh: int, bw: int,
                   cst: np.ndarray, spans: np.ndarray, nsp: np.ndarray, bounds: np.ndarray,
                   dbx: np.ndarray, bc_o: np.ndarray, pr_o: np.ndarray, runs: np.ndarray,
                   rvals: np.ndarray) -> None:
    """The standing gate's front factor and pass 3's levelled height (:func:`_front_row`)
    in a sweep of their own, after :func:`prep` (which wrote the x halves of both blurs,
    ``mbx`` and ``dbx``, and no ``bc``): with several Jacobi iterations
    :func:`advect_jacobi1` reads beta_c of the rows next to its own, which the next chunk
    writes. With one, advect_jacobi1 does this row by row itself (``front``)."""
    nch = bounds.shape[0] - 1
    for ch in prange(nch):
        am = np.empty(bw + 2, F32)
        ad = np.empty(bw + 2, F32)
        for j in range(bounds[ch], bounds[ch + 1]):
            y = y0 + j - 1
            for si in range(nsp[j]):
                slo, shi = _span(spans, j, si)
                _front_row(mbx, wet, w, h, block, block_time, vx, vy, fibre, dbx, taps, j,
                           y, x0, bh, slo, shi, cst, am, ad, pr_o, bc_o, runs, rvals)


@_inline
def _pin(wet_o: np.ndarray, wc: np.ndarray, h: np.ndarray, y0: int, x0: int,
         bounds: np.ndarray, spans: np.ndarray, nsp: np.ndarray, cmin: np.float32,
         cspan: np.float32, dsat: np.float32, dexp: np.float32, mbx: np.ndarray,
         taps: np.ndarray, bh: int) -> None:
    """The contact line pinned on dry paper (stencils.pinned). ``wet_o`` comes in as 1
    (wet by its own water), 3 (reached by the contact line) or 0: a 3 whose paper is no
    damper than ``damp_sat`` with under two non-zero 4-neighbours becomes 2 (its
    neighbours' counts in the same sweep still read it as wet, whichever thread gets there
    first); then 3 becomes 1 and 2 becomes 0, but with ``dexp`` (damp_exposure) a 3 on
    damp paper whose exposure ``1 - M'`` is below it becomes 0 (stencils.sheltered; M' the
    y half of the blur of ``mbx``, prep's x half of the wet-area mask, taps in order, rows
    outside the box skipped where the reference adds 0). One byte a cell read once (a
    vectorised maximum over each span: a span without a 3 is skipped, and so are the rows
    without one in the second sweep, i.e. the whole of a wash), the rest only at the
    front."""
    nch = bounds.shape[0] - 1
    front = np.zeros(bounds[nch] + 1, np.uint8)  # 1: the row holds a 3
    for ch in prange(nch):
        for j in range(bounds[ch], bounds[ch + 1]):
            y = y0 + j - 1
            row = wet_o[j]
            for si in range(nsp[j]):
                slo, shi = _span(spans, j, si)
                top = np.uint8(0)
                for u in range(np.uint64(slo), np.uint64(shi + 1)):  # unsigned: vectorises
                    v = row[u]
                    top = v if v > top else top
                if top < 3:
                    continue
                front[j] = 1
                for i in range(slo, shi + 1):
                    if wet_o[j, i] != 3:
                        continue
                    n = 0
                    if wet_o[j, i - 1] != 0:
                        n += 1
                    if wet_o[j, i + 1] != 0:
                        n += 1
                    if wet_o[j - 1, i] != 0:
                        n += 1
                    if wet_o[j + 1, i] != 0:
                        n += 1
                    if n >= 2:
                        continue
                    x = np.uint64(x0 + i - 1)
                    sat = wc[y, x] / (cmin + h[y, x] * cspan)
                    sat = ONE if sat > ONE else sat
                    if sat > dsat:
                        continue  # damp paper: the front runs on in the capillary film
                    wet_o[j, i] = 2
    for ch in prange(nch):
        for j in range(bounds[ch], bounds[ch + 1]):
            if front[j] == 0:
                continue
            y = y0 + j - 1
            for si in range(nsp[j]):
                slo, shi = _span(spans, j, si)
                for i in range(slo, shi + 1):
                    v = wet_o[j, i]
                    if v == 3 and dexp > ZERO:
                        x = np.uint64(x0 + i - 1)
                        sat = wc[y, x] / (cmin + h[y, x] * cspan)
                        sat = ONE if sat > ONE else sat
                        if sat > dsat and ONE - _blur_y_at(mbx, taps, j, i, bh) < dexp:
                            v = 2  # sheltered: the wash's paint holds in a bay
                    if v > 1:
                        wet_o[j, i] = 1 if v == 3 else 0


# ------------------------------------------------------------------ flow outward
@_inline
def _blur_y_at(src: np.ndarray, taps: np.ndarray, j: int, i: int, bh: int) -> np.float32:
    """The y half of a blur of ``src`` (box rows 1..bh) at row j, column i: one cell of
    :func:`_blur_y_row` (taps in order from 0, rows outside the box skipped)."""
    nt = taps.shape[0]
    r = (nt - 1) // 2
    acc = ZERO
    for k in range(nt):
        jj = j + k - r
        if jj >= 1 and jj <= bh:
            acc = acc + taps[k] * src[jj, i]
    return acc


@_inline
def _blur_x_row(src: np.ndarray, taps: np.ndarray, ulo: np.uint64, uhi: np.uint64,
                acc: np.ndarray, out: np.ndarray) -> None:
    """``out[ulo:uhi]`` = the x half of a blur of the padded row ``src`` (``src[u + k]``
    is column u's tap k, offset -R first): tap-outer, column-inner, three taps a pass
    (the same additions in the same order), the sum in ``acc``. Unsigned columns:
    vectorised (numba's negative-index wraparound keeps signed ones scalar)."""
    nt = taps.shape[0]
    for u in range(ulo, uhi):
        acc[u] = ZERO
    k = 0
    while k + 3 <= nt:
        g0, g1, g2 = taps[k], taps[k + 1], taps[k + 2]
        ka, kb, kc = np.uint64(k), np.uint64(k + 1), np.uint64(k + 2)
        for u in range(ulo, uhi):
            acc[u] = ((acc[u] + g0 * src[u + ka]) + g1 * src[u + kb]) + g2 * src[u + kc]
        k += 3
    for kk in range(k, nt):
        g = taps[kk]
        ka = np.uint64(kk)
        for u in range(ulo, uhi):
            acc[u] = acc[u] + g * src[u + ka]
    for u in range(ulo, uhi):
        out[u] = acc[u]


@_inline
def _tap_sum(taps: np.ndarray, v: np.float32) -> np.float32:
    """The blur of a constant ``v``: ``((0 + g0 v) + g1 v) + ...`` over the taps in order,
    the additions :func:`_blur_x_row` and :func:`_blur_y_row` make at a cell whose taps
    all read ``v`` (their groups of three are the same additions in the same order)."""
    acc = ZERO
    for k in range(taps.shape[0]):
        acc = acc + taps[k] * v
    return acc


@_inline
def _blur_x_run(src: np.ndarray, taps: np.ndarray, slo: int, shi: int, acc: np.ndarray,
                out: np.ndarray, run: np.ndarray, rval: np.ndarray, j: int) -> None:
    """:func:`_blur_x_row` on the span ``slo..shi`` of row j, and where the span's own
    values ``src[slo + R .. shi + R]`` are all one value v, ``_tap_sum(v)`` on the columns
    ``slo + R .. shi - R`` (their taps read only v) without the taps' arithmetic: the same
    float32 value. Such a run is kept as row j's in ``run``/``rval`` (the y half of the
    blur uses it, :func:`_blur_y_run`); a row's first span with one wins. A fully wet
    wash has one in nearly every row, where the 2 R + 1 taps cost ~3 ms a 1920x1080
    field."""
    nt = taps.shape[0]
    r = (nt - 1) // 2
    ur = np.uint64(r)
    a, b = slo + r, shi - r
    v = src[np.uint64(slo) + ur]
    if a <= b:
        same = 0
        for u in range(np.uint64(slo) + ur, np.uint64(shi + 1) + ur):  # vectorises
            same += 1 if src[u] == v else 0
        if same != shi - slo + 1:
            a, b = shi + 1, shi
    if a > b:
        _blur_x_row(src, taps, np.uint64(slo), np.uint64(shi + 1), acc, out)
        return
    _blur_x_row(src, taps, np.uint64(slo), np.uint64(a), acc, out)
    _blur_x_row(src, taps, np.uint64(b + 1), np.uint64(shi + 1), acc, out)
    s = _tap_sum(taps, v)
    for u in range(np.uint64(a), np.uint64(b + 1)):
        out[u] = s
    if run[j, 0] > run[j, 1]:
        run[j, 0] = a
        run[j, 1] = b
        rval[j] = s


@_inline
def _blur_y_run(src: np.ndarray, taps: np.ndarray, j: int, bh: int, ulo: np.uint64,
                uhi: np.uint64, acc: np.ndarray, run: np.ndarray,
                rval: np.ndarray) -> None:
    """:func:`_blur_y_row`, but on the columns where the 2 R + 1 rows it reads all hold
    one value (their runs, :func:`_blur_x_run`, overlap there with equal values, all rows
    in the box) ``_tap_sum`` of it: the same float32 value without the taps'
    arithmetic."""
    nt = taps.shape[0]
    r = (nt - 1) // 2
    a, b = int(ulo), int(uhi) - 1
    if j - r >= 1 and j + r <= bh:
        v = rval[j - r]
        for jj in range(j - r, j + r + 1):
            lo_, hi_ = run[jj, 0], run[jj, 1]
            a = lo_ if lo_ > a else a
            b = hi_ if hi_ < b else b
            if rval[jj] != v:
                b = a - 1
    else:
        b = a - 1
    if a > b:
        _blur_y_row(src, taps, j, bh, ulo, uhi, acc)
        return
    _blur_y_row(src, taps, j, bh, ulo, np.uint64(a), acc)
    _blur_y_row(src, taps, j, bh, np.uint64(b + 1), uhi, acc)
    s = _tap_sum(taps, rval[j - r])
    for u in range(np.uint64(a), np.uint64(b + 1)):
        acc[u] = s


@_inline
def _blur_y_row(src: np.ndarray, taps: np.ndarray, j: int, bh: int, ulo: np.uint64,
                uhi: np.uint64, acc: np.ndarray) -> None:
    """``acc[ulo:uhi]`` = the y half of a blur of ``src`` (an x-blurred scratch field, box
    rows 1..bh) at row j: taps in order, offset -R first, rows outside the box skipped
    where the reference adds 0; three taps a pass over the row where their rows are all in
    the box (the same additions in the same order): one load and store of acc per three
    taps. Unsigned columns: numba's negative-index wraparound keeps signed ones scalar."""
    nt = taps.shape[0]
    r = (nt - 1) // 2
    for u in range(ulo, uhi):
        acc[u] = ZERO
    k = 0
    while k < nt:
        jj = j + k - r
        if k + 3 <= nt and jj >= 1 and jj + 2 <= bh:
            g0, g1, g2 = taps[k], taps[k + 1], taps[k + 2]
            m0, m1, m2 = src[jj], src[jj + 1], src[jj + 2]
            for u in range(ulo, uhi):
                acc[u] = ((acc[u] + g0 * m0[u]) + g1 * m1[u]) + g2 * m2[u]
            k += 3
            continue
        if jj >= 1 and jj <= bh:
            g = taps[k]
            mk = src[jj]
            for u in range(ulo, uhi):
                acc[u] = acc[u] + g * mk[u]
        k += 1


@_inline
def _outward_pull(u: np.float32, rk: np.float32, ri: np.float32, ra: np.float32,
                  rinv: np.float32) -> np.float32:
    """The flow outward's pull per unit ``eta`` at the dry share ``u = 1 - M'``
    (reference ``stencils.outward_pull``): ``u``, or with ``rk`` (rim_sharpness k > 0)
    ``ri u + rk min(max((u - ra) rinv, 0), 1)``."""
    if rk > ZERO:
        s = (u - ra) * rinv
        s = s if s >= ZERO else ZERO  # np.maximum's and np.minimum's choices
        s = s if s <= ONE else ONE
        return ri * u + rk * s
    return u


@_inline
def _pressure_row(mbx: np.ndarray, wet: np.ndarray, w: np.ndarray, h: np.ndarray,
                  taps: np.ndarray, j: int, y: int, x0: int, bh: int, lo: int, hi: int,
                  eta: np.float32, relief: np.float32, outward: bool, acc: np.ndarray,
                  pr_o: np.ndarray, run: np.ndarray, rval: np.ndarray,
                  rim: np.ndarray) -> None:
    """Pass 3's levelled height ``P = (w + relief h) - eta pull(1 - M')`` on wet cells of
    row j (:func:`_outward_pull`, ``rim`` its constants ``C_RIMK .. C_RIMINV``; ``w``
    elsewhere; a term whose parameter is 0 is left out), ``M'`` the y half of the
    blur of ``mbx`` (taps in order, offset -R first; rows outside the box are skipped where
    the reference adds 0: :func:`_blur_y_row`)."""
    # unsigned columns throughout: numba cannot bound ``lo`` here, and its negative-index
    # wraparound made these loops scalar, the zeroing one a 16-lane scatter (~60 % of
    # this sweep at 1920x1080 between them)
    ulo, uhi = np.uint64(lo), np.uint64(hi + 1)
    if outward:
        _blur_y_run(mbx, taps, j, bh, ulo, uhi, acc, run, rval)
    wr, wsr, pro = wet[j], w[y], pr_o[j]
    hrow = h[y]
    xo = np.uint64(x0 - 1)
    for u in range(ulo, uhi):
        wv = wsr[xo + u]
        pv = wv
        if relief > ZERO:
            pv = wv + relief * hrow[xo + u]
        if outward:
            pv = pv - eta * _outward_pull(ONE - acc[u], rim[0], rim[1], rim[2], rim[3])
        pro[u] = pv if wr[u] != ZERO else wv


# ------------------------------------------------------------------ pass 1 + Jacobi 1
@_inline
def _backtrace_cell(wet: np.ndarray, vx: np.ndarray, vy: np.ndarray, y0: int, x0: int,
                    bh: int, bw: int, dx: int, dy: int, fdt: np.float32, j: int, i: int,
                    v1x_o: np.ndarray, v1y_o: np.ndarray) -> None:
    """Pass 1 at one cell (any cell of the box: the reference's clamps)."""
    y = y0 + j - 1
    if wet[j, i] != ZERO:
        # x axis (box-relative index i - 1, n = bw)
        if bw < 2:
            ix, fx = 0, ZERO
        else:
            off = -(vx[y, np.uint64(x0 + i - 1)] * fdt)
            fl = np.floor(off)
            fx = off - fl
            ix = (i - 1) + int(fl)
            if ix < 0:
                ix, fx = 0, ZERO
            elif ix >= bw - 1:
                ix, fx = bw - 2, ONE
        if bh < 2:
            iy, fy = 0, ZERO
        else:
            off = -(vy[y, np.uint64(x0 + i - 1)] * fdt)
            fl = np.floor(off)
            fy = off - fl
            iy = (j - 1) + int(fl)
            if iy < 0:
                iy, fy = 0, ZERO
            elif iy >= bh - 1:
                iy, fy = bh - 2, ONE
        gx = ONE - fx
        gy = ONE - fy
        a0, a1 = iy + 1, iy + 1 + dy
        b0, b1 = ix + 1, ix + 1 + dx
        # the masked velocity at the 4 corners (0 where not wet)
        ya, yb = np.uint64(y0 + a0 - 1), np.uint64(y0 + a1 - 1)
        xa, xb = np.uint64(x0 + b0 - 1), np.uint64(x0 + b1 - 1)
        m00 = wet[a0, b0] != 0
        m01 = wet[a0, b1] != 0
        m10 = wet[a1, b0] != 0
        m11 = wet[a1, b1] != 0
        top = gx * (vx[ya, xa] if m00 else ZERO) \
            + fx * (vx[ya, xb] if m01 else ZERO)
        bot = gx * (vx[yb, xa] if m10 else ZERO) \
            + fx * (vx[yb, xb] if m11 else ZERO)
        v1x_o[j, i] = gy * top + fy * bot
        top = gx * (vy[ya, xa] if m00 else ZERO) \
            + fx * (vy[ya, xb] if m01 else ZERO)
        bot = gx * (vy[yb, xa] if m10 else ZERO) \
            + fx * (vy[yb, xb] if m11 else ZERO)
        v1y_o[j, i] = gy * top + fy * bot
    else:
        v1x_o[j, i] = ZERO
        v1y_o[j, i] = ZERO


@_inline
def _backtrace_run(wet: np.ndarray, vx: np.ndarray, vy: np.ndarray, y0: int, x0: int,
                   fdt: np.float32, j: int, lo: int, hi: int, v1x_o: np.ndarray,
                   v1y_o: np.ndarray) -> None:
    """Pass 1 on the columns lo..hi of row j, all at least 2 cells inside the box
    (2 <= i <= bw - 2, 2 <= j <= bh - 2) where ``v dt <= 1`` (the caller checks): no clamp
    applies, ``floor(-v dt)`` is -1, 0 or 1, so every corner lies in rows j-1..j+2 and
    columns i-1..i+2; each is loaded from a contiguous row and picked by selects, so the
    column loop vectorises. The operands and their order are :func:`_backtrace_cell`'s."""
    y = y0 + j - 1
    for comp in range(2):
        v = vx if comp == 0 else vy
        o = v1x_o if comp == 0 else v1y_o
        rm, r0, rp, r2 = v[y - 1], v[y], v[y + 1], v[y + 2]
        wm, w0_, wp, w2 = wet[j - 1], wet[j], wet[j + 1], wet[j + 2]
        for i in range(lo, hi + 1):
            x = x0 + i - 1
            xm, x_, xp, x2 = (np.uint64(x - 1), np.uint64(x), np.uint64(x + 1),
                              np.uint64(x + 2))
            im, i_, ip, i2 = (np.uint64(i - 1), np.uint64(i), np.uint64(i + 1),
                              np.uint64(i + 2))
            offx = -(vx[y, x_] * fdt)
            flx = np.floor(offx)
            fx = offx - flx
            offy = -(vy[y, x_] * fdt)
            fly = np.floor(offy)
            fy = offy - fly
            gx = ONE - fx
            gy = ONE - fy
            cm = flx < ZERO
            c0 = flx == ZERO
            # per candidate row: gx * V[b0] + fx * V[b1], V masked by the wet flags
            t = rm[xm]
            a_m = t if wm[im] != 0 else ZERO
            t = rm[x_]
            a_0 = t if wm[i_] != 0 else ZERO
            t = rm[xp]
            a_p = t if wm[ip] != 0 else ZERO
            t = rm[x2]
            a_2 = t if wm[i2] != 0 else ZERO
            top_m = gx * (a_m if cm else (a_0 if c0 else a_p)) \
                + fx * (a_0 if cm else (a_p if c0 else a_2))
            t = r0[xm]
            a_m = t if w0_[im] != 0 else ZERO
            t = r0[x_]
            a_0 = t if w0_[i_] != 0 else ZERO
            t = r0[xp]
            a_p = t if w0_[ip] != 0 else ZERO
            t = r0[x2]
            a_2 = t if w0_[i2] != 0 else ZERO
            top_0 = gx * (a_m if cm else (a_0 if c0 else a_p)) \
                + fx * (a_0 if cm else (a_p if c0 else a_2))
            t = rp[xm]
            a_m = t if wp[im] != 0 else ZERO
            t = rp[x_]
            a_0 = t if wp[i_] != 0 else ZERO
            t = rp[xp]
            a_p = t if wp[ip] != 0 else ZERO
            t = rp[x2]
            a_2 = t if wp[i2] != 0 else ZERO
            top_p = gx * (a_m if cm else (a_0 if c0 else a_p)) \
                + fx * (a_0 if cm else (a_p if c0 else a_2))
            t = r2[xm]
            a_m = t if w2[im] != 0 else ZERO
            t = r2[x_]
            a_0 = t if w2[i_] != 0 else ZERO
            t = r2[xp]
            a_p = t if w2[ip] != 0 else ZERO
            t = r2[x2]
            a_2 = t if w2[i2] != 0 else ZERO
            top_2 = gx * (a_m if cm else (a_0 if c0 else a_p)) \
                + fx * (a_0 if cm else (a_p if c0 else a_2))
            rm_ = fly < ZERO
            r0_ = fly == ZERO
            top = top_m if rm_ else (top_0 if r0_ else top_p)
            bot = top_0 if rm_ else (top_p if r0_ else top_2)
            val = gy * top + fy * bot
            o[j, i_] = val if w0_[i_] != 0 else ZERO  # unsigned: a signed i made this a scatter


@_parallel
def advect_jacobi1(wet: np.ndarray, vx: np.ndarray, vy: np.ndarray, bc: np.ndarray,
                   w0: np.ndarray, p0: np.ndarray, mbx: np.ndarray, h: np.ndarray,
                   taps: np.ndarray, y0: int, x0: int, bh: int, bw: int, ns: int,
                   cst: np.ndarray, do_w: bool, do_p: bool, do_pr: bool, outward: bool,
                   spans: np.ndarray, nsp: np.ndarray, v1x_o: np.ndarray, v1y_o: np.ndarray,
                   xw_o: np.ndarray, xp_o: np.ndarray, pr_o: np.ndarray,
                   bounds: np.ndarray, front: bool, block: np.ndarray,
                   block_time: np.ndarray, fibre: np.ndarray, dbx: np.ndarray,
                   runs: np.ndarray, rvals: np.ndarray, w: np.ndarray) -> None:
    """Pass 1 (bilinear back-trace of the masked velocity: the state's ``vx``/``vy`` where
    the wet mask is set, 0 elsewhere; box-relative clamps), with
    ``do_pr`` pass 3's levelled height (:func:`_pressure_row`), with ``front`` instead the
    standing gate's front factor (:func:`_front_row`: pass 3's levelled height and beta_c
    into ``bc``; only without ``do_p``'s iteration, which reads beta_c of the next rows),
    and the first Jacobi iteration of the water and pigment solves (from x0 = u).
    Folding the front factor in here spares it a sweep of its own and the second read
    of the row's wet mask and velocity. The levelled height reads the cell's own water
    from the state's ``w`` (prep copies ``w0`` only for the Jacobi iterations here and in
    :func:`jacobi_blocked`)."""
    fdt = cst[C_DT]
    kw = cst[C_KW]
    kp = cst[C_KP]
    eta = cst[C_ETA]
    relief = cst[C_RELIEF]
    dx = 1 if bw > 1 else 0
    dy = 1 if bh > 1 else 0
    nch = bounds.shape[0] - 1
    for ch in prange(nch):
        j0, j1 = bounds[ch], bounds[ch + 1]
        acc = np.empty(bw + 2, F32)
        ad = np.empty(bw + 2 if front else 0, F32)
        for j in range(j0, j1):
            for si in range(nsp[j]):
                slo, shi = _span(spans, j, si)
                if do_pr:
                    _pressure_row(mbx, wet, w, h, taps, j, y0 + j - 1, x0, bh, slo, shi, eta,
                                  relief, outward, acc, pr_o, runs[0], rvals[0],
                                  cst[C_RIMK:C_RIMINV + 1])
                elif front:
                    _front_row(mbx, wet, w, h, block, block_time, vx, vy, fibre, dbx, taps,
                               j, y0 + j - 1, x0, bh, slo, shi, cst, acc, ad, pr_o, bc,
                               runs, rvals)
                y = y0 + j - 1
                # the cells 2 or more inside the box go through the vectorised run when
                # every |v dt| of the row's span is <= 1 (the step's CFL bound)
                lo, hi = shi + 1, shi
                if 2 <= j <= bh - 2 and bw >= 4:
                    fast = True
                    for i in range(slo, shi + 1):
                        xu = np.uint64(x0 + i - 1)
                        fast &= (vx[y, xu] * fdt <= ONE) & (-(vx[y, xu] * fdt) <= ONE) \
                            & (vy[y, xu] * fdt <= ONE) & (-(vy[y, xu] * fdt) <= ONE)
                    if fast:
                        lo, hi = max(slo, 2), min(shi, bw - 2)
                # the cells outside the vectorised run, one by one (a test of every
                # column of the span was a scalar loop: ~5 % of this sweep)
                for i in range(slo, min(lo, shi + 1)):
                    _backtrace_cell(wet, vx, vy, y0, x0, bh, bw, dx, dy, fdt, j, i,
                                    v1x_o, v1y_o)
                for i in range(max(hi + 1, slo), shi + 1):
                    _backtrace_cell(wet, vx, vy, y0, x0, bh, bw, dx, dy, fdt, j, i,
                                    v1x_o, v1y_o)
                if lo <= hi:
                    _backtrace_run(wet, vx, vy, y0, x0, fdt, j, lo, hi, v1x_o, v1y_o)
                if do_w:
                    _jacobi_w_row(wet, w0, w0, xw_o, j, slo, shi, kw)
                if do_p:
                    _jacobi_p_row(wet, bc, p0, p0, xp_o, j, slo, shi, ns, kp)


@_inline
def _jacobi_v_row(wet: np.ndarray, ux: np.ndarray, uy: np.ndarray, xx: np.ndarray,
                  xy: np.ndarray, ox: np.ndarray, oy: np.ndarray, j: int, lo: int, hi: int,
                  k: np.float32) -> None:
    """One Jacobi iteration of pass 2 on row j (open faces: both cells wet)."""
    wr, wn, ws = wet[j], wet[j - 1], wet[j + 1]
    for i in range(lo, hi + 1):
        c = F32(wr[i])
        be = c * F32(wr[i + 1])
        bwf = c * F32(wr[i - 1])
        bs = c * F32(ws[i])
        bn = c * F32(wn[i])
        den = ONE + k * (((be * ONE + bwf * ONE) + bs * ONE) + bn * ONE)
        sx = ((be * xx[j, i + 1] + bwf * xx[j, i - 1]) + bs * xx[j + 1, i]) + bn * xx[j - 1, i]
        sy = ((be * xy[j, i + 1] + bwf * xy[j, i - 1]) + bs * xy[j + 1, i]) + bn * xy[j - 1, i]
        ox[j, i] = (ux[j, i] + k * sx) / den
        oy[j, i] = (uy[j, i] + k * sy) / den


@_inline
def _jacobi_w_row(wet: np.ndarray, u: np.ndarray, xin: np.ndarray, xout: np.ndarray,
                  j: int, lo: int, hi: int, k: np.float32) -> None:
    """One Jacobi iteration of the water solve (pass 4) on row j."""
    wr, wn, ws = wet[j], wet[j - 1], wet[j + 1]
    for i in range(lo, hi + 1):
        c = F32(wr[i])
        be = c * F32(wr[i + 1])
        bwf = c * F32(wr[i - 1])
        bs = c * F32(ws[i])
        bn = c * F32(wn[i])
        den = ONE + k * (((be * ONE + bwf * ONE) + bs * ONE) + bn * ONE)
        acc = ((be * xin[j, i + 1] + bwf * xin[j, i - 1]) + bs * xin[j + 1, i]) \
            + bn * xin[j - 1, i]
        xout[j, i] = (acc * k + u[j, i]) / den


@_inline
def _jacobi_p_row(wet: np.ndarray, bc: np.ndarray, u: np.ndarray, xin: np.ndarray,
                  xout: np.ndarray, j: int, lo: int, hi: int, ns: int, k: np.float32) -> None:
    """One Jacobi iteration of the pigment solve (pass 5, controller conductances)."""
    wr, wn, ws = wet[j], wet[j - 1], wet[j + 1]
    br, bnr, bsr = bc[j], bc[j - 1], bc[j + 1]
    for kk in range(ns):
        for i in range(lo, hi + 1):
            c = wr[i]
            b0 = br[i]
            t = br[i + 1]
            be = (b0 if b0 < t else t) if (c != 0) & (wr[i + 1] != 0) else ZERO
            t = br[i - 1]
            bwf = (b0 if b0 < t else t) if (c != 0) & (wr[i - 1] != 0) else ZERO
            t = bsr[i]
            bs = (b0 if b0 < t else t) if (c != 0) & (ws[i] != 0) else ZERO
            t = bnr[i]
            bn = (b0 if b0 < t else t) if (c != 0) & (wn[i] != 0) else ZERO
            den = ONE + k * (((be * ONE + bwf * ONE) + bs * ONE) + bn * ONE)
            acc = ((be * xin[kk, j, i + 1] + bwf * xin[kk, j, i - 1]) + bs * xin[kk, j + 1, i]) \
                + bn * xin[kk, j - 1, i]
            xout[kk, j, i] = (acc * k + u[kk, j, i]) / den


# ------------------------------------------------------------------ Jacobi sweep
@_inline
def _jv_rows(wn: np.ndarray, wr: np.ndarray, ws: np.ndarray, u: np.ndarray, xn: np.ndarray,
             xr: np.ndarray, xs: np.ndarray, o: np.ndarray, lo: int, hi: int,
             k: np.float32) -> None:
    """One Jacobi iteration of one velocity component on one row, from row views
    (north, this, south) of the wet mask and the iterate: ``(u + k sum) / den``."""
    for i in range(lo, hi + 1):
        c = F32(wr[i])
        be = c * F32(wr[i + 1])
        bwf = c * F32(wr[i - 1])
        bs = c * F32(ws[i])
        bn = c * F32(wn[i])
        den = ONE + k * (((be * ONE + bwf * ONE) + bs * ONE) + bn * ONE)
        sx = ((be * xr[i + 1] + bwf * xr[i - 1]) + bs * xs[i]) + bn * xn[i]
        o[i] = (u[i] + k * sx) / den


@_inline
def _jw_rows(wn: np.ndarray, wr: np.ndarray, ws: np.ndarray, u: np.ndarray, xn: np.ndarray,
             xr: np.ndarray, xs: np.ndarray, o: np.ndarray, lo: int, hi: int,
             k: np.float32) -> None:
    """One Jacobi iteration of the water solve on one row: ``(sum k + u) / den``."""
    for i in range(lo, hi + 1):
        c = F32(wr[i])
        be = c * F32(wr[i + 1])
        bwf = c * F32(wr[i - 1])
        bs = c * F32(ws[i])
        bn = c * F32(wn[i])
        den = ONE + k * (((be * ONE + bwf * ONE) + bs * ONE) + bn * ONE)
        acc = ((be * xr[i + 1] + bwf * xr[i - 1]) + bs * xs[i]) + bn * xn[i]
        o[i] = (acc * k + u[i]) / den


@_inline
def _jp_rows(wn: np.ndarray, wr: np.ndarray, ws: np.ndarray, bn_: np.ndarray,
             br: np.ndarray, bs_: np.ndarray, u: np.ndarray, xn: np.ndarray, xr: np.ndarray,
             xs: np.ndarray, o: np.ndarray, lo: int, hi: int, k: np.float32) -> None:
    """One Jacobi iteration of one pigment slot on one row (controller conductances)."""
    for i in range(lo, hi + 1):
        c = wr[i]
        b0 = br[i]
        t = br[i + 1]
        be = (b0 if b0 < t else t) if (c != 0) & (wr[i + 1] != 0) else ZERO
        t = br[i - 1]
        bwf = (b0 if b0 < t else t) if (c != 0) & (wr[i - 1] != 0) else ZERO
        t = bs_[i]
        bs = (b0 if b0 < t else t) if (c != 0) & (ws[i] != 0) else ZERO
        t = bn_[i]
        bn = (b0 if b0 < t else t) if (c != 0) & (wn[i] != 0) else ZERO
        den = ONE + k * (((be * ONE + bwf * ONE) + bs * ONE) + bn * ONE)
        acc = ((be * xr[i + 1] + bwf * xr[i - 1]) + bs * xs[i]) + bn * xn[i]
        o[i] = (acc * k + u[i]) / den


BLOCK_ROWS = 16
"""Rows per chunk of the temporally blocked Jacobi sweep."""


@_parallel
def jacobi_blocked(wet: np.ndarray, bc: np.ndarray, v1x: np.ndarray, v1y: np.ndarray,
                   xvx: np.ndarray, xvy: np.ndarray, ovx: np.ndarray, ovy: np.ndarray,
                   w0: np.ndarray, xw: np.ndarray, ow: np.ndarray,
                   p0: np.ndarray, xp: np.ndarray, op: np.ndarray,
                   bh: int, bw: int, ns: int, cst: np.ndarray,
                   do_v: bool, do_w: bool, do_p: bool, levels: int, spans: np.ndarray,
                   nsp: np.ndarray, jbuf: np.ndarray) -> None:
    """``levels`` Jacobi iterations of each solve that is switched on, in ONE sweep
    (temporal blocking): each chunk of rows computes iteration l on its rows grown by
    ``levels - l`` rows on each side (recomputing its neighbours' edge rows) into
    chunk-local buffers that stay in cache, and writes only the last iteration. The
    values are those of ``levels`` plain one-iteration sweeps, bit for bit (the same
    row functions, the same operands).

    The buffers are the calling thread's part of ``jbuf`` (threads, 3 + slots, parity,
    rows, columns), allocated zero once: cells outside the spans are never computed, and
    a computed cell reads them only through a closed face (times 0), so they need only be
    finite."""
    kv = cst[C_KV]
    kw = cst[C_KW]
    kp = cst[C_KP]
    nch = (bh + BLOCK_ROWS - 1) // BLOCK_ROWS
    for ch in prange(nch):
        j0, j1 = _chunk(ch, nch, bh)
        base = j0 - levels  # global row of buffer row 0
        nrow = (j1 - j0) + 2 * levels
        tid = get_thread_id()
        bvx = jbuf[tid, 0]
        bvy = jbuf[tid, 1]
        bww = jbuf[tid, 2]
        for par in range(2):
            for t in range(nrow):
                bvx[par, t, 0] = ZERO
                bvx[par, t, bw + 1] = ZERO
                bvy[par, t, 0] = ZERO
                bvy[par, t, bw + 1] = ZERO
                bww[par, t, 0] = ZERO
                bww[par, t, bw + 1] = ZERO
                for kk in range(ns):
                    jbuf[tid, 3 + kk, par, t, 0] = ZERO
                    jbuf[tid, 3 + kk, par, t, bw + 1] = ZERO
                g = base + t
                if g < 1 or g > bh:  # the ring rows (and beyond): zero like the scratch ring
                    for i in range(bw + 2):
                        bvx[par, t, i] = ZERO
                        bvy[par, t, i] = ZERO
                        bww[par, t, i] = ZERO
                        for kk in range(ns):
                            jbuf[tid, 3 + kk, par, t, i] = ZERO
        for lev in range(1, levels + 1):
            src = (lev - 1) % 2
            dst = lev % 2
            g_lo = max(j0 - (levels - lev), 1)
            g_hi = min(j1 + (levels - lev), bh + 1)
            last = lev == levels
            for g in range(g_lo, g_hi):
                t = g - base
                wn, wr, ws = wet[g - 1], wet[g], wet[g + 1]
                for si in range(nsp[g]):
                    slo, shi = _span(spans, g, si)
                    if do_v:
                        if lev == 1:
                            xn, xr, xs = xvx[g - 1], xvx[g], xvx[g + 1]
                            yn, yr, ys = xvy[g - 1], xvy[g], xvy[g + 1]
                        else:
                            xn, xr, xs = bvx[src, t - 1], bvx[src, t], bvx[src, t + 1]
                            yn, yr, ys = bvy[src, t - 1], bvy[src, t], bvy[src, t + 1]
                        ox_ = ovx[g] if last else bvx[dst, t]
                        oy_ = ovy[g] if last else bvy[dst, t]
                        _jv_rows(wn, wr, ws, v1x[g], xn, xr, xs, ox_, slo, shi, kv)
                        _jv_rows(wn, wr, ws, v1y[g], yn, yr, ys, oy_, slo, shi, kv)
                    if do_w:
                        if lev == 1:
                            xn, xr, xs = xw[g - 1], xw[g], xw[g + 1]
                        else:
                            xn, xr, xs = bww[src, t - 1], bww[src, t], bww[src, t + 1]
                        o_ = ow[g] if last else bww[dst, t]
                        _jw_rows(wn, wr, ws, w0[g], xn, xr, xs, o_, slo, shi, kw)
                    if do_p:
                        for kk in range(ns):
                            bpp = jbuf[tid, 3 + kk]
                            if lev == 1:
                                xn, xr, xs = xp[kk, g - 1], xp[kk, g], xp[kk, g + 1]
                            else:
                                xn, xr, xs = bpp[src, t - 1], bpp[src, t], bpp[src, t + 1]
                            o_ = op[kk, g] if last else bpp[dst, t]
                            _jp_rows(wn, wr, ws, bc[g - 1], bc[g], bc[g + 1], p0[kk, g], xn,
                                     xr, xs, o_, slo, shi, kp)


# ------------------------------------------------------------------ pass 3 + limiters
@_inline
def _limiter_row(wet: np.ndarray, b_e: np.ndarray, b_s: np.ndarray, u: np.ndarray,
                 x: np.ndarray, s_o: np.ndarray, j: int, lo: int, hi: int, k: np.float32) -> None:
    """Donor limiter of the conservative implicit diffusion (water: b = open flags)."""
    for i in range(lo, hi + 1):
        fe = (k * b_e[i]) * (x[j, i] - x[j, i + 1])
        fw = (k * b_e[i - 1]) * (x[j, i - 1] - x[j, i])
        fs = (k * b_s[j, i]) * (x[j, i] - x[j + 1, i])
        fn = (k * b_s[j - 1, i]) * (x[j - 1, i] - x[j, i])
        out = (((fe if fe > ZERO else ZERO) - (fw if fw < ZERO else ZERO))
               + (fs if fs > ZERO else ZERO)) - (fn if fn < ZERO else ZERO)
        uv = u[j, i]
        s_o[j, i] = uv / out if out > uv else ONE


@_parallel
def height_limit(wet: np.ndarray, bc: np.ndarray, v1x: np.ndarray, v1y: np.ndarray,
                 xvx: np.ndarray, xvy: np.ndarray, w0: np.ndarray, xw: np.ndarray,
                 p0: np.ndarray, xp: np.ndarray, pr: np.ndarray, bh: int, bw: int, ns: int,
                 cst: np.ndarray, do_vjac: bool, do_height: bool, do_w: bool, do_p: bool,
                 v3x_o: np.ndarray, v3y_o: np.ndarray, sw_o: np.ndarray,
                 sp_o: np.ndarray,
        spans: np.ndarray, nsp: np.ndarray) -> None:
    """Last velocity Jacobi iteration, pass 3 (height term on ``pr``, boundary, clamp), and the
    donor limiters of the water and pigment diffusion from their final iterates."""
    kv = cst[C_KV]
    kw = cst[C_KW]
    kp = cst[C_KP]
    g = cst[C_G]
    oh = cst[C_OH]
    oi = cst[C_OI]
    vm = cst[C_VMAX]
    tgx = cst[C_TILTX]
    tgy = cst[C_TILTY]
    for j in prange(1, bh + 1):
        for si in range(nsp[j]):
            slo, shi = _span(spans, j, si)
            wr, wn, ws = wet[j], wet[j - 1], wet[j + 1]
            # the velocity after pass 2 (last Jacobi iteration, or the iterate as it is)
            if do_vjac:
                _jacobi_v_row(wet, v1x, v1y, xvx, xvy, v3x_o, v3y_o, j, slo, shi, kv)
            else:
                for i in range(slo, shi + 1):
                    v3x_o[j, i] = xvx[j, i]
                    v3y_o[j, i] = xvy[j, i]
            # pass 3, branch-free; non-wet cells 0
            for i in range(slo, shi + 1):
                c = wr[i]
                be = c * wr[i + 1]
                bwf = c * wr[i - 1]
                bs = c * ws[i]
                bn = c * wn[i]
                vx0 = v3x_o[j, i]
                vy0 = v3y_o[j, i]
                wc_ = pr[j, i]
                w_e = pr[j, i + 1] if be != ZERO else wc_
                w_w = pr[j, i - 1] if bwf != ZERO else wc_
                w_s = pr[j + 1, i] if bs != ZERO else wc_
                w_n = pr[j - 1, i] if bn != ZERO else wc_
                nvx = oi * vx0 + oh * (g * (w_e - w_w))
                nvy = oi * vy0 + oh * (g * (w_s - w_n))
                nvx = nvx + tgx if tgx != ZERO else nvx
                nvy = nvy + tgy if tgy != ZERO else nvy
                nvx = nvx if be != ZERO else (nvx if nvx < ZERO else ZERO)
                nvx = nvx if bwf != ZERO else (nvx if nvx > ZERO else ZERO)
                nvy = nvy if bs != ZERO else (nvy if nvy < ZERO else ZERO)
                nvy = nvy if bn != ZERO else (nvy if nvy > ZERO else ZERO)
                nvx = nvx if nvx > -vm else -vm
                nvx = nvx if nvx < vm else vm
                nvy = nvy if nvy > -vm else -vm
                nvy = nvy if nvy < vm else vm
                nvx = nvx if do_height else vx0
                nvy = nvy if do_height else vy0
                v3x_o[j, i] = nvx if c != ZERO else ZERO
                v3y_o[j, i] = nvy if c != ZERO else ZERO
            if do_w:
                # water conductances: 1 on open faces; b_e[i] = face (i, i+1), b_s = face (j, j+1)
                for i in range(slo, shi + 1):
                    fe = (kw * F32(wr[i] * wr[i + 1])) * (xw[j, i] - xw[j, i + 1])
                    fw = (kw * F32(wr[i - 1] * wr[i])) * (xw[j, i - 1] - xw[j, i])
                    fs = (kw * F32(wr[i] * ws[i])) * (xw[j, i] - xw[j + 1, i])
                    fn = (kw * F32(wn[i] * wr[i])) * (xw[j - 1, i] - xw[j, i])
                    out = (((fe if fe > ZERO else ZERO) - (fw if fw < ZERO else ZERO))
                           + (fs if fs > ZERO else ZERO)) - (fn if fn < ZERO else ZERO)
                    uv = w0[j, i]
                    uv = uv if uv > ZERO else ZERO  # a rounding error below 0 holds nothing
                    sw_o[j, i] = uv / out if out > uv else ONE
            if do_p:
                br, bnr, bsr = bc[j], bc[j - 1], bc[j + 1]
                for kk in range(ns):
                    for i in range(slo, shi + 1):
                        b0 = br[i]
                        t = br[i + 1]
                        be_ = (b0 if b0 < t else t) if wr[i] * wr[i + 1] != ZERO else ZERO
                        t = br[i - 1]
                        bw_ = (b0 if b0 < t else t) if wr[i] * wr[i - 1] != ZERO else ZERO
                        t = bsr[i]
                        bs_ = (b0 if b0 < t else t) if wr[i] * ws[i] != ZERO else ZERO
                        t = bnr[i]
                        bn_ = (b0 if b0 < t else t) if wr[i] * wn[i] != ZERO else ZERO
                        fe = (kp * be_) * (xp[kk, j, i] - xp[kk, j, i + 1])
                        fw = (kp * bw_) * (xp[kk, j, i - 1] - xp[kk, j, i])
                        fs = (kp * bs_) * (xp[kk, j, i] - xp[kk, j + 1, i])
                        fn = (kp * bn_) * (xp[kk, j - 1, i] - xp[kk, j, i])
                        out = (((fe if fe > ZERO else ZERO) - (fw if fw < ZERO else ZERO))
                               + (fs if fs > ZERO else ZERO)) - (fn if fn < ZERO else ZERO)
                        uv = p0[kk, j, i]
                        uv = uv if uv > ZERO else ZERO
                        sp_o[kk, j, i] = uv / out if out > uv else ONE


# ------------------------------------------------------------------ passes 4/5 apply
@_parallel
def diffuse_apply(wet: np.ndarray, bc: np.ndarray, w0: np.ndarray, xw: np.ndarray,
                  sw: np.ndarray, p0: np.ndarray, xp: np.ndarray, sp: np.ndarray,
                  bh: int, bw: int, ns: int, cst: np.ndarray, do_w: bool, do_p: bool,
                  w2_o: np.ndarray, p2_o: np.ndarray,
        spans: np.ndarray, nsp: np.ndarray) -> None:
    """Limited face fluxes ``F = k b (x_i - x_j)`` (times the donor's limiter), applied
    as ``u - F_E + F_W - F_S + F_N``; a solve that is off copies ``u``."""
    kw = cst[C_KW]
    kp = cst[C_KP]
    for j in prange(1, bh + 1):
        for si in range(nsp[j]):
            slo, shi = _span(spans, j, si)
            wr, wn, ws = wet[j], wet[j - 1], wet[j + 1]
            if do_w:
                for i in range(slo, shi + 1):
                    fe = (kw * F32(wr[i] * wr[i + 1])) * (xw[j, i] - xw[j, i + 1])
                    fw = (kw * F32(wr[i - 1] * wr[i])) * (xw[j, i - 1] - xw[j, i])
                    fs = (kw * F32(wr[i] * ws[i])) * (xw[j, i] - xw[j + 1, i])
                    fn = (kw * F32(wn[i] * wr[i])) * (xw[j - 1, i] - xw[j, i])
                    s0 = sw[j, i]
                    fe = (fe if fe > ZERO else ZERO) * s0 \
                        + (fe if fe < ZERO else ZERO) * sw[j, i + 1]
                    fw = (fw if fw > ZERO else ZERO) * sw[j, i - 1] \
                        + (fw if fw < ZERO else ZERO) * s0
                    fs = (fs if fs > ZERO else ZERO) * s0 \
                        + (fs if fs < ZERO else ZERO) * sw[j + 1, i]
                    fn = (fn if fn > ZERO else ZERO) * sw[j - 1, i] \
                        + (fn if fn < ZERO else ZERO) * s0
                    w2_o[j, i] = (((w0[j, i] - fe) + fw) - fs) + fn
            else:
                for i in range(slo, shi + 1):
                    w2_o[j, i] = w0[j, i]
            if do_p:
                br, bnr, bsr = bc[j], bc[j - 1], bc[j + 1]
                for kk in range(ns):
                    for i in range(slo, shi + 1):
                        b0 = br[i]
                        t = br[i + 1]
                        be_ = (b0 if b0 < t else t) if wr[i] * wr[i + 1] != ZERO else ZERO
                        t = br[i - 1]
                        bw_ = (b0 if b0 < t else t) if wr[i] * wr[i - 1] != ZERO else ZERO
                        t = bsr[i]
                        bs_ = (b0 if b0 < t else t) if wr[i] * ws[i] != ZERO else ZERO
                        t = bnr[i]
                        bn_ = (b0 if b0 < t else t) if wr[i] * wn[i] != ZERO else ZERO
                        fe = (kp * be_) * (xp[kk, j, i] - xp[kk, j, i + 1])
                        fw = (kp * bw_) * (xp[kk, j, i - 1] - xp[kk, j, i])
                        fs = (kp * bs_) * (xp[kk, j, i] - xp[kk, j + 1, i])
                        fn = (kp * bn_) * (xp[kk, j - 1, i] - xp[kk, j, i])
                        s0 = sp[kk, j, i]
                        fe = (fe if fe > ZERO else ZERO) * s0 \
                            + (fe if fe < ZERO else ZERO) * sp[kk, j, i + 1]
                        fw = (fw if fw > ZERO else ZERO) * sp[kk, j, i - 1] \
                            + (fw if fw < ZERO else ZERO) * s0
                        fs = (fs if fs > ZERO else ZERO) * s0 \
                            + (fs if fs < ZERO else ZERO) * sp[kk, j + 1, i]
                        fn = (fn if fn > ZERO else ZERO) * sp[kk, j - 1, i] \
                            + (fn if fn < ZERO else ZERO) * s0
                        p2_o[kk, j, i] = (((p0[kk, j, i] - fe) + fw) - fs) + fn
            else:
                for kk in range(ns):
                    for i in range(slo, shi + 1):
                        p2_o[kk, j, i] = p0[kk, j, i]


# ------------------------------------------------------------------ pass 6
@_inline
def _face_x(vx: np.ndarray, wet: np.ndarray, j: int, i: int,
            q4: np.float32) -> tuple[np.float32, np.float32]:
    """(rxp, rxn) of the x face between (j, i) and (j, i + 1)."""
    uf = HALF * (vx[j, i] + vx[j, i + 1]) if (wet[j, i] != 0) & (wet[j, i + 1] != 0) else ZERO
    r = abs(uf) * q4
    rp = r if uf > ZERO else ZERO
    return rp, r - rp


@_inline
def _face_y(vy: np.ndarray, wet: np.ndarray, j: int, i: int | np.uint64,
            q4: np.float32) -> tuple[np.float32, np.float32]:
    """(ryp, ryn) of the y face between (j, i) and (j + 1, i)."""
    uf = HALF * (vy[j, i] + vy[j + 1, i]) if (wet[j, i] != 0) & (wet[j + 1, i] != 0) else ZERO
    r = abs(uf) * q4
    rp = r if uf > ZERO else ZERO
    return rp, r - rp


@_inline
def _chunk(ch: int, nch: int, bh: int) -> tuple[int, int]:
    """Rows ``[j0, j1)`` of chunk ``ch`` of ``nch`` (rows 1..bh)."""
    return 1 + (ch * bh) // nch, 1 + ((ch + 1) * bh) // nch


@_inline
def _row_rates(vx: np.ndarray, vy: np.ndarray, wet: np.ndarray, j: int, lo: int, hi: int,
               q4: np.float32, buf: np.ndarray) -> None:
    """Face rates of row j into ``buf``: rows 0/1 x faces (i, i+1) for i = 0..bw
    (positive, negative direction), rows 2/3 the y faces (j, j+1), rows 4/5 the y faces
    (j-1, j), each for columns 1..bw."""
    for i in range(lo - 1, hi + 1):
        rp, rn = _face_x(vx, wet, j, i, q4)
        buf[0, i] = rp
        buf[1, i] = rn
    for i in range(lo, hi + 1):
        rp, rn = _face_y(vy, wet, j, i, q4)
        buf[2, i] = rp
        buf[3, i] = rn
        rp, rn = _face_y(vy, wet, j - 1, i, q4)
        buf[4, i] = rp
        buf[5, i] = rn


N_CHUNKS = 64
"""Row chunks per parallel sweep that needs row buffers (one allocation per chunk)."""


@_parallel
def advect_limit(wet: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray,
                 p: np.ndarray, bh: int, bw: int, ns: int, cst: np.ndarray,
                 sout_o: np.ndarray, sin_o: np.ndarray,
        spans: np.ndarray, nsp: np.ndarray) -> None:
    """Pass 6 limiters: donor ``s_out`` (never below min(w, w_min)) and receiver ``s_in``
    (never above max(w, w_max), no pigment above 1)."""
    q4 = cst[C_Q4]
    wmin = cst[C_WMIN]
    wmax = cst[C_WMAX]
    nch = min(bh, N_CHUNKS)
    for ch in prange(nch):
        j0, j1 = _chunk(ch, nch, bh)
        buf = np.empty((6, bw + 2), F32)
        for j in range(j0, j1):
            for si in range(nsp[j]):
                slo, shi = _span(spans, j, si)
                _row_rates(vx, vy, wet, j, slo, shi, q4, buf)
                rxp, rxn, syp, syn, nyp, nyn = buf[0], buf[1], buf[2], buf[3], buf[4], buf[5]
                for i in range(slo, shi + 1):
                    # r_out: E face (own), W face, S face (own), N face
                    r_out = ((rxp[i] + rxn[i - 1]) + syp[i]) + nyn[i]
                    wv = w[j, i]
                    lo = wv if wv < wmin else wmin
                    want = wv * r_out
                    room = wv - lo
                    sout_o[j, i] = room / want if want > room else ONE
                    # inflows: from W, E, N, S donors (the reference's order)
                    i_w = ((w[j, i - 1] * rxp[i - 1] + w[j, i + 1] * rxn[i])
                           + w[j - 1, i] * nyp[i]) + w[j + 1, i] * syn[i]
                    hi = wv if wv > wmax else wmax
                    room_w = hi - wv
                    room_w = room_w if room_w > ZERO else ZERO
                    sin_o[j, i] = room_w / i_w if i_w > room_w else ONE
                for kk in range(ns):
                    for i in range(slo, shi + 1):
                        i_p = ((p[kk, j, i - 1] * rxp[i - 1] + p[kk, j, i + 1] * rxn[i])
                               + p[kk, j - 1, i] * nyp[i]) + p[kk, j + 1, i] * syn[i]
                        room_p = ONE - p[kk, j, i]
                        room_p = room_p if room_p > ZERO else ZERO
                        sk = room_p / i_p if i_p > room_p else ONE
                        s = sin_o[j, i]
                        sin_o[j, i] = s if s < sk else sk
                for i in range(slo, shi + 1):
                    s = sin_o[j, i]
                    sin_o[j, i] = s if s < ONE else ONE


@_parallel
def advect_apply(wet: np.ndarray, vx: np.ndarray, vy: np.ndarray, sout: np.ndarray,
                 sin: np.ndarray, w: np.ndarray, p: np.ndarray, y0: int, x0: int,
                 bh: int, bw: int, ns: int, cst: np.ndarray, do_adv: bool,
                 w3_o: np.ndarray, p_state: np.ndarray,
        spans: np.ndarray, nsp: np.ndarray) -> None:
    """Pass 6 fluxes ``w_donor r'`` and ``p_donor r'``, ``r' = (r s_out[donor]) s_in[recv]``;
    water into the padded ``w3_o``, pigment straight into the state (own cell only)."""
    q4 = cst[C_Q4]
    nch = min(bh, N_CHUNKS)
    for ch in prange(nch):
        j0, j1 = _chunk(ch, nch, bh)
        buf = np.empty((6, bw + 2), F32)
        a = np.empty((6, bw + 2), F32)
        for j in range(j0, j1):
            for si in range(nsp[j]):
                slo, shi = _span(spans, j, si)
                y = y0 + j - 1
                if not do_adv:
                    for i in range(slo, shi + 1):
                        w3_o[j, i] = w[j, i]
                    for kk in range(ns):
                        for i in range(slo, shi + 1):
                            p_state[kk, y, np.uint64(x0 + i - 1)] = p[kk, j, i]
                    continue
                _row_rates(vx, vy, wet, j, slo, shi, q4, buf)
                # limited rates r' of the x faces (i, i+1), i = 0..bw, and of the y faces
                # (j, j+1) and (j-1, j): (r * s_out[donor]) * s_in[receiver]
                for i in range(slo - 1, shi + 1):
                    a[0, i] = (buf[0, i] * sout[j, i]) * sin[j, i + 1]
                    a[1, i] = (buf[1, i] * sout[j, i + 1]) * sin[j, i]
                for i in range(slo, shi + 1):
                    a[2, i] = (buf[2, i] * sout[j, i]) * sin[j + 1, i]
                    a[3, i] = (buf[3, i] * sout[j + 1, i]) * sin[j, i]
                    a[4, i] = (buf[4, i] * sout[j - 1, i]) * sin[j, i]
                    a[5, i] = (buf[5, i] * sout[j, i]) * sin[j - 1, i]
                axp, axn, asp, asn, anp, ann = a[0], a[1], a[2], a[3], a[4], a[5]
                for i in range(slo, shi + 1):
                    wv = w[j, i]
                    fe = wv * axp[i] - w[j, i + 1] * axn[i]
                    fw = w[j, i - 1] * axp[i - 1] - wv * axn[i - 1]
                    fs = wv * asp[i] - w[j + 1, i] * asn[i]
                    fn = w[j - 1, i] * anp[i] - wv * ann[i]
                    w3_o[j, i] = (((wv - fe) + fw) - fs) + fn
                for kk in range(ns):
                    for i in range(slo, shi + 1):
                        pv = p[kk, j, i]
                        fe = pv * axp[i] - p[kk, j, i + 1] * axn[i]
                        fw = p[kk, j, i - 1] * axp[i - 1] - pv * axn[i - 1]
                        fs = pv * asp[i] - p[kk, j + 1, i] * asn[i]
                        fn = p[kk, j - 1, i] * anp[i] - pv * ann[i]
                        p_state[kk, y, np.uint64(x0 + i - 1)] = (((pv - fe) + fw) - fs) + fn


# ------------------------------------------------------------------ passes 7, 8, 9a
@_inline
def _esa_row(wet: np.ndarray, w3: np.ndarray, opn: np.ndarray, h: np.ndarray,
             wc: np.ndarray, evap: np.ndarray, w_state: np.ndarray, p: np.ndarray,
             q: np.ndarray, beta: np.ndarray, gamma: np.ndarray, delta: np.ndarray, y0: int,
             x0: int, ns: int, cst: np.ndarray, do_evap: bool, do_surface: bool,
             do_absorb: bool, j: int, spans: np.ndarray, nsp: np.ndarray, wrow: np.ndarray,
             frow: np.ndarray, sat_r: np.ndarray) -> None:  # pragma: no cover - compiled
    """Passes 7, 8 and 9a on row ``j`` of the box: w, wc, evaporated, p, q in place,
    ``wc / c`` into ``sat_r`` on the spans' cells (the others are left as they are).
    One body for :func:`evap_surface_absorb` and the fused sweep's row ring."""
    e = cst[C_EVAP]
    edge = cst[C_EDGE]
    wmax = cst[C_WMAX]
    rate = cst[C_RATE]
    alpha = cst[C_ALPHA]
    cmin = cst[C_CMIN]
    cspan = cst[C_CSPAN]
    y = y0 + j - 1
    for si in range(nsp[j]):
        slo, shi = _span(spans, j, si)
        for i in range(slo, shi + 1):
            x = np.uint64(x0 + i - 1)
            wv = w3[j, i]
            if do_evap:
                nd = (((ZERO if w3[j, i + 1] > ZERO else ONE)
                       + (ZERO if w3[j, i - 1] > ZERO else ONE))
                      + (ZERO if w3[j + 1, i] > ZERO else ONE)) \
                    + (ZERO if w3[j - 1, i] > ZERO else ONE)
                loss = e + ((edge * nd) * wv) * e
                loss = loss if loss < wv else wv
                loss = loss if wv > ZERO else ZERO
                wv = wv - loss
                evap[y, x] = evap[y, x] + loss
            wrow[i] = wv
            f = wv / wmax
            f = f if f > ZERO else ZERO
            frow[i] = f if f < ONE else ONE
        if do_surface:
            for kk in range(ns):
                g = gamma[kk]
                d = delta[kk]
                db = d / beta[kk]
                for i in range(slo, shi + 1):
                    x = np.uint64(x0 + i - 1)
                    hv = h[y, x]
                    f = frow[i]
                    pv = p[kk, y, x]
                    qv = q[kk, y, x]
                    down = (((rate * pv) * (ONE - f)) * (ONE - hv * g)) * d
                    up = (((rate * qv) * f) * (ONE - (ONE - hv) * g)) * db
                    down = down if down < pv else pv
                    t = ONE - qv
                    down = down if down < t else t
                    up = up if up < qv else qv
                    t = ONE - pv
                    up = up if up < t else t
                    net = (down - up) if wet[j, i] != ZERO else ZERO
                    p[kk, y, x] = pv - net
                    q[kk, y, x] = qv + net
        for i in range(slo, shi + 1):
            x = np.uint64(x0 + i - 1)
            wv = wrow[i]
            wcv = wc[y, x]
            cv = cmin + h[y, x] * cspan
            if do_absorb:
                d = alpha if alpha < wv else wv
                room = cv - wcv
                room = room if room > ZERO else ZERO
                d = d if d < room else room
                d = d if (wv > ZERO and opn[j, i] != ZERO) else ZERO
                wv = wv - d
                wcv = wcv + d
            w_state[y, x] = wv
            wc[y, x] = wcv
            sat_r[i] = wcv / cv



@_parallel
def evap_surface_absorb(wet: np.ndarray, w3: np.ndarray, opn: np.ndarray,
                        h: np.ndarray, wc: np.ndarray, evap: np.ndarray, w_state: np.ndarray,
                        p: np.ndarray, q: np.ndarray, beta: np.ndarray, gamma: np.ndarray,
                        delta: np.ndarray, y0: int, x0: int, bh: int, bw: int, ns: int,
                        cst: np.ndarray, do_evap: bool, do_surface: bool, do_absorb: bool,
                        sat_o: np.ndarray,
        spans: np.ndarray, nsp: np.ndarray) -> None:
    """Pass 7 (edge-enhanced fluid evaporation), pass 8 (deposition/lifting) and
    pass 9a (absorption); writes w, wc, evaporated, p, q in place and ``wc / c``."""
    nch = min(bh, N_CHUNKS)
    for ch in prange(nch):
        j0, j1 = _chunk(ch, nch, bh)
        buf = np.empty((2, bw + 2), F32)
        wrow, frow = buf[0], buf[1]
        for j in range(j0, j1):
            _esa_row(wet, w3, opn, h, wc, evap, w_state, p, q, beta, gamma, delta, y0, x0,
                     ns, cst, do_evap, do_surface, do_absorb, j, spans, nsp, wrow, frow,
                     sat_o[j])


# ------------------------------------------------------------------ passes 9b, 9c, 10
@_parallel
def capillary_dry(sat: np.ndarray, c: np.ndarray, opn: np.ndarray, v3x: np.ndarray,
                  v3y: np.ndarray, w: np.ndarray, wc: np.ndarray, evap: np.ndarray,
                  p: np.ndarray, q: np.ndarray, vx: np.ndarray, vy: np.ndarray,
                  y0: int, x0: int, bh: int, bw: int, ns: int, cst: np.ndarray,
                  do_capdiff: bool, do_dry: bool,
        spans: np.ndarray, nsp: np.ndarray) -> None:
    """Pass 9b (explicit capillary diffusion of the saturation), 9c (capillary
    evaporation) and pass 10 (tiny water evaporates, dry cells deposit, v = 0)."""
    k = cst[C_KC]
    ecap = cst[C_ECAP]
    wdry = cst[C_WDRY]
    susp = cst[C_SUSP]
    suspending = susp > ZERO
    nch = min(bh, N_CHUNKS)
    for ch in prange(nch):
        j0, j1 = _chunk(ch, nch, bh)
        wcrow = np.empty(bw + 2, F32)
        for j in range(j0, j1):
            for si in range(nsp[j]):
                slo, shi = _span(spans, j, si)
                y = y0 + j - 1
                if do_capdiff:
                    for i in range(slo, shi + 1):
                        o0 = opn[j, i]
                        c0 = c[j, i]
                        s0 = sat[j, i]
                        t = c[j, i + 1]
                        fe = ((k * (c0 if c0 < t else t)) * (s0 - sat[j, i + 1])) \
                            if o0 * opn[j, i + 1] != ZERO else ZERO
                        t = c[j, i - 1]
                        fw = ((k * (t if t < c0 else c0)) * (sat[j, i - 1] - s0)) \
                            if opn[j, i - 1] * o0 != ZERO else ZERO
                        t = c[j + 1, i]
                        fs = ((k * (c0 if c0 < t else t)) * (s0 - sat[j + 1, i])) \
                            if o0 * opn[j + 1, i] != ZERO else ZERO
                        t = c[j - 1, i]
                        fn = ((k * (t if t < c0 else c0)) * (sat[j - 1, i] - s0)) \
                            if opn[j - 1, i] * o0 != ZERO else ZERO
                        wcv = (((wc[y, np.uint64(x0 + i - 1)] - fe) + fw) - fs) + fn
                        wcrow[i] = wcv if wcv > ZERO else ZERO
                else:
                    for i in range(slo, shi + 1):
                        wcrow[i] = wc[y, np.uint64(x0 + i - 1)]
                n_dry = 0
                for i in range(slo, shi + 1):
                    x = np.uint64(x0 + i - 1)
                    wcv = wcrow[i]
                    wv = w[y, x]
                    ev = evap[y, x]
                    e = (ecap if ecap < wcv else wcv) if wv == ZERO else ZERO
                    wc[y, x] = wcv - e
                    ev = ev + e
                    if do_dry:
                        tiny = wv > ZERO and wv < wdry
                        ev = ev + (wv if tiny else ZERO)
                        wv = ZERO if tiny else wv
                        w[y, x] = wv
                        dry = wv == ZERO
                        n_dry += 1 if dry else 0
                        vx[y, x] = ZERO if dry else v3x[j, i]
                        vy[y, x] = ZERO if dry else v3y[j, i]
                    evap[y, x] = ev
                if do_dry and n_dry > 0:
                    for kk in range(ns):
                        for i in range(slo, shi + 1):
                            x = np.uint64(x0 + i - 1)
                            pv = p[kk, y, x]
                            qv = q[kk, y, x]
                            t = ONE - qv
                            t = pv if pv < t else t
                            settle = w[y, x] == ZERO
                            if suspending and wc[y, x] > susp * c[j, i]:
                                settle = False  # damp paper keeps its pigment suspended
                            t = t if settle else ZERO
                            p[kk, y, x] = pv - t
                            q[kk, y, x] = qv + t


# ------------------------------------------------------------------ tile bookkeeping
@_serial
def update_tiles(ttl: np.ndarray, active: np.ndarray, boxes: np.ndarray, w: np.ndarray,
                 wc: np.ndarray, ts: int, renew: int, halo: int) -> None:
    """``tiles.update_tiles`` for the boxes ``(y0, y1, x0, x1)`` just simulated: count the
    active TTLs down, renew a tile of a box whose TTL is out and that holds water
    (``w > 0`` or ``wc > 0`` in any of its cells).

    Only tiles next to (or among) the tiles active before the step are looked at: the
    others were at rest and out of reach of the step (``tiles.HALO`` < a tile), so they
    hold no water and the reference would not renew them either. Of a tile that was not
    active, only the strips within ``halo`` (``tiles.HALO``) cells of an active neighbour
    are looked at, for the same reason."""
    nty, ntx = ttl.shape
    height, width = w.shape
    for ty in range(nty):
        for tx in range(ntx):
            if ttl[ty, tx] > 0:
                ttl[ty, tx] -= 1
    for b in range(boxes.shape[0]):
        ty0 = boxes[b, 0] // ts
        ty1 = (boxes[b, 1] + ts - 1) // ts
        tx0 = boxes[b, 2] // ts
        tx1 = (boxes[b, 3] + ts - 1) // ts
        for ty in range(ty0, ty1):
            for tx in range(tx0, tx1):
                if ttl[ty, tx] > 0:
                    continue
                ya, yb = ty * ts, min((ty + 1) * ts, height)
                xa, xb = tx * ts, min((tx + 1) * ts, width)
                alive = False
                if active[ty, tx] != 0:  # its TTL ran out in this step: any cell
                    alive = _water_in(w, wc, ya, yb, xa, xb)
                else:  # at rest before the step: only cells within HALO of an active
                    for dy in range(-1, 2):  # tile can have changed
                        for dx in range(-1, 2):
                            yy, xx = ty + dy, tx + dx
                            if alive or not (0 <= yy < nty and 0 <= xx < ntx):
                                continue
                            if active[yy, xx] == 0:
                                continue
                            y_lo = yb - halo if dy > 0 else ya
                            y_hi = ya + halo if dy < 0 else yb
                            x_lo = xb - halo if dx > 0 else xa
                            x_hi = xa + halo if dx < 0 else xb
                            alive = _water_in(w, wc, max(y_lo, ya), min(y_hi, yb),
                                              max(x_lo, xa), min(x_hi, xb))
                if alive:
                    ttl[ty, tx] = renew


@_inline
def _water_in(w: np.ndarray, wc: np.ndarray, ya: int, yb: int, xa: int, xb: int) -> bool:
    """Whether any cell of rows ``ya..yb-1``, columns ``xa..xb-1`` holds water."""
    alive = False
    for y in range(ya, yb):
        for x in range(xa, xb):  # vectorises
            alive |= (w[y, x] > ZERO) | (wc[y, x] > ZERO)
        if alive:
            break
    return alive
