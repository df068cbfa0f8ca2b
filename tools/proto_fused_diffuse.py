"""Prototype of issue 26 item 1's passes 2-5 fusion: ``height_limit`` (last velocity
iteration, pass 3, the diffusion donor limiters) + ``diffuse_apply`` in one sweep, the
limiter rows kept in a 3-row ring per chunk instead of the ``sw``/``sp`` scratch fields.

Wired in since as ``station.backends.cpu.fused.limit_diffuse_fused`` (the same code);
this keeps the measurement.  It runs one step's sweeps up to pass 5 on a wet canvas,
then both versions on the same inputs, checks the fused one bitwise (velocity, water,
pigment) and times both, interleaved.  Wired in it dropped ``sw``, ``sp`` and
diffuse_apply's re-reads (−14 floats, −56 B per cell-step with two slots).

    .venv/bin/python tools/proto_fused_diffuse.py [--size 1920x1080] [--rounds 9]
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
_inline = njit(inline="always", fastmath=False, cache=True, error_model="numpy")


@_inline
def _vel_row(wet: np.ndarray, v1x: np.ndarray, v1y: np.ndarray, xvx: np.ndarray,
             xvy: np.ndarray, pr: np.ndarray, cst: np.ndarray, do_vjac: bool,
             do_height: bool, j: int, slo: int, shi: int, v3x_o: np.ndarray,
             v3y_o: np.ndarray) -> None:  # pragma: no cover - compiled
    """height_limit's velocity part of row j (unchanged)."""
    kv, g, oh, oi, vm = cst[K.C_KV], cst[K.C_G], cst[K.C_OH], cst[K.C_OI], cst[K.C_VMAX]
    tgx, tgy = cst[K.C_TILTX], cst[K.C_TILTY]
    wr, wn, ws = wet[j], wet[j - 1], wet[j + 1]
    if do_vjac:
        K._jacobi_v_row(wet, v1x, v1y, xvx, xvy, v3x_o, v3y_o, j, slo, shi, kv)
    else:
        for i in range(slo, shi + 1):
            v3x_o[j, i] = xvx[j, i]
            v3y_o[j, i] = xvy[j, i]
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


@_inline
def _pface(br: np.ndarray, bnr: np.ndarray, bsr: np.ndarray, wr: np.ndarray, wn: np.ndarray,
           ws: np.ndarray, i: int) -> tuple[np.float32, np.float32, np.float32, np.float32]:
    # pragma: no cover - compiled
    b0 = br[i]
    t = br[i + 1]
    be_ = (b0 if b0 < t else t) if wr[i] * wr[i + 1] != ZERO else ZERO
    t = br[i - 1]
    bw_ = (b0 if b0 < t else t) if wr[i] * wr[i - 1] != ZERO else ZERO
    t = bsr[i]
    bs_ = (b0 if b0 < t else t) if wr[i] * ws[i] != ZERO else ZERO
    t = bnr[i]
    bn_ = (b0 if b0 < t else t) if wr[i] * wn[i] != ZERO else ZERO
    return be_, bw_, bs_, bn_


@_inline
def _lim_row(wet: np.ndarray, bc: np.ndarray, w0: np.ndarray, xw: np.ndarray,
             p0: np.ndarray, xp: np.ndarray, ns: int, kw: np.float32, kp: np.float32,
             do_w: bool, do_p: bool, r: int, spans: np.ndarray, nsp: np.ndarray,
             sw_r: np.ndarray, sp_r: np.ndarray) -> None:  # pragma: no cover - compiled
    """height_limit's donor limiters of row r into ring rows (zero outside the spans)."""
    sw_r[:] = ZERO
    sp_r[:, :] = ZERO
    wr, wn, ws = wet[r], wet[r - 1], wet[r + 1]
    for sx in range(nsp[r]):
        slo, shi = K._span(spans, r, sx)
        if do_w:
            for i in range(slo, shi + 1):
                fe = (kw * (wr[i] * wr[i + 1])) * (xw[r, i] - xw[r, i + 1])
                fw = (kw * (wr[i - 1] * wr[i])) * (xw[r, i - 1] - xw[r, i])
                fs = (kw * (wr[i] * ws[i])) * (xw[r, i] - xw[r + 1, i])
                fn = (kw * (wn[i] * wr[i])) * (xw[r - 1, i] - xw[r, i])
                out = (((fe if fe > ZERO else ZERO) - (fw if fw < ZERO else ZERO))
                       + (fs if fs > ZERO else ZERO)) - (fn if fn < ZERO else ZERO)
                uv = w0[r, i]
                uv = uv if uv > ZERO else ZERO
                sw_r[i] = uv / out if out > uv else ONE
        if do_p:
            br, bnr, bsr = bc[r], bc[r - 1], bc[r + 1]
            for kk in range(ns):
                for i in range(slo, shi + 1):
                    be_, bw_, bs_, bn_ = _pface(br, bnr, bsr, wr, wn, ws, i)
                    fe = (kp * be_) * (xp[kk, r, i] - xp[kk, r, i + 1])
                    fw = (kp * bw_) * (xp[kk, r, i - 1] - xp[kk, r, i])
                    fs = (kp * bs_) * (xp[kk, r, i] - xp[kk, r + 1, i])
                    fn = (kp * bn_) * (xp[kk, r - 1, i] - xp[kk, r, i])
                    out = (((fe if fe > ZERO else ZERO) - (fw if fw < ZERO else ZERO))
                           + (fs if fs > ZERO else ZERO)) - (fn if fn < ZERO else ZERO)
                    uv = p0[kk, r, i]
                    uv = uv if uv > ZERO else ZERO
                    sp_r[kk, i] = uv / out if out > uv else ONE


@njit(parallel=True, fastmath=False, cache=True, error_model="numpy", nogil=True)
def limit_diffuse_fused(wet: np.ndarray, bc: np.ndarray, v1x: np.ndarray, v1y: np.ndarray,
                        xvx: np.ndarray, xvy: np.ndarray, w0: np.ndarray, xw: np.ndarray,
                        p0: np.ndarray, xp: np.ndarray, pr: np.ndarray, bh: int, bw: int,
                        ns: int, cst: np.ndarray, do_vjac: bool, do_height: bool, do_w: bool,
                        do_p: bool, v3x_o: np.ndarray, v3y_o: np.ndarray, w2_o: np.ndarray,
                        p2_o: np.ndarray, spans: np.ndarray,
                        nsp: np.ndarray) -> None:  # pragma: no cover - compiled
    kw = cst[K.C_KW]
    kp = cst[K.C_KP]
    nch = min(bh, K.N_CHUNKS)
    for ch in prange(nch):
        j0, j1 = K._chunk(ch, nch, bh)
        swr = np.zeros((3, bw + 2), F32)  # ring: row r in slot r % 3
        spr = np.zeros((3, max(ns, 1), bw + 2), F32)
        for r in (j0 - 1, j0):
            if 1 <= r <= bh:
                _lim_row(wet, bc, w0, xw, p0, xp, ns, kw, kp, do_w, do_p, r, spans, nsp,
                         swr[r % 3], spr[r % 3])
            else:
                swr[r % 3, :] = ZERO
                spr[r % 3, :, :] = ZERO
        for j in range(j0, j1):
            r = j + 1
            if r <= bh:
                _lim_row(wet, bc, w0, xw, p0, xp, ns, kw, kp, do_w, do_p, r, spans, nsp,
                         swr[r % 3], spr[r % 3])
            else:
                swr[r % 3, :] = ZERO
                spr[r % 3, :, :] = ZERO
            sm, s0_, sp_ = (j - 1) % 3, j % 3, (j + 1) % 3
            wr, wn, ws = wet[j], wet[j - 1], wet[j + 1]
            for sx in range(nsp[j]):
                slo, shi = K._span(spans, j, sx)
                _vel_row(wet, v1x, v1y, xvx, xvy, pr, cst, do_vjac, do_height, j, slo, shi,
                         v3x_o, v3y_o)
                if do_w:
                    for i in range(slo, shi + 1):
                        fe = (kw * (wr[i] * wr[i + 1])) * (xw[j, i] - xw[j, i + 1])
                        fw = (kw * (wr[i - 1] * wr[i])) * (xw[j, i - 1] - xw[j, i])
                        fs = (kw * (wr[i] * ws[i])) * (xw[j, i] - xw[j + 1, i])
                        fn = (kw * (wn[i] * wr[i])) * (xw[j - 1, i] - xw[j, i])
                        s0 = swr[s0_, i]
                        fe = (fe if fe > ZERO else ZERO) * s0 \
                            + (fe if fe < ZERO else ZERO) * swr[s0_, i + 1]
                        fw = (fw if fw > ZERO else ZERO) * swr[s0_, i - 1] \
                            + (fw if fw < ZERO else ZERO) * s0
                        fs = (fs if fs > ZERO else ZERO) * s0 \
                            + (fs if fs < ZERO else ZERO) * swr[sp_, i]
                        fn = (fn if fn > ZERO else ZERO) * swr[sm, i] \
                            + (fn if fn < ZERO else ZERO) * s0
                        w2_o[j, i] = (((w0[j, i] - fe) + fw) - fs) + fn
                else:
                    for i in range(slo, shi + 1):
                        w2_o[j, i] = w0[j, i]
                if do_p:
                    br, bnr, bsr = bc[j], bc[j - 1], bc[j + 1]
                    for kk in range(ns):
                        for i in range(slo, shi + 1):
                            be_, bw_, bs_, bn_ = _pface(br, bnr, bsr, wr, wn, ws, i)
                            fe = (kp * be_) * (xp[kk, j, i] - xp[kk, j, i + 1])
                            fw = (kp * bw_) * (xp[kk, j, i - 1] - xp[kk, j, i])
                            fs = (kp * bs_) * (xp[kk, j, i] - xp[kk, j + 1, i])
                            fn = (kp * bn_) * (xp[kk, j - 1, i] - xp[kk, j, i])
                            s0 = spr[s0_, kk, i]
                            fe = (fe if fe > ZERO else ZERO) * s0 \
                                + (fe if fe < ZERO else ZERO) * spr[s0_, kk, i + 1]
                            fw = (fw if fw > ZERO else ZERO) * spr[s0_, kk, i - 1] \
                                + (fw if fw < ZERO else ZERO) * s0
                            fs = (fs if fs > ZERO else ZERO) * s0 \
                                + (fs if fs < ZERO else ZERO) * spr[sp_, kk, i]
                            fn = (fn if fn > ZERO else ZERO) * spr[sm, kk, i] \
                                + (fn if fn < ZERO else ZERO) * s0
                            p2_o[kk, j, i] = (((p0[kk, j, i] - fe) + fw) - fs) + fn
                else:
                    for kk in range(ns):
                        for i in range(slo, shi + 1):
                            p2_o[kk, j, i] = p0[kk, j, i]


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
    # one step's sweeps through the Jacobi iterates (the inputs of height_limit)
    S.step_region(st, (slice(0, h), slice(0, w)), st.params.dt, scratch,
                  stop_after="diffuse_pigment")
    s2, s3 = scratch.a2, scratch.a3
    ns = max(len(st.slots), 1)
    cst = S.constants(st.params, st.params.dt, st.sim_time)
    n_it = int(st.params.jacobi_iters)
    prm = st.params
    do_v = prm.viscosity * prm.dt > 0 and n_it >= 1
    do_w, do_p = prm.nu_w * prm.dt > 0, prm.nu_p * prm.dt > 0
    do_pr = prm.flow_outward > 0 or prm.paper_relief > 0
    pr = s2["pr"] if do_pr else s2["w0"]
    # the iterates as step_region leaves them for one Jacobi iteration (profile: 1)
    xvx, xvy = s2["v1x"], s2["v1y"]
    xw = s2["xwa"] if do_w else s2["w0"]
    xp = s3["xpa"] if do_p else s3["p0"]
    base = (s2["wet"], s2["bc"], s2["v1x"], s2["v1y"], xvx, xvy, s2["w0"], xw, s3["p0"],
            xp, pr, h, w, ns, cst, do_v, True, do_w, do_p)
    outs = {k: (np.zeros_like(s2["v3x"]), np.zeros_like(s2["v3y"]), np.zeros_like(s2["w2"]),
                np.zeros_like(s3["p2"])) for k in ("two", "one")}
    sw, sp = np.zeros_like(s2["w2"]), np.zeros_like(s3["p2"])  # the fields the fusion dropped

    def two() -> None:
        vx_, vy_, w2_, p2_ = outs["two"]
        K.height_limit(*base, vx_, vy_, sw, sp, scratch.spans, scratch.nsp)
        K.diffuse_apply(s2["wet"], s2["bc"], s2["w0"], xw, sw, s3["p0"], xp, sp, h, w, ns,
                        cst, do_w, do_p, w2_, p2_, scratch.spans, scratch.nsp)

    def one() -> None:
        vx_, vy_, w2_, p2_ = outs["one"]
        limit_diffuse_fused(*base, vx_, vy_, w2_, p2_, scratch.spans, scratch.nsp)

    two()
    one()
    equal = all(np.array_equal(a, b) for a, b in zip(outs["two"], outs["one"], strict=True))
    times: dict[str, list[float]] = {"two_sweeps": [], "fused": []}
    load0 = [round(x, 2) for x in os.getloadavg()]
    for k in range(args.rounds):
        for name, fn in ((("two_sweeps", two), ("fused", one)) if k % 2 == 0
                         else (("fused", one), ("two_sweeps", two))):
            t0 = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
    med = {k: statistics.median(v) for k, v in times.items()}
    print(json.dumps({"size": args.size, "jacobi_iters": n_it, "bitwise_equal": equal,
                      "load_average": load0,
                      "ms": {k: round(1e3 * v, 3) for k, v in med.items()},
                      "fused_over_two": round(med["fused"] / med["two_sweeps"], 3)}, indent=2))


if __name__ == "__main__":
    main()
