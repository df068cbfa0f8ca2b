"""A compiled SQP for one spine's equilibrium (issue 26 item 5).

NLopt's SLSQP calls back into Python for the objective and each constraint
block at every iterate (~10 µs a call, 15–40 iterates a pressed frame), so a
solve cost 0.2–0.4 ms of which the arithmetic is a few per cent.  This module
is the same method — sequential quadratic programming with a damped-BFGS
Hessian of the Lagrangian and an ℓ1 merit line search (Kraft's SLSQP, which
NLopt wraps) — written for numba, so a whole frame's solve is one call:

* the quadratic subproblem ``min ½dᵀBd + gᵀd`` subject to the linearised
  heights and the angle bounds is solved by Goldfarb and Idnani's dual
  active-set method (exact for a strictly convex QP; no feasible start needed);
* an infeasible linearisation, a non-descent direction or an exhausted budget
  returns a status, and the caller falls back to NLopt (whose SLSQP relaxes an
  infeasible subproblem) — so the fast path never loses a frame the old one
  solved.

The problem is tiny (``2n`` ≤ 24 angles, ``n`` heights, ``4n`` bounds), so the
QP recomputes its projections from the Cholesky inverse at each active-set
change instead of updating factorisations.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from station.brush.energy import evaluate
from station.brush.spine import chain

OK = 0
INFEASIBLE = 1
"""The linearised constraints have no solution within the bounds."""
NO_PROGRESS = 2
"""The line search found no decrease of the merit function."""
BUDGET = 3
"""The evaluation budget ran out before the step fell below the tolerance."""
NOT_CONVEX = 4

_EPS = 1e-13


@numba.njit(cache=True)
def _inverse_spd(g: np.ndarray, out: np.ndarray, lo: np.ndarray,
                 li: np.ndarray) -> bool:  # pragma: no cover - compiled
    """``out = g⁻¹`` for a symmetric positive-definite ``g`` (Cholesky); False if not.
    ``lo``, ``li``: scratch at least as large as ``g``."""
    n = g.shape[0]
    lo[:n, :n] = 0.0
    for j in range(n):
        s = g[j, j]
        for k in range(j):
            s -= lo[j, k] * lo[j, k]
        if s <= 1e-300:
            return False
        d = math.sqrt(s)
        lo[j, j] = d
        for i in range(j + 1, n):
            t = g[i, j]
            for k in range(j):
                t -= lo[i, k] * lo[j, k]
            lo[i, j] = t / d
    # L⁻¹ by forward substitution, then g⁻¹ = L⁻ᵀ L⁻¹
    li[:n, :n] = 0.0
    for c in range(n):
        for i in range(c, n):
            t = 1.0 if i == c else 0.0
            for k in range(c, i):
                t -= lo[i, k] * li[k, c]
            li[i, c] = t / lo[i, i]
    for i in range(n):
        for j in range(n):
            t = 0.0
            for k in range(max(i, j), n):
                t += li[k, i] * li[k, j]
            out[i, j] = t
    return True


@numba.njit(cache=True)
def _projections(ginv: np.ndarray, c: np.ndarray, sign: np.ndarray, active: np.ndarray,
                 q: int, nstar: np.ndarray, h: np.ndarray,
                 w: np.ndarray) -> bool:  # pragma: no cover - compiled
    """For the ``q`` active normals ``N``: ``N* = (NᵀG⁻¹N)⁻¹NᵀG⁻¹`` and
    ``H = G⁻¹ - G⁻¹N N*`` (the reduced inverse Hessian).  ``w`` (5, n, n): scratch."""
    n = ginv.shape[0]
    if q == 0:
        h[:, :] = ginv
        return True
    gn = w[0]  # G⁻¹N, (n, q)
    for j in range(q):
        r = active[j]
        for i in range(n):
            t = 0.0
            for k in range(n):
                t += ginv[i, k] * c[r, k]
            gn[i, j] = sign[r] * t
    m = w[1]  # (q, q)
    for a in range(q):
        ra = active[a]
        for b in range(q):
            t = 0.0
            for k in range(n):
                t += sign[ra] * c[ra, k] * gn[k, b]
            m[a, b] = t
    minv = w[2]
    if not _inverse_spd(m[:q, :q], minv, w[3], w[4]):
        return False
    for a in range(q):
        for i in range(n):
            t = 0.0
            for b in range(q):
                t += minv[a, b] * gn[i, b]
            nstar[a, i] = t
    for i in range(n):
        for j in range(n):
            t = ginv[i, j]
            for a in range(q):
                t -= gn[i, a] * nstar[a, j]
            h[i, j] = t
    return True


@numba.njit(cache=True)
def qp(g: np.ndarray, a: np.ndarray, c: np.ndarray, b: np.ndarray, meq: int,
       d: np.ndarray, lam: np.ndarray, w: np.ndarray) -> int:  # pragma: no cover - compiled
    """Goldfarb–Idnani: ``min ½dᵀGd + aᵀd`` s.t. ``c[i]·d = b[i]`` (``i < meq``),
    ``c[i]·d ≥ b[i]`` (others).  Writes ``d`` and the multipliers ``lam`` (m,)
    (``≥ 0`` for inequalities; ``Σ lam_i c_i = Gd + a``).  ``w`` (9, n, n):
    scratch (a frame's solve calls this a dozen times: no allocations here).
    Returns OK, INFEASIBLE or NOT_CONVEX."""
    n = g.shape[0]
    m = c.shape[0]
    ginv = w[0]
    if not _inverse_spd(g, ginv, w[1], w[2]):
        return NOT_CONVEX
    for i in range(n):
        t = 0.0
        for k in range(n):
            t -= ginv[i, k] * a[k]
        d[i] = t
    active = np.empty(n, np.int64)
    u = np.zeros(n + 1)
    sign = np.ones(m)
    done = np.zeros(m, np.bool_)  # equalities added (or dependent and met)
    nstar = w[1]
    h = w[2]
    z = w[3, 0]
    r = w[3, 1]
    q = 0
    scale = 0.0
    for i in range(m):
        scale = max(scale, abs(b[i]))
    tol = 1e-12 * (1.0 + scale)
    for _outer in range(4 * (m + n) + 10):
        p = -1
        sp = 0.0
        for i in range(meq):
            if not done[i]:
                p = i
                break
        if p >= 0:
            s = -b[p]
            for k in range(n):
                s += c[p, k] * d[k]
            sign[p] = -1.0 if s > 0.0 else 1.0
            sp = sign[p] * s
        else:
            worst = -tol
            for i in range(meq, m):
                s = -b[i]
                for k in range(n):
                    s += c[i, k] * d[k]
                if s < worst:
                    worst = s
                    p = i
            if p < 0:
                break
            sp = worst
        unew = 0.0
        added = False
        for _inner in range(2 * n + 2):
            if not _projections(ginv, c, sign, active, q, nstar, h, w[4:]):
                return NOT_CONVEX
            zn = 0.0
            for i in range(n):
                t = 0.0
                for k in range(n):
                    t += h[i, k] * c[p, k]
                z[i] = sign[p] * t
                zn += z[i] * sign[p] * c[p, i]
            for j in range(q):
                t = 0.0
                for k in range(n):
                    t += nstar[j, k] * c[p, k]
                r[j] = sign[p] * t
            t1 = math.inf
            kdrop = -1
            for j in range(q):
                if active[j] >= meq and r[j] > _EPS:
                    ratio = u[j] / r[j]
                    if ratio < t1:
                        t1 = ratio
                        kdrop = j
            t2 = math.inf
            if zn > _EPS:
                t2 = -sp / zn
            elif p < meq and abs(sp) <= tol:
                done[p] = True  # dependent on the active set and already met
                added = True
                break
            t = min(t1, t2)
            if t == math.inf:
                return INFEASIBLE
            for j in range(q):
                u[j] -= t * r[j]
            unew += t
            if t2 < math.inf:
                for i in range(n):
                    d[i] += t * z[i]
                sp += t * zn
            if t2 <= t1:
                active[q] = p
                u[q] = unew
                q += 1
                if p < meq:
                    done[p] = True
                added = True
                break
            for j in range(kdrop, q - 1):  # drop the blocking inequality
                active[j] = active[j + 1]
                u[j] = u[j + 1]
            q -= 1
        if not added:
            return INFEASIBLE
    else:
        return INFEASIBLE
    lam[:] = 0.0
    for j in range(q):
        lam[active[j]] = sign[active[j]] * u[j]
    return OK


@numba.njit(cache=True)
def frame_setup(x: np.ndarray, lengths: np.ndarray, root: np.ndarray, handle: np.ndarray,
                last_pos: np.ndarray, last_contact: np.ndarray, has_last: bool, hold: bool,
                contact_tol: float, anchor: np.ndarray, pull: np.ndarray,
                contact: np.ndarray) -> bool:  # pragma: no cover - compiled
    """The frame's contact set, drag anchors and pull directions (see
    :mod:`station.brush.solver`, steps 1–2); returns whether any joint touches."""
    n = lengths.shape[0]
    pred, _f, _j = chain(x, lengths, root, handle)
    touching = False
    for j in range(n):
        t = pred[j, 2] <= contact_tol
        touching = touching or t
        contact[j] = 1.0 if (t and hold) else 0.0
        anchor[j, 0] = 0.0
        anchor[j, 1] = 0.0
        pull[j, 0] = 0.0
        pull[j, 1] = 0.0
    if not has_last:
        for j in range(n):
            anchor[j, 0] = pred[j, 0]
            anchor[j, 1] = pred[j, 1]
        return touching
    for j in range(n):
        if contact[j] <= 0.0:
            continue
        if last_contact[j]:
            anchor[j, 0] = last_pos[j, 0]
            anchor[j, 1] = last_pos[j, 1]
        else:  # touched down during this frame: where its path crossed the plane
            z0, z1 = last_pos[j, 2], pred[j, 2]
            f = z0 / (z0 - z1) if z0 > z1 else 1.0
            anchor[j, 0] = last_pos[j, 0] + f * (pred[j, 0] - last_pos[j, 0])
            anchor[j, 1] = last_pos[j, 1] + f * (pred[j, 1] - last_pos[j, 1])
        if j == 0:
            sx, sy = root[0], root[1]
        else:
            sx, sy = last_pos[j - 1, 0], last_pos[j - 1, 1]
        vx, vy = sx - last_pos[j, 0], sy - last_pos[j, 1]
        norm = math.hypot(vx, vy)
        if norm > 1e-9:
            pull[j, 0] = vx / norm
            pull[j, 1] = vy / norm
    return touching


@numba.njit(cache=True)
def _rows(x: np.ndarray, lo: np.ndarray, hi: np.ndarray, z: np.ndarray, zg: np.ndarray,
          contact: np.ndarray, eqs: np.ndarray, cmat: np.ndarray,
          bvec: np.ndarray) -> None:  # pragma: no cover - compiled
    """The QP's constraint rows at ``x``: held heights (equalities) first, then the
    free heights, then the bounds (``c·d ≥ b``)."""
    n = z.shape[0]
    nv = x.shape[0]
    row = 0
    for k in range(eqs.shape[0]):
        j = eqs[k]
        for a in range(nv):
            cmat[row, a] = zg[j, a]
        bvec[row] = -z[j]
        row += 1
    for j in range(n):
        if contact[j] > 0.0:
            continue
        for a in range(nv):
            cmat[row, a] = zg[j, a]
        bvec[row] = -z[j]
        row += 1
    for a in range(nv):
        cmat[row, :] = 0.0
        cmat[row, a] = 1.0
        bvec[row] = lo[a] - x[a]
        row += 1
        cmat[row, :] = 0.0
        cmat[row, a] = -1.0
        bvec[row] = x[a] - hi[a]
        row += 1


@numba.njit(cache=True)
def _violation(z: np.ndarray, contact: np.ndarray, rho: np.ndarray) -> float:
    # pragma: no cover - compiled
    """``Σ ρ_j`` times each height's violation (``|z|`` held, ``max(-z, 0)`` free)."""
    v = 0.0
    for j in range(z.shape[0]):
        v += rho[j] * (abs(z[j]) if contact[j] > 0.0 else max(-z[j], 0.0))
    return v


@numba.njit(cache=True)
def _feasible(z: np.ndarray, contact: np.ndarray, tol: float) -> bool:
    # pragma: no cover - compiled
    for j in range(z.shape[0]):
        v = abs(z[j]) if contact[j] > 0.0 else -z[j]
        if not v <= tol:  # NaN is not feasible
            return False
    return True


@numba.njit(cache=True)
def _x_close(x: np.ndarray, xo: np.ndarray, xtol: float) -> bool:  # pragma: no cover
    """NLopt's relative x test: every ``|Δx_i| < xtol·(|x_i|+|xo_i|)/2`` or no change."""
    for a in range(x.shape[0]):
        dx = abs(x[a] - xo[a])
        if not (dx < xtol * 0.5 * (abs(x[a]) + abs(xo[a])) or x[a] == xo[a]):
            return False
    return True


@numba.njit(cache=True)
def sqp(x: np.ndarray, lo: np.ndarray, hi: np.ndarray, lengths: np.ndarray,
        stiffness: np.ndarray, rest: np.ndarray, root: np.ndarray, handle: np.ndarray,
        contact: np.ndarray, anchor: np.ndarray, pull: np.ndarray, mu_n: np.ndarray,
        c_eta: float, k_eta: float, max_evals: int, xtol: float, ftol: float,
        ctol: float, stats: np.ndarray) -> int:  # pragma: no cover - compiled
    """Minimise the spine's energy from ``x`` (2n,) in place: joints in ``contact``
    held at ``z = 0``, the others ``z ≥ 0``, the angles within ``[lo, hi]``.

    The iteration follows Kraft's SLSQP as NLopt runs it, so that both find the
    same local minimum (a touch-down may have two: the tip sticking at its anchor or
    sliding): ``B₀ = I``; ℓ1 merit with Powell's penalties; a step is accepted when
    the merit falls by a tenth of its predicted decrease, else shortened to the
    quadratic fit's minimum (at least a tenth), accepted anyway after ten tries; a
    direction that does not descend resets ``B`` (five times at most).  It stops,
    as NLopt does, after a line search that changes the energy by less than
    ``ftol`` or no angle by ``xtol`` relative, once a point within ``ctol`` of the
    constraints was seen; ``x`` is then the lowest-energy such point.  ``stats``
    (2,) gets the evaluations and the iterations.  Returns a status (OK, …).
    """
    n = lengths.shape[0]
    nv = 2 * n
    m = n + 2 * nv
    neq = 0
    for j in range(n):
        if contact[j] > 0.0:
            neq += 1
    eqs = np.empty(neq, np.int64)
    k = 0
    for j in range(n):
        if contact[j] > 0.0:
            eqs[k] = j
            k += 1
    g = np.empty(nv)
    z = np.empty(n)
    zg = np.empty((n, nv))
    g1 = np.empty(nv)
    z1 = np.empty(n)
    zg1 = np.empty((n, nv))
    x0 = x.copy()
    xprev = x.copy()
    best = x.copy()
    bmat = np.eye(nv)
    cmat = np.zeros((m, nv))
    bvec = np.empty(m)
    d = np.empty(nv)
    lam = np.empty(m)
    rho = np.zeros(n)
    s = np.empty(nv)
    y = np.empty(nv)
    bs = np.empty(nv)
    work = np.empty((9, nv, nv))
    e = evaluate(x, g, z, zg, lengths, stiffness, rest, root, handle, contact, anchor, pull,
                 mu_n, c_eta, k_eta)
    evals = 1
    fbest = math.inf
    if math.isfinite(e) and _feasible(z, contact, ctol):
        fbest = e
        best[:] = x
    fprev = math.inf
    status = BUDGET
    it = 0
    resets = 0
    while evals < max_evals:
        it += 1
        _rows(x, lo, hi, z, zg, contact, eqs, cmat, bvec)
        st = qp(bmat, g, cmat, bvec, neq, d, lam, work)
        if st != OK:
            status = st
            break
        # Powell's penalties, then the merit's directional derivative
        row = 0
        for k in range(neq):
            j = eqs[k]
            lj = abs(lam[row])
            rho[j] = max(lj, 0.5 * (rho[j] + lj))
            row += 1
        for j in range(n):
            if contact[j] > 0.0:
                continue
            lj = abs(lam[row])
            rho[j] = max(lj, 0.5 * (rho[j] + lj))
            row += 1
        viol = _violation(z, contact, rho)
        t0 = e + viol
        slope = -viol
        for a in range(nv):
            slope += g[a] * d[a]
        if not slope < 0.0:
            resets += 1
            if resets > 5:
                status = NO_PROGRESS
                break
            bmat[:, :] = 0.0
            for a in range(nv):
                bmat[a, a] = 1.0
            continue
        x0[:] = x
        alpha = 1.0
        h3 = slope
        e1 = 0.0
        for line in range(1, 12):
            h3 *= alpha
            for a in range(nv):
                d[a] *= alpha
                x[a] = x0[a] + d[a]
            e1 = evaluate(x, g1, z1, zg1, lengths, stiffness, rest, root, handle, contact,
                          anchor, pull, mu_n, c_eta, k_eta)
            evals += 1
            if math.isfinite(e1) and e1 < fbest and _feasible(z1, contact, ctol):
                fbest = e1
                best[:] = x
            h1 = e1 + _violation(z1, contact, rho) - t0
            if h1 <= h3 / 10.0 or line > 10 or evals >= max_evals:
                break
            alpha = max(h3 / (2.0 * (h3 - h1)), 0.1)
        if not math.isfinite(e1) or evals >= max_evals:
            break
        # damped BFGS on the Lagrangian's gradient, the QP's multipliers at both ends
        for a in range(nv):
            s[a] = d[a]
            y[a] = g1[a] - g[a]
        row = 0
        for k in range(neq):
            j = eqs[k]
            for a in range(nv):
                y[a] -= lam[row] * (zg1[j, a] - zg[j, a])
            row += 1
        for j in range(n):
            if contact[j] > 0.0:
                continue
            for a in range(nv):
                y[a] -= lam[row] * (zg1[j, a] - zg[j, a])
            row += 1
        sbs = 0.0
        sy = 0.0
        for a in range(nv):
            t = 0.0
            for b2 in range(nv):
                t += bmat[a, b2] * s[b2]
            bs[a] = t
            sbs += s[a] * t
            sy += s[a] * y[a]
        if sy < 0.2 * sbs:
            th = 0.8 * sbs / (sbs - sy)
            for a in range(nv):
                y[a] = th * y[a] + (1.0 - th) * bs[a]
            sy = 0.2 * sbs
        if sy > 1e-300 and sbs > 1e-300:
            for a in range(nv):
                for b2 in range(nv):
                    bmat[a, b2] += y[a] * y[b2] / sy - bs[a] * bs[b2] / sbs
        e = e1
        g[:] = g1
        z[:] = z1
        zg[:, :] = zg1
        if fprev < math.inf and fbest < math.inf and (
                abs(e - fprev) < ftol or _x_close(x, xprev, xtol)):
            status = OK
            break
        fprev = e
        xprev[:] = x
    if status == OK and fbest < math.inf:
        x[:] = best
    elif status == OK:
        status = NO_PROGRESS
    stats[0] = evals
    stats[1] = it
    return status


@numba.njit(cache=True)
def solve_frame(x_last: np.ndarray, lo: np.ndarray, hi: np.ndarray, lengths: np.ndarray,
                stiffness: np.ndarray, rest: np.ndarray, root: np.ndarray, handle: np.ndarray,
                last_pos: np.ndarray, last_contact: np.ndarray, has_last: bool, hold: bool,
                contact_tol: float, buckle: float, mu: float, c_eta: float, k_eta: float,
                max_evals: int, xtol: float, ftol: float, ctol: float, x: np.ndarray,
                anchor: np.ndarray, pull: np.ndarray, contact: np.ndarray,
                stats: np.ndarray) -> int:  # pragma: no cover - compiled
    """One frame of :class:`~station.brush.solver.SpineSolver` in one call: the
    contact set, anchors and pulls (:func:`frame_setup`), the warm start ``x``
    (``x_last`` within the bounds, buckled when straight and touching), and
    :func:`sqp`.  ``x``, ``anchor``, ``pull``, ``contact`` are written for the
    caller (and NLopt, should this decline); ``stats[2]`` is 1 when ``x`` is the
    buckled start.  Returns sqp's status."""
    touching = frame_setup(x_last, lengths, root, handle, last_pos, last_contact, has_last,
                           hold, contact_tol, anchor, pull, contact)
    nv = x.shape[0]
    big = 0.0
    for a in range(nv):
        x[a] = min(max(x_last[a], lo[a]), hi[a])
        big = max(big, abs(x[a]))
    stats[2] = 0
    if touching and big < buckle:
        for a in range(1, nv, 2):
            x[a] += buckle
        stats[2] = 1
    mu_n = np.empty(contact.shape[0])
    for j in range(contact.shape[0]):
        mu_n[j] = mu * contact[j]
    x0 = x.copy()
    status = sqp(x, lo, hi, lengths, stiffness, rest, root, handle, contact, anchor, pull,
                 mu_n, c_eta, k_eta, max_evals, xtol, ftol, ctol, stats)
    if status != OK:
        x[:] = x0  # the start, for NLopt
    return status
