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
@pytest.mark.xfail(strict=True, reason="a drop into a fresh wash spreads ~1.8x as a soft, "
                   "round blot (feather ~1.04): no feathering mechanism in a shiny wash")
def test_wet_in_wet_spreads_twice_its_footprint_feathered() -> None:
    e = fx.wet_in_wet()
    assert e.numbers["spread_area_ratio"] >= 2.0 and e.numbers["feather"] >= 1.3


@pytest.mark.xfail(strict=True, reason="ink spreads ~1.2x with a smooth edge: no fibre "
                   "texture drives anisotropic capillary flow yet")
def test_ink_bleeds_along_fibres() -> None:
    assert fx.ink_bleed().ok
