"""``GLCanvas``: the three-layer canvas on the GPU (moderngl compute shaders).

The step runs the passes of ``station/canvas/reference.py`` (the contract) as
compute programs in ``shaders/``, fused where the maths allows without
changing it (see docs/gpu.md for the mapping):

===================  =====================================================
program              reference passes
===================  =====================================================
``prep``             wet mask, diffusion-controller beta_c, 1 advect_velocity
``jacobi`` x n       Jacobi iterations of 2, 4 and 5 at once
``limit``            end of 2, 3 water_height_and_boundary, limiters of 4/5
``diffuse_apply``    donor-limited fluxes of 4 diffuse_water, 5 diffuse_pigment
``advect_limit``     6 advect_water_and_pigment: s_out, s_in
``advect_apply``     6: limited face fluxes
``evap_surface``     7 evaporate, 8 surface_exchange, 9a absorption
``capillary_dry``    9b capillary diffusion, 9c evaporation, 10 dry_cells
``tile_update``      tiles.update_tiles (TTL countdown, renewal)
===================  =====================================================

Dirty tiles live entirely on the GPU: ``tile_list`` builds each step's list of
tiles (the active ones and their neighbours) and the indirect dispatch size, so
the step loop never reads anything back.  Sources, ``render`` run on the GPU;
``dry``, ``new_layer``, ``clear`` and ``set_profile`` (rare UI actions) move the
state to a :class:`CanvasState`, apply the reference operation and move it back
(lossless).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from station.canvas import operations, tiles
from station.canvas.palette import Palette
from station.canvas.paper import make_paper
from station.canvas.params import CanvasInputError, SimParams
from station.canvas.profiles import get_profile, profile_palette
from station.canvas.state import DEFAULT_SLOTS, CanvasState, check_size
from station.canvas.stats import CanvasStats, canvas_stats
from station.glkit.context import GLUnavailable, create_context, query_limits
from station.glkit.shaderlib import compile_compute
from station.render.km import band_matrix, km_coefficients, render_bands, white_filler

from . import textures as tx
from .passes import (
    _B_ADDED,
    _B_MARK,
    _B_TTL,
    GLStepPasses,
    _set,
    param_constants,
)
from .traffic import bytes_per_cell_step, floats_per_program, front_mode, shelters

if TYPE_CHECKING:
    import moderngl

F32 = np.float32

#: Rows of its tile's column each blur_x invocation blurs, the settings GLCanvas takes.
BLUR_ROWS = (1, 2, 4, 8)
_CPU_RASTERIZERS = ("llvmpipe", "softpipe", "swrast")
#: Bytes of the indirect-dispatch buffer: the passes' (x, y, tiles) groups, the cell count
#: (tile_list.comp's Args), then blur_x's (x, y, tiles) groups.
ARGS_BYTES = 28


def default_blur_rows(renderer: str) -> int:
    """Rows each blur_x invocation blurs on this driver (how the work is split, not what is
    computed): 4 on a CPU rasterizer, where a pass pays its invocations' id and tile mapping
    once per vector of lanes and blur_x is a short loop over rows (800x600 wash on llvmpipe:
    blur_x about 8.5 -> 5.5 ms CPU, docs/gpu.md), 1 on a GPU, which wants many invocations."""
    return 4 if is_cpu_rasterizer(renderer) else 1


def is_cpu_rasterizer(renderer: str) -> bool:
    """Whether GL_RENDERER ``renderer`` names a CPU rasterizer (Mesa's llvmpipe, softpipe).
    The per-driver choices it makes (``GLCanvas`` ``blur_rows``, ``slot_constants``) split
    or declare the work differently; what a pass computes is the same on every driver."""
    name = renderer.lower()
    return any(r in name for r in _CPU_RASTERIZERS)


#: Programs compiled per canvas: name -> (file, extra defines).
_PROGRAMS: dict[str, tuple[str, dict[str, object]]] = {
    "prep": ("prep.comp", {}),
    "jacobi": ("jacobi.comp", {}),
    "limit": ("limit.comp", {}),
    "diffuse_apply": ("diffuse_apply.comp", {}),
    "advect_limit": ("advect_limit.comp", {}),
    "advect_apply": ("advect_apply.comp", {}),
    "evap_surface": ("evap_surface.comp", {"SLOT_CONST": 0}),
    "capillary_dry": ("capillary_dry.comp", {}),
    "tile_list": ("tile_list.comp", {}),
    "tile_update": ("tile_update.comp", {}),
    "tile_mark": ("tile_mark.comp", {}),
    "sources": ("sources.comp", {}),
    "fold": ("fold.comp", {}),
    "render_km": ("render.comp", {"RENDER_KM": 1}),
    "render_gouache": ("render.comp", {}),
}

# SSBO binding points (tiles.glsl, tile_*.comp, capillary_dry.comp, sources.comp)


class GLCanvas(GLStepPasses):
    """The canvas backend on OpenGL 4.3+ compute shaders (see module docstring).

    Args mirror :class:`~station.backends.numpy_canvas.NumpyCanvas`; in addition
    ``ctx`` (an existing moderngl context) and ``gl_backend`` (moderngl's
    context backend, ``"egl"`` by default).  Raises :class:`GLUnavailable` when
    no OpenGL 4.3 context can be made.
    """

    def __init__(self, width: int, height: int, profile: str = "watercolor", seed: int = 0,
                 *, tiling: bool = True, n_slots: int = DEFAULT_SLOTS,
                 params: SimParams | None = None, paper: str | None = None,
                 palette: Palette | None = None, ctx: moderngl.Context | None = None,
                 gl_backend: str | None = None, blur_rows: int | None = None,
                 slot_constants: bool | None = None) -> None:
        check_size(width, height)
        prof = get_profile(profile)
        prm = params if params is not None else prof.params
        preset = paper if paper is not None else prof.paper

        h = make_paper(preset, height, width, seed)
        blank = CanvasState.blank(width, height, prm, h, profile=prof.name,
                                  paper_preset=preset, seed=seed,
                                  palette=palette or profile_palette(prof),
                                  n_slots=n_slots, tiling=tiling)
        self._own_ctx = ctx is None
        self.ctx = create_context(gl_backend) if ctx is None else ctx
        self.limits = query_limits(self.ctx)
        self.renderer = self.limits.renderer
        if blur_rows is None:
            blur_rows = default_blur_rows(self.renderer)
        if blur_rows not in BLUR_ROWS:
            raise CanvasInputError(f"blur_rows must be one of {BLUR_ROWS}, not {blur_rows!r}",
                                   "blur_rows")
        self.blur_rows = int(blur_rows)
        self.slot_constants = (is_cpu_rasterizer(self.renderer) if slot_constants is None
                               else bool(slot_constants))
        self._shape: tuple[int, int, int, int, int] | None = None
        self._programs: dict[str, Any] = {}  # compile_compute's programs
        self._pass_seconds = None
        self.load_state(blank)

    # ------------------------------------------------------------ allocation
    def _allocate(self, width: int, height: int, n_slots: int, tile: int,
                  bands: int = 3) -> None:
        """(Re)create textures, buffers and programs for this canvas geometry."""
        if max(width, height) > self.limits.max_texture_size:
            raise CanvasInputError(
                f"canvas {width}x{height} exceeds this GPU's texture size "
                f"{self.limits.max_texture_size}", "--size")
        self._release_resources()
        ctx = self.ctx
        self.width, self.height = int(width), int(height)
        self.n_slots = int(n_slots)
        self.npl = -(-self.n_slots // 4)
        self.tile = int(tile)
        self.tiles_x, self.tiles_y = -(-width // tile), -(-height // tile)
        self.ntiles = self.tiles_x * self.tiles_y
        # work-group shape: fits the tile, within the implementation's limits
        lx = min(32, tile, self.limits.max_work_group_size[0])
        ly = max(1, min(8, tile, self.limits.max_work_group_invocations // lx,
                        self.limits.max_work_group_size[1]))
        self.lx, self.ly = lx, ly
        self.groups = (-(-tile // lx), -(-tile // ly))
        # blur_x: each invocation blurs every blur_rows-th row of its tile (blur_x.comp)
        self.blur_groups = (self.groups[0], -(-tile // (ly * self.blur_rows)))
        if self.ntiles > min(self.limits.max_work_group_count[2], 1 << 23):  # tiles.glsl
            raise CanvasInputError(f"too many tiles ({self.ntiles}) for this GPU", "--size")
        self.bands = int(bands)
        self.nrl = -(-self.bands // 4)
        self.f = tx.allocate(ctx, width, height, self.npl, self.nrl)
        # scratch: aux = (v1, w) right-hand sides; jv = (xv, xw, wb) iterate, then limiters;
        # jd = pigment iterate, then pigment limiters
        self.aux = ctx.texture((width, height), 4, dtype="f4")
        self.jv = [ctx.texture((width, height), 4, dtype="f4") for _ in range(2)]
        self.jd = [ctx.texture_array((width, height, self.npl), 4, dtype="f4")
                   for _ in range(2)]
        self.srcw = ctx.texture((width, height), 4, dtype="f4")
        self.pr = ctx.texture((width, height), 1, dtype="f4")  # pass 3's levelled height P
        self.bx = ctx.texture((width, height), 1, dtype="f4")  # pass 3's mask blurred along x
        # the not-dry paper blurred along x (standing_front_dry; written only with it on)
        self.dx = ctx.texture((width, height), 1, dtype="f4")
        self.srcp = ctx.texture_array((width, height, self.npl), 4, dtype="f4")
        self.rgb = ctx.texture((width, height), 4, dtype="f4")
        n = self.ntiles
        self.b_list = ctx.buffer(reserve=4 * n)
        self.b_alive = ctx.buffer(reserve=4 * n)
        self.b_ttl = ctx.buffer(reserve=4 * n)
        self.b_prev = ctx.buffer(reserve=4 * n)
        self.b_mark = ctx.buffer(reserve=4 * n)
        # the passes' indirect dispatch (x, y, tiles), the cell count, blur_x's (x, y, tiles)
        self.b_args = ctx.buffer(reserve=ARGS_BYTES)
        self.b_all = ctx.buffer(np.arange(n, dtype=np.uint32).tobytes())
        self.src_groups = (-(-width // 16), -(-height // 16))
        self.nacc = 1 + 4 * self.npl
        self.b_added = ctx.buffer(reserve=8 * self.nacc * self.src_groups[0]
                                  * self.src_groups[1])
        self.b_folded = ctx.buffer(reserve=8 * self.src_groups[0] * self.src_groups[1])
        # TILES_X: tile_cell divides by a constant (a division by a uniform is 8 scalar
        # divisions a vector on llvmpipe, in every pass)
        self._defines: dict[str, object] = {
            "NPL": self.npl, "TILE": tile, "LX": lx, "LY": ly, "NBANDS": self.bands,
            "TILES_X": self.tiles_x, "SIZE_X": self.width, "SIZE_Y": self.height}
        self._compile_programs(self.tiling)
        self._shape = (width, height, n_slots, tile, self.bands)

    def _compile_programs(self, tiling: bool) -> None:
        """Compile every program for the tiling mode: with tiling on the passes read their
        tile from the list (``TILE_LIST``), with it off the dispatch's z is the tile
        (tiles.glsl), which spares llvmpipe a gather in every lane of every pass."""
        for prog in self._programs.values():
            prog.release()
        self._defines["TILE_LIST"] = 1 if tiling else 0
        self._defines.update(self._param_consts)
        self._programs = {name: self._compile(fname, extra)
                          for name, (fname, extra) in _PROGRAMS.items()}
        # blur_x, jacobi_first (and front, shelter): compiled per blur at the step
        self._pressure_taps = ((), -1, -1, False)
        self._slot_key = None  # evap_surface with the slots' constants: compiled at the step
        self._tile_list_mode = bool(tiling)

    def _compile(self, fname: str, extra: Mapping[str, object]) -> moderngl.ComputeShader:
        """Compile ``shaders/fname`` for this canvas geometry (its uniforms set)."""
        prog = cast("moderngl.ComputeShader",
                    compile_compute(self.ctx, fname, {**self._defines, **extra}))
        _set(prog, "u_size", (self.width, self.height))
        _set(prog, "u_tiles", (self.tiles_x, self.tiles_y))
        _set(prog, "u_ntiles", self.ntiles)
        return prog

    def _release_resources(self) -> None:
        for name in ("aux", "pr", "bx", "dx", "srcw", "srcp", "rgb", "b_list", "b_alive", "b_ttl",
                     "b_prev", "b_mark", "b_args", "b_all", "b_added", "b_folded"):
            obj = getattr(self, name, None)
            if obj is not None:
                obj.release()
        for name in ("jv", "jd"):
            for obj in getattr(self, name, []):
                obj.release()
        for fld in getattr(self, "f", {}).values():
            for t in fld.textures:
                t.release()
        for prog in self._programs.values():
            prog.release()
        self._programs = {}

    def close(self) -> None:
        """Release every GPU object (and the context when this canvas made it)."""
        self._release_resources()
        self._shape = None
        if self._own_ctx and self.ctx is not None:
            self.ctx.release()
            self.ctx = None

    # ------------------------------------------------------------ state in/out
    def load_state(self, state: CanvasState) -> None:
        """Upload ``state`` completely (both textures of every ping-pong pair)."""
        st = state
        shape = (st.width, st.height, st.n_slots, int(st.params.tile_size),
                 st.r_composed.shape[-1])
        # the programs are compiled for the tiling mode and the parameters' constants
        self.tiling = st.tiling
        consts = param_constants(st.params, float(st.params.dt))
        self._param_key = None  # _set_step_uniforms checks the parameters again
        if shape != self._shape:
            self._param_consts = consts
            self._allocate(*shape)
        elif self._tile_list_mode != self.tiling or consts != self._param_consts:
            self._param_consts = consts
            self._compile_programs(self.tiling)
        f = self.f
        for t in f["vel"].textures:
            t.write(tx.pack_planes(st.vx, st.vy).tobytes())
        for t in f["water"].textures:
            t.write(tx.pack_planes(st.w, st.wc, st.evaporated, st.removed_w).tobytes())
        f["paper"].src.write(tx.pack_planes(st.h, st.mask, st.block, st.block_time).tobytes())
        f["fibre"].src.write(tx.pack_planes(st.fibre[0], st.fibre[1]).tobytes())
        self.fibre = st.fibre.copy()  # static: the state read back carries this copy
        self._fibred = bool(st.fibre.any())
        f["area"].src.write(np.ascontiguousarray(st.wet_area, np.float32).tobytes())
        for t in f["pig"].textures:
            t.write(tx.pack_stack(st.p, self.npl).tobytes())
        f["dep"].src.write(tx.pack_stack(st.q, self.npl).tobytes())
        f["rem"].src.write(tx.pack_stack(st.removed_p, self.npl).tobytes())
        rc = tx.pack_stack(np.moveaxis(st.r_composed, -1, 0), self.nrl)
        f["rcomp"].src.write(rc.tobytes())
        for fld in f.values():
            fld.cur = 0
        self.b_ttl.write(np.ascontiguousarray(st.tile_ttl, np.int32).tobytes())
        zeros = np.zeros(self.ntiles, np.uint32).tobytes()
        self.b_alive.write(zeros)
        self.b_prev.write(zeros)
        self.b_added.write(bytes(self.b_added.size))
        self.b_folded.write(bytes(self.b_folded.size))
        self.b_args.write(bytes(ARGS_BYTES))
        # metadata (everything that is not an array)
        self.params = st.params
        self.palette = st.palette
        self.profile = st.profile
        self.paper_preset = st.paper_preset
        self.seed = st.seed
        self.slots = list(st.slots)
        self.step_count = st.step_count
        self.sim_time = st.sim_time
        self.tiling = st.tiling
        self.water_added_base = float(st.water_added)
        self.evaporated_folded_base = float(st.evaporated_folded)
        self.pigment_added_base = dict(st.pigment_added)
        self.pigment_removed_past = dict(st.pigment_removed_past)
        self.pigment_dried = dict(st.pigment_dried)
        self.layers = [dict(d) for d in st.layers]
        self._renderer_kind = get_profile(st.profile).renderer
        self._cells_cpu = 0

    def _read(self, tex: moderngl.Texture | moderngl.TextureArray) -> bytes:
        return bytes(tex.read())

    def state(self) -> CanvasState:
        """A complete copy of the canvas state, read back from the GPU."""
        self.ctx.memory_barrier()  # all bits: texture and buffer reads follow
        f = self.f
        hh, ww, npl = self.height, self.width, self.npl
        vx, vy = tx.unpack_planes(self._read(f["vel"].src), 2, hh, ww)
        w, wc, evap, rem_w = tx.unpack_planes(self._read(f["water"].src), 4, hh, ww)
        h, mask, block, block_time = tx.unpack_planes(self._read(f["paper"].src), 4, hh, ww)
        p = tx.unpack_stack(self._read(f["pig"].src), self.n_slots, npl, hh, ww)
        q = tx.unpack_stack(self._read(f["dep"].src), self.n_slots, npl, hh, ww)
        rp = tx.unpack_stack(self._read(f["rem"].src), self.n_slots, npl, hh, ww)
        rc = np.moveaxis(tx.unpack_stack(self._read(f["rcomp"].src), self.bands, self.nrl,
                                         hh, ww), 0, -1)
        (area,) = tx.unpack_planes(self._read(f["area"].src), 1, hh, ww)
        ttl = np.frombuffer(self.b_ttl.read(), np.int32).reshape(self.tiles_y, self.tiles_x)
        added = np.frombuffer(self.b_added.read(), np.float64).reshape(-1, self.nacc).sum(0)
        pig_added = dict(self.pigment_added_base)
        for k, name in enumerate(self.slots):
            pig_added[name] = pig_added.get(name, 0.0) + float(added[1 + k])
        return CanvasState(
            width=ww, height=hh, params=self.params, palette=self.palette,
            profile=self.profile, paper_preset=self.paper_preset, seed=self.seed,
            vx=vx, vy=vy, w=w, wc=wc, h=h, mask=mask, block=block, block_time=block_time,
            p=p, q=q, r_composed=np.ascontiguousarray(rc), evaporated=evap, removed_w=rem_w,
            removed_p=rp, tile_ttl=ttl.copy(), slots=list(self.slots), fibre=self.fibre.copy(),
            wet_area=area.copy(),  # a writable array (one channel: frombuffer view)
            step_count=self.step_count, sim_time=self.sim_time, tiling=self.tiling,
            water_added=self.water_added_base + float(added[0]),
            evaporated_folded=self.evaporated_folded_base + float(
                np.frombuffer(self.b_folded.read(), np.float64).sum()),
            pigment_added=pig_added,
            pigment_removed_past=dict(self.pigment_removed_past),
            pigment_dried=dict(self.pigment_dried),
            layers=[dict(d) for d in self.layers],
        )

    def paper_water(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The fluid water height ``w``, the mask, the capillary water ``wc`` and the paper
        height ``h`` (float32 (H, W)), read back from the GPU: two of the state's textures,
        not all of it (a freshly dipped brush's first touch-down reads them once to let its
        bead run out into a film or damp paper, :mod:`station.brush.bead`)."""
        self.ctx.memory_barrier()
        hh, ww = self.height, self.width
        water = tx.unpack_planes(self._read(self.f["water"].src), 4, hh, ww)
        paper = tx.unpack_planes(self._read(self.f["paper"].src), 4, hh, ww)
        return water[0], paper[1], water[1], paper[0]

    def forget_wet_memory(self, y0: int, x0: int, drier: np.ndarray) -> None:
        """Drop the faded wet-area memory (``wet_area < 1``) where ``drier`` (a bool window
        at row ``y0``, column ``x0``) is set: a fresh load run out into a damp wash starts a
        new wet phase (:meth:`station.sim.player.SessionPlayer._fresh_wet_phase`). Reads the
        one-float mask texture back and rewrites only the window."""
        self.ctx.memory_barrier()
        hh, ww = self.height, self.width
        y1, x1 = min(y0 + drier.shape[0], hh), min(x0 + drier.shape[1], ww)
        if y0 < 0 or x0 < 0 or y0 >= y1 or x0 >= x1:
            return
        tex = self.f["area"].src
        area = np.frombuffer(self._read(tex), np.float32).reshape(hh, ww)
        win = np.array(area[y0:y1, x0:x1], np.float32)
        win[(win < np.float32(1.0)) & drier[:y1 - y0, :x1 - x0]] = np.float32(0.0)
        # ``area`` is a plain 2-D texture (no layers); Field.src is typed for arrays too,
        # whose write takes a 3-D viewport
        box: tuple[int, int, int, int] = (x0, y0, x1 - x0, y1 - y0)
        tex.write(np.ascontiguousarray(win).tobytes(), viewport=box)  # type: ignore[arg-type]

    # ------------------------------------------------------------ sources
    def _slot_of(self, name: str) -> int:
        canonical = self.palette.get(name).name
        if canonical in self.slots:
            return self.slots.index(canonical)
        if len(self.slots) >= self.n_slots:
            raise CanvasInputError(
                f"the active layer already holds {self.n_slots} pigments "
                f"({', '.join(self.slots)}); start a new layer to use {canonical!r}", "pigment")
        self.slots.append(canonical)
        return len(self.slots) - 1

    def _placed(self, a: np.ndarray, y0: int, x0: int, what: str
                ) -> tuple[tuple[int, int, int, int], np.ndarray] | None:
        """Clip source ``a`` placed at (y0, x0): ((cy0, cy1, cx0, cx1), clipped array)."""
        arr = np.asarray(a, dtype=F32)
        if arr.ndim != 2:
            raise CanvasInputError(f"source {what} must be a 2-D array", "add_sources")
        if not np.isfinite(arr).all():
            raise CanvasInputError(f"source {what} holds non-finite values", "add_sources")
        hh, ww = arr.shape
        cy0, cx0 = max(y0, 0), max(x0, 0)
        cy1, cx1 = min(y0 + hh, self.height), min(x0 + ww, self.width)
        if cy1 <= cy0 or cx1 <= cx0:
            return None
        return (cy0, cy1, cx0, cx1), arr[cy0 - y0:cy1 - y0, cx0 - x0:cx1 - x0]

    def add_sources(self, dw: np.ndarray | None = None,
                    dp: Mapping[str, np.ndarray] | None = None,
                    dvx: np.ndarray | None = None, dvy: np.ndarray | None = None,
                    *, y0: int = 0, x0: int = 0) -> None:
        """Spec step 1 on the GPU (reference ``operations.add_sources``)."""
        dp = dict(dp or {})
        placed_p = {}
        for name, arr in dp.items():
            self.palette.get(name)
            pl = self._placed(arr, y0, x0, f"dp[{name!r}]")
            if pl is not None:
                if (pl[1] < 0).any():
                    raise CanvasInputError("pigment sources must be >= 0", "add_sources")
                if pl[1].any():  # an all-zero source takes no slot (as the reference)
                    placed_p[name] = pl
        placed_w = self._placed(dw, y0, x0, "dw") if dw is not None else None
        if placed_w is not None and (placed_w[1] < 0).any():
            raise CanvasInputError("water sources must be >= 0", "add_sources")
        placed_vx = self._placed(dvx, y0, x0, "dvx") if dvx is not None else None
        placed_vy = self._placed(dvy, y0, x0, "dvy") if dvy is not None else None
        new = {self.palette.get(n).name for n in placed_p} - set(self.slots)
        if len(new) > self.n_slots - len(self.slots):
            raise CanvasInputError(
                f"the active layer holds {len(self.slots)} of {self.n_slots} pigments; "
                "start a new layer for more", "pigment")
        rects = [pl[0] for pl in (placed_w, placed_vx, placed_vy, *placed_p.values())
                 if pl is not None]
        if not rects:
            return
        ry0 = min(r[0] for r in rects)
        ry1 = max(r[1] for r in rects)
        rx0 = min(r[2] for r in rects)
        rx1 = max(r[3] for r in rects)
        eh, ew = ry1 - ry0, rx1 - rx0
        srcw = np.zeros((eh, ew, 4), F32)
        for ch, pl in ((0, placed_w), (1, placed_vx), (2, placed_vy)):
            if pl is not None:
                (a0, a1, b0, b1), arr = pl
                srcw[a0 - ry0:a1 - ry0, b0 - rx0:b1 - rx0, ch] = arr
        self.srcw.write(srcw.tobytes(), viewport=(0, 0, ew, eh))
        if placed_p:
            srcp = np.zeros((self.npl * 4, eh, ew), F32)
            for name, ((a0, a1, b0, b1), arr) in placed_p.items():
                k = self._slot_of(name)
                srcp[k, a0 - ry0:a1 - ry0, b0 - rx0:b1 - rx0] += arr
            data = np.ascontiguousarray(srcp.reshape(self.npl, 4, eh, ew).transpose(0, 2, 3, 1))
            self.srcp.write(data.tobytes(), viewport=(0, 0, 0, ew, eh, self.npl))
        prm = self.params
        prog = self._programs["sources"]
        _set(prog, "u_origin", (rx0, ry0))
        _set(prog, "u_extent", (ew, eh))
        _set(prog, "u_wmax", prm.w_max)
        _set(prog, "u_vmax", prm.v_max)
        _set(prog, "u_has_dw", int(placed_w is not None))
        _set(prog, "u_has_dvx", int(placed_vx is not None))
        _set(prog, "u_has_dvy", int(placed_vy is not None))
        _set(prog, "u_has_dp", int(bool(placed_p)))
        f = self.f
        self._bind(1, self.srcw, True, False)
        self._bind(2, self.srcp, True, False)
        self._bind(3, f["water"].src, True, True)
        self._bind(4, f["pig"].src, True, True)
        self._bind(5, f["vel"].src, True, True)
        self._bind(6, f["paper"].src, True, False)
        self.b_added.bind_to_storage_buffer(_B_ADDED)
        prog.run(-(-ew // 16), -(-eh // 16), 1)
        self._barrier()
        # dirty tiles: those in which a source array is nonzero (reference tiles.mark_nonzero)
        touched = np.zeros((self.tiles_y, self.tiles_x), bool)
        for pl in (placed_w, *placed_p.values(), placed_vx, placed_vy):
            if pl is not None:
                self._touch_nonzero(touched, *pl)
        marks = np.flatnonzero(touched).astype(np.uint32)
        if marks.size:
            mark = self._programs["tile_mark"]
            _set(mark, "u_ttl", prm.tile_ttl_steps())
            _set(mark, "u_count", int(marks.size))
            self.b_mark.write(marks.tobytes())
            self.b_mark.bind_to_storage_buffer(_B_MARK)
            self.b_ttl.bind_to_storage_buffer(_B_TTL)
            mark.run(-(-int(marks.size) // 64), 1, 1)
            self._barrier()

    def _touch_nonzero(self, touched: np.ndarray, rect: tuple[int, int, int, int],
                       values: np.ndarray) -> None:
        """Flag the tiles in which ``values`` (placed at ``rect``) is nonzero."""
        nz = values != 0
        if not nz.any():
            return
        ts = self.tile
        cy0, cy1, cx0, cx1 = rect
        ty0, tx0 = cy0 // ts, cx0 // ts
        ty1, tx1 = (cy1 - 1) // ts + 1, (cx1 - 1) // ts + 1
        pad = np.zeros(((ty1 - ty0) * ts, (tx1 - tx0) * ts), bool)
        pad[cy0 - ty0 * ts:cy1 - ty0 * ts, cx0 - tx0 * ts:cx1 - tx0 * ts] = nz
        hit = pad.reshape(ty1 - ty0, ts, tx1 - tx0, ts).any(axis=(1, 3))
        touched[ty0:ty1, tx0:tx1] |= hit

    # ------------------------------------------------------------ the step
    def step(self, dt: float | None = None) -> None:
        """One simulation step on the GPU (no read-back)."""
        d = self._check_dt(dt)
        self._set_step_uniforms(d)
        self._begin_step()
        self._pass_prep()
        self._pass_diffusion()
        self._pass_advect()
        self._pass_evap_surface()
        self._pass_capillary_dry()
        self._end_step(d)

    # ------------------------------------------------------------ operations
    def _via_state(self, op: Callable[[CanvasState], object]) -> None:
        st = self.state()
        op(st)
        self.load_state(st)

    def dry(self) -> None:
        self._via_state(operations.dry)

    def new_layer(self) -> None:
        self.dry()
        # the dried canvas per render band (r_composed), from the read-back state by the
        # reference: the GPU render keeps only RGB, and a layer change is rare
        kind = self._renderer_kind
        self._via_state(lambda st: operations.new_layer(st, render_bands(st, kind)))

    def clear(self) -> None:
        self._via_state(operations.clear)

    def set_profile(self, name: str) -> None:
        self._via_state(lambda st: operations.set_profile(st, name))

    def set_tiling(self, on: bool) -> None:
        """Switch dirty tiles on or off (the result does not change)."""
        def switch(st: CanvasState) -> None:
            st.tiling = bool(on)
            if on:
                tiles.activate_all_live(st)

        self._via_state(switch)

    def stats(self) -> CanvasStats:
        return canvas_stats(self.state(), self.renderer)

    def save(self, path: str) -> None:
        self.state().save(path)

    def load(self, path: str) -> None:
        self.load_state(CanvasState.load(path))

    # ------------------------------------------------------------ rendering
    def render(self) -> np.ndarray:
        """Linear reflectance float32 (H, W, 3) in [0, 1], computed on the GPU."""
        self.render_texture()
        self.ctx.memory_barrier()  # all bits: the read-back follows image stores
        out = np.frombuffer(self._read(self.rgb), F32).reshape(self.height, self.width, 4)
        return np.ascontiguousarray(out[..., :3])

    def render_texture(self) -> moderngl.Texture:
        """Render into the RGBA32F texture ``self.rgb`` (linear reflectance) and return
        it, with no read-back: a window sharing this context samples it directly."""
        kind = self._renderer_kind
        prog = self._programs["render_gouache" if kind == "gouache" else "render_km"]
        n = 4 * self.npl
        nb = self.bands
        pigs = [self.palette.get(s) for s in self.slots]
        kk = np.zeros((n, nb), F32)
        ss = np.ones((n, nb), F32)
        if pigs:
            k_used, s_used = km_coefficients(pigs, nb)
            kk[:len(pigs)], ss[:len(pigs)] = k_used, s_used
        # the filler as the reference takes it (the palette's Titanium White, per band)
        white_k, white_s = white_filler(self.palette, nb)
        _set(prog, "u_white", self.params.gouache_white)
        _set(prog, "u_white_K", [float(v) for v in white_k])
        _set(prog, "u_white_S", [float(v) for v in white_s])
        _set(prog, "u_used", len(pigs))
        _set(prog, "u_K", [float(v) for v in kk.ravel()])
        _set(prog, "u_S", [float(v) for v in ss.ravel()])
        _set(prog, "u_to_rgb", [float(v) for v in band_matrix(nb).ravel()])
        _set(prog, "u_opaque", max(self.params.gouache_opaque, 1e-6))
        f = self.f
        self._bind(1, f["pig"].src, True, False)
        self._bind(2, f["dep"].src, True, False)
        self._bind(3, f["rcomp"].src, True, False)
        self._bind(4, self.rgb, False, True)
        prog.run(-(-self.width // 16), -(-self.height // 16), 1)
        self._barrier()
        return self.rgb

    # ------------------------------------------------------------ benchmarks
    def sync(self) -> None:
        """Wait until the GPU has finished everything submitted so far."""
        self.ctx.finish()

    def take_cells(self) -> int:
        """Cells simulated since the last call (the tile list's count; resets it)."""
        if not self.tiling:
            n, self._cells_cpu = self._cells_cpu, 0
            return n
        self.ctx.memory_barrier()  # all bits: the read-back follows SSBO atomics
        data = np.frombuffer(self.b_args.read(), np.uint32)
        n = int(data[3])
        self.b_args.write(np.array([0], np.uint32).tobytes(), offset=12)
        return n

    def bytes_per_cell_step(self) -> int:
        """Honest bytes per cell-step: the passes process the RGBA pigment layers in use
        (4 slots each), so those slots are counted, not the 8 the textures hold."""
        layers = -(-len(self.slots) // 4)
        prm = self.params
        return bytes_per_cell_step(4 * layers, int(prm.jacobi_iters), prm.wet_hold > 0,
                                   front_mode(*prm.standing_front()),
                                   shelters(prm.damp_exposure, prm.flow_outward,
                                            prm.wet_blur))

    def bytes_per_cell_by_pass(self) -> dict[str, int]:
        """:meth:`bytes_per_cell_step` per program (the names of ``take_pass_times``)."""
        layers = -(-len(self.slots) // 4)
        prm = self.params
        return {name: 4 * n for name, n in floats_per_program(
            4 * layers, int(prm.jacobi_iters), prm.wet_hold > 0,
            front_mode(*prm.standing_front()),
            shelters(prm.damp_exposure, prm.flow_outward, prm.wet_blur)).items()}


__all__ = ["GLCanvas", "GLUnavailable"]
