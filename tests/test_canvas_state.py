"""Canvas state: lossless save/load, tiling on/off equivalence, operations, bad input."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np
import pytest

from station.backends.factory import create_backend
from station.backends.numpy_canvas import NumpyCanvas
from station.canvas.palette import default_palette
from station.canvas.paper import PAPER_PRESETS, make_paper
from station.canvas.params import SimParams
from station.canvas.profiles import PROFILES, get_profile
from station.canvas.state import CanvasState
from station.errors import BadInput
from station.pictures.scenarios import disc, paint, rect

FIELDS = ("vx", "vy", "w", "wc", "p", "q", "evaporated", "r_composed", "tile_ttl",
          "wet_area")


def _session(c: NumpyCanvas, steps: int = 80) -> None:
    """A small deterministic painting: two strokes, velocity, a second pigment."""
    paint(c, disc(c.height, c.width, 20, 20, 7), 0.6, {"French Ultramarine": 0.1}, vx=20.0)
    for i in range(steps):
        if i == 30:
            paint(c, rect(c.height, c.width, 30, 40, 10, 60), 0.5, {"Cadmium Red": 0.08},
                  vy=-15.0)
        c.step()


def test_save_load_continues_bitwise(tmp_path: Path) -> None:
    a = NumpyCanvas(72, 56, seed=11)
    _session(a, 40)
    path = tmp_path / "state.npz"
    a.save(str(path))
    b = NumpyCanvas(8, 8, profile="ink")  # anything: load replaces it all
    b.load(str(path))
    for c in (a, b):
        paint(c, disc(56, 72, 40, 50, 5), 0.4, {"Hansa Yellow": 0.1})
        for _ in range(60):
            c.step()
    sa, sb = a.live_state, b.live_state
    for f in FIELDS:
        assert np.array_equal(getattr(sa, f), getattr(sb, f)), f
    assert sa.wet_area.any()  # the wet-area memory (watercolor's wet_hold) was carried on
    assert sa.slots == sb.slots and sa.step_count == sb.step_count
    assert sa.sim_time == sb.sim_time
    assert a.stats() == b.stats()
    assert np.array_equal(a.render(), b.render())


def test_a_state_saved_without_the_wet_area_loads_with_none(tmp_path: Path) -> None:
    a = NumpyCanvas(40, 36, seed=3)
    _session(a, 30)
    path = tmp_path / "old.npz"
    a.save(str(path))
    with np.load(path) as z:
        old = {k: z[k] for k in z.files if k != "wet_area"}
    np.savez_compressed(path, **old)  # a state from before the field existed
    b = CanvasState.load(path)
    assert b.wet_area.shape == (36, 40) and not b.wet_area.any()
    assert np.array_equal(b.w, a.live_state.w)


def test_save_load_keeps_layers_profile_params_palette(tmp_path: Path) -> None:
    prm = SimParams().replace(nu_p=0.123456789)
    a = NumpyCanvas(40, 40, seed=3, params=prm)
    paint(a, disc(40, 40, 20, 20, 6), 0.5, {"Cerulean Blue": 0.1})
    a.new_layer()
    a.set_profile("gouache")
    paint(a, disc(40, 40, 20, 20, 4), 0.5, {"Titanium White": 0.3})
    path = tmp_path / "s.npz"
    a.save(str(path))
    st = CanvasState.load(path)
    assert st.profile == "gouache" and st.layers == a.live_state.layers
    assert st.params == a.live_state.params
    assert st.palette.names() == a.live_state.palette.names()
    assert np.array_equal(st.r_composed, a.live_state.r_composed)
    assert np.array_equal(st.h, a.live_state.h)
    b = NumpyCanvas(40, 40)
    b.load_state(st)
    assert np.array_equal(a.render(), b.render())


def test_tiling_on_off_same_painting() -> None:
    on = NumpyCanvas(96, 80, seed=5, tiling=True)
    off = NumpyCanvas(96, 80, seed=5, tiling=False)
    for c in (on, off):
        _session(c, 150)
    for f in ("vx", "vy", "w", "wc", "p", "q", "evaporated", "wet_area"):
        a, b = getattr(on.live_state, f), getattr(off.live_state, f)
        assert np.allclose(a, b, atol=1e-6, rtol=1e-5), f
    assert np.allclose(on.render(), off.render(), atol=1e-6)


def test_tiles_simulate_only_the_active_region_and_retire_when_dry() -> None:
    prm = SimParams().replace(tile_size=16)
    c = NumpyCanvas(96, 96, seed=2, params=prm)
    st = c.live_state
    paint(c, disc(96, 96, 10, 10, 5), 0.5, {"Black": 0.05})
    assert (st.tile_ttl > 0).sum() == 1  # one 16x16 tile touched
    far = st.h.copy()
    for _ in range(30):
        c.step()
    assert (st.tile_ttl[3:, 3:] == 0).all()
    assert np.array_equal(st.h, far)
    for _ in range(4000):
        c.step()
        if not (st.tile_ttl > 0).any():
            break
    assert not (st.tile_ttl > 0).any()
    assert not (st.w > 0).any() and not (st.wc > 0).any()


def test_tiles_follow_capillary_expansion_across_tile_borders() -> None:
    prm = SimParams().replace(tile_size=8, cap_diffusion=3.5, moist_threshold=0.05, alpha=0.3)
    on = NumpyCanvas(48, 48, seed=9, params=prm, tiling=True)
    off = NumpyCanvas(48, 48, seed=9, params=prm, tiling=False)
    for c in (on, off):
        paint(c, rect(48, 48, 4, 8, 4, 8), 0.9, {"Sumi Ink": 0.1})
        for _ in range(90):
            c.step()
    assert (off.live_state.wc[:, 8:] > 0.01).any()  # water left the first tile
    assert np.allclose(on.live_state.wc, off.live_state.wc, atol=1e-6)
    assert np.allclose(on.live_state.q, off.live_state.q, atol=1e-6)


def test_dry_new_layer_clear() -> None:
    c = NumpyCanvas(40, 40, seed=1)
    paint(c, disc(40, 40, 20, 20, 8), 0.6, {"Indian Red": 0.1})
    for _ in range(10):
        c.step()
    c.dry()
    st = c.live_state
    assert st.w.max() == 0 and st.wc.max() == 0 and st.p.max() == 0 and st.q.max() > 0
    before = c.render()
    c.new_layer()
    assert st.q.max() == 0 and st.slots == [] and len(st.layers) == 1
    assert np.allclose(c.render(), before, atol=1e-6)  # folded into R_composed
    s = c.stats()
    assert s["pigments"]["Indian Red"]["surface"] > 0
    assert s["balance"]["pigment_rel_error"] < 1e-6
    c.clear()
    assert st.layers == [] and st.q.max() == 0
    assert np.allclose(c.render(), st.paper_reflectance()[..., None].repeat(3, axis=2))
    assert c.stats()["water"]["added"] == 0


def test_nine_pigments_need_a_new_layer_and_nothing_is_lost() -> None:
    c = NumpyCanvas(32, 32)
    names = default_palette().names()
    assert len(names) > 8  # the palette is larger than a layer
    fp = disc(32, 32, 16, 16, 4)
    for n in names[:8]:
        paint(c, fp, 0.1, {n: 0.01})
    snapshot = c.state()
    with pytest.raises(BadInput, match="new layer"):
        paint(c, fp, 0.1, {names[8]: 0.01})
    assert np.array_equal(c.live_state.p, snapshot.p)
    assert np.array_equal(c.live_state.w, snapshot.w)  # the failed call added no water
    c.new_layer()
    paint(c, fp, 0.1, {names[8]: 0.01})
    assert c.live_state.slots == [names[8]]


def test_bad_input() -> None:
    with pytest.raises(BadInput, match="unknown pigment"):
        NumpyCanvas(16, 16).add_sources(dp={"Unobtainium": np.ones((2, 2), np.float32)})
    with pytest.raises(BadInput, match="unknown profile"):
        NumpyCanvas(16, 16, profile="oil")
    with pytest.raises(BadInput, match="unknown profile"):
        NumpyCanvas(16, 16).set_profile("acrylic")
    with pytest.raises(BadInput, match="unknown canvas backend"):
        create_backend("cuda", 16, 16)
    for w, h in ((0, 10), (3, 100), (100000, 100000), (-5, 5)):
        with pytest.raises(BadInput):
            NumpyCanvas(w, h)
    with pytest.raises(BadInput):
        NumpyCanvas(16, 16).add_sources(dw=np.full((4, 4), np.nan, np.float32))
    with pytest.raises(BadInput):
        NumpyCanvas(16, 16).add_sources(dw=-np.ones((4, 4), np.float32))
    with pytest.raises(BadInput):
        SimParams(dt=0.5)  # v_max * dt > 1 cell per step
    with pytest.raises(BadInput):
        make_paper("velvet", 8, 8, 0)


def _corrupt_variants(good: Path, tmp: Path) -> list[Path]:
    out = []
    raw = good.read_bytes()
    (tmp / "garbage.npz").write_bytes(b"not a zip at all")
    out.append(tmp / "garbage.npz")
    (tmp / "truncated.npz").write_bytes(raw[: len(raw) // 2])
    out.append(tmp / "truncated.npz")
    with np.load(good) as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(str(arrays["meta"]))

    def variant(name: str, **changes: np.ndarray) -> None:
        d = {**arrays, **changes}
        with open(tmp / name, "wb") as fh:
            np.savez(fh, **d)
        out.append(tmp / name)

    variant("shape.npz", w=np.zeros((3, 3), np.float32))
    variant("dtype.npz", w=arrays["w"].astype(np.float64))
    variant("nan.npz", wc=np.full_like(arrays["wc"], np.nan))
    variant("version.npz", meta=np.array(json.dumps({**meta, "version": 99})))
    variant("meta.npz", meta=np.array("{broken json"))
    variant("pigment.npz", meta=np.array(json.dumps({**meta, "slots": ["Unobtainium"]})))
    variant("profile.npz", meta=np.array(json.dumps({**meta, "profile": "oil"})))
    variant("size.npz", meta=np.array(json.dumps({**meta, "width": 999})))
    d = dict(arrays)
    d.pop("q")
    with open(tmp / "missing.npz", "wb") as fh:
        np.savez(fh, **d)
    out.append(tmp / "missing.npz")
    with zipfile.ZipFile(tmp / "emptyzip.npz", "w"):
        pass
    out.append(tmp / "emptyzip.npz")
    out.append(tmp / "does-not-exist.npz")
    return out


def test_corrupt_or_mismatched_state_is_bad_input(tmp_path: Path) -> None:
    c = NumpyCanvas(24, 20, seed=1)
    paint(c, disc(20, 24, 10, 10, 4), 0.5, {"Black": 0.1})
    good = tmp_path / "good.npz"
    c.save(str(good))
    CanvasState.load(good)  # sanity: the good one loads
    for bad in _corrupt_variants(good, tmp_path):
        with pytest.raises(BadInput):
            CanvasState.load(bad)
    # a failed load leaves the canvas as it was
    before = c.state()
    with pytest.raises(BadInput):
        c.load(str(tmp_path / "garbage.npz"))
    assert np.array_equal(c.live_state.w, before.w)


def test_profiles_and_papers() -> None:
    assert {"watercolor", "gouache", "ink"} <= set(PROFILES)
    assert get_profile("ink").params.alpha > get_profile("watercolor").params.alpha
    assert get_profile("gouache").renderer == "gouache"
    assert "Titanium White" in get_profile("gouache").pigments
    hs = {}
    for name in PAPER_PRESETS:
        h = make_paper(name, 64, 64, 42)
        assert h.dtype == np.float32 and h.min() >= 0 and h.max() <= 1
        assert np.array_equal(h, make_paper(name, 64, 64, 42))  # seedable
        assert not np.array_equal(h, make_paper(name, 64, 64, 43))
        hs[name] = h
    rough = np.abs(np.diff(hs["rough"], axis=1)).mean()
    smooth = np.abs(np.diff(hs["hot-press"], axis=1)).mean()
    assert rough > 2 * smooth
    # switching profile mid-painting keeps the painting and changes the physics
    c = NumpyCanvas(32, 32)
    paint(c, disc(32, 32, 16, 16, 5), 0.5, {"Black": 0.1})
    c.step()
    c.set_profile("ink")
    assert c.params.alpha == get_profile("ink").params.alpha
    assert c.live_state.q.sum() + c.live_state.p.sum() > 0
    c.step()


def test_masking_fluid_protects_cells_and_bookkeeping_closes() -> None:
    from station.canvas import operations

    c = NumpyCanvas(48, 32, seed=2)
    st = c.live_state
    paint(c, rect(32, 48, 8, 24, 8, 20), 0.5, {"Cadmium Red": 0.1})  # under the mask
    run = 0
    # dry: no standing water, and nothing still suspended on damp paper (issue 21's
    # backruns keep pigment movable while the paper is over half full)
    while ((st.w > 0).any() or (st.p[0] > 0).any()) and run < 4000:
        c.step()
        run += 1
    assert not (st.p[0] > 0).any(), run
    under = st.q[0].copy()
    wc_under = st.wc.copy()
    mask = rect(32, 48, 0, 32, 0, 24)
    operations.apply_mask(st, mask)
    paint(c, rect(32, 48, 4, 28, 4, 44), 0.6, {"Phthalo Green": 0.1}, vx=25.0)
    for _ in range(120):
        c.step()
    k = st.slots.index("Phthalo Green")
    assert st.p[k][:, :24].sum() == 0 and st.q[k][:, :24].sum() == 0
    assert st.w[:, :24].sum() == 0
    assert (st.wc[:, :24] <= wc_under[:, :24]).all()  # the paper under the mask only dries
    assert np.array_equal(st.q[0], under)  # the protected paint is untouched
    assert st.q[k][:, 24:].sum() > 0
    operations.remove_mask(st)
    assert st.mask.max() == 0
    bal = c.stats()["balance"]
    assert bal["water_rel_error"] < 1e-3 and bal["pigment_rel_error"] < 1e-3


def test_numpy_backend_satisfies_the_protocol() -> None:
    from station.backends.protocol import CanvasBackend

    c = create_backend("numpy", 20, 16, "ink", 4, tiles=False)
    assert isinstance(c, CanvasBackend)
    assert (c.width, c.height, c.renderer) == (20, 16, "numpy")
    with pytest.raises(BadInput):
        c.step(dt=1.0)  # more than one cell per step at v_max
    st = c.state()
    assert st.profile == "ink" and st.paper_preset == "rough" and not st.tiling


@pytest.mark.parametrize("profile", ["watercolor", "gouache", "ink"])
def test_random_sessions_keep_invariants_in_every_profile(profile: str) -> None:
    """Random strokes, layers and dries: ranges, bookkeeping and tiling equivalence hold."""
    prof = get_profile(profile)
    runs = {}
    for tiling in (True, False):
        c = NumpyCanvas(56, 44, profile=profile, seed=21, tiling=tiling)
        rng = np.random.default_rng(5)
        st = c.live_state
        for i in range(160):
            if i % 16 == 0:
                cy, cx = rng.uniform(0, 44), rng.uniform(0, 56)
                pig = prof.pigments[int(rng.integers(len(prof.pigments)))]
                paint(c, disc(44, 56, cy, cx, float(rng.uniform(2, 10))),
                      float(rng.uniform(0.2, 1.2)), {pig: float(rng.uniform(0.05, 0.6))},
                      vx=float(rng.uniform(-30, 30)), vy=float(rng.uniform(-30, 30)))
            if i == 90:
                c.new_layer()
            c.step()
        assert st.w.min() >= 0 and st.w.max() <= st.params.w_max + 1e-6
        assert st.wc.min() >= 0 and (st.wc <= st.capacity() + 1e-6).all()
        assert st.p.min() >= 0 and st.p.max() <= 1 + 1e-6
        assert st.q.min() >= 0 and st.q.max() <= 1 + 1e-6
        img = c.render()
        assert np.isfinite(img).all() and img.min() >= 0 and img.max() <= 1
        bal = c.stats()["balance"]
        assert bal["water_rel_error"] < 1e-3 and bal["pigment_rel_error"] < 1e-3
        runs[tiling] = (c.live_state, img)
    for f in ("w", "wc", "p", "q", "vx", "vy"):
        assert np.allclose(getattr(runs[True][0], f), getattr(runs[False][0], f), atol=1e-6), f
    assert np.allclose(runs[True][1], runs[False][1], atol=1e-6)


def test_separate_tile_groups_are_simulated_as_separate_boxes() -> None:
    from station.canvas import tiles

    prm = SimParams().replace(tile_size=16)
    on = NumpyCanvas(128, 96, seed=3, params=prm, tiling=True)
    off = NumpyCanvas(128, 96, seed=3, params=prm, tiling=False)
    for c in (on, off):
        paint(c, disc(96, 128, 8, 8, 5), 0.7, {"Cerulean Blue": 0.2}, vx=30.0)
        paint(c, disc(96, 128, 86, 118, 6), 0.7, {"Indian Red": 0.2}, vy=-30.0)
        paint(c, disc(96, 128, 40, 20, 4), 0.7, {"Indian Red": 0.2})
    boxes = tiles.active_regions(on.live_state)
    assert len(boxes) == 3
    cells = sum((b[0].stop - b[0].start) * (b[1].stop - b[1].start) for b in boxes)
    assert cells < 0.15 * 128 * 96
    for a in boxes:  # disjoint
        for b in boxes:
            if a is not b:
                assert not (a[0].start < b[0].stop and b[0].start < a[0].stop
                            and a[1].start < b[1].stop and b[1].start < a[1].stop)
    for c in (on, off):
        for _ in range(120):
            c.step()
    for f in ("w", "wc", "p", "q", "vx", "vy", "evaporated"):
        assert np.allclose(getattr(on.live_state, f), getattr(off.live_state, f), atol=1e-6), f
    # an L-shaped group and a tile in its corner: overlapping boxes are merged
    st = on.live_state
    st.tile_ttl[...] = 0
    st.tile_ttl[0, 0:4] = 5
    st.tile_ttl[0:4, 0] = 5
    st.tile_ttl[2, 2] = 5
    boxes = tiles.active_regions(st)
    assert boxes == [(slice(0, 64 + tiles.HALO), slice(0, 64 + tiles.HALO))]


def test_benchmark_hooks_count_cells_and_traffic() -> None:
    from station.backends.numpy_canvas import floats_per_cell_step

    on = NumpyCanvas(128, 96, seed=1, tiles=True)
    off = NumpyCanvas(128, 96, seed=1, tiles=False)
    for c in (on, off):
        paint(c, disc(96, 128, 10, 10, 4), 0.5, {"Black": 0.1})
        c.step()
        c.sync()
    assert off.cells_last_step() == 128 * 96
    assert 0 < on.cells_last_step() <= 34 * 34  # one 32x32 tile plus its 2-cell halo, clipped
    one = on.bytes_per_cell_step()
    paint(on, disc(96, 128, 10, 10, 4), 0.5, {"Hansa Yellow": 0.1})
    assert on.bytes_per_cell_step() > one  # more slots in use, more traffic
    # n Jacobi iterations cost 13 + 3 S floats each
    f4, f5 = (sum(floats_per_cell_step(2, n).values()) for n in (4, 5))
    assert f5 - f4 == 13 + 3 * 2


def test_zero_pigment_sources_take_no_slot() -> None:
    c = NumpyCanvas(16, 16)
    fp = disc(16, 16, 8, 8, 3)
    c.add_sources(dw=fp, dp={"Black": fp * 0.1, "Hansa Yellow": fp * 0})
    assert c.live_state.slots == ["Black"]
