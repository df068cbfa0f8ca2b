"""``station effects``: the sheet, its JSON, bad flags; tiles not covered elsewhere."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest
from PIL import Image

from station.canvas.profiles import get_profile
from station.cli import main
from station.pictures import effects as fx


def test_effects_json_and_sheet(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "fx.png"
    code = main(["effects", "-o", str(out), "--json", "--only", "density,ink_bleed,glazing",
                 "--scale", "2"])
    cap = capsys.readouterr()
    assert code == 0, cap.err
    data = json.loads(cap.out)
    # the rectangle tiles are the labelled physics row, never the measure (issue 21)
    assert set(data) == {"physics: density", "physics: ink bleed", "physics: glazing"}
    assert {d["row"] for d in data.values()} == {"physics"}
    data = {k.removeprefix("physics: "): v for k, v in data.items()}
    dens = data["density"]
    assert dens["ok"] and dens["checks"] == {"heavy settles faster": True}
    assert dens["numbers"]["settled_heavy_2s"] > 2 * dens["numbers"]["settled_light_2s"]
    with Image.open(out) as im:
        assert im.mode == "RGB" and im.size[0] > 2 * 64 and im.size[1] > 2 * 48
    assert data["ink bleed"]["ok"] and "missed: ink bleed" not in cap.err
    glaze = data["glazing"]  # the spectral render: green, and unlike the mix
    assert glaze["ok"] and "missed: glazing" not in cap.err, glaze
    assert glaze["numbers"]["delta_e76_glaze_vs_mix"] >= 5.0
    assert 90.0 <= glaze["numbers"]["glaze_hue_deg"] <= 160.0


@pytest.mark.parametrize("flags", [["--only", "sparkle"], ["--only", ","],
                                   ["--scale", "0"], ["-o", "/nonexistent/dir/x.png"]])
def test_effects_bad_flags_are_exit_2(flags: list[str], capsys: pytest.CaptureFixture[str]
                                      ) -> None:
    assert main(["effects", *flags]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1


def test_gouache_covers_a_dark_layer() -> None:
    e = fx.gouache_over_dark()
    assert e.numbers["hiding_share"] >= 0.8 and e.ok, e.numbers


def test_colour_science() -> None:
    import numpy as np

    assert fx.lab(np.ones(3))[0] == pytest.approx(100.0, abs=0.01)
    assert fx.delta_e76(np.ones(3), np.ones(3)) == 0.0
    assert fx.hue_deg(np.array([0.1, 0.8, 0.1])) == pytest.approx(120.0)


def test_wet_in_wet_stroke_feathers_along_the_fibres() -> None:
    # The rectangle tile (the sheet's physics row) measures the fibres' feathering of a
    # blot in a fully wet rectangle. Its spread (>= 2x the footprint, asserted here until
    # session 12) is not issue 21's measure: with the wet-wash drop's levers on by default
    # (the pigment's own diffusion 0.005 in standing water, so a drop dries feathered
    # instead of as a soft round blot) the blot spreads 1.84x (2.11x with standing_depth
    # 0, 2.24x with no fibres either): the very diffusion the drop loses. The issue's
    # spread is the brushed drop's (tests/test_drop_wet_wash.py: >= 2.5 brush radii).
    # Measured at the old rim flow (flow_outward 0.3, edge_evap 1), as before.
    calm = dataclasses.replace(get_profile("watercolor").params, flow_outward=0.3,
                               edge_evap=1.0)
    e = fx.wet_in_wet(calm)
    # feather 1.49 (1.60 with session 12's standing_depth 0.005, which cost a deep wash its
    # granulation; main before session 12: 1.12, a soft blur), spread 1.84
    assert e.numbers["feather"] >= 1.4 and e.numbers["spread_area_ratio"] >= 1.8, e.numbers
    # the fibres do it: without their channel and dispersion the same stroke is a soft
    # blur (feather 1.00)
    still = fx.wet_in_wet(dataclasses.replace(calm, fibre_dispersivity=0.0,
                                              fibre_permeability=0.0))
    assert still.numbers["feather"] < e.numbers["feather"] - 0.3, still.numbers


def test_ink_bleeds_along_fibres() -> None:
    e = fx.ink_bleed()
    assert e.ok, e.numbers
    # the fibres do it: the same stroke on the same paper with the front pinned along
    # fibres (fibre_wick 0) neither spreads nor feathers as far
    assert e.numbers["feather"] >= 1.3 and e.numbers["spread_area_ratio"] >= 1.3
    pinned = fx.ink_bleed(dataclasses.replace(get_profile("ink").params, fibre_wick=0.0))
    assert pinned.numbers["feather"] < e.numbers["feather"] - 0.2, pinned.numbers
    assert pinned.numbers["spread_area_ratio"] < e.numbers["spread_area_ratio"], pinned.numbers


def test_render_scale_smooths_edges_and_keeps_cell_means(tmp_path: Path) -> None:
    import numpy as np

    from station.backends.numpy_canvas import NumpyCanvas
    from station.canvas.params import CanvasInputError
    from station.pictures.measure import _contour_segments
    from station.pictures.scenarios import disc, paint, run_until_dry
    from station.render.upscale import render_scaled

    c = NumpyCanvas(40, 40, seed=3)
    paint(c, disc(40, 40, 20, 20, 12), 0.5, {"French Ultramarine": 0.3})
    run_until_dry(c, 4000)
    c.dry()
    st = c.state()
    one = render_scaled(st, "km", 1)
    three = render_scaled(st, "km", 3)
    assert three.shape == (120, 120, 3)
    # cell averages stay close to the one-pixel-per-cell picture, inside the dried rim (its
    # band, 2-3 cells with a sharp inner side since the flow outward's pull was cut to the
    # contact line, reaches 9 cells from the centre where the edge wanders in: the
    # upscale smooths edges on purpose)
    means = three.reshape(40, 3, 40, 3, 3).mean(axis=(1, 3))
    inner = disc(40, 40, 20, 20, 8) > 0
    err = np.abs(means[inner] - one[inner])
    assert err.mean() < 0.01 and err.max() < 0.05, (err.mean(), err.max())
    # detail below the cell: pixels of one cell differ (paper grain, granulation)
    cells = three.reshape(40, 3, 40, 3, 3).transpose(0, 2, 1, 3, 4)
    assert cells[inner].std(axis=(1, 2)).mean() > 1e-3
    # no staircase: a deposit whose cells end in a 45-degree staircase renders with a
    # straight edge at 4 pixels per cell (its 1/2 iso-line keeps row + col within a
    # quarter cell; plain bicubic fields wiggle by about half a cell)
    flat = NumpyCanvas(32, 32, seed=1).state()
    k = flat.slot_of("French Ultramarine")
    yy, xx = np.mgrid[0:32, 0:32]
    flat.q[k] = np.where(xx + yy < 30, 0.3, 0.0).astype(np.float32)
    lum = render_scaled(flat, "km", 4).mean(axis=2)
    level = 0.5 * (np.median(lum[:32, :32]) + np.median(lum[-32:, -32:]))
    mid = _contour_segments(lum, float(level)).mean(axis=1) / 4  # [cells]
    diag = mid.sum(axis=1)
    diag = diag[(mid[:, 0] > 4) & (mid[:, 0] < 26) & (np.abs(diag - 30) < 5)]
    assert len(diag) > 100 and np.ptp(diag) < 0.25, (len(diag), np.ptp(diag))
    # a lone painted cell stays visible (a round dot about a cell wide)
    dot = NumpyCanvas(12, 12, seed=1).state()
    dot.q[dot.slot_of("French Ultramarine"), 6, 6] = 0.5
    lum = render_scaled(dot, "km", 4).mean(axis=2)
    assert lum[24:28, 24:28].mean() < lum[:8, :8].mean() - 0.1
    assert (lum < lum[:8, :8].mean() - 0.1).sum() >= 12
    for bad in (0, 5):
        with pytest.raises(CanvasInputError):
            render_scaled(st, "km", bad)
    out = tmp_path / "s.png"
    assert main(["demo", "-o", str(out), "--scale", "9"]) == 2


def test_dry_brush_leaves_flying_white_a_wet_brush_does_not() -> None:
    e = fx.dry_brush()
    assert e.ok, e.numbers
    assert e.numbers["bare_share_dry"] >= 0.2
    assert e.numbers["bare_share_dry"] >= 3 * e.numbers["bare_share_wet"]


def test_ink_is_black_and_flies_white_when_dry() -> None:
    e = fx.ink_flying_white()
    assert e.ok, e.numbers
    assert e.numbers["L_loaded_p10"] <= 30.0 and e.numbers["bare_share_dry"] >= 0.2


def test_wet_on_dry_edge_is_hard_wet_in_wet_soft() -> None:
    e = fx.wet_on_dry_edge()
    assert e.ok, e.numbers
    assert e.numbers["edge_width_dry_cells"] <= 2.0
    assert e.numbers["edge_width_wet_cells"] >= 3 * e.numbers["edge_width_dry_cells"]


def test_flow_patterns_run_downhill_on_a_tilted_sheet() -> None:
    e = fx.flow_patterns()
    assert e.ok, e.numbers
    assert abs(e.numbers["centre_shift_flat_cells"]) < 1.0
    assert e.numbers["centre_shift_tilted_cells"] >= 3.0
    assert e.numbers["front_roughness_cells"] >= 1.0
    # the sheet draws the tile with the sub-cell renderer: finer than its cells
    pic = e.picture(3)
    assert pic.shape == (64 * 3, 64 * 3 * 2, 3)
    cells = pic.reshape(64, 3, 128, 3, 3).transpose(0, 2, 1, 3, 4)
    assert cells.std(axis=(2, 3)).mean() > 1e-3


def test_measures_bare_share_and_edge_width() -> None:
    import numpy as np

    from station.pictures.measure import bare_share, edge_width

    solid = np.zeros((20, 40), bool)
    solid[8:12, 5:35] = True
    assert bare_share(solid) == pytest.approx(0.0, abs=1e-9)
    broken = solid.copy()
    broken[:, ::3] = False
    assert bare_share(broken) == pytest.approx(1 / 3, abs=0.05)
    assert edge_width(np.array([0, 0, 0, 1, 1, 1, 1, 1.0])) == pytest.approx(0.8)
    ramp = np.array([0, 0.1, 0.3, 0.5, 0.7, 0.9, 1, 1, 1, 1, 1, 1.0])
    assert edge_width(ramp) == pytest.approx(4.0)
