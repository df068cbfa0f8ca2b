"""The ten passes of one reference step (``reference.py`` documents the maths and is the
contract the cpu and GL backends follow)."""

from __future__ import annotations

import numpy as np

from station.canvas.params import SimParams
from station.canvas.state import CanvasState
from station.canvas.stencils import (
    _ONE,
    _ZERO,
    F32,
    apply_fluxes,
    capacity,
    implicit_diffusion,
    neighbour_sum,
    open_faces,
)


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
                              prm: SimParams, dt: float | None = None,
                              fibre: np.ndarray | None = None,
                              gate: np.ndarray | None = None
                              ) -> tuple[np.ndarray, np.ndarray]:
    """Pass 3: blend in the water-height velocity and the tilt's gravity, then the
    no-penetration boundary (``dt`` defaults to ``prm.dt``). With ``fibre_permeability``
    and the fibre texture ``fibre`` (2, H, W) the height term along each axis is
    multiplied by ``base + gain * fibre[axis]`` (``prm.fibre_channel()``): the film's
    levelling flow runs along the paper's fibres. With ``gate`` (per cell, in [0, 1]:
    :func:`standing_gate`) by ``(1 - gate a) + (gate gain) fibre[axis]`` instead: the
    channel faded in where the gate is open (``a`` = ``fibre_permeability``)."""
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
    dx = w_e - w_w
    dy = w_s - w_n
    if prm.fibre_permeability > 0 and fibre is not None:
        base, gain = (F32(v) for v in prm.fibre_channel())
        if gate is not None:
            bg = _ONE - gate * F32(prm.fibre_permeability)
            gg = gate * gain
            dx = dx * (bg + gg * fibre[0])
            dy = dy * (bg + gg * fibre[1])
        else:
            dx = dx * (base + gain * fibre[0])
            dy = dy * (base + gain * fibre[1])
    nvx = oi * vx + oh * (g * dx)
    nvy = oi * vy + oh * (g * dy)
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
             speed: np.ndarray | None = None,
             standing: np.ndarray | None = None) -> np.ndarray:
    """Diffusion-controller cell value beta_c (1 free, 0 blocked), in [0, 1] without
    fibre dispersion. With ``fibre_dispersivity > 0``, the fibre texture ``fibre`` (2, H, W)
    and the water's speed ``speed`` (H, W) [cell/s] it is multiplied by
    ``1 + gd * (max(fibre[0], fibre[1]) * speed)``, ``gd = fibre_dispersivity / nu_p``:
    where water moves through fibre channels the pigment it carries disperses along them
    (``D = alpha |v|``, Bear's hydrodynamic dispersion); still water is untouched.
    With ``standing`` (per cell: :func:`standing_gate` of ``w``, ``standing_depth``) the
    ``1`` of that factor (or beta_c itself without dispersion) is ``1 - drop * standing``,
    ``drop = 1 - standing_nu_p / nu_p``: the pigment's own diffusion is ``standing_nu_p``
    in standing water, the fibre dispersion unchanged."""
    if prm.block_fade > 0:
        age = np.clip((F32(sim_time) - block_time) / F32(prm.block_fade), _ZERO, _ONE)
    else:
        age = np.ones_like(block)
    eff = block + (_ONE - block) * age
    paper = _ONE - F32(prm.block_paper) * (_ONE - h)
    beta = np.minimum(paper, eff).astype(F32)
    gd = F32(prm.fibre_dispersion_gain())
    own = _ONE if standing is None else _ONE - F32(prm.standing_diffusion()[1]) * standing
    if gd > 0 and fibre is not None and speed is not None:
        beta = beta * (own + gd * (np.maximum(fibre[0], fibre[1]) * speed))
    elif standing is not None:
        beta = beta * own
    return beta.astype(F32)


def standing_gate(w: np.ndarray, inv_depth: float) -> np.ndarray:
    """``smoothstep(min(w * inv_depth, 1))`` (float32, ``t t (3 - 2 t)``; ``w >= 0``): 0 on
    paper without standing water, 1 where it stands ``1 / inv_depth`` deep or more."""
    t = np.minimum(w * F32(inv_depth), _ONE)
    return (t * t) * (F32(3.0) - F32(2.0) * t)


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
def slot_properties(state: CanvasState, lift: bool = True
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """beta, gamma, delta per slot (float32 (S,)); free slots: beta 1, gamma 0, delta 0.

    With ``lift`` (pass 8's exchange) beta is the staining over ``lift_gain``, rounded to
    float32 once here so every backend divides by the same number; ``lift=False`` gives
    the pigments' own staining (the removal tools)."""
    n = state.n_slots
    beta = np.ones(n, F32)
    gamma = np.zeros(n, F32)
    delta = np.zeros(n, F32)
    gain = float(state.params.lift_gain) if lift else 1.0
    for k, pig in enumerate(state.slot_pigments()):
        beta[k], gamma[k], delta[k] = pig.beta / gain, pig.gamma, pig.delta
    return beta, gamma, delta
