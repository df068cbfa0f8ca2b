"""Paint profiles as XML data (issue 14, item 5): built-ins reproduce the old code values,
files round-trip, user profiles switch mid-painting, bad files name element and line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from station.backends.factory import create_backend
from station.canvas.errors import CanvasInputError
from station.canvas.palette import default_palette
from station.canvas.params import SimParams
from station.canvas.profiles import (
    PROFILES,
    get_profile,
    load_profile_file,
    parse_profile,
    profile_palette,
    profile_xml,
)
from station.cli import main

# The values the profiles had as code before they became files (params.py, issue 14).
OLD = {
    # (issue 10's wet-in-wet: pigment disperses along the cold-press fibres, alpha 4.5 cells)
    # (issue 21's rim: the edge evaporates 7x faster and water flows out to it, Curtis 1997)
    # (issue 21's backruns: damp paper is not wet, keeps pigment suspended above half
    # full, and draws a front in between 70 % full and full; Curtis 1997 section 4.7)
    # (and bloom2's fibre flow capped at capillary speed, 1 cell/s, so a front keeps its
    # pigment)
    # (issue 26: one Jacobi iteration per implicit diffusion in every profile, was 4: the
    # picture moves by at most 0.067 of an 8-bit level, docs/canvas-model.md)
    # (bloom7: paper counts as damp from 65 % full, was 70 %: the returning water of a
    # bloom runs on further into the damp wash, its front darker and lobed, issue 21 item 4)
    # (lift7: returning water lifts settled pigment 5x faster than it settled, eq. 4.12's
    # desorption over adsorption, so a bloom's water carries the damp wash's pigment to its
    # front, issue 21 item 4)
    # (wetarea: a cell stays in the wet-area mask 30 s after its water has gone while its
    # paper is damp, so rows laid over half-dry rows draw no line, issue 21 item 8)
    # (rows: absorption 0.03 -> 0.02 /s and flow outward 0.5 -> 0.4, so a row laid 3.5 s
    # after the last still merges into it: no line, no arrowhead at the turns, item 8)
    # (rim: edge evaporation 7 -> 3 and the wet-area blur 2 -> 3.5 cells, so a dried stroke's
    # rim is a band, not a one-cell line, on the memory's pinned edge: item 3)
    # (s9: on damp paper the advancing height the same on every cell, not 1.5 - h: a front
    # crept into damp paper no longer traces the paper's height blobs in whole-cell blocks;
    # blooms' CV 0.161 -> 0.169, items 3/4)
    # (s10: on drier paper the contact line's reach feels the meniscus's curvature: a front
    # crept into dry paper no longer dries as rectangular battlements, items 3/8)
    # (s12: the wet-wash drop's levers (wetdrop3: the gated fibre channel, its dispersion a
    # fibre long, the pigment's own diffusion 0.005 in standing water) with drop12's
    # recipe D (that diffusion kept at nu_p at fronts over dry paper, flow outward 0.55
    # over a 4-cell blur), so a drop of colour into a wet wash feathers and the brush rim
    # keeps its 2-cell band, issue 21 items 3/4)
    # (s13: that diffusion low only in water deeper than 0.05 (0.002 there), so the thin
    # film a flat wash dries through still lets the pigment settle by the paper's height
    # (granulation), and flow outward 0.48, so rows laid 3.5 s apart meet without an
    # arrowhead, issue 21 items 4/7/8)
    # (s14: the advection floor w_min 0.0005, so a drying stroke's film drains to its
    # pinned edge to the last (the coffee ring's rush hour), which frees the rows' turn for
    # flow outward 0.53: the brush rim a 2-cell band on the darkness, issue 21 item 3; and
    # the sized paper absorbs the film more slowly (0.02 -> 0.011 /s) while the air dries
    # it a little faster (eps_shallow 0.01 -> 0.012): a kiosk visitor's zig-zag sky, whose
    # single-coverage strips between overlapping rows held less water, no longer dries
    # them first into dark lines, item 8; s15: the flow outward's pull cut to the contact
    # line, rim_sharpness 0.5 at flow outward 0.43: a crisper band, narrow strokes too)
    # (s15: damp_exposure 0.6: fresh water in a damp wash runs on at its front's bulges,
    # not into its bays, so a bloom branches, item 4)
    "watercolor": SimParams().replace(advance_grain=0.0, advance_curvature=1.0,
                                      fibre_dispersivity=9.0, flow_outward=0.43,
                                      rim_sharpness=0.5, rim_onset=0.22, rim_full=0.36,
                                      w_min=0.0005,
                                      edge_evap=3.0, wet_blur=4.0, fibre_permeability=1.0,
                                      fibre_gate_depth=0.15, fibre_gate_pull=0.04,
                                      standing_depth=0.05, standing_nu_p=0.002,
                                      standing_front_pull=0.04, standing_front_dry=0.5,
                                      moist_threshold=1.0, damp_ease=2.7, damp_sat=0.65,
                                      damp_exposure=0.6, suspend_sat=0.5,
                                      fibre_flow_max=1.0, lift_gain=5.0,
                                      wet_hold=30.0, alpha=0.011, eps_shallow=0.012,
                                      jacobi_iters=1),
    "gouache": SimParams().replace(viscosity=2.0, nu_w=0.1, nu_p=0.05, alpha=0.005,
                                   height_gain=20.0, eps_shallow=0.008, jacobi_iters=1),
    # (issue 10's fibre feathering changed the ink in code just before: alpha 0.05, fibre_wick 1)
    "ink": SimParams().replace(alpha=0.05, cap_diffusion=3.0, moist_threshold=0.15, nu_p=0.8,
                               block_paper=0.7, eps_cap=0.006, flow_outward=0.0,
                               surface_rate=0.5, fibre_wick=1.0, jacobi_iters=1),
}


def test_builtin_files_reproduce_the_old_parameters_exactly() -> None:
    for name, prm in OLD.items():
        assert PROFILES[name].params == prm
    assert PROFILES["gouache"].brush.pigment_load == 1.0
    assert PROFILES["ink"].paper == "rough" and PROFILES["gouache"].renderer == "gouache"
    pal = default_palette()
    for prof in PROFILES.values():
        for p in prof.pigment_defs:  # K, S, staining ... equal the packaged tables
            assert pal.get(p.name) == p
        assert profile_palette(prof) is pal


@pytest.mark.parametrize("name", ["watercolor", "gouache", "ink"])
def test_profile_round_trips_through_xml(name: str) -> None:
    prof = PROFILES[name]
    back = parse_profile(profile_xml(prof), "mem")
    assert back.params == prof.params and back.pigment_defs == prof.pigment_defs
    assert (back.brush, back.paper, back.renderer, back.pigments) == (
        prof.brush, prof.paper, prof.renderer, prof.pigments)


def _user(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str, text: str) -> Path:
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path))
    d = tmp_path / "station" / "profiles"
    d.mkdir(parents=True, exist_ok=True)
    f = d / f"{name}.xml"
    f.write_text(text)
    return f


WET = """<?xml version="1.0"?>
<profile name="wet" renderer="km">
  <paper preset="hot-press" alpha="0.001"/>
  <fluid nu_p="0.9" eps_shallow="0.0"/>
  <palette>
    <pigment name="French Ultramarine"/>
    <pigment name="Mars Violet" K="0.5 1.2 0.6" S="0.2 0.1 0.2" staining="1.5" \
granulation="0.4" density="0.7"/>
  </palette>
  <brush radius="3" pigment="Mars Violet"/>
</profile>
"""


def test_user_profile_switches_mid_painting(tmp_path: Path,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    _user(tmp_path, monkeypatch, "wet", WET)
    prof = get_profile("wet")
    assert prof.params.alpha == 0.001 and prof.params.nu_p == 0.9
    assert prof.params.viscosity == SimParams().viscosity  # left out: default
    b = create_backend("numpy", 24, 16, "watercolor", seed=1)
    b.add_sources(np.full((4, 4), 0.5, np.float32), {"French Ultramarine":
                                                     np.full((4, 4), 0.2, np.float32)}, y0=6, x0=4)
    b.step()
    b.set_profile("wet")
    st = b.state()
    assert st.params == prof.params and st.profile == "wet"
    b.add_sources(np.full((4, 4), 0.5, np.float32),
                  {"Mars Violet": np.full((4, 4), 0.2, np.float32)}, y0=6, x0=14)
    b.step()
    st = b.state()
    assert st.slots == ["French Ultramarine", "Mars Violet"]
    assert st.palette.get("mars violet").K == (0.5, 1.2, 0.6)
    img = b.render()
    assert img[8, 16, 1] < img[8, 16, 0]  # the new pigment shows (absorbs green most)
    b.set_profile("watercolor")
    assert b.state().params == OLD["watercolor"]


@pytest.mark.parametrize("text, element, line", [
    (WET.replace('nu_p="0.9"', 'nu_p="fast"'), "fluid", 4),
    (WET.replace('alpha="0.001"', 'alpha="0.001" humidity="0.5"'), "paper", 3),
    (WET.replace('humidity', 'x') .replace('eps_shallow="0.0"', 'humidity="1.5"'), "fluid", 4),
    (WET.replace('staining="1.5"', 'staining="0"'), "pigment", 7),
    (WET.replace('<brush radius="3" pigment="Mars Violet"/>', '<brush pigment="Teal"/>'),
     "brush", 9),
    (WET.replace("</palette>", "</palete>"), None, 8),
])
def test_bad_profile_file_names_element_and_line(tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch, text: str,
                                                 element: str | None, line: int) -> None:
    f = _user(tmp_path, monkeypatch, "wet", text)
    with pytest.raises(CanvasInputError) as ei:
        load_profile_file(f)
    msg = str(ei.value)
    assert msg.startswith(f"{f}:{line}:"), msg
    if element:
        assert f"<{element}>" in msg, msg
    assert "\n" not in msg


def test_cli_bad_profile_exits_2_with_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    f = _user(tmp_path, monkeypatch, "wet", WET.replace('nu_p="0.9"', 'nu_p="-1"'))
    log = tmp_path / "s.jsonl"
    log.write_text('{"format": "station-session", "version": 1, '
                   '"canvas": {"width": 16, "height": 16}, "profile": "watercolor", "seed": 1}\n'
                   '{"type": "cmd", "t": 0.0, "cmd": "profile", "args": {"name": "wet"}}\n')
    rc = main(["paint", str(log), "-o", str(tmp_path / "o.png"), "--backend", "numpy"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1
    assert f"{f}:4: element <fluid>" in err[0]
