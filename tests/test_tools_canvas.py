"""Masking fluid, the selective eraser and the textured tissue (issue 14, items 1, 3, 4, 9)."""

from __future__ import annotations

import numpy as np
import pytest

from station.arttools import eraser, mask, tissue
from station.backends.factory import create_backend, numba_available
from station.canvas.stats import canvas_stats
from station.errors import BadInput
from station.events import Command, PenSample
from station.sim.player import SessionPlayer

W, H = 48, 32
BLUE, YELLOW = "French Ultramarine", "Hansa Yellow"



def pen(t: float, x: float, y: float, touching: bool = True, tool: str = "pen",
        pressure: float = 1.0) -> PenSample:
    return PenSample(t=t, device="d", tool=tool, x=x, y=y,  # type: ignore[arg-type]
                     pressure=pressure if touching else 0.0, touching=touching)


def balanced(st) -> None:
    b = canvas_stats(st, "numpy")["balance"]
    assert b["water_rel_error"] < 1e-5 and b["pigment_rel_error"] < 1e-5


def test_masked_cells_are_bit_identical_after_painting_over_them() -> None:
    b = create_backend("numpy", W, H, seed=2)
    b.add_sources(0.6 * np.ones((8, 10), np.float32), {YELLOW: 0.2 * np.ones((8, 10),
                                                                             np.float32)},
                  y0=4, x0=4)
    for _ in range(60):
        b.step()
    b.dry()
    st = b.live_state
    mask.paint(st, 16.0, 12.0, 6.0)
    masked = st.mask > 0
    assert masked.sum() > 90 and masked[12, 16] and not masked[8, 30]
    before = st.copy()
    wash = np.ones((H - 4, W - 4), np.float32)
    b.add_sources(0.9 * wash, {BLUE: 0.3 * wash}, y0=2, x0=2)
    for _ in range(40):
        b.step()
    for name in ("w", "wc", "vx", "vy", "p", "q"):
        a, c = getattr(before, name), getattr(st, name)
        assert a[..., masked].tobytes() == c[..., masked].tobytes(), name
    k = st.slots.index(BLUE)
    assert st.p[k][~masked].sum() + st.q[k][~masked].sum() > 100  # painted around it
    # rubbing the mask off leaves the crisp hole: no blue inside, blue right outside
    mask.rub_off(st)
    assert not st.mask.any()
    assert (st.p[k] + st.q[k])[masked].max() == 0
    ring = np.zeros_like(masked)
    ring[1:-1, 1:-1] = masked[1:-1, 1:-1] & ~masked[:-2, 1:-1]
    out = np.roll(ring, -1, axis=0) & ~masked
    assert (st.p[k] + st.q[k])[out].min() > 0.01
    balanced(st)
    shown = mask.overlay(b.render(), before.mask)
    assert not np.array_equal(shown[masked], b.render()[masked])


def test_eraser_removes_only_the_chosen_pigment_and_field() -> None:
    b = create_backend("numpy", W, H, seed=2)
    a = np.ones((H, W), np.float32)
    b.add_sources(0.8 * a, {BLUE: 0.2 * a, YELLOW: 0.2 * a})
    for _ in range(20):
        b.step()
    st = b.live_state
    before = st.copy()
    kb, ky = st.slots.index(BLUE), st.slots.index(YELLOW)
    er = eraser.Eraser(fields=(f"p:{BLUE}",), fraction=0.8, radius=6.0)
    hit = eraser.erase(st, er, 24.0, 16.0)
    assert st.p[kb][16, 24] < 0.25 * before.p[kb][16, 24]
    assert np.array_equal(st.p[kb][~hit], before.p[kb][~hit])
    for name in ("w", "wc", "q"):
        assert np.array_equal(getattr(st, name), getattr(before, name)), name
    assert np.array_equal(st.p[ky], before.p[ky])
    # the next dab of the stroke skips the cells the previous one hit
    p_mid = st.p[kb].copy()
    hit2 = eraser.erase(st, er, 27.0, 16.0, previous=hit)
    assert np.array_equal(st.p[kb][hit], p_mid[hit]) and hit2.any()
    # water of the capillary layer only
    er_wc = eraser.Eraser(fields=("wc",), fraction=1.0, radius=4.0)
    wc0, w0 = st.wc.copy(), st.w.copy()
    eraser.erase(st, er_wc, 10.0, 10.0)
    assert st.wc[10, 10] < 0.1 * wc0[10, 10] and wc0[10, 10] > 0 and np.array_equal(st.w, w0)
    balanced(st)
    with pytest.raises(BadInput):
        eraser.Eraser(fields=("z",))


def test_tissue_removes_more_where_its_texture_is_high_and_nothing_elsewhere() -> None:
    b = create_backend("numpy", W, H, seed=2)
    a = np.ones((H, W), np.float32)
    b.add_sources(0.8 * a, {BLUE: 0.3 * a})
    b.step()
    st = b.live_state
    before = st.copy()
    t = tissue.Tissue(kind="weave", scale=4.0, radius=10.0, absorb=0.9)
    tex = tissue.texture(t.kind, H, W, t.scale)
    taken, blotted = tissue.blot(st, t, tex, 24.0, 16.0)
    assert taken > 10
    lost = before.w - st.w
    inside = blotted
    hi, lo = inside & (tex > 0.7), inside & (tex < 0.2)
    assert hi.sum() > 20 and lo.sum() > 20
    assert lost[hi].mean() > 4 * lost[lo].mean()  # the imprint of the weave
    assert np.array_equal(st.w[~inside], before.w[~inside])  # untouched: nothing
    assert np.array_equal(st.p[0][~inside], before.p[0][~inside])
    # the same press again blots nothing more; a new press does
    w1 = st.w.copy()
    tissue.blot(st, t, tex, 25.0, 16.0, blotted=blotted)
    assert np.array_equal(st.w[blotted], w1[blotted])
    balanced(st)
    assert np.corrcoef(lost[inside], tex[inside])[0, 1] > 0.9
    crepe = tissue.texture("crepe", H, W, 4.0, seed=1)
    assert crepe.min() >= 0 and crepe.max() <= 1 and crepe.std() > 0.1


def tool_session() -> list[PenSample | Command]:
    return [
        Command(t=0.0, cmd="mask", args={"size": 10, "x": 0.3, "y": 0.5}),
        Command(t=0.05, cmd="brush", args={"size": 14, "water": 1.0,
                                           "pigment": {BLUE: 0.5}}),
        pen(0.1, 0.1, 0.5), pen(0.4, 0.9, 0.5), pen(0.42, 0.9, 0.5, touching=False),
        Command(t=0.5, cmd="tissue", args={"kind": "weave", "scale": 3, "size": 12}),
        pen(0.55, 0.6, 0.5), pen(0.6, 0.6, 0.5), pen(0.62, 0.6, 0.5, touching=False),
        Command(t=0.7, cmd="eraser", args={"fields": ["w", f"p:{BLUE}"], "fraction": 0.7,
                                           "size": 8}),
        pen(0.75, 0.8, 0.4), pen(0.8, 0.85, 0.45), pen(0.82, 0.85, 0.45, touching=False),
        pen(0.9, 0.2, 0.5, tool="eraser"), pen(0.92, 0.2, 0.5, touching=False, tool="eraser"),
        Command(t=1.0, cmd="tilt", args={"angle": 45, "direction": 90}),
        Command(t=1.5, cmd="mask_remove", args={}),
    ]


def play(backend: str) -> SessionPlayer:
    b = create_backend(backend, W, H, seed=3)
    p = SessionPlayer(b, W, H)
    p.play(tool_session())
    p.settle(0.5)
    return p


def test_tool_commands_replay_bit_identically() -> None:
    a, b = play("numpy"), play("numpy")
    sa, sb = a.backend.state(), b.backend.state()
    for name in ("w", "wc", "p", "q", "removed_w", "removed_p", "mask"):
        assert getattr(sa, name).tobytes() == getattr(sb, name).tobytes(), name
    assert a.counters.commands == {"mask": 1, "brush": 1, "tissue": 1, "eraser": 1,
                                   "tilt": 1, "mask_remove": 1}
    assert not a.counters.skipped_commands
    assert sa.params.tilt == 45 and float(sa.removed_w.sum()) > 1
    balanced(sa)
    if numba_available():
        sc = play("cpu").backend.state()
        for name in ("w", "wc", "p", "q", "removed_w", "removed_p"):
            assert getattr(sa, name).tobytes() == getattr(sc, name).tobytes(), name


@pytest.mark.parametrize("cmd, args, what", [
    ("tissue", {"kind": "silk"}, "kind"),
    ("tissue", {"absorb": 2}, "absorb"),
    ("eraser", {"fields": ["q:Unobtainium"], "x": 0.5, "y": 0.5}, "Unobtainium"),
    ("eraser", {"fields": "w"}, "list"),
    ("mask", {"size": -1}, "size"),
    ("mask", {"colour": 1}, "colour"),
    ("tilt", {"angle": 91}, "angle"),
    ("mask_remove", {"all": True}, "all"),
])
def test_bad_tool_arguments_are_bad_input_naming_the_line(cmd: str, args: dict, what: str
                                                         ) -> None:
    b = create_backend("numpy", W, H, seed=3)
    p = SessionPlayer(b, W, H)
    with pytest.raises(BadInput) as ei:
        p.play([Command(t=0.0, cmd=cmd, args=args)], where=lambda: "s.jsonl:7")
    assert str(ei.value).startswith("s.jsonl:7:") and what in str(ei.value)


def test_tool_session_on_the_gl_backend_agrees_with_the_reference() -> None:
    gl = pytest.importorskip("station.backends.gl")
    try:
        gl.create_context().release()
    except gl.GLUnavailable as exc:
        pytest.skip(f"no OpenGL 4.3 context: {exc}")
    ref = play("numpy").backend.state()
    got = play("gl").backend.state()
    assert np.array_equal(got.mask, ref.mask)
    for name in ("w", "p", "q", "removed_w"):
        a, b = getattr(got, name).astype(np.float64), getattr(ref, name)
        assert np.abs(a - b).max() <= 1e-3 * max(1.0, float(np.abs(b).max())), name


def test_tissue_texture_from_a_grayscale_image(tmp_path) -> None:
    pil = pytest.importorskip("PIL.Image")
    a = np.zeros((4, 6), np.uint8)
    a[:, ::2] = 255
    pil.fromarray(a).save(tmp_path / "t.png")
    tex = tissue.texture("flat", 10, 13, image=str(tmp_path / "t.png"))
    assert tex.shape == (10, 13) and tex[0, 0] == 1 and tex[0, 1] == 0 and tex[5, 12] == 1
    (tmp_path / "bad.png").write_bytes(b"not a png")
    with pytest.raises(BadInput, match=r"bad\.png"):
        tissue.texture("flat", 10, 13, image=str(tmp_path / "bad.png"))


def test_station_send_checks_tool_arguments_like_the_player() -> None:
    from station.sim.player import check_command

    check_command(Command(t=0.0, cmd="tissue", args={"kind": "weave"}))
    check_command(Command(t=0.0, cmd="undo", args={}))
    for cmd, args in (("tissue", {"kind": "silk"}), ("eraser", {"fraction": 2}),
                      ("tilt", {"angle": -1}), ("well", {"add": "Nope"})):
        with pytest.raises(BadInput):
            check_command(Command(t=0.0, cmd=cmd, args=args), where="send")
