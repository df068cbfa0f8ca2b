"""Kiosk parts without a window: views, idle rules, dirty tiles, the display, the panel."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from station.backends.factory import create_backend
from station.errors import BadInput
from station.events import Command, PenSample, Tool
from station.kiosk.display import tile_runs
from station.kiosk.idle import IdleClock, IdleConfig
from station.kiosk.views import VIEWS, Viewport, input_camera, make_camera
from station.render.km import render_region, render_state
from station.sim.live import LiveConfig

AREA = Viewport(300, 0, 724, 768)


@pytest.mark.parametrize("view", VIEWS)
def test_screen_and_canvas_round_trip(view: str) -> None:
    cam = make_camera(view, AREA, 4 / 3, (0.3, 0.6))
    for u, v in [(0.5, 0.5), (0.1, 0.2), (0.9, 0.8), (0.3, 0.6)]:
        xy = cam.world_to_screen(cam.canvas_to_world(u, v))
        assert xy is not None
        back = cam.screen_to_canvas(*xy)
        assert back == pytest.approx((u, v), abs=1e-9)


def test_2d_fits_the_canvas_and_3d_is_a_table_in_perspective() -> None:
    cam = make_camera("2d", AREA, 4 / 3)
    x0, y0 = cam.world_to_screen(cam.canvas_to_world(0, 0))
    x1, y1 = cam.world_to_screen(cam.canvas_to_world(1, 1))
    assert (x1 - x0) / (y1 - y0) == pytest.approx(4 / 3)
    assert (x0 + x1) / 2 == pytest.approx(300 + 724 / 2) and (y0 + y1) / 2 == pytest.approx(384)
    assert AREA.x <= x0 and x1 <= AREA.x + AREA.w and y0 >= 0 and y1 <= 768
    t = make_camera("3d", AREA, 4 / 3)
    far = [t.world_to_screen(t.canvas_to_world(u, 0)) for u in (0, 1)]
    near = [t.world_to_screen(t.canvas_to_world(u, 1)) for u in (0, 1)]
    assert near[1][0] - near[0][0] > 1.2 * (far[1][0] - far[0][0])  # nearer = wider
    assert near[0][1] > far[0][1]  # the near edge is lower on the screen
    # the pen paints through the 3D camera in 3d, through the 2D one otherwise
    assert input_camera("3d", AREA, 4 / 3).name == "3d"
    assert input_camera("follow", AREA, 4 / 3).name == "2d"
    # above the horizon there is no table to paint on
    assert t.screen_to_world(AREA.x + 10, -5000) is None


def test_idle_rules() -> None:
    clock = IdleClock(IdleConfig(attract_after=10, finish_after=60), now=0.0)
    assert not clock.attract(9.9) and clock.attract(10.0)
    assert not clock.should_finish(100.0)  # nothing painted: the canvas just stays
    clock.painted = True
    assert not clock.should_finish(59.0) and clock.should_finish(60.0)
    clock.activity(50.0)
    assert not clock.attract(55.0) and not clock.should_finish(100.0)
    assert clock.should_finish(110.0)
    clock.fresh(110.0)
    assert not clock.should_finish(500.0)
    with pytest.raises(ValueError):
        IdleConfig(attract_after=0)


def test_tile_runs() -> None:
    d = np.zeros((3, 6), bool)
    d[0, 1:3] = True
    d[0, 4] = True
    d[2, :] = True
    assert tile_runs(d) == [(0, 1, 3), (0, 4, 5), (2, 0, 6)]


def _painted_canvas():  # type: ignore[no-untyped-def]
    c = create_backend("numpy", 96, 64, "watercolor", seed=3)
    yy, xx = np.mgrid[0:20, 0:30]
    blob = np.exp(-((yy - 10) ** 2 + (xx - 15) ** 2) / 40.0).astype(np.float32)
    c.add_sources(blob * 0.5, {"French Ultramarine": blob * 0.3}, y0=20, x0=30)
    for _ in range(5):
        c.step()
    return c


def test_render_region_equals_the_full_render_and_previews_add_sources() -> None:
    c = _painted_canvas()
    st = c.live_state
    full = render_state(st, "km")
    ys, xs = slice(16, 48), slice(25, 70)
    assert np.array_equal(render_region(st, "km", ys, xs), full[ys, xs])
    assert np.array_equal(render_region(st, "gouache", ys, xs), render_state(st, "gouache")[ys, xs])
    # the preview of stamps not yet added = rendering after add_sources (in a slot, and new)
    add = {"French Ultramarine": np.full((32, 45), 0.2, np.float32),
           "Hansa Yellow": np.full((32, 45), 0.1, np.float32)}
    preview = render_region(st, "km", ys, xs, add)
    c.add_sources(None, add, y0=16, x0=25)
    after = render_state(c.live_state, "km")
    assert np.abs(preview - after[ys, xs]).max() < 1e-6


def _session(tmp_path, size=(96, 64), **kw):  # type: ignore[no-untyped-def]
    from station.kiosk.session import KioskSession

    cfg = LiveConfig(bus=f"ipc://{tmp_path}/bus", width=size[0], height=size[1],
                     backend="numpy",
                     status="none", cmd="none", log_path=str(tmp_path / "s.jsonl"))
    return KioskSession(cfg, **kw)


def test_dirty_tiles_cover_every_pixel_that_changes(tmp_path) -> None:  # type: ignore[no-untyped-def]
    s = _session(tmp_path, (256, 192))
    try:
        s.take_dirty()  # the first full render
        ts = int(s.canvas.params.tile_size)
        before = s.canvas.render()
        s.command("brush", size=10, water=1.0, pigment={"French Ultramarine": 0.5})
        for i in range(8):
            s.handle("pen", PenSample(t=0.01 * i, device="p", tool=Tool.PEN, x=0.3 + 0.02 * i,
                                      y=0.4, pressure=0.8, touching=True, t_mono=1.0 + i))
        assert len(s.awaiting_paint) == 8 and s.painted_stamps > 0
        for _ in range(20):
            s.step()
        after = s.canvas.render()
        dirty = s.take_dirty()
        changed = np.abs(after - before).max(axis=2) > 0
        ys, xs = np.nonzero(changed)
        assert ys.size > 0
        assert dirty[ys // ts, xs // ts].all()  # nothing changed outside the dirty tiles
        assert dirty.mean() < 0.5  # and not everything is re-rendered
        assert not s.take_dirty().any()  # taken
        s.command("clear")
        assert s.take_dirty().all()  # a whole-canvas command
        assert s.player.counters.commands["clear"] == 1
    finally:
        s.shutdown()
    log = (tmp_path / "s.jsonl").read_text()
    assert '"cmd": "brush"' in log and '"cmd": "clear"' in log


def test_the_screen_is_mapped_and_window_commands_stay_out_of_the_canvas(tmp_path) -> None:  # type: ignore[no-untyped-def]
    seen: list[str] = []

    def mapper(s: PenSample) -> PenSample | None:
        return None if s.x < 0.3 else s.with_(x=(s.x - 0.3) / 0.7)

    s = _session(tmp_path, map_pen=mapper, kiosk_command=lambda c: seen.append(c.cmd) or
                 c.cmd == "view")
    try:
        s.handle("pen", PenSample(t=0, device="p", tool=Tool.PEN, x=0.1, y=0.5, touching=True,
                                  pressure=0.5))
        assert s.counters.samples == 0 and s.last_pen is not None and s.last_canvas_pen is None
        s.handle("pen", PenSample(t=0, device="p", tool=Tool.ERASER, x=0.65, y=0.5))
        assert s.counters.samples == 1 and s.last_canvas_pen.x == pytest.approx(0.5)
        assert s.eraser_selected()
        s.handle("cmd", Command(t=0, cmd="view", args={"name": "3d"}))
        s.handle("cmd", Command(t=0, cmd="dry", args={}))
        assert seen == ["view", "dry"] and s.counters.commands == 1  # only dry reached the player
    finally:
        s.shutdown()


def test_cpu_display_texture_equals_a_full_render(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from station.glkit.context import GLUnavailable, create_context
    from station.kiosk.display import CpuDisplay

    try:
        import moderngl

        ctx = moderngl.create_context(standalone=True, backend="egl")
    except Exception as exc:  # no EGL here
        pytest.skip(f"no EGL context: {exc}")
    del create_context, GLUnavailable
    s = _session(tmp_path)
    try:
        disp = CpuDisplay(ctx, s)
        disp.update()
        s.command("brush", size=12, water=1.0, pigment={"Hansa Yellow": 0.6})
        for i in range(6):
            s.handle("pen", PenSample(t=0.01 * i, device="p", tool=Tool.PEN, x=0.5 + 0.03 * i,
                                      y=0.5, pressure=0.9, touching=True))
        # stamps not yet simulated are on screen at once (the preview)
        cells = disp.update()
        tex = disp.read()[..., :3]
        preview_only = render_state(s.cpu_state, "km")
        assert cells < 96 * 64 and (np.abs(tex - preview_only).max(axis=2) > 0.01).sum() > 20
        for _ in range(10):
            s.step()
            disp.update()
        # the tiles render on a time budget a frame: a slow machine needs more frames
        frames = 0
        while disp.behind() and frames < 1000:
            disp.update()
            frames += 1
        assert not disp.behind()
        tex = disp.read()
        # nothing pending: the texture is the canvas's (the compiled KM: to float32
        # rounding), its colour extended by the paint and the contour level
        assert s.player.brush.pending == 0
        assert np.abs(tex - disp.expected()).max() < 2e-6
        inside = tex[..., 3] >= 0.999
        assert inside.sum() > 20
        assert np.abs(tex[..., :3] - s.canvas.render())[inside].max() < 2e-6
    finally:
        s.shutdown()
        ctx.release()


def test_panel_controls_send_commands() -> None:
    from station.canvas.palette import default_palette
    from station.kiosk.ui import PanelState, swatch, undo_available

    sent: list[tuple[str, dict]] = []
    saved: list[int] = []
    p = PanelState(default_palette(), lambda c, a: sent.append((c, a)),
                   lambda: saved.append(1), mix={})
    p.add_pigment("Hansa Yellow")
    p.add_pigment("Hansa Yellow")
    p.add_pigment("Phthalo Green")
    assert sent[-1] == ("brush", {"kind": "round", "size": 24.0, "water": 0.8, "pigment": {
        "Hansa Yellow": pytest.approx(0.8 * 2 / 3), "Phthalo Green": pytest.approx(0.8 / 3)}})
    for name in ("Black", "Cadmium Red", "Burnt Umber"):
        p.add_pigment(name)
    assert len(p.mix) == 4 and "Burnt Umber" not in p.mix and "fresh mix" in p.message
    p.set_water(0.3)
    assert sent[-1][1]["water"] == 0.3
    p.ask_clear()
    assert sent[-1][0] == "brush"  # nothing until confirmed
    p.answer_clear(True)
    assert sent[-1] == ("clear", {})
    p.simple("dry")
    p.save()
    assert sent[-1] == ("dry", {}) and saved == [1]
    # the mix swatch is the KM colour: yellow + green is a yellow-green, white paper is white
    r, g, b = swatch(default_palette(), {"Hansa Yellow": 1, "Phthalo Green": 1}, 1.0)
    assert g > r > b
    assert swatch(default_palette(), {}) == (1.0, 1.0, 1.0)
    assert undo_available() is True  # the player runs `undo` (issue 14)
    assert p.can_undo() is False  # a panel without a painting has nothing to undo


def test_compiled_km_matches_the_reference() -> None:
    from station.canvas.palette import default_palette
    from station.render.km import km_layer
    from station.render.km_fast import km_layer_fast

    pal = default_palette()
    pigs = [pal.get(n) for n in ("French Ultramarine", "Hansa Yellow", "Burnt Umber", "Black")]
    rng = np.random.default_rng(0)
    a = (rng.random((4, 60, 80)) * 0.6).astype(np.float32)
    a[:, :10] = 0.0  # bare paper
    a[:, 10:20] = 1e-7  # nearly none: the b -> 0 branch and tiny d
    a[:, 20:30] = 50.0  # thick: t capped at 30
    r = (0.6 + 0.4 * rng.random((60, 80, 3))).astype(np.float32)
    ref = km_layer(a, pigs, r)
    assert np.abs(km_layer_fast(a, pigs, r) - ref).max() < 2e-6
    assert np.array_equal(km_layer_fast(a, [], r), r)


@pytest.mark.parametrize(("argv", "where"), [
    (["kiosk", "--bus", "@ipc:x"], "--bus"),
    (["kiosk", "--size", "3x3"], "--size"),
    (["kiosk", "--serve", "no-port"], "--serve"),
    (["kiosk", "--idle-minutes", "0"], "--idle-minutes"),
    (["kiosk", "--attract-after", "-1"], "--attract-after"),
    (["kiosk", "--windowed", "10"], "--windowed"),
    (["bench", "latency", "--seconds", "0"], "--seconds"),
    (["bench", "latency", "--rate", "5"], "--rate"),
    (["bench", "latency", "--predict-ms", "-1"], "--predict-ms"),
    (["bench", "latency", "--brush", "broom"], "--brush"),
    (["bench", "latency", "--window", "100x50"], "--window"),
    (["kiosk", "--mouse-pressure", "hard"], "--mouse-pressure"),
    (["kiosk", "--predict-ms", "500"], "--predict-ms"),
])
def test_bad_flags_exit_2_with_one_line(argv: list[str], where: str) -> None:
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "station", *argv], capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and where in lines[0], proc.stderr


def test_the_mouse_pen_smooths_jitter_and_presses_by_speed() -> None:
    from station.kiosk.mouse import PRESSURE_FAST, PRESSURE_SLOW, MousePen, parse_pressure

    rng = np.random.default_rng(1)
    pen = MousePen((4000, 1000), pressure=None)
    pen.move(100, 500, 0.0, 0.0)
    pen.button(True, 0.0, 0.0)
    raw = []
    for i in range(1, 120):  # a slow, straight drag (60 px/s) with a finger's 3 px jitter
        t = i / 120
        yy = 500 + rng.normal(0, 3.0)
        raw.append(yy)
        pen.move(100 + 60 * t, yy, t, t)
    slow = pen.take()
    ys = np.array([s.y * 1000 for s in slow[20:]])
    assert np.std(ys - 500) < 0.4 * np.std(np.array(raw[20:]) - 500)  # jitter removed
    assert all(s.touching for s in slow[1:]) and slow[-1].pressure > PRESSURE_SLOW - 0.1
    for i in range(1, 60):  # then fast (3000 px/s): lighter
        t = 1 + i / 120
        pen.move(160 + 3000 * (t - 1), 500, t, t)
    fast = pen.take()
    assert fast[-1].pressure < PRESSURE_FAST + 0.1
    # on a fast stroke the filter keeps up (lag well under 10 ms of travel)
    assert abs(fast[-1].x * 4000 - (160 + 3000 * 59 / 120)) < 30
    pen.button(False, 2.0, 2.0)
    assert pen.take()[-1].touching is False
    assert parse_pressure("speed") is None and parse_pressure("0.4") == 0.4
    with pytest.raises(BadInput):
        parse_pressure("2")


def test_the_mouse_sets_the_brush_down_from_the_tip_and_reads_speed_per_screen() -> None:
    from station.kiosk.mouse import ATTACK_FROM, ATTACK_S, MousePen

    pen = MousePen((1920, 1080), pressure=0.7)
    pen.move(500, 500, 0.0, 0.0)
    pen.button(True, 0.0, 0.0)
    for i in range(1, 30):  # 200 Hz, 0.145 s
        pen.move(500 + 2 * i, 500, i / 200, i / 200)
    p = [s.pressure for s in pen.take() if s.touching]
    # the stroke starts at the tip (main: 0.6 from the first sample, a round stamp) and
    # swells to the held pressure within ATTACK_S
    assert p[0] == pytest.approx(0.7 * ATTACK_FROM)
    assert all(b >= a for a, b in itertools.pairwise(p))
    assert p[int(200 * ATTACK_S) + 1] == pytest.approx(0.7) and p[-1] == pytest.approx(0.7)
    # the same hand movement (a tenth of the screen's height in 0.1 s) presses the same
    # on a 1080 and a 2160 screen
    got = []
    for size in ((1920, 1080), (3840, 2160)):
        m = MousePen(size)
        m.move(100, 100, 0.0, 0.0)
        m.button(True, 0.0, 0.0)
        for i in range(1, 60):
            m.move(100 + size[1] * i / 200, 100, i / 200, i / 200)
        got.append(m.take()[-1].pressure)
    assert got[0] == pytest.approx(got[1], abs=0.01) and 0.3 < got[0] < 0.8


def test_the_compiled_subcell_fields_match_their_definition() -> None:
    from station.kiosk.subcell import fields, fields_reference

    rng = np.random.default_rng(3)
    painted = rng.random((50, 70)) > 0.8
    painted[10:30, 20:50] = True  # a wash with ragged surroundings and lone cells
    rgb = rng.random((50, 70, 3)).astype(np.float32)
    for inner in [(slice(0, 50), slice(0, 70)), (slice(3, 47), slice(3, 67))]:
        got = fields(rgb, painted, inner)
        assert np.abs(got - fields_reference(rgb, painted, inner)).max() < 1e-6
    whole = fields(rgb, painted, (slice(0, 50), slice(0, 70)))
    lvl = whole[..., 3]
    assert (lvl[12:28, 22:48] > 0.99).all()  # inside the wash: the contour level is 1
    # a blank cell beside paint takes the mean colour of its painted neighbours
    p2 = np.zeros((6, 6), bool)
    p2[2, 1] = p2[3, 1] = True
    c2 = np.full((6, 6, 3), 0.9, np.float32)
    c2[2, 1], c2[3, 1] = (0.2, 0.3, 0.4), (0.4, 0.5, 0.6)
    f2 = fields(c2, p2, (slice(0, 6), slice(0, 6)))
    assert np.allclose(f2[2, 2, :3], (0.3, 0.4, 0.5)) and np.allclose(f2[2, 4, :3], 0.9)
    assert f2[2, 1, 3] > 0.5 > f2[2, 3, 3]  # the contour runs between paint and paper


def test_station_send_reaches_the_kiosk_with_its_window_commands(tmp_path) -> None:  # type: ignore[no-untyped-def]
    import subprocess
    import sys

    from station.answer import Answerer, parse_request
    from station.bus import Subscriber, runtime_dir

    ep = f"ipc://{tmp_path}/kiosk-cmd"
    sub = Subscriber("@" + ep, topics=("cmd",))
    try:
        got = []
        for words in (["view", "name=3d"], ["fresh"], ["screenshot", "name=top-1"]):
            proc = subprocess.Popen([sys.executable, "-m", "station", "send", *words, "--to",
                                     ">" + ep], stderr=subprocess.PIPE, text=True)
            msg = None
            for _ in range(200):  # a generous deadline: the sender starts a Python
                msg = sub.recv(100)
                if msg is not None:
                    break
            if msg is not None and msg.value.reply:  # answer as the kiosk does
                req = parse_request(msg.value.reply, runtime_dir())
                Answerer("kiosk").answer(req, msg.value.cmd, True, "taken", "test")
            _, err = proc.communicate(timeout=60)
            assert proc.returncode == 0, err
            assert msg is not None
            got.append((msg.value.cmd, msg.value.args))
        assert got == [("view", {"name": "3d"}), ("fresh", {}),
                       ("screenshot", {"name": "top-1"})]
    finally:
        sub.close()
    proc = subprocess.run([sys.executable, "-m", "station", "send", "view", "name=4d", "--to",
                           ">" + ep, "--timeout", "0.2"], capture_output=True, text=True,
                          timeout=60)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and "view" in lines[0], proc.stderr
    from station.kiosk.commands import check_kiosk_command

    for cmd, args in (("screenshot", {"name": "../x"}), ("fresh", {"now": 1}),
                      ("message", {"text": " "})):
        with pytest.raises(BadInput):
            check_kiosk_command(Command(t=0, cmd=cmd, args=args))


def test_the_status_tells_wet_damp_and_dry(tmp_path) -> None:  # type: ignore[no-untyped-def]
    s = _session(tmp_path)
    try:
        s.command("brush", size=10, water=1.0, pigment={"French Ultramarine": 0.5})
        for i in range(6):
            s.handle("pen", PenSample(t=0.01 * i, device="p", tool=Tool.PEN, x=0.3 + 0.03 * i,
                                      y=0.5, pressure=0.8, touching=True))
        s.step()
        m = s.moisture()
        assert m is not None and m.word == "wet" and m.line().startswith("wet ")
        st = s.cpu_state
        st.wc[st.w > 0] = 0.05  # the surface water gone into the paper
        st.w[:] = 0.0
        m = s.moisture()
        assert m.word == "damp" and m.wet == 0 and m.damp > 0.01
        assert m.line().startswith("damp ") and "wet" not in m.line()
        st.wc[:] = 0.0
        assert s.moisture().word == "dry" and s.moisture().line() == "dry"
    finally:
        s.shutdown()


def test_a_tap_picks_mixing_is_a_mode_with_a_preview_and_swatches_differ() -> None:
    import itertools

    from station.canvas.palette import default_palette
    from station.kiosk.ui import PanelState, mix_words, swatch_pair

    sent: list[tuple[str, dict]] = []
    p = PanelState(default_palette(), lambda c, a: sent.append((c, a)), lambda: None,
                   mix={"Black": 1.0})
    p.tap_pigment("Hansa Yellow")
    p.tap_pigment("French Ultramarine")  # a tap picks: the colour in the brush is that one
    assert p.mix == {"French Ultramarine": 1.0}
    assert sent[-1][1]["pigment"] == {"French Ultramarine": pytest.approx(p.strength)}
    p.toggle_mixing()
    p.hovered = "Hansa Yellow"  # the pen over a swatch while mixing: the preview
    assert p.preview_mix() == {"French Ultramarine": 1.0, "Hansa Yellow": 1.0}
    assert p.mix == {"French Ultramarine": 1.0}  # ... changes nothing yet
    p.tap_pigment("Hansa Yellow")
    p.tap_pigment("Hansa Yellow")
    assert p.mix == {"French Ultramarine": 1.0, "Hansa Yellow": 2.0}
    assert mix_words(p.mix) == "1 French Ultramarine + 2 Hansa Yellow"
    p.toggle_mixing()
    p.tap_pigment("Cadmium Red")
    assert p.mix == {"Cadmium Red": 1.0}
    # every swatch (masstone and wash) differs from every other by a visible step
    pal = default_palette()
    look = {n: np.array(swatch_pair(pal, n)).ravel() for n in pal.names()}
    worst = min(np.abs(look[a] - look[b]).max() for a, b in itertools.combinations(look, 2))
    assert worst > 0.12, worst


def test_without_replays_the_attract_screen_paints_a_demo_stroke(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from station.kiosk.attract import AttractShow, demo_stroke

    show = AttractShow(tmp_path)  # an empty gallery
    show.start(0.0)
    assert not show.playing and show.frame(1.0) == (None, False)
    early, later = demo_stroke(0.5, 800, 600), demo_stroke(3.0, 800, 600)
    assert 2 <= len(early) < len(later)  # the stroke paints itself along
    assert all(0 <= x <= 800 and 0 <= y <= 600 for x, y in later)


def test_a_live_painting_held_by_another_kiosk_is_neither_resumed_nor_removed(tmp_path) -> None:  # type: ignore[no-untyped-def]
    import os

    pytest.importorskip("glfw")
    from station.kiosk.app import hold_live_log, painting_in_progress

    header = '{"format": "station-session", "version": 1}\n'
    stroke = tmp_path / "20260101-000000-aaaaaa.jsonl"
    stroke.write_text(header + '{"type": "pen", "touching": true}\n')
    empty = tmp_path / "20260101-000001-bbbbbb.jsonl"
    empty.write_text(header)
    held = [hold_live_log(stroke), hold_live_log(empty)]  # a kiosk beside this one
    assert painting_in_progress(tmp_path) is None
    assert stroke.exists() and empty.exists()  # not its to remove
    for fd in held:
        os.close(fd)
    assert painting_in_progress(tmp_path) == stroke and not empty.exists()


def test_the_safety_net_while_the_pen_paints_is_a_rolling_band_not_a_whole_frame() -> None:
    """A partial-presenting window is presented whole once a second in case the X server
    lost pixels; on a software rasteriser that whole frame is the slowest of all (at
    3840×2160 60-130 ms), so while the pen paints a band of rows rolls down the window
    instead, every row presented again within ROLL_PERIOD_S (main: a whole frame every
    10 s)."""
    from types import SimpleNamespace

    from station.kiosk.present import FULL_EVERY_S, ROLL_PERIOD_S, Presenter

    glfw = SimpleNamespace(set_window_refresh_callback=lambda window, cb: None)
    p = Presenter(glfw, None, "llvmpipe", (3840, 2160), mode="swap")
    p._copy_sub = object()  # as if GLX_MESA_copy_sub_buffer were there
    p.whole_next = False
    assert FULL_EVERY_S == 1.0 and ROLL_PERIOD_S <= 10.0
    assert p.needs_whole(10.0, 8.5)  # idle: a whole frame after a second
    assert not p.needs_whole(10.0, 8.5, painting=True)  # painting: never on the clock
    assert not p.needs_whole(100.0, 8.5, painting=True)
    # frames at 200 Hz: bands of a few rows going down, every row once a period
    assert p.rolling_band(0.0) is None
    rows = np.zeros(2160, int)
    widest, k = 0, 0
    while rows[-1] == 0 and k < 10_000:
        k += 1
        band = p.rolling_band(k / 200)
        if band is None:
            continue
        assert band[0] == 0 and band[2] == 3840
        rows[band[1]:band[3]] += 1
        widest = max(widest, band[3] - band[1])
    assert (rows == 1).all() and widest <= 3  # every row, once; a few rows a frame
    assert abs(k / 200 - ROLL_PERIOD_S) < 0.05
    p.lost()
    assert p.needs_whole(10.0, 9.9, painting=True)  # an expose: at once, painting or not
