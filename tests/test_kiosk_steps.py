"""The kiosk window draws hard edges INSIDE the paint (one paint over another) as smooth
sub-cell contours where it magnifies the canvas, as the headless renderer does (issue 21,
the look): the step fields' compiled twin against its definition, and the window's
canvas shader against its numpy definition (:func:`subcell.draw_reference`)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from test_render_steps import _edge_wiggle  # the same 48x32 canvas and slope

from station.backends.numpy_canvas import NumpyCanvas
from station.kiosk import subcell
from station.kiosk.display import CanvasSurface
from station.kiosk.drawing import use_steps
from station.render.km import render_state

W, H, K = 48, 32, 4  # cells; pixels a cell on the screen
SLOPE = 0.3


def _fields() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, Any]:
    """Burnt Umber laid (cells only) below a line over a French Ultramarine wash: the
    canvas texture (high side's colour, paint level), the steps' texture, the canvas
    texture without steps (main's), the bare paper, the state."""
    st = NumpyCanvas(W, H, seed=1).state()
    yy, xx = np.mgrid[0:H, 0:W]
    st.q[st.slot_of("French Ultramarine")] = 0.2
    st.q[st.slot_of("Burnt Umber")] = np.where(yy + 0.5 > 10 + SLOPE * (xx + 0.5), 0.3,
                                               0.0).astype(np.float32)
    rgb = render_state(st, "km")
    paper = st.paper_reflectance()
    n = len(st.slot_pigments())
    painted = subcell.painted_cells(st.p[:n] + st.q[:n], st.r_composed, paper)
    whole = (slice(0, H), slice(0, W))
    plain = subcell.fields(rgb, painted, whole)
    hi, lo = subcell.step_fields(rgb, paper, painted, plain[..., :3], whole)
    canvas = plain.copy()
    canvas[..., :3] = hi
    return canvas, lo, plain, paper, st


def test_the_compiled_step_fields_match_their_definition() -> None:
    canvas, lo, plain, paper, st = _fields()
    rgb = render_state(st, "km")
    n = len(st.slot_pigments())
    painted = subcell.painted_cells(st.p[:n] + st.q[:n], st.r_composed, paper)
    for ys, xs in [(slice(0, H), slice(0, W)), (slice(9, 25), slice(12, 40))]:
        gy, gx = subcell.grow(ys, xs, subcell.STEP_HALO, H, W)
        inner = (slice(ys.start - gy.start, ys.stop - gy.start),
                 slice(xs.start - gx.start, xs.stop - gx.start))
        ext = subcell.fields(rgb[gy, gx], painted[gy, gx], inner)
        got = subcell.step_fields(rgb[gy, gx], paper[gy, gx], painted[gy, gx], ext[..., :3],
                                  inner)
        want = subcell.step_fields_reference(rgb, paper, painted, plain[..., :3], (ys, xs))
        assert np.abs(got[0] - want[0]).max() < 1e-6
        assert np.abs(got[1] - want[1]).max() < 1e-6
    # a glaze's step (density +0.5, under twice), a harder one, a thin dark line, the
    # paper's noise, ragged blank cells
    rng = np.random.default_rng(3)
    yy, xx = np.mgrid[0:50, 0:70]
    c2 = np.float32(0.6) * (1 + 0.04 * rng.random((50, 70, 3))).astype(np.float32)
    c2[yy > 20 + 0.3 * xx] *= 0.6
    c2[yy > 30 + 0.2 * xx] *= 0.3
    c2[5:8, 5:40] *= 0.4
    p2 = rng.random((50, 70)) > 0.02
    pap = np.full((50, 70), 0.85, np.float32)
    e2 = subcell.fields(c2, p2, (slice(0, 50), slice(0, 70)))[..., :3]
    for ys, xs in [(slice(0, 50), slice(0, 70)), (slice(7, 40), slice(8, 60))]:
        gy, gx = subcell.grow(ys, xs, subcell.STEP_HALO, 50, 70)
        inner = (slice(ys.start - gy.start, ys.stop - gy.start),
                 slice(xs.start - gx.start, xs.stop - gx.start))
        got = subcell.step_fields(c2[gy, gx], pap[gy, gx], p2[gy, gx], e2[ys, xs], inner)
        want = subcell.step_fields_reference(c2, pap, p2, e2, (ys, xs))
        assert np.abs(got[0] - want[0]).max() < 1e-6
        assert np.abs(got[1] - want[1]).max() < 1e-6
        assert (np.abs(want[0] - e2[ys, xs]).max(axis=-1) > 0).sum() > 100  # steps found
    # no step (a smooth blend): both textures the paint's colour, level 0, as defined
    smooth = np.float32(0.6) * (1 - 0.02 * xx[..., None] / 70).astype(np.float32) \
        * np.ones(3, np.float32)
    got = subcell.step_fields(smooth, pap, p2, e2, (slice(0, 50), slice(0, 70)))
    want = subcell.step_fields_reference(smooth, pap, p2, e2, (slice(0, 50), slice(0, 70)))
    assert (got[1][..., 3] == 0).all() and (got[0] == e2).all()
    assert np.abs(got[1] - want[1]).max() < 1e-6
    # the two sides differ along the step only, and the level splits them
    differ = np.abs(canvas[..., :3] - lo[..., :3]).max(axis=-1) > 1e-3
    assert 1.5 * W < differ.sum() < 4 * W
    assert (np.abs(canvas - plain)[~differ] == 0).all()  # elsewhere the texture as on main


def _draw(ctx: Any, canvas: np.ndarray, steps: np.ndarray | None,
          surface: CanvasSurface) -> np.ndarray:
    """The textures through the window's canvas shader at K pixels a cell (sRGB8, top
    row first), the grain's shading off (the reference leaves it out)."""
    prog = ctx.program(vertex_shader=subcell.CANVAS_VERT, fragment_shader=subcell.CANVAS_FRAG)
    quad = np.array([[-1, 1, 0, 0, 0], [1, 1, 0, 1, 0], [-1, -1, 0, 0, 1], [1, -1, 0, 1, 1]],
                    "f4")
    vbo = ctx.buffer(quad.tobytes())
    vao = ctx.vertex_array(prog, [(vbo, "3f 2f", "pos", "uv")])
    fbo = ctx.simple_framebuffer((W * K, H * K))
    texs = []
    for a in (canvas, steps):
        if a is not None:
            t = ctx.texture((W, H), 4, np.ascontiguousarray(a, np.float32).tobytes(),
                            dtype="f4")
            t.filter = (ctx.LINEAR, ctx.LINEAR)
            t.repeat_x = t.repeat_y = False
            texs.append(t)
    try:
        fbo.use()
        fbo.clear(0, 0, 0, 1)
        texs[0].use(0)
        prog["canvas"].value = 0
        surface.use(prog, 1)
        prog["shade"].value = 0.0
        prog["granulation"].value = 0.0
        use_steps(prog, texs[1] if steps is not None else None, 3)
        prog["cells"].value = (float(W), float(H))
        prog["vp"].write(np.eye(4, dtype="f4").tobytes())
        vao.render(ctx.TRIANGLE_STRIP)
        data = fbo.read(components=3, alignment=1)
    finally:
        for o in (fbo, vao, vbo, prog, *texs):
            o.release()
    return np.frombuffer(data, np.uint8).reshape(H * K, W * K, 3)[::-1].astype(int)


def test_the_window_draws_an_edge_between_two_paints_as_a_smooth_contour() -> None:
    from station.glkit.context import GLUnavailable, create_context

    try:
        ctx = create_context()
    except GLUnavailable as exc:
        pytest.skip(f"no GL: {exc}")
    canvas, lo, plain, paper, st = _fields()
    surface = CanvasSurface.make(ctx, paper, st.paper_preset, st.seed, 0.0, contours=True)
    try:
        got = _draw(ctx, canvas, lo, surface)
        before = _draw(ctx, plain, None, surface)  # main's window: no steps' texture
    finally:
        surface.release()
        ctx.release()
    # the shader is its numpy definition (a level where the sRGB rounding differs, a few
    # at the few pixels of the contour where the quads' derivatives differ: 5 measured)
    ref = subcell.draw_reference(canvas, lo, paper, K)
    diff = np.abs(got - ref).max(axis=2)
    assert diff.max() <= 8 and (diff > 1).mean() < 0.002, (diff.max(), (diff > 1).mean())
    assert np.abs(before - subcell.draw_reference(plain, None, paper, K)).max() <= 3
    # the staircase is gone: main's window draws it (1.82 px measured at 4 px a cell),
    # the steps' contour keeps within 0.3 cell of a straight line (1.08 px measured)
    stair, smooth = (_edge_wiggle(img.mean(axis=2), K) for img in (before, got))
    assert stair > 0.4 * K and smooth < 0.3 * K, (stair, smooth)
    # both sides keep their colours away from the edge
    assert np.abs(got[:6 * K] - before[:6 * K]).max() <= 2
    assert np.abs(got[-6 * K:] - before[-6 * K:]).max() <= 2
