"""The GL backend's canvas in the kiosk window: the same sub-cell contour as the CPU
backends' (issue 22 item 1).  One painting state, loaded into a numpy canvas and a GL
canvas; each display's texture drawn through the window's shader at the screen's
resolution (8 pixels a cell); the two pictures compared pixel by pixel."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from station.canvas.palette import default_palette
from station.events import Command, PenSample, Tool
from station.kiosk import subcell
from station.kiosk.display import CanvasSurface, GpuDisplay
from station.render.km import to_srgb8
from station.sim.paint import make_backend
from station.sim.player import SessionPlayer

W, H, K = 48, 36, 8  # cells; pixels a cell on the screen


def _painted_state() -> Any:
    """A dried stroke and a wet one across it (wet pigment, dried layers, bare paper)."""
    canvas, _ = make_backend("numpy", W, H, "watercolor", 0)
    player = SessionPlayer(canvas, W, H, "watercolor", rate=30.0, pigments=default_palette())

    def stroke(y: float, pigment: str, t0: float) -> None:
        player.apply(Command(t=t0, cmd="brush",
                             args={"size": 5, "water": 1.0, "pigment": {pigment: 0.6}}))
        for i in range(25):
            player.apply(PenSample(t=t0 + 0.01 * i, device="p", tool=Tool.PEN,
                                   x=0.15 + 0.028 * i, y=y + 0.01 * i, pressure=0.8,
                                   touching=i < 24))
        for _ in range(6):
            player.step()

    stroke(0.3, "French Ultramarine", 0.0)
    canvas.dry()
    stroke(0.45, "Indian Red", 1.0)
    return canvas


def _draw(ctx: Any, texture: Any, surface: CanvasSurface) -> np.ndarray:
    """``texture`` through the window's canvas shader at K pixels a cell (sRGB8)."""
    prog = ctx.program(vertex_shader=subcell.CANVAS_VERT, fragment_shader=subcell.CANVAS_FRAG)
    quad = np.array([[-1, 1, 0, 0, 0], [1, 1, 0, 1, 0], [-1, -1, 0, 0, 1], [1, -1, 0, 1, 1]],
                    "f4")
    vbo = ctx.buffer(quad.tobytes())
    vao = ctx.vertex_array(prog, [(vbo, "3f 2f", "pos", "uv")])
    fbo = ctx.simple_framebuffer((W * K, H * K))
    try:
        fbo.use()
        fbo.clear(0, 0, 0, 1)
        texture.use(0)
        prog["canvas"].value = 0
        surface.use(prog, 1)
        prog["cells"].value = (float(W), float(H))
        prog["vp"].write(np.eye(4, dtype="f4").tobytes())
        vao.render(ctx.TRIANGLE_STRIP)
        data = fbo.read(components=3, alignment=1)
    finally:
        for o in (fbo, vao, vbo, prog):
            o.release()
    return np.frombuffer(data, np.uint8).reshape(H * K, W * K, 3)[::-1].astype(int)


def test_the_gl_canvas_shows_the_same_subcell_contour_as_the_cpu_canvas() -> None:
    from station.backends.gl.canvas import GLCanvas
    from station.glkit.context import GLUnavailable, create_context

    try:
        ctx = create_context()
    except GLUnavailable as exc:
        pytest.skip(f"no GL 4.3: {exc}")
    cpu = _painted_state()
    st = cpu.state()
    gl = GLCanvas(W, H, "watercolor", 0, ctx=ctx)
    try:
        gl.load_state(st)
        session = SimpleNamespace(canvas=gl, cfg=SimpleNamespace(width=W, height=H),
                                  player=SimpleNamespace(flush_sources=lambda: None),
                                  take_dirty=lambda: None)
        display = GpuDisplay(ctx, session)
        display.update_preview()
        assert display.surface.contours  # the window's shader draws the contour
        got = display.fields.read()
        # the CPU displays' texture, from the same state (CpuDisplay.expected)
        rgb = np.asarray(cpu.render(), np.float32)
        pigments = st.slot_pigments()
        painted = subcell.painted_cells(st.p[:len(pigments)] + st.q[:len(pigments)],
                                        st.r_composed, st.paper_reflectance())
        want = subcell.fields(rgb, painted, (slice(0, H), slice(0, W)))
        # the hard steps inside the paint (the wet stroke over the dried one)
        hi, lo = subcell.step_fields(rgb, st.paper_reflectance(), painted, want[..., :3],
                                     (slice(0, H), slice(0, W)))
        want[..., :3] = hi
        assert 0.05 < painted.mean() < 0.6  # paint, dried paint and bare paper
        assert np.abs(got[..., 3] - want[..., 3]).max() < 1e-4  # the contour level
        assert np.abs(got[..., :3] - want[..., :3]).max() < 2e-3  # the extended colour
        steps = display.fields.read_steps()
        assert np.abs(steps[..., 3] - lo[..., 3]).max() < 1e-4  # the steps' level
        assert np.abs(steps[..., :3] - lo[..., :3]).max() < 2e-3  # the low side's colour
        # at the screen's resolution, through the window's shader, the same picture
        cpu_tex = ctx.texture((W, H), 4, np.ascontiguousarray(want).tobytes(), dtype="f4")
        cpu_tex.filter = (ctx.LINEAR, ctx.LINEAR)
        cpu_tex.repeat_x = cpu_tex.repeat_y = False
        surface = display.surface
        on_gl = _draw(ctx, display.texture, surface)
        on_cpu = _draw(ctx, cpu_tex, surface)
        diff = np.abs(on_gl - on_cpu).max(axis=2)
        assert diff.max() <= 2, diff.max()
        # the contour is there: the paint's edge is drawn within a pixel or two, between
        # cells (pixels part-covered by paint, and a sharp step across the edge), where
        # the render without it (main's GL window: colour bicubic, no level) smears it
        # over cells
        surface.contours = False
        plain_tex = ctx.texture((W, H), 4, np.ascontiguousarray(
            np.concatenate([rgb, np.ones((H, W, 1), np.float32)], axis=2)).tobytes(),
            dtype="f4")
        plain_tex.filter = (ctx.LINEAR, ctx.LINEAR)
        without = _draw(ctx, plain_tex, surface)
        surface.contours = True
        off = np.abs(without - on_cpu).max(axis=2)
        assert off.max() > 20 and (off > 2).mean() > 0.02, (off.max(), (off > 2).mean())
        for img in (on_gl, on_cpu, without):  # nothing black or torn anywhere
            assert img.min() > 20
        # the top-left cell's colour is the paper's, the shader's sRGB of the reference
        paper8 = to_srgb8(np.full((1, 1, 3), st.paper_reflectance()[0, 0], np.float32))[0, 0]
        assert np.abs(on_gl[2, 2] - paper8).max() <= 12
        # a wash's edge over another (Burnt Umber laid in cells below a line over an
        # Ultramarine wash): the hard steps' passes find what step_fields finds
        band = cpu.state()
        yy, xx = np.mgrid[0:H, 0:W]
        band.q[...] = 0.0
        band.p[...] = 0.0
        band.q[band.slot_of("French Ultramarine")] = 0.2
        band.q[band.slot_of("Burnt Umber")] = np.where(yy + 0.5 > 10 + 0.3 * (xx + 0.5), 0.3,
                                                       0.0).astype(np.float32)
        cpu.load_state(band)
        gl.load_state(band)
        display.update_preview()
        b_rgb = np.asarray(cpu.render(), np.float32)
        b_painted = subcell.painted_cells(band.p[:len(pigments)] + band.q[:len(pigments)],
                                          band.r_composed, band.paper_reflectance())
        b_want = subcell.fields(b_rgb, b_painted, (slice(0, H), slice(0, W)))
        b_hi, b_lo = subcell.step_fields(b_rgb, band.paper_reflectance(), b_painted,
                                         b_want[..., :3], (slice(0, H), slice(0, W)))
        assert (b_lo[..., 3] > 0.5).sum() > 100  # steps found
        got_steps = display.fields.read_steps()
        assert np.abs(got_steps[..., 3] - b_lo[..., 3]).max() < 1e-4
        assert np.abs(got_steps[..., :3] - b_lo[..., :3]).max() < 2e-3
        assert np.abs(display.fields.read()[..., :3] - b_hi).max() < 2e-3
        cpu_tex.release()
        plain_tex.release()
        display.release()
    finally:
        gl.close()
        ctx.release()
