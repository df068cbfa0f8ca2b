"""Honest memory traffic of one cell-step of the ``cpu`` backend, per fused sweep.

Counted like ``station/backends/gl/traffic.py``: the values each sweep must read and
write per cell, each field once per sweep (a stencil's neighbours come from cache), for
a wet cell (the cell of a wash); ``slots`` = pigment slots in use (the sweeps process
only those), ``jacobi_iters`` = n >= 1. Fields are float32 (4 bytes) except the two
scratch flags, the wet mask and the open flag, which are uint8 (1 byte). The scratch
copies the sweeps make (wet mask, w, p, beta_c, open flag, iterates, limiters) are
counted: they are real traffic. Not scratch fields any more (issue 26 item 1): the
capacity ``c`` (recomputed from ``h`` where read, the reference's float32 expression)
and the masked velocity (pass 1 reads the state's ``vx``/``vy`` at its corners and the
wet mask there).
"""

from __future__ import annotations

FLOAT = 4
FLAG = 1


def bytes_per_sweep(slots: int, jacobi_iters: int, wet_memory: bool = False,
                    front: int = -1, levelled: bool = True) -> dict[str, int]:
    """Per sweep: bytes read + written per cell for one step; ``wet_memory``: the
    profile keeps a wet-area memory (``SimParams.wet_hold > 0``); ``front``: the standing
    gate's front factor (``gl.traffic.front_mode``: -1 off, 0 on, 1 on with its dry-paper
    term), which moves beta_c, the dispersion and pass 3's levelled height out of prep
    (``kernels._front_row``: in advect_jacobi1's rows with one Jacobi iteration, else a
    sweep of its own, ``kernels.standing_front``); ``levelled``: pass 3 levels a height
    of its own (``flow_outward`` or ``paper_relief``; else it levels the padded copy of w,
    ``w0``, which prep then writes)."""
    s = int(slots)
    n = max(int(jacobi_iters), 1)
    f, b = FLOAT, FLAG
    sweeps = {
        # read w, wc, mask, h, block, block_time, fibre(2) and vx, vy (the fibres'
        # dispersion on beta_c: every profile has it), p(S), w0 again (second sweep);
        # write w0, bc, mbx (the x half of the wet-area blur), p0(S); flags wet, opn
        "prep (wet mask, copies, diffusion controller, row blur)":
            f * ((11 + s) + (3 + s)) + b * 2,
        # read vx, vy (state), w0, mbx, h, wet; write v1(2), pr; with n >= 2 also
        # water/pigment iteration 1: read bc, p0(S), write xw, xp(S) (with n = 1
        # limit_diffuse computes it in its row ring)
        "advect_jacobi1 (pass 1, pass 3's levelled height, water/pigment Jacobi 1)":
            (f * ((6 + s) + (4 + s)) + b) if n >= 2 else f * (5 + 3) + b,
        # one temporally blocked sweep for all remaining iterations (the intermediate
        # iterates live in per-chunk buffers in cache): read wet, bc, v1(2), xv(2), w0, xw,
        # p0(S), xp(S) once; write the last xv(2), xw, xp(S) once
        "jacobi_blocked (velocity 1..n-1, water/pigment 2..n)":
            (f * ((7 + 2 * s) + (3 + s)) + b) if n >= 2 else 0,
        # one sweep (fused.limit_diffuse_fused): read wet, bc, v1(2), xv(2), w0, xw, pr,
        # p0(S), xp(S); write v3(2), w2, p2(S) (the donor limiters stay in a row ring).
        # With n = 1 the iterates xw, xp are Jacobi iteration 1 computed in a row ring
        # from w0, p0 (not read), and xv is v1 (the same field, read once)
        "limit_diffuse (last velocity iteration, pass 3, passes 4/5 limiters and fluxes)":
            (f * ((8 + 2 * s) + (3 + s)) + b) if n >= 2 else f * ((6 + s) + (3 + s)) + b,
        # one sweep (fused.advect_fused): read wet, v3(2), w2, p2(S); write w3, p(S)
        "advect (pass 6 limiters and fluxes)": f * ((3 + s) + (1 + s)) + b,
        # one sweep (fused.evap_cap_fused): read wet, opn, w3, h, wc, evaporated, p(S),
        # q(S), v3(2); write w, wc, evaporated, p(S), q(S), vx, vy (sat stays in a row
        # ring; a wet cell deposits nothing: the pigment loop of pass 10 runs only on rows
        # with dry cells)
        "evap_capillary (passes 7, 8, 9a, 9b, 9c, 10)":
            f * ((7 + 2 * s) + (5 + 2 * s)) + b * 2,
    }
    if front >= 0:
        # prep runs without the dispersion and without beta_c (the front factor's sweep
        # writes it once): fibre(2), vx, vy, block, block_time not read, bc not written;
        # with the dry-paper term it writes the x half of that blur, dbx (wc and h it
        # reads anyway)
        sweeps["prep (wet mask, copies, diffusion controller, row blur)"] -= \
            f * 7 - (f if front > 0 else 0)
        # the front factor (kernels._front_row): read mbx, wet, w0, h, block, block_time,
        # fibre(2), vx, vy, dbx (with the dry-paper term); write pr, bc
        fr = f * ((9 + (1 if front > 0 else 0)) + 2) + b
        aj = "advect_jacobi1 (pass 1, pass 3's levelled height, water/pigment Jacobi 1)"
        if n >= 2:
            # a sweep of its own (kernels.standing_front): advect_jacobi1's pigment
            # iteration reads beta_c of the next rows; advect_jacobi1 without do_pr: mbx,
            # h not read, pr not written
            sweeps[aj] = f * ((4 + s) + (3 + s)) + b
            sweeps["standing_front (the standing gate's front factor, pass 3's levelled "
                   "height)"] = fr
        else:
            # folded into advect_jacobi1's rows: the wet mask and the velocity are read
            # once for pass 1 and the front factor; pass 1 adds its writes, v1(2)
            sweeps[aj] = fr + f * 2
    if n == 1 and (levelled or front >= 0):
        # no w0/p0 copies (step.copy): prep's contact line reads the state's w through a
        # ring of padded rows (w read once, not w0 again, p not at all) and writes neither
        # copy; the sweeps after it read the state's w and p where they read the copies
        sweeps["prep (wet mask, copies, diffusion controller, row blur)"] -= f * (2 + 2 * s)
    if wet_memory:
        # prep's own loop per span reads the wet area and writes M = max(area, own)
        sweeps["prep (wet mask, copies, diffusion controller, row blur)"] += f * 2
        # its fade at the end of pass 10 runs in evap_capillary's rows (fused._cd_row), on
        # the row's w, wc and open flag while they are in cache: read area, write area
        sweeps["evap_capillary (passes 7, 8, 9a, 9b, 9c, 10)"] += f * 2
    return sweeps


def bytes_per_cell_step(slots: int, jacobi_iters: int, wet_memory: bool = False,
                        front: int = -1, levelled: bool = True) -> int:
    """Bytes of honest memory traffic per simulated cell and step."""
    return sum(bytes_per_sweep(slots, jacobi_iters, wet_memory, front, levelled).values())
