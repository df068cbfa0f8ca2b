"""Honest memory traffic of one cell-step of the ``cpu`` backend, per fused sweep.

Counted like ``station/backends/gl/traffic.py``: float32 values each sweep must read and
write per cell (x 4 bytes), each field once per sweep (a stencil's neighbours come from
cache), for a wet cell (the cell of a wash); ``slots`` = pigment slots in use (the
sweeps process only those), ``jacobi_iters`` = n >= 1. The scratch copies the sweeps
make (wet mask, w, p, beta_c, capacity, open flag, iterates, limiters) are counted: they
are real traffic.
"""

from __future__ import annotations


def floats_per_cell_step(slots: int, jacobi_iters: int) -> dict[str, int]:
    """Per sweep: float32 values read + written per cell for one step."""
    s = int(slots)
    n = max(int(jacobi_iters), 1)
    return {
        # read w, wc, mask, vx, vy, h, block, block_time, p(S), w0 again (second sweep);
        # write wet, w0, bc, vsx, vsy, c, opn, mbx (the x half of the wet-area blur), p0(S)
        "prep (wet mask, copies, diffusion controller, capacity, row blur)":
            (9 + s) + (8 + s),
        # read vsx, vsy, wet, w0, bc, mbx, h, p0(S); write v1(2), pr, xw, xp(S)
        "advect_jacobi1 (pass 1, pass 3's levelled height, water/pigment Jacobi 1)":
            (7 + s) + (4 + s),
        # one temporally blocked sweep for all remaining iterations (the intermediate
        # iterates live in per-chunk buffers in cache): read wet, bc, v1(2), xv(2), w0, xw,
        # p0(S), xp(S) once; write the last xv(2), xw, xp(S) once
        "jacobi_blocked (velocity 1..n-1, water/pigment 2..n)":
            ((8 + 2 * s) + (3 + s)) if n >= 2 else 0,
        # one sweep (fused.limit_diffuse_fused): read wet, bc, v1(2), xv(2), w0, xw, pr,
        # p0(S), xp(S); write v3(2), w2, p2(S) (the donor limiters stay in a row ring)
        "limit_diffuse (last velocity iteration, pass 3, passes 4/5 limiters and fluxes)":
            (9 + 2 * s) + (3 + s),
        # one sweep (fused.advect_fused): read wet, v3(2), w2, p2(S); write w3, p(S)
        "advect (pass 6 limiters and fluxes)": (4 + s) + (1 + s),
        # one sweep (fused.evap_cap_fused): read wet, w3, c, opn, h, wc, evaporated, p(S),
        # q(S), v3(2); write w, wc, evaporated, p(S), q(S), vx, vy (sat stays in a row ring;
        # a wet cell deposits nothing: the pigment loop of pass 10 runs only on rows with
        # dry cells)
        "evap_capillary (passes 7, 8, 9a, 9b, 9c, 10)": (9 + 2 * s) + (5 + 2 * s),
    }


def bytes_per_cell_step(slots: int, jacobi_iters: int) -> int:
    """Bytes of honest memory traffic per simulated cell and step."""
    return 4 * sum(floats_per_cell_step(slots, jacobi_iters).values())
