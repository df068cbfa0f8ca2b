"""``station effects``: the sheet, its JSON, bad flags; tiles not covered elsewhere."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from PIL import Image

from station.canvas import effects as fx
from station.cli import main


def test_effects_json_and_sheet(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "fx.png"
    code = main(["effects", "-o", str(out), "--json", "--only", "density,ink_bleed",
                 "--scale", "2"])
    cap = capsys.readouterr()
    assert code == 0, cap.err
    data = json.loads(cap.out)
    assert set(data) == {"density", "ink bleed"}
    dens = data["density"]
    assert dens["ok"] and dens["checks"] == {"heavy settles faster": True}
    assert dens["numbers"]["settled_heavy_2s"] > 2 * dens["numbers"]["settled_light_2s"]
    with Image.open(out) as im:
        assert im.mode == "RGB" and im.size[0] > 2 * 64 and im.size[1] > 2 * 48
    assert "missed: ink bleed" in cap.err  # the sheet reports what misses its threshold


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


# issue 10 thresholds the model does not meet yet: strict, so a fix is noticed
def test_wet_in_wet_stroke_spreads_twice_its_footprint() -> None:
    e = fx.wet_in_wet()
    assert e.checks["spread >= 2x"], e.numbers
    assert e.numbers["feather"] < 1.3, e.numbers  # see the strict xfail below
    pytest.xfail("a stroke into a fresh wash spreads as a soft blur (feather ~1.07 < 1.3): "
                 "no feathering mechanism in a shiny wash")


@pytest.mark.xfail(strict=True, reason="ink spreads ~1.2x with a smooth edge: no fibre "
                   "texture drives anisotropic capillary flow yet")
def test_ink_bleeds_along_fibres() -> None:
    assert fx.ink_bleed().ok


def test_render_scale_smooths_edges_and_keeps_cell_means(tmp_path: Path) -> None:
    import numpy as np

    from station.canvas.numpy_backend import NumpyCanvas
    from station.canvas.params import CanvasInputError
    from station.canvas.scenarios import disc, paint, run_until_dry
    from station.canvas.upscale import render_scaled

    c = NumpyCanvas(40, 40, seed=3)
    paint(c, disc(40, 40, 20, 20, 12), 0.5, {"French Ultramarine": 0.3})
    run_until_dry(c, 4000)
    c.dry()
    st = c.state()
    one = render_scaled(st, "km", 1)
    three = render_scaled(st, "km", 3)
    assert three.shape == (120, 120, 3)
    # cell averages stay close to the one-pixel-per-cell picture
    means = three.reshape(40, 3, 40, 3, 3).mean(axis=(1, 3))
    inner = disc(40, 40, 20, 20, 9) > 0
    err = np.abs(means[inner] - one[inner])
    assert err.mean() < 0.01 and err.max() < 0.05, (err.mean(), err.max())
    # detail below the cell: pixels of one cell differ (paper grain, granulation)
    cells = three.reshape(40, 3, 40, 3, 3).transpose(0, 2, 1, 3, 4)
    assert cells[inner].std(axis=(1, 2)).mean() > 1e-3
    # smoother edge: the largest step between neighbouring pixels across the rim is
    # smaller than between neighbouring cells at one pixel per cell
    lum1 = one.mean(axis=2)
    lum3 = three.mean(axis=2)
    assert np.abs(np.diff(lum3, axis=1)).max() < 0.8 * np.abs(np.diff(lum1, axis=1)).max()
    for bad in (0, 5):
        with pytest.raises(CanvasInputError):
            render_scaled(st, "km", bad)
    out = tmp_path / "s.png"
    assert main(["demo", "-o", str(out), "--scale", "9"]) == 2
