"""Prototype of issue 26 item 1's pass-6 fusion: ``advect_limit`` + ``advect_apply`` in one
sweep, the limiter rows kept in a 3-row ring per chunk instead of two full scratch fields.

Wired in since as ``station.backends.cpu.fused.advect_fused`` (the same code); this
keeps the measurement: it runs the cpu backend's own sweeps up to pass 6 on a wet canvas, then
both versions of pass 6 on the same inputs, checks that the fused one is bitwise equal
(water and pigment) and times both, interleaved.  To re-apply: move ``advect_fused``
into ``station/backends/cpu/kernels.py``, call it from ``step.step_region`` in place of
the two sweeps, drop ``sout``/``sin`` from the scratch and ``advect_limit`` from
``traffic.py`` (−10 floats, −40 B per cell-step).

    .venv/bin/python tools/proto_fused_advect.py [--size 1024x1024] [--rounds 5]
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

from station.backends.cpu import kernels as K
from station.backends.cpu import step as S
from station.backends.factory import create_backend
from station.bench._sim_driver import wash

F32 = np.float32
ZERO, ONE = K.ZERO, K.ONE


@njit(inline="always", fastmath=False, cache=True, error_model="numpy")
def _limit_row(wet: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray,
               p: np.ndarray, r: int, ns: int, q4: np.float32, wmin: np.float32,
               wmax: np.float32, spans: np.ndarray, nsp: np.ndarray, buf: np.ndarray,
               so: np.ndarray, si: np.ndarray) -> None:  # pragma: no cover - compiled
    """advect_limit's row ``r`` into ``so``/``si`` (zero outside the row's spans)."""
    so[:] = ZERO
    si[:] = ZERO
    for sx in range(nsp[r]):
        slo, shi = K._span(spans, r, sx)
        K._row_rates(vx, vy, wet, r, slo, shi, q4, buf)
        rxp, rxn, syp, syn, nyp, nyn = buf[0], buf[1], buf[2], buf[3], buf[4], buf[5]
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


@njit(parallel=True, fastmath=False, cache=True, error_model="numpy", nogil=True)
def advect_fused(wet: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray,
                 p: np.ndarray, y0: int, x0: int, bh: int, bw: int, ns: int,
                 cst: np.ndarray, w3_o: np.ndarray, p_state: np.ndarray,
                 spans: np.ndarray, nsp: np.ndarray) -> None:  # pragma: no cover - compiled
    """Pass 6 (limiters and fluxes) in one sweep: each chunk computes the limiter rows
    j-1, j, j+1 into a ring and applies row j, exactly as advect_apply does."""
    q4 = cst[K.C_Q4]
    wmin = cst[K.C_WMIN]
    wmax = cst[K.C_WMAX]
    nch = min(bh, K.N_CHUNKS)
    for ch in prange(nch):
        j0, j1 = K._chunk(ch, nch, bh)
        buf = np.empty((6, bw + 2), F32)
        a = np.empty((6, bw + 2), F32)
        so = np.zeros((3, bw + 2), F32)  # ring: row r lives in slot r % 3
        si = np.zeros((3, bw + 2), F32)
        for r in (j0 - 1, j0):
            if 1 <= r <= bh:
                _limit_row(wet, vx, vy, w, p, r, ns, q4, wmin, wmax, spans, nsp, buf,
                           so[r % 3], si[r % 3])
            else:
                so[r % 3, :] = ZERO
                si[r % 3, :] = ZERO
        for j in range(j0, j1):
            r = j + 1
            if r <= bh:
                _limit_row(wet, vx, vy, w, p, r, ns, q4, wmin, wmax, spans, nsp, buf,
                           so[r % 3], si[r % 3])
            else:
                so[r % 3, :] = ZERO
                si[r % 3, :] = ZERO
            sm, s0, sp = (j - 1) % 3, j % 3, (j + 1) % 3
            y = y0 + j - 1
            for sx in range(nsp[j]):
                slo, shi = K._span(spans, j, sx)
                K._row_rates(vx, vy, wet, j, slo, shi, q4, buf)
                for i in range(slo - 1, shi + 1):
                    a[0, i] = (buf[0, i] * so[s0, i]) * si[s0, i + 1]
                    a[1, i] = (buf[1, i] * so[s0, i + 1]) * si[s0, i]
                for i in range(slo, shi + 1):
                    a[2, i] = (buf[2, i] * so[s0, i]) * si[sp, i]
                    a[3, i] = (buf[3, i] * so[sp, i]) * si[s0, i]
                    a[4, i] = (buf[4, i] * so[sm, i]) * si[s0, i]
                    a[5, i] = (buf[5, i] * so[s0, i]) * si[sm, i]
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="1024x1024")
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    canvas: Any = create_backend("cpu", w, h, "watercolor", 1, tiling=False)
    wash(canvas, w, h)
    for _ in range(3):
        canvas.step()
    st = canvas.live_state
    # one step's sweeps up to pass 5 on the state (the scratch then holds pass 6's inputs)
    scratch = S.Scratch(h, w, max(len(st.slots), 1))
    S.step_region(st, (slice(0, h), slice(0, w)), st.params.dt, scratch,
                  stop_after="diffuse_pigment")
    s2, s3 = scratch.a2, scratch.a3
    ns = max(len(st.slots), 1)
    cst = S.constants(st.params, st.params.dt, st.sim_time)
    wet, vx, vy = s2["wet"], s2["v3x"], s2["v3y"]
    w2, p2 = s2["w2"], s3["p2"]
    spans, nsp = scratch.spans, scratch.nsp
    w3a, w3b = np.zeros_like(w2), np.zeros_like(w2)
    pa_, pb_ = np.zeros_like(st.p), np.zeros_like(st.p)
    sout, sin = np.zeros_like(w2), np.zeros_like(w2)  # the fields the fusion dropped

    def two() -> tuple[np.ndarray, np.ndarray]:
        K.advect_limit(wet, vx, vy, w2, p2, h, w, ns, cst, sout, sin, spans, nsp)
        K.advect_apply(wet, vx, vy, sout, sin, w2, p2, 0, 0, h, w, ns, cst, True,
                       w3a, pa_, spans, nsp)
        return w3a, pa_

    def one() -> tuple[np.ndarray, np.ndarray]:
        advect_fused(wet, vx, vy, w2, p2, 0, 0, h, w, ns, cst, w3b, pb_, spans, nsp)
        return w3b, pb_

    wa, pa = two()
    wb, pb = one()
    equal = bool(np.array_equal(wa, wb) and np.array_equal(pa, pb))
    times: dict[str, list[float]] = {"two_sweeps": [], "fused": []}
    load0 = [round(x, 2) for x in os.getloadavg()]
    for k in range(args.rounds):
        for name, fn in ((("two_sweeps", two), ("fused", one)) if k % 2 == 0
                         else (("fused", one), ("two_sweeps", two))):
            t0 = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
    med = {k: statistics.median(v) for k, v in times.items()}
    print(json.dumps({"size": args.size, "bitwise_equal": equal, "load_average": load0,
                      "ms": {k: round(1e3 * v, 3) for k, v in med.items()},
                      "fused_over_two": round(med["fused"] / med["two_sweeps"], 3),
                      "max_abs_w": float(np.abs(wa - wb).max()),
                      "max_abs_p": float(np.abs(pa - pb).max())}, indent=2))


if __name__ == "__main__":
    main()
