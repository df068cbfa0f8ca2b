"""Prototype of issue 26 item 1's passes 7-10 fusion: ``evap_surface_absorb`` and
``capillary_dry`` in one sweep, the saturation rows in a 3-row ring per chunk instead of
the ``sat`` scratch field.

Pass 7-9a write the state in place, so a chunk cannot recompute its neighbours'
boundary rows (the neighbour may have written them already): a first parallel loop
computes each chunk's two boundary ``sat`` rows side-effect free from the state as the
step found it (``sat`` depends on the state only through that row's ``wc``), and the
fused loop seeds its ring with them.  Wired in since as
``station.backends.cpu.fused.evap_cap_fused`` (the same code); this keeps the
measurement: it checks itself bitwise (w, wc,
evaporated, p, q, vx, vy) against the two live sweeps on a wet canvas and times both,
interleaved.  Re-applied it drops ``sat`` and capillary_dry's re-reads of w, wc,
evaporated, c, opn (−10 floats, −40 B per cell-step).

    .venv/bin/python tools/proto_fused_evap.py [--size 1920x1080] [--rounds 9]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from typing import Any

import numpy as np
from numba import njit, prange

from station.backends.cpu import fused as F
from station.backends.cpu import kernels as K
from station.backends.cpu import step as S
from station.backends.factory import create_backend
from station.bench._sim_driver import wash
from station.canvas import reference

F32 = np.float32
ZERO, ONE = K.ZERO, K.ONE
_inline = njit(inline="always", fastmath=False, cache=True, error_model="numpy")


@_inline
def _sat_row(w3: np.ndarray, c: np.ndarray, opn: np.ndarray, wc: np.ndarray, y0: int,
             x0: int, r: int, cst: np.ndarray, do_evap: bool, do_absorb: bool,
             spans: np.ndarray, nsp: np.ndarray, out: np.ndarray) -> None:
    # pragma: no cover - compiled
    """The ``sat`` row ``r`` that pass 7-9a would write, without writing anything else."""
    e = cst[K.C_EVAP]
    edge = cst[K.C_EDGE]
    alpha = cst[K.C_ALPHA]
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
            cv = c[r, i]
            if do_absorb:
                d = alpha if alpha < wv else wv
                room = cv - wcv
                room = room if room > ZERO else ZERO
                d = d if d < room else room
                d = d if (wv > ZERO and opn[r, i] != ZERO) else ZERO
                wcv = wcv + d
            out[i] = wcv / cv


@_inline
def _esa_row(wet: np.ndarray, w3: np.ndarray, c: np.ndarray, opn: np.ndarray, h: np.ndarray,
             wc: np.ndarray, evap: np.ndarray, w_state: np.ndarray, p: np.ndarray,
             q: np.ndarray, beta: np.ndarray, gamma: np.ndarray, delta: np.ndarray, y0: int,
             x0: int, ns: int, cst: np.ndarray, do_evap: bool, do_surface: bool,
             do_absorb: bool, j: int, spans: np.ndarray, nsp: np.ndarray, wrow: np.ndarray,
             frow: np.ndarray, sat_r: np.ndarray) -> None:  # pragma: no cover - compiled
    """evap_surface_absorb's row j (unchanged), ``sat`` into the ring row."""
    e = cst[K.C_EVAP]
    edge = cst[K.C_EDGE]
    wmax = cst[K.C_WMAX]
    rate = cst[K.C_RATE]
    alpha = cst[K.C_ALPHA]
    sat_r[:] = ZERO
    y = y0 + j - 1
    for si in range(nsp[j]):
        slo, shi = K._span(spans, j, si)
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
            cv = c[j, i]
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


@_inline
def _cd_row(sm: np.ndarray, s0r: np.ndarray, sp: np.ndarray, c: np.ndarray, opn: np.ndarray,
            v3x: np.ndarray, v3y: np.ndarray, w: np.ndarray, wc: np.ndarray, evap: np.ndarray,
            p: np.ndarray, q: np.ndarray, vx: np.ndarray, vy: np.ndarray, y0: int, x0: int,
            ns: int, cst: np.ndarray, do_capdiff: bool, do_dry: bool, j: int,
            spans: np.ndarray, nsp: np.ndarray, wcrow: np.ndarray) -> None:
    # pragma: no cover - compiled
    """capillary_dry's row j (unchanged) with ``sat`` rows j-1, j, j+1 from the ring."""
    k = cst[K.C_KC]
    ecap = cst[K.C_ECAP]
    wdry = cst[K.C_WDRY]
    susp = cst[K.C_SUSP]
    suspending = susp > ZERO
    y = y0 + j - 1
    for si in range(nsp[j]):
        slo, shi = K._span(spans, j, si)
        if do_capdiff:
            for i in range(slo, shi + 1):
                o0 = opn[j, i]
                c0 = c[j, i]
                s0 = s0r[i]
                t = c[j, i + 1]
                fe = ((k * (c0 if c0 < t else t)) * (s0 - s0r[i + 1])) \
                    if o0 * opn[j, i + 1] != ZERO else ZERO
                t = c[j, i - 1]
                fw = ((k * (t if t < c0 else c0)) * (s0r[i - 1] - s0)) \
                    if opn[j, i - 1] * o0 != ZERO else ZERO
                t = c[j + 1, i]
                fs = ((k * (c0 if c0 < t else t)) * (s0 - sp[i])) \
                    if o0 * opn[j + 1, i] != ZERO else ZERO
                t = c[j - 1, i]
                fn = ((k * (t if t < c0 else c0)) * (sm[i] - s0)) \
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
                        settle = False  # damp paper keeps its pigment suspended (bloom's)
                    t = t if settle else ZERO
                    p[kk, y, x] = pv - t
                    q[kk, y, x] = qv + t


@njit(parallel=True, fastmath=False, cache=True, error_model="numpy", nogil=True)
def evap_cap_fused(wet: np.ndarray, w3: np.ndarray, c: np.ndarray, opn: np.ndarray,
                   h: np.ndarray, wc: np.ndarray, evap: np.ndarray, w_state: np.ndarray,
                   p: np.ndarray, q: np.ndarray, beta: np.ndarray, gamma: np.ndarray,
                   delta: np.ndarray, v3x: np.ndarray, v3y: np.ndarray, vx: np.ndarray,
                   vy: np.ndarray, y0: int, x0: int, bh: int, bw: int, ns: int,
                   cst: np.ndarray, do_evap: bool, do_surface: bool, do_absorb: bool,
                   do_capdiff: bool, do_dry: bool, spans: np.ndarray,
                   nsp: np.ndarray) -> None:  # pragma: no cover - compiled
    nch = min(bh, K.N_CHUNKS)
    edge_sat = np.zeros((nch, 2, bw + 2), F32)
    for ch in prange(nch):  # the boundary rows, from the state as the step found it
        j0, j1 = K._chunk(ch, nch, bh)
        if j0 - 1 >= 1:
            _sat_row(w3, c, opn, wc, y0, x0, j0 - 1, cst, do_evap, do_absorb, spans, nsp,
                     edge_sat[ch, 0])
        if j1 <= bh:
            _sat_row(w3, c, opn, wc, y0, x0, j1, cst, do_evap, do_absorb, spans, nsp,
                     edge_sat[ch, 1])
    for ch in prange(nch):
        j0, j1 = K._chunk(ch, nch, bh)
        ring = np.zeros((3, bw + 2), F32)
        wrow = np.empty(bw + 2, F32)
        frow = np.empty(bw + 2, F32)
        wcrow = np.empty(bw + 2, F32)
        ring[(j0 - 1) % 3, :] = edge_sat[ch, 0]
        _esa_row(wet, w3, c, opn, h, wc, evap, w_state, p, q, beta, gamma, delta, y0, x0, ns,
                 cst, do_evap, do_surface, do_absorb, j0, spans, nsp, wrow, frow,
                 ring[j0 % 3])
        for j in range(j0, j1):
            r = j + 1
            if r < j1:
                _esa_row(wet, w3, c, opn, h, wc, evap, w_state, p, q, beta, gamma, delta, y0,
                         x0, ns, cst, do_evap, do_surface, do_absorb, r, spans, nsp, wrow,
                         frow, ring[r % 3])
            else:
                ring[r % 3, :] = edge_sat[ch, 1]
            _cd_row(ring[(j - 1) % 3], ring[j % 3], ring[(j + 1) % 3], c, opn, v3x, v3y,
                    w_state, wc, evap, p, q, vx, vy, y0, x0, ns, cst, do_capdiff, do_dry, j,
                    spans, nsp, wcrow)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--rounds", type=int, default=9)
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    canvas: Any = create_backend("cpu", w, h, "watercolor", 1, tiling=False)
    wash(canvas, w, h)
    for _ in range(3):
        canvas.step()
    st = canvas.live_state
    scratch = S.Scratch(h, w, max(len(st.slots), 1))
    # one step's sweeps through pass 6 (advect_apply writes w3 and the state's p)
    S.step_region(st.copy(), (slice(0, h), slice(0, w)), st.params.dt, scratch,
                  stop_after="diffuse_pigment")
    s2, s3 = scratch.a2, scratch.a3
    ns = max(len(st.slots), 1)
    cst = S.constants(st.params, st.params.dt, st.sim_time)
    F.advect_fused(s2["wet"], s2["v3x"], s2["v3y"], s2["w2"], s3["p2"], 0, 0, h, w, ns, cst,
                   s2["w3"], st.p, scratch.spans, scratch.nsp)
    beta, gamma, delta = (a[:ns].copy() for a in reference.slot_properties(st))
    prm = st.params
    names = ("w", "wc", "evaporated", "p", "q", "vx", "vy")
    start = {n: getattr(st, n).copy() for n in names}
    copies = {k: {n: v.copy() for n, v in start.items()} for k in ("two", "one")}
    do_cap = prm.cap_diffusion * prm.dt > 0

    def two() -> None:
        f = copies["two"]
        K.evap_surface_absorb(s2["wet"], s2["w3"], s2["c"], s2["opn"], st.h, f["wc"],
                              f["evaporated"], f["w"], f["p"], f["q"], beta, gamma, delta,
                              0, 0, h, w, ns, cst, True, True, True, s2["sat"],
                              scratch.spans, scratch.nsp)
        K.capillary_dry(s2["sat"], s2["c"], s2["opn"], s2["v3x"], s2["v3y"], f["w"], f["wc"],
                        f["evaporated"], f["p"], f["q"], f["vx"], f["vy"], 0, 0, h, w, ns,
                        cst, do_cap, True, scratch.spans, scratch.nsp)

    def one() -> None:
        f = copies["one"]
        evap_cap_fused(s2["wet"], s2["w3"], s2["c"], s2["opn"], st.h, f["wc"],
                       f["evaporated"], f["w"], f["p"], f["q"], beta, gamma, delta,
                       s2["v3x"], s2["v3y"], f["vx"], f["vy"], 0, 0, h, w, ns, cst, True,
                       True, True, do_cap, True, scratch.spans, scratch.nsp)

    def reset() -> None:
        for k in copies:
            for n in names:
                copies[k][n][...] = start[n]

    two()
    one()
    equal = all(np.array_equal(copies["two"][n], copies["one"][n]) for n in names)
    times: dict[str, list[float]] = {"two_sweeps": [], "fused": []}
    load0 = [round(x, 2) for x in os.getloadavg()]
    for k in range(args.rounds):
        reset()
        for name, fn in ((("two_sweeps", two), ("fused", one)) if k % 2 == 0
                         else (("fused", one), ("two_sweeps", two))):
            t0 = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
    med = {k: statistics.median(v) for k, v in times.items()}
    print(json.dumps({"size": args.size, "bitwise_equal": equal, "load_average": load0,
                      "ms": {k: round(1e3 * v, 3) for k, v in med.items()},
                      "fused_over_two": round(med["fused"] / med["two_sweeps"], 3)}, indent=2))


if __name__ == "__main__":
    main()
