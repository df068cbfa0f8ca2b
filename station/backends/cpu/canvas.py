"""``CpuCanvas``: the reference model in fused, parallel numba sweeps.

State handling, operations, rendering, stats and tiles are the reference backend's
(:class:`~station.backends.numpy_canvas.NumpyCanvas`); only the step is new
(:mod:`station.backends.cpu.step`).
"""

from __future__ import annotations

from typing import Any

import numba

from station.backends.cpu import step as cpu_step
from station.backends.cpu import traffic
from station.backends.numpy_canvas import NumpyCanvas
from station.canvas import operations

_THREADS = int(getattr(numba.config, "NUMBA_NUM_THREADS", 1))


class CpuCanvas(NumpyCanvas):
    """The three-layer model on the CPU: same passes and maths as the reference, fused
    into ten sweeps, rows in parallel on all cores (numba ``prange``).

    Same arguments as :class:`NumpyCanvas`.
    """

    renderer = f"cpu (numba {numba.__version__}, {_THREADS} threads)"

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # the step's scratch is made with the canvas, not in its first step: at 512x512
        # its ~25 MB of zeroed fields cost that step ~7 ms, the first touch of a stroke
        self._scratch()
        # and so are the pages of the state's fields that only a step writes first (the
        # blank state's other fields are copies, written when made): the first step paid
        # a page fault per 4 KiB of them (see cpu_step.Scratch)
        st = self._state  # a blank sheet: these are zeros
        for a in (st.q, st.wet_area):
            a.fill(0)

    def _scratch(self) -> cpu_step.Scratch:
        st = self._state
        slots = max(len(st.slots), 1)
        sc: cpu_step.Scratch | None = getattr(self, "_scratch_fields", None)
        if sc is None or not sc.fits(st.height, st.width, slots):
            sc = cpu_step.Scratch(st.height, st.width, max(slots, 2))
            self._scratch_fields = sc
        return sc

    def step(self, dt: float | None = None) -> None:
        self._cells_last = cpu_step.step(self._state, self._scratch(), dt)
        if self._state.step_count % operations.FOLD_EVERY == 0:
            operations.fold_accumulators(self._state)

    def bytes_per_cell_step(self) -> int:
        """Honest bytes per simulated cell and step of the fused sweeps (see traffic.py)."""
        slots = max(len(self._state.slots), 1)
        prm = self._state.params
        finv, fdry = prm.standing_front()
        front = (1 if fdry > 0 else 0) if finv > 0 else -1  # as gl.traffic.front_mode
        # pass 3 levels a height of its own (step_region's do_pr): prep copies nothing
        levelled = (prm.flow_outward > 0 and prm.wet_blur > 0) or prm.paper_relief > 0
        return traffic.bytes_per_cell_step(slots, prm.jacobi_iters, prm.wet_hold > 0, front,
                                           levelled)
