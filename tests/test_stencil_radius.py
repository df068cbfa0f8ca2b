"""The stencil radius of one step, measured: the halo width of the distributed canvas.

A point perturbation of every field of a fully wet canvas must not change any cell
farther than ``reference.stencil_radius(params)`` after one step. A new model term
that reaches farther (a blurred mask, a wider kernel) fails here until
``STENCIL_RADIUS_EXTRA`` is raised, and the distributed canvas would otherwise give
a result different from one process.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from station.backends.numpy_canvas import NumpyCanvas
from station.canvas import reference
from station.canvas.params import SimParams
from station.canvas.profiles import get_profile

N = 72
C = N // 2


def _params(iters: int) -> SimParams:
    # strong coupling: with the profile's small k = nu dt, a perturbation fades below
    # float32 resolution after two or three Jacobi hops and the probe would see less
    return dataclasses.replace(get_profile("watercolor").params, jacobi_iters=iters,
                               viscosity=30.0, nu_w=30.0, nu_p=30.0, cap_diffusion=3.0)


def _wet_canvas(iters: int, seed: int) -> NumpyCanvas:
    prm = _params(iters)
    cv = NumpyCanvas(N, N, params=prm, tiling=False, seed=seed)
    rng = np.random.default_rng(seed)
    st = cv.live_state
    st.slot_of("French Ultramarine")
    st.slot_of("Burnt Umber")
    st.w[...] = rng.uniform(0.05, 1.0, (N, N)).astype(np.float32) * np.float32(prm.w_max)
    st.wc[...] = rng.uniform(0.0, 0.5, (N, N)).astype(np.float32) * st.capacity()
    vm = np.float32(prm.v_max)
    st.vx[...] = rng.uniform(-1, 1, (N, N)).astype(np.float32) * vm
    st.vy[...] = rng.uniform(-1, 1, (N, N)).astype(np.float32) * vm
    st.p[:2] = rng.uniform(0, 0.4, (2, N, N)).astype(np.float32)
    st.q[:2] = rng.uniform(0, 0.4, (2, N, N)).astype(np.float32)
    # short and dry cells: the limiters, closed faces and edge evaporation take part
    u = rng.random((N, N))
    st.w[u < 0.3] = np.float32(0.5 * prm.w_min)
    st.w[u < 0.1] = 0
    return cv


def _reach(iters: int, seed: int) -> int:
    """Largest Chebyshev distance from the centre of a cell changed by the perturbation."""
    a = _wet_canvas(iters, seed)
    b = _wet_canvas(iters, seed)
    sb = b.live_state
    for f in (sb.w, sb.wc, sb.vx, sb.vy, sb.p[0], sb.p[1], sb.q[0], sb.q[1]):
        f[C, C] *= np.float32(0.5)
    sb.vx[C, C] = -sb.vx[C, C]
    a.step()
    b.step()
    sa = a.live_state
    diff = np.zeros((N, N), bool)
    for name in ("w", "wc", "vx", "vy", "p", "q", "evaporated"):
        x, y = getattr(sa, name), getattr(sb, name)
        d = x != y
        diff |= d.any(axis=0) if d.ndim == 3 else d
    ys, xs = np.nonzero(diff)
    return int(np.max(np.maximum(np.abs(ys - C), np.abs(xs - C))))


@pytest.mark.parametrize("iters", [1, 4])
def test_one_step_reaches_no_farther_than_the_declared_radius(iters: int) -> None:
    radius = reference.stencil_radius(_params(iters))
    reach = max(_reach(iters, seed) for seed in (2, 3, 4))
    assert reach <= radius, f"one step reaches {reach} cells, the declared radius is {radius}"
    # the probe is sensitive: it sees the whole Jacobi chain (velocity: 1 + n, then the
    # face fluxes of pass 6). The bound is wider (n + 6) because the limiters and the
    # edge terms act only where cells run short or dry, which one probe rarely lines up.
    assert reach >= iters + 2, (reach, radius)
