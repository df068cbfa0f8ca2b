"""Fused sweeps of the ``cpu`` backend (issue 26 item 1): two pairs of sweeps of
:mod:`station.backends.cpu.kernels` in one pass each, with the same arithmetic in the
same order, so the results stay bitwise equal to the two-sweep kernels (and to the
reference); the limiter rows a pass needs from its neighbours live in a three-row ring
per chunk of rows instead of full scratch fields:

* :func:`advect_fused`: pass 6's limiters (``advect_limit``) and fluxes
  (``advect_apply``): no ``sout``/``sin`` fields, −10 floats per cell-step;
* :func:`limit_diffuse_fused`: the last velocity iteration, pass 3 and the diffusion
  donor limiters (``height_limit``) with the limited fluxes of passes 4/5
  (``diffuse_apply``): no ``sw``/``sp`` fields and none of diffuse_apply's re-reads,
  −(6 + 4·slots) floats per cell-step;
* :func:`evap_cap_fused`: passes 7-9a (``evap_surface_absorb``) with 9b, 9c and 10
  (``capillary_dry``): no ``sat`` field and none of capillary_dry's re-reads, −10 floats.

A chunk's first ring rows belong to its neighbour chunk: they are recomputed here (the
limiters are pure functions of the sweep's inputs).  So these sweeps take as few chunks as
there are threads (``bounds``: :func:`ring_chunks` chunks of about equal work, from
``step.row_bounds``; every parallel sweep of a step takes the same split): prange hands
each thread an equal share of the chunks anyway (a static schedule), and at 1920x1080
the 64 chunks of the
other sweeps cost ~10 % more work here (2 limiter and 3 face-rate rows of pass 6, 3
iterate rows and a limiter row of passes 4/5, 2 saturation rows of pass 9 per chunk).
The cpu backend's bitwise tests against the numpy reference (tests/test_cpu_backend.py)
hold them; the prototypes that first compared them with the two-sweep kernels were
copies of this code and are gone (git history: tools/proto_fused_*.py).
"""

from __future__ import annotations

import numpy as np
from numba import get_num_threads, njit, prange

from station.backends.cpu import kernels as K

F32 = np.float32
ZERO, ONE = K.ZERO, K.ONE
_inline = njit(inline="always", fastmath=False, cache=True, error_model="numpy")
_parallel = njit(parallel=True, fastmath=False, cache=True, error_model="numpy", nogil=True)


def ring_chunks() -> int:
    """The ``chunks`` argument of the ringed sweeps: one chunk per thread."""
    n: int = get_num_threads()
    return n


@_inline
def _open(a: np.uint8, b: np.uint8) -> np.float32:  # pragma: no cover - compiled
    """1 on a face whose two cells' flags are set, else 0 (float32, as the reference's
    product of float32 wet masks)."""
    return ONE if (a != 0) & (b != 0) else ZERO


@_inline
def _zero_gaps(o: np.ndarray, r: int, spans: np.ndarray,
               nsp: np.ndarray) -> None:  # pragma: no cover - compiled
    """Zero a ring row ``o`` outside row r's spans (the loops that follow write every
    column inside them): a whole-row fill of each ring row was ~1 ms a 1920x1080 step."""
    prev = 0
    for sx in range(nsp[r]):
        slo, shi = K._span(spans, r, sx)
        for i in range(prev, slo):
            o[i] = ZERO
        prev = shi + 1
    for i in range(prev, o.shape[0]):
        o[i] = ZERO


@_inline
def _x_rates(vx: np.ndarray, wet: np.ndarray, r: int, spans: np.ndarray, nsp: np.ndarray,
             q4: np.float32, xo: np.ndarray) -> None:  # pragma: no cover - compiled
    """The x-face rates of row r, (positive, negative) into ``xo[0]``/``xo[1]`` for the
    faces (i, i+1), i = slo-1..shi of each span (``K._row_rates``' rows 0/1)."""
    for sx in range(nsp[r]):
        slo, shi = K._span(spans, r, sx)
        for i in range(slo - 1, shi + 1):
            rp, rn = K._face_x(vx, wet, r, i, q4)
            xo[0, i] = rp
            xo[1, i] = rn


@_inline
def _pair_columns(spans: np.ndarray, nsp: np.ndarray, r: int, bh: int,
                  bw: int) -> tuple[int, int]:  # pragma: no cover - compiled
    """The columns ``lo..hi`` that a span of row r or row r+1 holds (the y faces between
    them); ``lo > hi`` when neither row has a span."""
    lo = bw + 1
    hi = 0
    for rr in (r, r + 1):
        if 1 <= rr <= bh and nsp[rr] > 0:
            a, _ = K._span(spans, rr, 0)
            b = spans[rr, nsp[rr] - 1, 1]
            lo = a if a < lo else lo
            hi = b if b > hi else hi
    return lo, hi


@_inline
def _y_rates(vy: np.ndarray, wet: np.ndarray, r: int, bh: int, bw: int, spans: np.ndarray,
             nsp: np.ndarray, q4: np.float32, yo: np.ndarray) -> None:
    # pragma: no cover - compiled
    """The rates of the y faces (r, r+1) into ``yo[0]``/``yo[1]`` on every column that a
    span of row r or row r+1 holds: ``K._row_rates`` computes them as row r's south faces
    and again as row r+1's north faces, from the same operands (a pure function of the
    scratch), so one row of them serves both."""
    lo, hi = _pair_columns(spans, nsp, r, bh, bw)
    y0_, y1_ = yo[0], yo[1]
    for i in range(lo, hi + 1):
        u = np.uint64(i)  # unsigned: see _flux_rows (no wraparound, no gathers)
        rp, rn = K._face_y(vy, wet, r, u, q4)
        y0_[u] = rp
        y1_[u] = rn


@_inline
def _limit_row(w: np.ndarray, p: np.ndarray, r: int, ns: int, wmin: np.float32,
               wmax: np.float32, spans: np.ndarray, nsp: np.ndarray, xr: np.ndarray,
               ys: np.ndarray, yn: np.ndarray, so: np.ndarray,
               si: np.ndarray) -> None:  # pragma: no cover - compiled
    """advect_limit's row ``r`` into ``so``/``si`` (zero outside the row's spans), from
    the row's x-face rates ``xr`` and the rates of its south ``ys`` and north ``yn``
    faces."""
    _zero_gaps(so, r, spans, nsp)
    _zero_gaps(si, r, spans, nsp)
    rxp, rxn, syp, syn, nyp, nyn = xr[0], xr[1], ys[0], ys[1], yn[0], yn[1]
    for sx in range(nsp[r]):
        slo, shi = K._span(spans, r, sx)
        for i in range(slo, shi + 1):
            r_out = ((rxp[i] + rxn[i - 1]) + syp[i]) + nyn[i]
            wv = w[r, i]
            lo = wv if wv < wmin else wmin
            want = wv * r_out
            room = wv - lo
            so[i] = room / want if want > room else ONE
            i_w = ((w[r, i - 1] * rxp[i - 1] + w[r, i + 1] * rxn[i])
                   + w[r - 1, i] * nyp[i]) + w[r + 1, i] * syn[i]
            hi = wv if wv > wmax else wmax
            room_w = hi - wv
            room_w = room_w if room_w > ZERO else ZERO
            si[i] = room_w / i_w if i_w > room_w else ONE
        for kk in range(ns):
            for i in range(slo, shi + 1):
                i_p = ((p[kk, r, i - 1] * rxp[i - 1] + p[kk, r, i + 1] * rxn[i])
                       + p[kk, r - 1, i] * nyp[i]) + p[kk, r + 1, i] * syn[i]
                room_p = ONE - p[kk, r, i]
                room_p = room_p if room_p > ZERO else ZERO
                sk = room_p / i_p if i_p > room_p else ONE
                s = si[i]
                si[i] = s if s < sk else sk
        for i in range(slo, shi + 1):
            s = si[i]
            si[i] = s if s < ONE else ONE


@_parallel
def advect_fused(wet: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray,
                 p: np.ndarray, y0: int, x0: int, bh: int, bw: int, ns: int,
                 cst: np.ndarray, w3_o: np.ndarray, p_state: np.ndarray,
                 spans: np.ndarray, nsp: np.ndarray,
                 bounds: np.ndarray) -> None:  # pragma: no cover - compiled
    """Pass 6 (limiters and fluxes) in one sweep: each chunk computes the limiter rows
    j-1, j, j+1 into a ring and applies row j, exactly as advect_apply does. The face
    rates live in rings too: a row's x faces serve its limiter and its fluxes, a row of
    y faces serves the cells on both sides (each face rate computed once, not four
    times)."""
    q4 = cst[K.C_Q4]
    wmin = cst[K.C_WMIN]
    wmax = cst[K.C_WMAX]
    nch = bounds.shape[0] - 1
    for ch in prange(nch):
        j0, j1 = bounds[ch], bounds[ch + 1]
        a = np.empty((6, bw + 2), F32)
        so = np.zeros((3, bw + 2), F32)  # rings: row r lives in slot r % 3
        si = np.zeros((3, bw + 2), F32)
        xr = np.zeros((3, 2, bw + 2), F32)  # x-face rates of row r
        yr = np.zeros((3, 2, bw + 2), F32)  # rates of the y faces (r, r+1)
        for r in (j0 - 2, j0 - 1, j0):
            if 0 <= r <= bh:
                _y_rates(vy, wet, r, bh, bw, spans, nsp, q4, yr[r % 3])
            if 1 <= r <= bh:
                _x_rates(vx, wet, r, spans, nsp, q4, xr[r % 3])
        for r in (j0 - 1, j0):
            if 1 <= r <= bh:
                _limit_row(w, p, r, ns, wmin, wmax, spans, nsp, xr[r % 3], yr[r % 3],
                           yr[(r - 1) % 3], so[r % 3], si[r % 3])
            else:
                so[r % 3, :] = ZERO
                si[r % 3, :] = ZERO
        for j in range(j0, j1):
            r = j + 1
            if r <= bh:
                _y_rates(vy, wet, r, bh, bw, spans, nsp, q4, yr[r % 3])
                _x_rates(vx, wet, r, spans, nsp, q4, xr[r % 3])
                _limit_row(w, p, r, ns, wmin, wmax, spans, nsp, xr[r % 3], yr[r % 3],
                           yr[j % 3], so[r % 3], si[r % 3])
            else:
                so[r % 3, :] = ZERO
                si[r % 3, :] = ZERO
            sm, s0, sp = (j - 1) % 3, j % 3, (j + 1) % 3
            bx, bs, bn = xr[s0], yr[s0], yr[sm]
            y = y0 + j - 1
            for sx in range(nsp[j]):
                slo, shi = K._span(spans, j, sx)
                for i in range(slo - 1, shi + 1):
                    a[0, i] = (bx[0, i] * so[s0, i]) * si[s0, i + 1]
                    a[1, i] = (bx[1, i] * so[s0, i + 1]) * si[s0, i]
                for i in range(slo, shi + 1):
                    a[2, i] = (bs[0, i] * so[s0, i]) * si[sp, i]
                    a[3, i] = (bs[1, i] * so[sp, i]) * si[s0, i]
                    a[4, i] = (bn[0, i] * so[sm, i]) * si[s0, i]
                    a[5, i] = (bn[1, i] * so[s0, i]) * si[sm, i]
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


@_inline
def _vel_row(wet: np.ndarray, v1x: np.ndarray, v1y: np.ndarray, xvx: np.ndarray,
             xvy: np.ndarray, pr: np.ndarray, cst: np.ndarray, do_vjac: bool,
             do_height: bool, j: int, slo: int, shi: int, v3x_o: np.ndarray,
             v3y_o: np.ndarray, fibre: np.ndarray, y0: int,
             x0: int, w: np.ndarray, h: np.ndarray) -> None:  # pragma: no cover - compiled
    """height_limit's velocity part of row j; with ``C_PGAIN`` the height term along each
    axis times ``C_PBASE + C_PGAIN * fibre[axis]`` (passes.water_height_and_boundary:
    the film's levelling flow runs along the paper's fibres), with ``C_PGATE`` times
    ``(1 - g C_PA) + (g C_PGAIN) fibre[axis]``, ``g`` the standing-water gate of the
    cell's water ``w`` (the state's, as the step found it), with ``C_PPULL`` times ``1 -
    smoothstep(pull C_PPULL)``, ``pull = max((w + relief h) - P, 0)`` (reference
    ``fibre_gate``; step_region zeroes C_PGAIN on paper without fibre)."""
    kv, g, oh, oi, vm = cst[K.C_KV], cst[K.C_G], cst[K.C_OH], cst[K.C_OI], cst[K.C_VMAX]
    tgx, tgy = cst[K.C_TILTX], cst[K.C_TILTY]
    pbase, pgain = cst[K.C_PBASE], cst[K.C_PGAIN]
    pa, pgate, ppull = cst[K.C_PA], cst[K.C_PGATE], cst[K.C_PPULL]
    relief = cst[K.C_RELIEF]
    channel = pgain != ZERO
    gated = pgate != ZERO
    y = np.uint64(y0 + j - 1)
    wr, wn, ws = wet[j], wet[j - 1], wet[j + 1]
    if do_vjac:
        K._jacobi_v_row(wet, v1x, v1y, xvx, xvy, v3x_o, v3y_o, j, slo, shi, kv)
    else:
        for i in range(slo, shi + 1):
            v3x_o[j, i] = xvx[j, i]
            v3y_o[j, i] = xvy[j, i]
    for i in range(slo, shi + 1):
        c = wr[i] != 0
        be = c & (wr[i + 1] != 0)
        bwf = c & (wr[i - 1] != 0)
        bs = c & (ws[i] != 0)
        bn = c & (wn[i] != 0)
        vx0 = v3x_o[j, i]
        vy0 = v3y_o[j, i]
        wc_ = pr[j, i]
        w_e = pr[j, i + 1] if be else wc_
        w_w = pr[j, i - 1] if bwf else wc_
        w_s = pr[j + 1, i] if bs else wc_
        w_n = pr[j - 1, i] if bn else wc_
        dx = w_e - w_w
        dy = w_s - w_n
        if channel and gated:
            x = np.uint64(x0 + i - 1)
            gv = K._smoothstep_w(w[y, x], pgate)
            if ppull != ZERO:
                top = w[y, x] + relief * h[y, x] if relief > ZERO else w[y, x]
                pull = top - pr[j, i]
                pull = pull if pull > ZERO else ZERO
                gv = gv * (ONE - K._smoothstep_w(pull, ppull))
            bg = ONE - gv * pa
            gg = gv * pgain
            dx = dx * (bg + gg * fibre[0, y, x])
            dy = dy * (bg + gg * fibre[1, y, x])
        elif channel:
            x = np.uint64(x0 + i - 1)
            dx = dx * (pbase + pgain * fibre[0, y, x])
            dy = dy * (pbase + pgain * fibre[1, y, x])
        nvx = oi * vx0 + oh * (g * dx)
        nvy = oi * vy0 + oh * (g * dy)
        nvx = nvx + tgx if tgx != ZERO else nvx
        nvy = nvy + tgy if tgy != ZERO else nvy
        nvx = nvx if be else (nvx if nvx < ZERO else ZERO)
        nvx = nvx if bwf else (nvx if nvx > ZERO else ZERO)
        nvy = nvy if bs else (nvy if nvy < ZERO else ZERO)
        nvy = nvy if bn else (nvy if nvy > ZERO else ZERO)
        nvx = nvx if nvx > -vm else -vm
        nvx = nvx if nvx < vm else vm
        nvy = nvy if nvy > -vm else -vm
        nvy = nvy if nvy < vm else vm
        nvx = nvx if do_height else vx0
        nvy = nvy if do_height else vy0
        v3x_o[j, i] = nvx if c else ZERO
        v3y_o[j, i] = nvy if c else ZERO


@_inline
def _flux_rows(wet: np.ndarray, bc: np.ndarray, xr: np.ndarray, xs: np.ndarray,
               pc: np.ndarray, ps: np.ndarray, ns: int, kw: np.float32, kp: np.float32,
               do_w: bool, do_p: bool, r: int, bh: int, bw: int, spans: np.ndarray,
               nsp: np.ndarray, fx: np.ndarray, fy: np.ndarray, px: np.ndarray,
               py: np.ndarray) -> None:  # pragma: no cover - compiled
    """The unlimited face fluxes of passes 4/5 on row r, each face once: the x faces
    (i, i + 1), i = slo-1..shi of each span of row r (1 <= r <= bh), into ``fx`` (water)
    and ``px`` (slot, column), and the y faces (r, r + 1) on the columns a span of row r
    or row r + 1 holds into ``fy``/``py`` (0 <= r <= bh), from the final iterates of rows
    r (``xr``, ``pc``) and r + 1 (``xs``, ``ps``).  A face's flux is the expression both
    of its cells computed before (height_limit's E/W/S/N terms, the same operands in the
    same order: cell i's west face is cell i - 1's east face, row r's north face row
    r - 1's south face), so the limiter and the fluxes read it from these rows."""
    wr, ws = wet[r], wet[r + 1]
    if 1 <= r <= bh:
        br = bc[r]
        for sx in range(nsp[r]):
            slo, shi = K._span(spans, r, sx)
            if do_w:
                for i in range(slo - 1, shi + 1):
                    fx[i] = (kw * _open(wr[i], wr[i + 1])) * (xr[i] - xr[i + 1])
            if do_p:
                for kk in range(ns):
                    for i in range(slo - 1, shi + 1):
                        b0 = br[i]
                        t = br[i + 1]
                        be_ = (b0 if b0 < t else t) if (wr[i] != 0) & (wr[i + 1] != 0) \
                            else ZERO
                        px[kk, i] = (kp * be_) * (pc[kk, i] - pc[kk, i + 1])
    lo, hi = _pair_columns(spans, nsp, r, bh, bw)
    # an unsigned column: numba cannot bound lo, and its negative-index wraparound made
    # this loop gathers (limit_diffuse 1.9x slower)
    if do_w:
        for i in range(lo, hi + 1):
            u = np.uint64(i)
            fy[u] = (kw * _open(wr[u], ws[u])) * (xr[u] - xs[u])
    if do_p:
        br, bsr = bc[r], bc[r + 1]
        for kk in range(ns):
            pck, psk, pyk = pc[kk], ps[kk], py[kk]
            for i in range(lo, hi + 1):
                u = np.uint64(i)
                b0 = br[u]
                t = bsr[u]
                bs_ = (b0 if b0 < t else t) if (wr[u] != 0) & (ws[u] != 0) else ZERO
                pyk[u] = (kp * bs_) * (pck[u] - psk[u])


@_inline
def _lim_row(w: np.ndarray, p: np.ndarray, y0: int, x0: int, ns: int, do_w: bool,
             do_p: bool, r: int, spans: np.ndarray, nsp: np.ndarray, fx: np.ndarray,
             fyn: np.ndarray, fys: np.ndarray, px: np.ndarray, pyn: np.ndarray,
             pys: np.ndarray, sw_r: np.ndarray,
             sp_r: np.ndarray) -> None:  # pragma: no cover - compiled
    """height_limit's donor limiters of row r into ring rows (zero outside the spans),
    from the face fluxes of row r (:func:`_flux_rows`: x faces ``fx``/``px``, south
    faces ``fys``/``pys``) and row r - 1's south faces (``fyn``/``pyn``); the donors'
    water and pigment ``w``/``p`` are the state's (as the step found them)."""
    if do_w:
        _zero_gaps(sw_r, r, spans, nsp)
    else:
        sw_r[:] = ZERO
    if do_p:
        for kk in range(ns):
            _zero_gaps(sp_r[kk], r, spans, nsp)
    else:
        sp_r[:, :] = ZERO
    y = y0 + r - 1
    for sx in range(nsp[r]):
        slo, shi = K._span(spans, r, sx)
        if do_w:
            for i in range(slo, shi + 1):
                fe = fx[i]
                fw = fx[i - 1]
                fs = fys[i]
                fn = fyn[i]
                out = (((fe if fe > ZERO else ZERO) - (fw if fw < ZERO else ZERO))
                       + (fs if fs > ZERO else ZERO)) - (fn if fn < ZERO else ZERO)
                uv = w[y, np.uint64(x0 + i - 1)]
                uv = uv if uv > ZERO else ZERO
                sw_r[i] = uv / out if out > uv else ONE
        if do_p:
            for kk in range(ns):
                for i in range(slo, shi + 1):
                    fe = px[kk, i]
                    fw = px[kk, i - 1]
                    fs = pys[kk, i]
                    fn = pyn[kk, i]
                    out = (((fe if fe > ZERO else ZERO) - (fw if fw < ZERO else ZERO))
                           + (fs if fs > ZERO else ZERO)) - (fn if fn < ZERO else ZERO)
                    uv = p[kk, y, np.uint64(x0 + i - 1)]
                    uv = uv if uv > ZERO else ZERO
                    sp_r[kk, i] = uv / out if out > uv else ONE


@_inline
def _donor(f: np.float32, s_pos: np.float32, s_neg: np.float32
           ) -> np.float32:  # pragma: no cover - compiled
    """A face flux limited by its donor's limiter: the reference's
    ``max(f, 0) s_pos + min(f, 0) s_neg`` as one product, bit for bit: one of the two
    terms is ``+0 * s`` (the limiters are >= +0), and ``x + 0`` is ``x`` but for a -0
    product, which the reference's sum turns into +0 and so does the ``+ ZERO`` here (a
    multiply, a compare and an add a face instead of two of each and two selects)."""
    return f * (s_pos if f > ZERO else s_neg) + ZERO


@_inline
def _iterate_row(wet: np.ndarray, bc: np.ndarray, w: np.ndarray, xw: np.ndarray,
                 p: np.ndarray, xp: np.ndarray, y0: int, x0: int, bh: int, ns: int,
                 kw: np.float32, kp: np.float32, jac1: bool, do_w: bool, do_p: bool, r: int,
                 spans: np.ndarray, nsp: np.ndarray, uw: np.ndarray, up: np.ndarray,
                 xo: np.ndarray, po: np.ndarray) -> None:  # pragma: no cover - compiled
    """Row r of the final water/pigment iterates into ring rows (zero outside the spans
    and the box, like the scratch): with ``jac1`` Jacobi iteration 1 from x0 = u
    (``K._jw_rows``/``K._jp_rows``, the operands and order of ``advect_jacobi1``'s
    rows), else a copy of the iterates ``xw``/``xp`` that ``jacobi_blocked`` left.
    With ``jac1`` u is the state's ``w``/``p`` in rings of padded rows ``uw``/``up``
    (row r in slot r % 3, :func:`K._state_row`: the values prep's ``w0``/``p0`` copies
    held): called for r = r0, r0 + 1, ... with rows r0 - 1 and r0 loaded, each call
    loads row r + 1."""
    if jac1 and do_w:
        K._state_row(w, y0, x0, r + 1, bh, spans, nsp, uw[(r + 1) % 3])
    if jac1 and do_p:
        for kk in range(ns):
            K._state_row(p[kk], y0, x0, r + 1, bh, spans, nsp, up[(r + 1) % 3, kk])
    if r < 1 or r > bh:
        xo[:] = ZERO
        po[:, :] = ZERO
        return
    if do_w:
        _zero_gaps(xo, r, spans, nsp)
    else:
        xo[:] = ZERO
    if do_p:
        for kk in range(ns):
            _zero_gaps(po[kk], r, spans, nsp)
    else:
        po[:, :] = ZERO
    wn, wr, ws = wet[r - 1], wet[r], wet[r + 1]
    for sx in range(nsp[r]):
        slo, shi = K._span(spans, r, sx)
        if do_w:
            if jac1:
                un, ur, us = uw[(r - 1) % 3], uw[r % 3], uw[(r + 1) % 3]
                K._jw_rows(wn, wr, ws, ur, un, ur, us, xo, slo, shi, kw)
            else:
                for i in range(slo, shi + 1):
                    xo[i] = xw[r, i]
        if do_p:
            for kk in range(ns):
                if jac1:
                    un, ur, us = up[(r - 1) % 3, kk], up[r % 3, kk], up[(r + 1) % 3, kk]
                    K._jp_rows(wn, wr, ws, bc[r - 1], bc[r], bc[r + 1], ur, un, ur, us,
                               po[kk], slo, shi, kp)
                else:
                    for i in range(slo, shi + 1):
                        po[kk, i] = xp[kk, r, i]


@_parallel
def limit_diffuse_fused(wet: np.ndarray, bc: np.ndarray, v1x: np.ndarray, v1y: np.ndarray,
                        xvx: np.ndarray, xvy: np.ndarray, w: np.ndarray, xw: np.ndarray,
                        p: np.ndarray, xp: np.ndarray, pr: np.ndarray, bh: int, bw: int,
                        ns: int, cst: np.ndarray, do_vjac: bool, do_height: bool, do_w: bool,
                        do_p: bool, jac1: bool, v3x_o: np.ndarray, v3y_o: np.ndarray,
                        w2_o: np.ndarray, p2_o: np.ndarray, spans: np.ndarray,
                        nsp: np.ndarray, bounds: np.ndarray, fibre: np.ndarray, y0: int,
                        x0: int, h: np.ndarray) -> None:  # pragma: no cover - compiled
    """height_limit and diffuse_apply in one sweep (their maths unchanged): each chunk
    keeps the donor limiters of rows j-1, j, j+1 in a ring instead of ``sw``/``sp``,
    and the final iterates of rows j-1..j+2 in another; with ``jac1`` (one Jacobi
    iteration) it computes them here instead of reading ``xw``/``xp`` (issue 26: the
    iterate fields are neither written nor read). ``w``/``p``: the state's water and
    pigment as the step found them (u of passes 4/5; nothing writes them before this
    sweep ends), read in place of prep's padded copies: the cells themselves directly,
    the Jacobi iteration's neighbours from rings of padded rows (:func:`_iterate_row`)."""
    kw = cst[K.C_KW]
    kp = cst[K.C_KP]
    nch = bounds.shape[0] - 1
    for ch in prange(nch):
        j0, j1 = bounds[ch], bounds[ch + 1]
        swr = np.zeros((3, bw + 2), F32)  # ring: row r in slot r % 3
        spr = np.zeros((3, max(ns, 1), bw + 2), F32)
        xwr = np.zeros((4, bw + 2), F32)  # final iterates: row r in slot r % 4
        xpr = np.zeros((4, max(ns, 1), bw + 2), F32)
        fxr = np.zeros((3, bw + 2), F32)  # face fluxes of row r in slot r % 3: x faces,
        fyr = np.zeros((3, bw + 2), F32)  # the y faces (r, r + 1)
        pxr = np.zeros((3, max(ns, 1), bw + 2), F32)
        pyr = np.zeros((3, max(ns, 1), bw + 2), F32)
        uwr = np.empty((3, bw + 2), F32)  # u = the state's w, p: row r in slot r % 3
        upr = np.empty((3, max(ns, 1), bw + 2), F32)
        if jac1:
            for r in (j0 - 3, j0 - 2):
                if do_w:
                    K._state_row(w, y0, x0, r, bh, spans, nsp, uwr[r % 3])
                if do_p:
                    for kk in range(ns):
                        K._state_row(p[kk], y0, x0, r, bh, spans, nsp, upr[r % 3, kk])
        for r in range(j0 - 2, j0 + 2):
            _iterate_row(wet, bc, w, xw, p, xp, y0, x0, bh, ns, kw, kp, jac1, do_w, do_p, r,
                         spans, nsp, uwr, upr, xwr[r % 4], xpr[r % 4])
        for r in (j0 - 2, j0 - 1, j0):
            if 0 <= r <= bh:
                _flux_rows(wet, bc, xwr[r % 4], xwr[(r + 1) % 4], xpr[r % 4],
                           xpr[(r + 1) % 4], ns, kw, kp, do_w, do_p, r, bh, bw, spans, nsp,
                           fxr[r % 3], fyr[r % 3], pxr[r % 3], pyr[r % 3])
        for r in (j0 - 1, j0):
            if 1 <= r <= bh:
                _lim_row(w, p, y0, x0, ns, do_w, do_p, r, spans, nsp, fxr[r % 3],
                         fyr[(r - 1) % 3], fyr[r % 3], pxr[r % 3], pyr[(r - 1) % 3],
                         pyr[r % 3], swr[r % 3], spr[r % 3])
            else:
                swr[r % 3, :] = ZERO
                spr[r % 3, :, :] = ZERO
        for j in range(j0, j1):
            _iterate_row(wet, bc, w, xw, p, xp, y0, x0, bh, ns, kw, kp, jac1, do_w, do_p,
                         j + 2, spans, nsp, uwr, upr, xwr[(j + 2) % 4], xpr[(j + 2) % 4])
            r = j + 1
            if r <= bh:
                _flux_rows(wet, bc, xwr[r % 4], xwr[(r + 1) % 4], xpr[r % 4],
                           xpr[(r + 1) % 4], ns, kw, kp, do_w, do_p, r, bh, bw, spans, nsp,
                           fxr[r % 3], fyr[r % 3], pxr[r % 3], pyr[r % 3])
                _lim_row(w, p, y0, x0, ns, do_w, do_p, r, spans, nsp, fxr[r % 3],
                         fyr[j % 3], fyr[r % 3], pxr[r % 3], pyr[j % 3], pyr[r % 3],
                         swr[r % 3], spr[r % 3])
            else:
                swr[r % 3, :] = ZERO
                spr[r % 3, :, :] = ZERO
            sm, s0_, sp_ = (j - 1) % 3, j % 3, (j + 1) % 3
            fx, fys, fyn = fxr[s0_], fyr[s0_], fyr[sm]
            px, pys, pyn = pxr[s0_], pyr[s0_], pyr[sm]
            y = y0 + j - 1
            for sx in range(nsp[j]):
                slo, shi = K._span(spans, j, sx)
                _vel_row(wet, v1x, v1y, xvx, xvy, pr, cst, do_vjac, do_height, j, slo, shi,
                         v3x_o, v3y_o, fibre, y0, x0, w, h)
                if do_w:
                    for i in range(slo, shi + 1):
                        fe = fx[i]
                        fw = fx[i - 1]
                        fs = fys[i]
                        fn = fyn[i]
                        s0 = swr[s0_, i]
                        fe = _donor(fe, s0, swr[s0_, i + 1])
                        fw = _donor(fw, swr[s0_, i - 1], s0)
                        fs = _donor(fs, s0, swr[sp_, i])
                        fn = _donor(fn, swr[sm, i], s0)
                        w2_o[j, i] = (((w[y, np.uint64(x0 + i - 1)] - fe) + fw) - fs) + fn
                else:
                    for i in range(slo, shi + 1):
                        w2_o[j, i] = w[y, np.uint64(x0 + i - 1)]
                if do_p:
                    for kk in range(ns):
                        for i in range(slo, shi + 1):
                            fe = px[kk, i]
                            fw = px[kk, i - 1]
                            fs = pys[kk, i]
                            fn = pyn[kk, i]
                            s0 = spr[s0_, kk, i]
                            fe = _donor(fe, s0, spr[s0_, kk, i + 1])
                            fw = _donor(fw, spr[s0_, kk, i - 1], s0)
                            fs = _donor(fs, s0, spr[sp_, kk, i])
                            fn = _donor(fn, spr[sm, kk, i], s0)
                            p2_o[kk, j, i] = (((p[kk, y, np.uint64(x0 + i - 1)] - fe) + fw)
                                              - fs) + fn
                else:
                    for kk in range(ns):
                        for i in range(slo, shi + 1):
                            p2_o[kk, j, i] = p[kk, y, np.uint64(x0 + i - 1)]


@_inline
def _sat_row(w3: np.ndarray, h: np.ndarray, opn: np.ndarray, wc: np.ndarray, y0: int,
             x0: int, r: int, cst: np.ndarray, do_evap: bool, do_absorb: bool,
             spans: np.ndarray, nsp: np.ndarray, out: np.ndarray) -> None:
    # pragma: no cover - compiled
    """The ``sat`` row ``r`` that pass 7-9a would write, without writing anything else."""
    e = cst[K.C_EVAP]
    edge = cst[K.C_EDGE]
    alpha = cst[K.C_ALPHA]
    cmin = cst[K.C_CMIN]
    cspan = cst[K.C_CSPAN]
    out[:] = ZERO
    y = y0 + r - 1
    for sx in range(nsp[r]):
        slo, shi = K._span(spans, r, sx)
        for i in range(slo, shi + 1):
            x = np.uint64(x0 + i - 1)
            wv = w3[r, i]
            if do_evap:
                nd = (((ZERO if w3[r, i + 1] > ZERO else ONE)
                       + (ZERO if w3[r, i - 1] > ZERO else ONE))
                      + (ZERO if w3[r + 1, i] > ZERO else ONE)) \
                    + (ZERO if w3[r - 1, i] > ZERO else ONE)
                loss = e + ((edge * nd) * wv) * e
                loss = loss if loss < wv else wv
                loss = loss if wv > ZERO else ZERO
                wv = wv - loss
            wcv = wc[y, x]
            cv = cmin + h[y, x] * cspan
            if do_absorb:
                d = alpha if alpha < wv else wv
                room = cv - wcv
                room = room if room > ZERO else ZERO
                d = d if d < room else room
                d = d if (wv > ZERO and opn[r, i] != ZERO) else ZERO
                wcv = wcv + d
            out[i] = wcv / cv


@_inline
def _cd_row(sm: np.ndarray, s0r: np.ndarray, sp: np.ndarray, h: np.ndarray, opn: np.ndarray,
            v3x: np.ndarray, v3y: np.ndarray, w: np.ndarray, wc: np.ndarray, evap: np.ndarray,
            p: np.ndarray, q: np.ndarray, vx: np.ndarray, vy: np.ndarray, y0: int, x0: int,
            ns: int, cst: np.ndarray, do_capdiff: bool, do_dry: bool, j: int,
            spans: np.ndarray, nsp: np.ndarray, wcrow: np.ndarray, crow: np.ndarray,
            area: np.ndarray, fade: np.float32, holding: bool) -> None:
    # pragma: no cover - compiled
    """capillary_dry's row j (unchanged) with ``sat`` rows j-1, j, j+1 from the ring;
    ``crow``: a row buffer for the capacity of row j.  With ``do_dry and holding`` the
    end of pass 10 (reference ``wet_area_update``) on the row's final w and wc, while
    they are in cache: ``area`` is 1 where the open cell is wet by its own water, else
    ``max(area - fade, 0)`` while its paper is damp, else 0."""
    k = cst[K.C_KC]
    ecap = cst[K.C_ECAP]
    wdry = cst[K.C_WDRY]
    susp = cst[K.C_SUSP]
    suspending = susp > ZERO
    cmin = cst[K.C_CMIN]
    cspan = cst[K.C_CSPAN]
    y = y0 + j - 1
    # the capacity c = c_min + h (c_max - c_min) from the paper, as the reference computes
    # it, at the cell and its 4 neighbours (row j's in ``crow``, one column either side of
    # the span); a neighbour off the canvas is not computed: its flux is 0 anyway (only a
    # cell in the spans is open)
    height, width = h.shape
    hn_, h0_, hs_ = h[max(y - 1, 0)], h[y], h[min(y + 1, height - 1)]
    for si in range(nsp[j]):
        slo, shi = K._span(spans, j, si)
        if do_capdiff:
            for i in range(max(slo - 1, 1 - x0), min(shi + 1, width - x0) + 1):
                # unsigned: the start is a max() LLVM cannot bound, and numba's
                # wraparound made this store a scatter
                crow[np.uint64(i)] = cmin + h0_[np.uint64(x0 + i - 1)] * cspan
            for i in range(slo, shi + 1):
                o0 = opn[j, i]
                xu = np.uint64(x0 + i - 1)
                c0 = crow[i]
                s0 = s0r[i]
                t = crow[i + 1]
                fe = ((k * (c0 if c0 < t else t)) * (s0 - s0r[i + 1])) \
                    if (o0 != 0) & (opn[j, i + 1] != 0) else ZERO
                t = crow[i - 1]
                fw = ((k * (t if t < c0 else c0)) * (s0r[i - 1] - s0)) \
                    if (opn[j, i - 1] != 0) & (o0 != 0) else ZERO
                t = cmin + hs_[xu] * cspan
                fs = ((k * (c0 if c0 < t else t)) * (s0 - sp[i])) \
                    if (o0 != 0) & (opn[j + 1, i] != 0) else ZERO
                t = cmin + hn_[xu] * cspan
                fn = ((k * (t if t < c0 else c0)) * (sm[i] - s0)) \
                    if (opn[j - 1, i] != 0) & (o0 != 0) else ZERO
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
        if do_dry and holding:  # a loop of its own: the loop above stays as it was
            moist = cst[K.C_MOIST]
            for i in range(slo, shi + 1):  # selects, not branches: the loop vectorises
                x = np.uint64(x0 + i - 1)
                wcv = wc[y, x]
                own = ((w[y, x] > ZERO) | (wcv > moist)) & (opn[j, i] != 0)
                a = area[y, x] - fade
                a = a if a > ZERO else ZERO
                a = a if wcv > ZERO else ZERO
                area[y, x] = ONE if own else a
        if do_dry and n_dry > 0:
            for kk in range(ns):
                for i in range(slo, shi + 1):
                    x = np.uint64(x0 + i - 1)
                    pv = p[kk, y, x]
                    qv = q[kk, y, x]
                    t = ONE - qv
                    t = pv if pv < t else t
                    settle = w[y, x] == ZERO
                    if suspending and wc[y, x] > susp * (cmin + h0_[x] * cspan):
                        settle = False  # damp paper keeps its pigment suspended (bloom's)
                    t = t if settle else ZERO
                    p[kk, y, x] = pv - t
                    q[kk, y, x] = qv + t


@_parallel
def evap_cap_fused(wet: np.ndarray, w3: np.ndarray, opn: np.ndarray,
                   h: np.ndarray, wc: np.ndarray, evap: np.ndarray, w_state: np.ndarray,
                   p: np.ndarray, q: np.ndarray, beta: np.ndarray, gamma: np.ndarray,
                   delta: np.ndarray, v3x: np.ndarray, v3y: np.ndarray, vx: np.ndarray,
                   vy: np.ndarray, y0: int, x0: int, bh: int, bw: int, ns: int,
                   cst: np.ndarray, do_evap: bool, do_surface: bool, do_absorb: bool,
                   do_capdiff: bool, do_dry: bool, spans: np.ndarray,
                   nsp: np.ndarray, bounds: np.ndarray, area: np.ndarray, fade: np.float32,
                   holding: bool) -> None:  # pragma: no cover - compiled
    """evap_surface_absorb and capillary_dry in one sweep (their maths unchanged): pass
    7-9a write the state in place, so each chunk's two boundary ``sat`` rows are computed
    first, side-effect free, from the state as the step found it; the fused loop keeps
    the rows j-1, j, j+1 of ``sat`` in a ring instead of a scratch field.  With
    ``do_dry and holding`` (``wet_hold > 0``) each row ends with the wet-area memory's
    fade (``fade = dt / wet_hold``), so it needs no sweep of its own."""
    nch = bounds.shape[0] - 1
    edge_sat = np.zeros((nch, 2, bw + 2), F32)
    for ch in prange(nch):  # the boundary rows, from the state as the step found it
        j0, j1 = bounds[ch], bounds[ch + 1]
        if j0 - 1 >= 1:
            _sat_row(w3, h, opn, wc, y0, x0, j0 - 1, cst, do_evap, do_absorb, spans, nsp,
                     edge_sat[ch, 0])
        if j1 <= bh:
            _sat_row(w3, h, opn, wc, y0, x0, j1, cst, do_evap, do_absorb, spans, nsp,
                     edge_sat[ch, 1])
    for ch in prange(nch):
        j0, j1 = bounds[ch], bounds[ch + 1]
        ring = np.zeros((3, bw + 2), F32)
        wrow = np.empty(bw + 2, F32)
        frow = np.empty(bw + 2, F32)
        wcrow = np.empty(bw + 2, F32)
        crow = np.zeros(bw + 2, F32)
        ring[(j0 - 1) % 3, :] = edge_sat[ch, 0]
        ring[j0 % 3, :] = ZERO
        K._esa_row(wet, w3, opn, h, wc, evap, w_state, p, q, beta, gamma, delta, y0, x0, ns,
                 cst, do_evap, do_surface, do_absorb, j0, spans, nsp, wrow, frow,
                 ring[j0 % 3])
        for j in range(j0, j1):
            r = j + 1
            if r < j1:
                ring[r % 3, :] = ZERO
                K._esa_row(wet, w3, opn, h, wc, evap, w_state, p, q, beta, gamma, delta, y0,
                         x0, ns, cst, do_evap, do_surface, do_absorb, r, spans, nsp, wrow,
                         frow, ring[r % 3])
            else:
                ring[r % 3, :] = edge_sat[ch, 1]
            _cd_row(ring[(j - 1) % 3], ring[j % 3], ring[(j + 1) % 3], h, opn, v3x, v3y,
                    w_state, wc, evap, p, q, vx, vy, y0, x0, ns, cst, do_capdiff, do_dry, j,
                    spans, nsp, wcrow, crow, area, fade, holding)
