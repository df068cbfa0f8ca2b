"""Honest memory traffic of one cell-step: the fields each pass must read and write.

Counted in float32 values per cell (x 4 bytes), each field once per pass (a
stencil's neighbours come from cache), only the fields the maths needs (a
channel a texture carries along but the pass does not need is not counted),
for a wet cell (the cell of a wash).  ``slots`` is the number of pigment slots
the backend processes per cell: the GL passes always process all ``4 * NPL``
slots, the NumPy reference only the slots in use.
"""

from __future__ import annotations


def floats_per_cell_step(slots: int, jacobi_iters: int) -> dict[str, int]:
    """Per pass: float32 values read + written per cell for one step."""
    s = int(slots)
    n = int(jacobi_iters)
    passes = {
        # read v(2), w, wc, h, mask, block, block_time; write wet, beta_c, v1(2)
        "prep (wet, controller, advect_velocity)": 8 + 4,
        # first iteration: read wet, beta_c, v1(2), w, p(S); write xv(2), xw, xp(S)
        # later ones also read the previous iterate xv(2), xw, xp(S)
        "jacobi (velocity, water, pigment)": (6 + s + 3 + s) + (n - 1) * (9 + 2 * s + 3 + s),
        # read xv(2), xw, xp(S), w, p(S), wet, beta_c; write v(2), s_w, s_p(S)
        "limit (height term, boundary, limiters)": (6 + 2 * s) + (3 + s),
        # read xw, xp(S), s_w, s_p(S), w, p(S), wet, beta_c; write w, p(S)
        "diffuse_apply": (5 + 3 * s) + (1 + s),
        # read v(2), w, p(S), wet; write s_out, s_in
        "advect_limit": (4 + s) + 2,
        # read v(2), w, p(S), wet, s_out, s_in; write w, p(S)
        "advect_apply": (6 + s) + (1 + s),
        # read w, wc, evaporated, h, mask, wet, p(S), q(S); write w, wc, evaporated, p, q
        "evap_surface (evaporate, surface_exchange, absorb)": (6 + 2 * s) + (3 + 2 * s),
        # read w, wc, evaporated, h, mask; write w, wc, evaporated (wet cell: no deposit)
        "capillary_dry (capillary diffusion/evaporation, dry_cells)": 5 + 3,
    }
    return passes


def bytes_per_cell_step(slots: int, jacobi_iters: int) -> int:
    """Bytes of honest memory traffic per simulated cell and step."""
    return 4 * sum(floats_per_cell_step(slots, jacobi_iters).values())
