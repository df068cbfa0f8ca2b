"""Honest memory traffic of one cell-step: the fields each pass must read and write.

Counted in float32 values per cell (x 4 bytes), each field once per pass (a
stencil's neighbours come from cache), only the fields the maths needs (a
channel a texture carries along but the pass does not need is not counted),
for a wet cell (the cell of a wash).  ``slots`` is the number of pigment slots
the backend processes per cell: the GL passes always process all ``4 * NPL``
slots, the NumPy reference only the slots in use.
"""

from __future__ import annotations


def floats_per_cell_step(slots: int, jacobi_iters: int, wet_memory: bool = False,
                         front: int = -1, shelter: bool = False) -> dict[str, int]:
    """Per pass: float32 values read + written per cell for one step; ``wet_memory``:
    the profile keeps a wet-area memory (``SimParams.wet_hold > 0``); ``front``: the
    standing gate's front factor (``SimParams.standing_front``; -1 off, 0 at every
    front, 1 over dry paper); ``shelter``: the damp exposure's pass (:func:`shelters`)."""
    s = int(slots)
    n = int(jacobi_iters)
    passes = {
        # read v(2), w, wc, h, mask, block, block_time; write aux = (v1(2), w) and the
        # first iterate jv = (v1(2), w, wb)
        "prep (wet, controller, advect_velocity)": 8 + 7,
        # pass 3's blur along x: read w, wc, mask (own wet, the neighbours from cache);
        # write bx
        "blur_x (pass 3's wet area blurred along x)": 3 + 1,
        # each iteration reads the iterate jv = (xv(2), xw, wb), the right-hand sides
        # (v1(2), w), p(S) and the pigment iterate xp(S) (= p in the first iteration);
        # writes jv(4) and xp(S).  The first iteration also forms pass 3's levelled height
        # from the w and wb it reads anyway: reads h and bx (the blur's neighbours come
        # from cache), writes P
        "jacobi (pass 3's levelled height; velocity, water, pigment)":
            (7 + s + 4 + s) + (2 + 1) + (n - 1) * (7 + 2 * s + 4 + s),
        # read jv(4), xp(S), w, P, p(S); write v(2), (xw, s_w, wb), s_p(S)
        "limit (height term, boundary, limiters)": (6 + 2 * s) + (5 + s),
        # read (xw, s_w, wb), xp(S), s_p(S), w, p(S); write w, p(S)
        "diffuse_apply": (4 + 3 * s) + (1 + s),
        # read v(2), wb, w, p(S); write (s_out, s_in, wb)
        "advect_limit": (4 + s) + 3,
        # read v(2), (s_out, s_in, wb), w, p(S); write w, p(S)
        "advect_apply": (6 + s) + (1 + s),
        # read w, wc, evaporated, h, mask, wb, p(S), q(S); write w, wc, evaporated, p, q
        "evap_surface (evaporate, surface_exchange, absorb)": (6 + 2 * s) + (3 + 2 * s),
        # read w, wc, evaporated, h, mask; write w, wc, evaporated (wet cell: no deposit)
        "capillary_dry (capillary diffusion/evaporation, dry_cells)": 5 + 3,
    }
    if wet_memory:
        # prep writes a wet cell's area (1); blur_x blurs the area instead of w, wc, mask;
        # capillary_dry writes a wet cell's area again (the fade reads it only on damp
        # paper)
        passes["prep (wet, controller, advect_velocity)"] += 1
        passes["blur_x (pass 3's wet area blurred along x)"] = 1 + 1
        passes["capillary_dry (capillary diffusion/evaporation, dry_cells)"] += 1
    if front >= 0:
        # read jv(4), bx, h, block, block_time, w, fibre(2), v(2) (the y blur's neighbours
        # from cache); write jv(4) and pass 3's levelled height P, which the first Jacobi
        # iteration then neither forms nor reads h and bx for (PR_DONE)
        passes["front (the standing gate's front factor on wb)"] = 14 + 4 + 1
        passes["jacobi (pass 3's levelled height; velocity, water, pigment)"] -= 2 + 1
    if front > 0:
        # blur_x also reads wc, h and writes dx; front.comp reads dx
        passes["blur_x (pass 3's wet area blurred along x)"] += 3
        passes["front (the standing gate's front factor on wb)"] += 1
    if shelter:
        # read wb, w, wc: a cell wet by its own water is done (a damp cell the front
        # reached also reads h and the blur's column, and may write wb and v1)
        passes["shelter (damp_exposure on wb)"] = 3
    return passes


def shelters(damp_exposure: float, flow_outward: float, wet_blur: float) -> bool:
    """``shelter`` of :func:`floats_per_cell_step`: shelter.comp runs (stencils.sheltered
    is on)."""
    return damp_exposure > 0 and flow_outward > 0 and wet_blur > 0


def bytes_per_cell_step(slots: int, jacobi_iters: int, wet_memory: bool = False,
                        front: int = -1, shelter: bool = False) -> int:
    """Bytes of honest memory traffic per simulated cell and step."""
    return 4 * sum(floats_per_cell_step(slots, jacobi_iters, wet_memory, front,
                                        shelter).values())


def front_mode(finv: float, fdry: float) -> int:
    """``front`` of :func:`floats_per_cell_step` from ``SimParams.standing_front()``."""
    return (1 if fdry > 0 else 0) if finv > 0 else -1


def floats_per_program(slots: int, jacobi_iters: int, wet_memory: bool = False,
                       front: int = -1, shelter: bool = False) -> dict[str, int]:
    """:func:`floats_per_cell_step` keyed by the program that runs each pass (``prep``,
    ``pressure``, ``jacobi`` (all its iterations), ...), the names
    ``GLCanvas.take_pass_times`` reports."""
    return {name.split()[0]: n
            for name, n in floats_per_cell_step(slots, jacobi_iters, wet_memory,
                                                front, shelter).items()}
