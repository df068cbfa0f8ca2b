"""``NumpyCanvas``: the reference backend (``reference.py`` passes on a CanvasState)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from station.canvas import operations, reference, tiles
from station.canvas.palette import Palette
from station.canvas.paper import make_paper
from station.canvas.params import SimParams
from station.canvas.profiles import get_profile, profile_palette
from station.canvas.state import DEFAULT_SLOTS, CanvasState, check_size
from station.canvas.stats import CanvasStats, canvas_stats
from station.render.km import render_bands, render_state


def floats_per_cell_step(slots: int, jacobi_iters: int,
                         wet_memory: bool = False) -> dict[str, int]:
    """Honest memory traffic of the reference per cell-step, in float32 values per pass.

    Each field a pass must read or write counts once (a stencil's neighbours come from
    cache), for a wet cell; ``slots`` = pigment slots in use (the reference skips the
    others), ``jacobi_iters`` = n; ``wet_memory``: the profile keeps a wet-area memory
    (``SimParams.wet_hold > 0``).
    """
    s, n = int(slots), int(jacobi_iters)
    passes = {
        "wet mask (read w, wc, mask; write wet)": 4,
        "advect_velocity (read v, wet; write v)": 5,
        "diffuse_velocity (n x: read x, u, wet; write x)": 7 * n,
        "water_height_and_boundary (read v, w, wet; write v)": 6,
        "diffuse_water (n x: read x, u, wet; write x; fluxes: read x, u, wet; write w)":
            4 * n + 4,
        "blocking (read h, block, block_time; write beta_c)": 4,
        "diffuse_pigment (n x: read x, u, beta_c, wet; write x; fluxes likewise)":
            (3 * s + 2) * n + 3 * s + 2,
        "advect limiters (read v, w, p, wet; write s_out, s_in)": s + 6,
        "advect apply (read v, w, p, wet, s_out, s_in; write w, p)": 2 * s + 8,
        "evaporate (read w, evaporated; write both)": 4,
        "surface_exchange (read p, q, w, h, wet; write p, q)": 4 * s + 3,
        "capillary (read w, wc, h, mask, evaporated; write w, wc, evaporated)": 8,
        "dry_cells (read w, p, q, v, evaporated; write them)": 4 * s + 8,
    }
    if wet_memory:
        passes["wet_memory (read wet_area, own; write wet_area)"] = 3
        passes["wet_area_update (read w, wc, wet_area; write wet_area)"] = 4
    return passes


class NumpyCanvas:
    """The whole three-layer model in NumPy, float32, vectorised, no global state.

    Args:
        width, height: canvas size in cells.
        profile: paint profile name (``watercolor``, ``gouache``, ``ink``).
        seed: paper seed.
        tiling: simulate only dirty tiles (default True); ``tiles`` is an alias.
        n_slots: pigment slots per layer (default 8).
        params: parameters replacing the profile's (tests, calibration).
        paper: paper preset replacing the profile's.
        palette: palette replacing the packaged one.
    """

    renderer = "numpy"

    def __init__(self, width: int, height: int, profile: str = "watercolor", seed: int = 0,
                 *, tiling: bool = True, tiles: bool | None = None,
                 n_slots: int = DEFAULT_SLOTS,
                 params: SimParams | None = None, paper: str | None = None,
                 palette: Palette | None = None) -> None:
        check_size(width, height)
        if tiles is not None:
            tiling = tiles
        prof = get_profile(profile)
        prm = params if params is not None else prof.params
        preset = paper if paper is not None else prof.paper

        h = make_paper(preset, height, width, seed)
        self._state = CanvasState.blank(width, height, prm, h, profile=prof.name,
                                        paper_preset=preset, seed=seed,
                                        palette=palette or profile_palette(prof),
                                        n_slots=n_slots, tiling=tiling)
        self._renderer_kind = prof.renderer
        self._cells_last = 0

    # ------------------------------------------------------------------ protocol
    @property
    def width(self) -> int:
        return self._state.width

    @property
    def height(self) -> int:
        return self._state.height

    @property
    def params(self) -> SimParams:
        return self._state.params

    @property
    def live_state(self) -> CanvasState:
        """The state itself (no copy): for tests and tools that mutate fields."""
        return self._state

    def add_sources(self, dw: np.ndarray | None = None,
                    dp: Mapping[str, np.ndarray] | None = None,
                    dvx: np.ndarray | None = None, dvy: np.ndarray | None = None,
                    *, y0: int = 0, x0: int = 0) -> None:
        operations.add_sources(self._state, dw, dp, dvx, dvy, y0=y0, x0=x0)

    def step(self, dt: float | None = None) -> None:
        self._cells_last = reference.step(self._state, dt)
        if self._state.step_count % operations.FOLD_EVERY == 0:
            operations.fold_accumulators(self._state)

    def dry(self) -> None:
        operations.dry(self._state)

    def new_layer(self) -> None:
        operations.dry(self._state)
        composed = render_bands(self._state, self._renderer_kind)
        operations.new_layer(self._state, composed)

    def clear(self) -> None:
        operations.clear(self._state)

    def set_profile(self, name: str) -> None:
        operations.set_profile(self._state, name)
        self._renderer_kind = get_profile(name).renderer

    def render(self) -> np.ndarray:
        return render_state(self._state, self._renderer_kind)

    def state(self) -> CanvasState:
        return self._state.copy()

    def load_state(self, state: CanvasState) -> None:
        self._state = state.copy()
        self._renderer_kind = get_profile(state.profile).renderer

    def stats(self) -> CanvasStats:
        return canvas_stats(self._state, self.renderer)

    # ------------------------------------------------------------------ extras
    def set_tiling(self, on: bool) -> None:
        """Switch dirty tiles on or off (the result does not change)."""
        self._state.tiling = bool(on)
        if on:
            tiles.activate_all_live(self._state)

    def sync(self) -> None:
        """Wait for pending work (none: NumPy is synchronous); for benchmarks."""

    def close(self) -> None:
        """Release resources (none held)."""

    def cells_last_step(self) -> int:
        """Cells simulated by the last step (area of the tile boxes, or the canvas)."""
        return self._cells_last

    def bytes_per_cell_step(self) -> int:
        """Honest bytes of memory traffic per simulated cell and step (see above)."""
        slots = max(len(self._state.slots), 1)
        prm = self._state.params
        return 4 * sum(floats_per_cell_step(slots, prm.jacobi_iters,
                                            prm.wet_hold > 0).values())

    def save(self, path: str) -> None:
        self._state.save(path)

    def load(self, path: str) -> None:
        self.load_state(CanvasState.load(path))
