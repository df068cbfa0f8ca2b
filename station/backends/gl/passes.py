"""The GL step's passes: uniforms, dispatches and barriers of the compute programs that
run ``station/canvas/reference.py``'s passes (the mapping is in ``canvas.py``'s docstring);
:class:`GLStepPasses` is a mixin of :class:`station.backends.gl.canvas.GLCanvas`."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from station.canvas import operations, reference, stencils
from station.canvas.params import CanvasInputError, SimParams

if TYPE_CHECKING:
    import moderngl

    from station.backends.gl.textures import Field
    from station.canvas.palette import Palette

F32 = np.float32
# SSBO binding points (tiles.glsl, tile_*.comp, capillary_dry.comp, sources.comp)
_B_LIST, _B_ALIVE, _B_TTL, _B_PREV, _B_ARGS, _B_ADDED, _B_MARK, _B_FOLDED = 0, 1, 2, 3, 4, 5, 6, 7
# byte offset of blur_x's indirect dispatch (x, y, tiles) in the args buffer (canvas.ARGS_BYTES)
_ARGS_BLUR = 16
MAX_TAPS = 17
"""Most Gaussian taps the pressure blur (blur_x.comp, pressure.glsl) takes (wet_blur <= 4):
the tap loops unroll into one program per tap count."""


class GLStepPasses:
    """One step's passes on the canvas's textures (the attributes are the canvas's)."""

    ctx: Any  # released to None by GLCanvas.close
    params: SimParams
    sim_time: float
    step_count: int
    slots: list[str]
    npl: int
    tiling: bool
    _programs: dict[str, moderngl.ComputeShader]
    # (taps' bits, hold, front: -1 off, 0 every front, 1 over dry paper) of the blur programs
    _pressure_taps: tuple[tuple[int, ...], int, int, bool]
    _pass_seconds: dict[str, float] | None  # per-pass wall time while profiling, else None
    width: int
    height: int
    palette: Palette
    groups: tuple[int, int]
    blur_groups: tuple[int, int]
    src_groups: tuple[int, int]
    ntiles: int
    _cells_cpu: int
    f: dict[str, Field]
    aux: moderngl.Texture
    jv: list[moderngl.Texture]
    jd: list[moderngl.TextureArray]
    pr: moderngl.Texture
    bx: moderngl.Texture
    dx: moderngl.Texture
    rgb: moderngl.Texture
    b_list: moderngl.Buffer
    b_prev: moderngl.Buffer
    b_args: moderngl.Buffer
    b_all: moderngl.Buffer
    b_alive: moderngl.Buffer
    b_ttl: moderngl.Buffer
    b_folded: moderngl.Buffer

    # the canvas compiles (GLCanvas._compile: its context, its include path)
    _compile: Callable[[str, Mapping[str, object]], moderngl.ComputeShader]
    _compile_programs: Callable[[bool], None]
    _param_consts: dict[str, str]  # param_constants the programs were compiled with
    _param_key: tuple[SimParams, float | None] | None  # what _param_consts came from
    slot_constants: bool  # evap_surface takes the slots' values as constants (a driver's choice)
    _slot_key: tuple[int, ...] | None  # their bits in the evap_surface program, None: uniforms
    _fibred: bool  # the paper has fibre (load_state); without, pass 3's channel is off

    def _bind(self, unit: int, tex: moderngl.Texture | moderngl.TextureArray, read: bool,
              write: bool) -> None:
        tex.bind_to_image(unit, read=read, write=write)

    def _barrier(self) -> None:
        """Make image and SSBO writes (and the indirect dispatch size) visible to the next
        dispatch; uploads and read-backs are ordered by GL itself."""
        ctx = self.ctx
        ctx.memory_barrier(ctx.SHADER_IMAGE_ACCESS_BARRIER_BIT | ctx.SHADER_STORAGE_BARRIER_BIT
                           | ctx.COMMAND_BARRIER_BIT)

    def _slot_uniforms(self) -> dict[str, list[tuple[float, ...]]]:
        n = 4 * self.npl
        beta = np.ones(n, F32)
        gamma = np.zeros(n, F32)
        delta = np.zeros(n, F32)
        for k, name in enumerate(self.slots):
            pig = self.palette.get(name)
            # the reference's slot_properties: the staining over lift_gain, float32 once
            beta[k], gamma[k], delta[k] = (pig.beta / float(self.params.lift_gain), pig.gamma,
                                           pig.delta)
        dob = (delta / beta).astype(F32)

        def vec4s(a: np.ndarray) -> list[tuple[float, ...]]:
            return [tuple(float(x) for x in a[4 * i:4 * i + 4]) for i in range(self.npl)]

        return {"u_gamma": vec4s(gamma), "u_delta": vec4s(delta), "u_dob": vec4s(dob)}

    def _set_step_uniforms(self, dt: float) -> None:
        prm = self.params
        made_of = (prm, dt if dt == float(prm.dt) else None)
        if made_of != self._param_key:  # the same parameters object: no work a step
            self._param_key = made_of
            consts = param_constants(prm, made_of[1])
            if consts != self._param_consts:  # parameters set since load_state, another dt
                self._param_consts = consts
                self._compile_programs(self.tiling)
        slot_vals = self._slot_uniforms()
        if self.slot_constants:  # before any uniform is set: it may recompile evap_surface
            self._slot_program(slot_vals)
        p = self._programs
        _set(p["prep"], "u_dt", dt)
        _set(p["prep"], "u_sim_time", float(F32(self.sim_time)))
        hold = 1 if prm.wet_hold > 0 else 0
        taps = reference.gaussian_taps(prm.wet_blur) if prm.flow_outward > 0 else np.zeros(0, F32)
        if len(taps) > MAX_TAPS:
            raise CanvasInputError("wet_blur too large for the GL backend (at most 4)", "params")
        finv, fdry = prm.standing_front()
        self._blur_programs(taps, hold, (1 if fdry > 0 else 0) if finv > 0 and len(taps) else -1,
                            prm.damp_exposure > 0)
        if "front" in p:
            _set(p["front"], "u_sim_time", float(F32(self.sim_time)))
        kv, kw, kp = (float(F32(prm.viscosity * dt)), float(F32(prm.nu_w * dt)),
                      float(F32(prm.nu_p * dt)))
        layers = -(-len(self.slots) // 4)
        for prog in p.values():
            _set(prog, "u_layers", layers)
        for name in ("jacobi", "jacobi_first", "limit", "diffuse_apply"):
            _set(p[name], "u_kv", kv)
            _set(p[name], "u_kw", kw)
            _set(p[name], "u_kp", kp)
        _set(p["limit"], "u_tilt", [float(x) for x in reference.tilt_kick(prm, dt)])
        # paper without any fibre: pass 3's channel is off (reference.fibre_gate)
        _set(p["limit"], "u_fibred", 1.0 if self._fibred else 0.0)
        q4 = float(F32(0.25 * dt))
        for name in ("advect_limit", "advect_apply"):
            _set(p[name], "u_q4", q4)
        es = p["evap_surface"]
        _set(es, "u_e", float(F32(prm.evap_shallow() * dt)))
        _set(es, "u_rate", float(F32(prm.surface_rate * dt)))
        for key, val in slot_vals.items():
            _set(es, key, val)  # (the constants' program has none of them)
        _set(es, "u_absorb", float(F32(prm.alpha * dt)))
        cd = p["capillary_dry"]
        _set(cd, "u_kcap", float(F32(prm.cap_diffusion * dt)))
        _set(cd, "u_ecap", float(F32(prm.evap_cap() * dt)))
        _set(cd, "u_fade", float(F32(dt / prm.wet_hold)) if hold else 0.0)
        _set(p["tile_update"], "u_ttl", prm.tile_ttl_steps())

    def _slot_program(self, vals: dict[str, list[tuple[float, ...]]]) -> moderngl.ComputeShader:
        """evap_surface compiled with the pigment slots' values ``vals`` as constants
        (``SLOT_CONST``: exact float32 bits), again when a slot's pigment changes: on a CPU
        rasterizer every uniform component a pass reads is a load per vector of lanes."""
        arrays = {name: np.asarray(v, F32).reshape(-1) for name, v in vals.items()}
        key = tuple(int(b) for a in arrays.values() for b in a.view(np.uint32))
        if key != self._slot_key:
            def vec4s(a: np.ndarray) -> str:
                bits = a.view(np.uint32)
                items = ", ".join(
                    "vec4({})".format(", ".join(f"uintBitsToFloat(0x{int(b):08x}u)"
                                                for b in bits[4 * i:4 * i + 4]))
                    for i in range(len(a) // 4))
                return f"vec4[{len(a) // 4}]({items})"
            old = self._programs.pop("evap_surface")
            old.release()
            self._programs["evap_surface"] = self._compile(
                "evap_surface.comp", {"SLOT_CONST": 1, "K_GAMMA": vec4s(arrays["u_gamma"]),
                                      "K_DELTA": vec4s(arrays["u_delta"]),
                                      "K_DOB": vec4s(arrays["u_dob"])})
            self._slot_key = key
        return self._programs["evap_surface"]

    def _blur_programs(self, taps: np.ndarray, hold: int, front: int = -1,
                       shelter: bool = False) -> None:
        """blur_x.comp and the first Jacobi iteration (jacobi.comp with FIRST_ITER, which
        forms pass 3's levelled height, pressure.glsl) for the float32 Gaussian ``taps``
        (none: no flow-outward term, no blur_x) and ``hold`` (1: blur the wet-area
        memory), compiled when they change.  The taps are constants of the program (their
        exact bits, ``TAPS``), not a uniform array: llvmpipe then multiplies by
        immediates instead of loading the array in every lane, about 2 ms CPU a 15-tap
        loop at 800x600; the loops unroll, the mask's source is fixed.  ``front`` >= 0: the
        standing gate's front factor (front.comp; 1: over dry paper, blur_x also blurs the
        not-dry paper into ``dx``), -1: off.  ``shelter``: damp_exposure's pass
        (shelter.comp, stencils.sheltered) after blur_x."""
        bits = tuple(int(b) for b in np.asarray(taps, F32).view(np.uint32))
        if (bits, hold, front, shelter) == self._pressure_taps:
            return
        ntaps = len(bits)
        for name in ("blur_x", "jacobi_first", "front", "shelter"):
            old = self._programs.pop(name, None)
            if old is not None:
                old.release()
        const = {"NTAPS": max(1, ntaps),
                 "TAPS": "float[{}]({})".format(
                     max(1, ntaps), ", ".join(f"uintBitsToFloat(0x{b:08x}u)" for b in bits)
                     or "0.0")}
        dry = 1 if front > 0 else 0
        if ntaps:
            self._programs["blur_x"] = self._compile("blur_x.comp", {**const, "HOLD": hold,
                                                                     "FRONT_DRY": dry})
        if ntaps and front >= 0:
            self._programs["front"] = self._compile("front.comp", {**const, "FRONT_DRY": dry})
        if ntaps and shelter:
            self._programs["shelter"] = self._compile("shelter.comp", const)
        # with the front pass, front.comp writes pass 3's levelled height (PR_DONE)
        self._programs["jacobi_first"] = self._compile(
            "jacobi.comp", {**const, "FIRST_ITER": 1,
                            "PR_DONE": 1 if ntaps and front >= 0 else 0})
        self._pressure_taps = (bits, hold, front, shelter)

    def _begin_step(self) -> None:
        """Bind the tile list and build it (tiling) for the passes of one step."""
        gx, gy = self.groups
        self.b_ttl.bind_to_storage_buffer(_B_TTL)
        if self.tiling:
            self.b_args.write(np.array([gx, gy, 0], np.uint32).tobytes())  # keeps the count
            self.b_args.write(np.array(self.blur_groups, np.uint32).tobytes(), offset=_ARGS_BLUR)
            self.b_list.bind_to_storage_buffer(_B_LIST)
            self.b_prev.bind_to_storage_buffer(_B_PREV)
            self.b_args.bind_to_storage_buffer(_B_ARGS)
            self._programs["tile_list"].run(-(-self.ntiles // 64), 1, 1)
            ctx = self.ctx
            ctx.memory_barrier(ctx.BUFFER_UPDATE_BARRIER_BIT | ctx.SHADER_STORAGE_BARRIER_BIT
                               | ctx.COMMAND_BARRIER_BIT | ctx.SHADER_IMAGE_ACCESS_BARRIER_BIT)
            # blur_x's dispatch: the same tiles (no read-back), its own groups along y
            self.b_args.bind_to_storage_buffer(_B_ARGS)
            ctx.copy_buffer(self.b_args, self.b_args, 4, read_offset=8,
                            write_offset=_ARGS_BLUR + 8)
        else:
            self.b_all.bind_to_storage_buffer(_B_LIST)
            self._cells_cpu += self.width * self.height
        self.b_alive.bind_to_storage_buffer(_B_ALIVE)

    def profile_passes(self, on: bool) -> None:
        """Time every pass of the step (``take_pass_times``): a ``glFinish`` before and
        after each dispatch, so the step runs slower and the passes do not overlap."""
        self._pass_seconds = {} if on else None

    def take_pass_times(self) -> dict[str, float]:
        """Wall seconds per pass (program name) since the last call, while profiling."""
        out = dict(self._pass_seconds or {})
        if self._pass_seconds is not None:
            self._pass_seconds = {}
        return out

    def _dispatch(self, name: str, label: str | None = None) -> None:
        """Run program ``name`` on the step's cells; its profiled time counts under
        ``label`` (default ``name``).  blur_x runs with its own groups along y
        (``blur_groups``: each invocation blurs several rows on a CPU rasterizer)."""
        prog = self._programs[name]
        times = self._pass_seconds
        if times is not None:
            self.ctx.finish()
            t0 = time.perf_counter()
        blur = name == "blur_x"
        if self.tiling:
            prog.run_indirect(self.b_args, _ARGS_BLUR if blur else 0)
        else:
            gx, gy = self.blur_groups if blur else self.groups
            prog.run(gx, gy, self.ntiles)
        self._barrier()
        if times is not None:
            self.ctx.finish()
            key = label or name
            times[key] = times.get(key, 0.0) + time.perf_counter() - t0

    def _pass_prep(self) -> None:
        f = self.f
        self._bind(1, f["vel"].src, True, False)
        self._bind(2, f["water"].src, True, False)
        self._bind(3, f["paper"].src, True, False)
        self._bind(4, self.aux, False, True)
        self._bind(5, self.jv[0], False, True)
        self._bind(6, f["fibre"].src, True, False)
        self._bind(7, f["area"].src, True, True)
        self._dispatch("prep")
        self._bind(1, f["water"].src, True, False)
        self._bind(2, f["paper"].src, True, False)
        if "blur_x" in self._programs:
            self._bind(4, self.bx, False, True)
            self._bind(5, f["area"].src, True, False)
            self._bind(6, self.dx, False, True)
            self._dispatch("blur_x")
        if "shelter" in self._programs:  # damp cells in a bay of the front do not join
            self._bind(2, f["water"].src, True, False)
            self._bind(3, f["paper"].src, True, False)
            self._bind(4, self.bx, True, False)
            self._bind(5, self.aux, True, True)
            self._bind(7, self.jv[0], True, True)
            self._dispatch("shelter")
        if "front" in self._programs:  # beta_c's standing share, with M' (after blur_x)
            self._bind(1, f["vel"].src, True, False)
            self._bind(2, f["water"].src, True, False)
            self._bind(3, f["paper"].src, True, False)
            self._bind(4, self.bx, True, False)
            self._bind(5, self.dx, True, False)
            self._bind(6, f["fibre"].src, True, False)
            self._bind(7, self.jv[0], True, True)
            self._bind(0, self.pr, False, True)
            self._dispatch("front")
        # pass 3's levelled height P runs in the first Jacobi iteration (_pass_diffusion);
        # until the diffusion passes run, jv[0] holds wb (.w) and jv[1] is free
        self._js, self._jfree = self.jv[0], self.jv[1]

    def _pass_diffusion(self) -> None:
        """Pass 3's levelled height (in the first Jacobi iteration), the Jacobi
        iterations, limit (velocity final + limiters), diffuse_apply."""
        f = self.f
        n = int(self.params.jacobi_iters)
        cur = 0
        for i in range(n):
            self._bind(1, self.jv[cur], True, False)
            self._bind(2, self.aux, True, False)
            self._bind(4, f["pig"].src, True, False)
            self._bind(6, self.jv[1 - cur], False, True)
            self._bind(7, self.jd[1 - cur], False, True)
            if i == 0:
                # the pigment iterate starts at p (unit 4); P from w (aux), wb (jv), h, bx
                self._bind(0, self.pr, False, True)
                self._bind(3, f["paper"].src, True, False)
                if "blur_x" in self._programs:
                    self._bind(5, self.bx, True, False)
                self._dispatch("jacobi_first", "jacobi")
            else:
                self._bind(5, self.jd[cur], True, False)
                self._dispatch("jacobi")
            cur = 1 - cur
        # the converged iterate is in jv[cur], jd[cur]
        self._bind(1, self.jv[cur], True, False)
        self._bind(2, self.jd[cur], True, False)
        self._bind(3, f["water"].src, True, False)
        self._bind(4, f["pig"].src, True, False)
        self._bind(5, f["vel"].dst, False, True)
        self._bind(6, self.jv[1 - cur], False, True)
        self._bind(7, self.jd[1 - cur], False, True)
        self._bind(0, self.pr, True, False)
        f["fibre"].src.use(location=0)  # a sampler: the image units are all taken
        f["paper"].src.use(location=1)  # h for the gate's relief term, a sampler too
        self._dispatch("limit")
        f["vel"].swap()
        self._bind(1, self.jv[1 - cur], True, False)
        self._bind(2, self.jd[cur], True, False)
        self._bind(3, self.jd[1 - cur], True, False)
        self._bind(4, f["water"].src, True, False)
        self._bind(5, f["pig"].src, True, False)
        self._bind(6, f["water"].dst, False, True)
        self._bind(7, f["pig"].dst, False, True)
        self._dispatch("diffuse_apply")
        f["water"].swap()
        f["pig"].swap()
        self._js = self.jv[1 - cur]  # holds wb (.w) for the rest of the step
        self._jfree = self.jv[cur]

    def _pass_advect(self) -> None:
        f = self.f
        self._bind(1, f["vel"].src, True, False)
        self._bind(2, self._js, True, False)
        self._bind(3, f["water"].src, True, False)
        self._bind(4, f["pig"].src, True, False)
        self._bind(5, self._jfree, False, True)
        self._dispatch("advect_limit")
        self._bind(2, self._jfree, True, False)
        self._bind(5, f["water"].dst, False, True)
        self._bind(6, f["pig"].dst, False, True)
        self._dispatch("advect_apply")
        f["water"].swap()
        f["pig"].swap()

    def _pass_evap_surface(self) -> None:
        f = self.f
        self._bind(1, f["water"].src, True, False)
        self._bind(2, f["water"].dst, False, True)
        self._bind(3, f["pig"].src, True, True)
        self._bind(4, f["dep"].src, True, True)
        self._bind(5, f["paper"].src, True, False)
        self._bind(6, self._js, True, False)
        self._dispatch("evap_surface")
        f["water"].swap()

    def _pass_capillary_dry(self) -> None:
        f = self.f
        self._bind(1, f["water"].src, True, False)
        self._bind(2, f["water"].dst, False, True)
        self._bind(3, f["paper"].src, True, False)
        self._bind(4, f["pig"].src, True, True)
        self._bind(5, f["dep"].src, True, True)
        self._bind(6, f["vel"].src, True, True)
        self._bind(7, f["area"].src, True, True)
        self._dispatch("capillary_dry")
        f["water"].swap()

    def _end_step(self, dt: float) -> None:
        if self.tiling:
            self.b_alive.bind_to_storage_buffer(_B_ALIVE)
            self.b_ttl.bind_to_storage_buffer(_B_TTL)
            self._programs["tile_update"].run(-(-self.ntiles // 64), 1, 1)
            self._barrier()
        self.sim_time += dt
        self.step_count += 1
        if self.step_count % operations.FOLD_EVERY == 0:
            self._fold()

    def _fold(self) -> None:
        """reference operations.fold_accumulators on the GPU (no read-back)."""
        water = self.f["water"]
        self._bind(1, water.textures[0], True, True)
        self._bind(2, water.textures[1], True, True)
        self.b_folded.bind_to_storage_buffer(_B_FOLDED)
        self._programs["fold"].run(self.src_groups[0], self.src_groups[1], 1)
        self._barrier()

    def _check_dt(self, dt: float | None) -> float:
        d = self.params.dt if dt is None else float(dt)
        if not d > 0 or not math.isfinite(d):
            raise CanvasInputError("dt must be > 0", "step")
        if d * self.params.v_max > 1.0 + 1e-9:
            raise CanvasInputError("dt too large for v_max (more than one cell per step)",
                                   "step")
        return d


def param_constants(prm: SimParams, dt: float | None) -> dict[str, str]:
    """The step's parameters as compile-time constants of the pass programs (``K_*``
    defines, the exact float32 bits the uniforms had): on llvmpipe every uniform a pass
    reads is a load in every vector of lanes (about 0.25 ms CPU each at 800x600; prep
    read 15).  The values that depend on dt are constants for ``dt`` (``DT_CONST``; the
    parameters' own dt, every caller's) and uniforms when ``dt`` is None (a step given
    another dt).  The programs are recompiled when these change (a new profile or
    parameters); the pigment slots' values and the layer count stay uniforms, which
    change while painting."""
    vals = {
        "MOIST": prm.moist_threshold, "BLOCK_FADE": prm.block_fade,
        "BLOCK_PAPER": prm.block_paper, "ADVANCE": prm.advance_height,
        "ADV_BASE": float(stencils.advance_base(prm)), "ADV_GRAIN": prm.advance_grain,
        "CURV": prm.advance_curvature, "CURV_N": float(F32(1.0 + 2.0 * prm.advance_curvature)),
        "WICK": prm.fibre_wick, "DISPERSE": float(F32(prm.fibre_dispersion_gain())),
        "FIBRE_FLOW_MAX": prm.fibre_flow_max, "EASE": prm.damp_ease, "DSAT": prm.damp_sat,
        "DSPAN": float(F32(1.0 - prm.damp_sat)), "CMIN": prm.c_min,
        "PBASE": float(prm.fibre_channel()[0]), "PGAIN": float(prm.fibre_channel()[1]),
        "PA": prm.fibre_permeability, "PGATE": prm.fibre_gate(), "PPULL": prm.fibre_gate_front(),
        "SINV": prm.standing_diffusion()[0], "SDROP": prm.standing_diffusion()[1],
        "FINV": prm.standing_front()[0], "FDRY": prm.standing_front()[1],
        "CRANGE": float(F32(prm.c_max - prm.c_min)), "ETA": prm.flow_outward,
        "RIMK": prm.rim_profile()[0], "RIMI": prm.rim_profile()[1],
        "RIMA": prm.rim_profile()[2], "RIMINV": prm.rim_profile()[3],
        "RELIEF": prm.paper_relief, "OMEGA_H": prm.omega_h,
        "OMEGA_I": float(F32(1.0 - prm.omega_h)),
        "HALF_GAIN": float(F32(-0.5 * prm.height_gain)), "VMAX": prm.v_max,
        "WMIN": prm.w_min, "WMAX": prm.w_max, "EDGE_EVAP": prm.edge_evap,
        "DRY_EPS": prm.w_dry_eps, "SUSP": prm.suspend_sat, "DEXP": prm.damp_exposure,
    }
    if dt is not None:
        vals.update({
            "DT": dt, "KV": float(F32(prm.viscosity * dt)), "KW": float(F32(prm.nu_w * dt)),
            "KP": float(F32(prm.nu_p * dt)), "Q4": float(F32(0.25 * dt)),
            "E": float(F32(prm.evap_shallow() * dt)), "RATE": float(F32(prm.surface_rate * dt)),
            "ABSORB": float(F32(prm.alpha * dt)), "KCAP": float(F32(prm.cap_diffusion * dt)),
            "ECAP": float(F32(prm.evap_cap() * dt)),
            "FADE": float(F32(dt / prm.wet_hold)) if prm.wet_hold > 0 else 0.0})
        tilt = reference.tilt_kick(prm, dt)
        vals.update({"TILT_X": float(tilt[0]), "TILT_Y": float(tilt[1])})
    out = {f"K_{k}": f"uintBitsToFloat(0x{int(F32(v).view(np.uint32)):08x}u)"
           for k, v in vals.items()}
    out["K_HOLD"] = "1" if prm.wet_hold > 0 else "0"
    out["DT_CONST"] = "0" if dt is None else "1"
    return out


def _set(prog: moderngl.ComputeShader, name: str, value: object) -> None:
    """Set uniform ``name`` when the program uses it (drivers drop unused ones)."""
    try:
        u = prog[name]
    except KeyError:
        return
    if isinstance(value, list) and len(value) == 1 and getattr(u, "array_length", 1) == 1:
        value = value[0]  # a one-element uniform array is set like a plain uniform
    u.value = value
