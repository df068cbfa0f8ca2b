"""The palette with a mixing well (issue 14, item 6)."""

from __future__ import annotations

import colorsys

import pytest

from station.arttools.well import MixingWell
from station.backends.factory import create_backend
from station.canvas.params import SimParams
from station.errors import BadInput
from station.events import Command, PenSample
from station.sim.player import SessionPlayer

BLUE, YELLOW = "Cerulean Blue", "Hansa Yellow"


def hue(rgb: tuple[float, float, float]) -> float:
    return colorsys.rgb_to_hsv(*rgb)[0] * 360.0


def test_blue_and_yellow_in_the_well_give_green() -> None:
    w = MixingWell(SimParams())
    w.add(BLUE, 0.5)
    blue = w.colour()
    assert 180 < hue(blue) < 240
    w.add(YELLOW, 0.5)
    green = w.colour()
    assert 90 < hue(green) < 150, green
    assert green[1] > green[0] + 0.1 and green[1] > green[2] + 0.1
    mix = w.mix()
    assert set(mix) == {BLUE, YELLOW} and all(0.4 < v < 0.6 for v in mix.values())
    # passive mixing by the model: paint spreads and stays (the well neither soaks nor dries)
    st = w.state
    assert abs(float(st.p.sum() + st.q.sum()) - sum(st.pigment_added.values())) < 1e-3


def test_the_brush_picks_up_the_mix_and_paints_green() -> None:
    b = create_backend("numpy", 32, 24, seed=1)
    p = SessionPlayer(b, 32, 24)
    p.play([Command(t=0.0, cmd="well", args={"add": BLUE, "amount": 0.6}),
            Command(t=0.0, cmd="well", args={"add": YELLOW, "amount": 0.6, "settle": 3}),
            Command(t=0.0, cmd="well", args={"pick": True}),
            PenSample(t=0.1, device="d", tool="pen", x=0.2, y=0.5,  # type: ignore[arg-type]
                      pressure=1.0, touching=True),
            PenSample(t=0.3, device="d", tool="pen", x=0.8, y=0.5,  # type: ignore[arg-type]
                      pressure=1.0, touching=True)])
    p.settle(1.0)
    assert set(p.brush.settings.pigment) == {BLUE, YELLOW}
    rgb = b.render()[12, 16]
    assert 80 < hue(tuple(float(x) for x in rgb)) < 160, rgb


@pytest.mark.parametrize("args, what", [
    ({"add": "Unobtainium"}, "Unobtainium"), ({"add": BLUE, "amount": 3}, "amount"),
    ({"stir": 1}, "stir"),
])
def test_bad_well_commands(args: dict, what: str) -> None:
    p = SessionPlayer(create_backend("numpy", 16, 16), 16, 16)
    with pytest.raises(BadInput, match=what):
        p.play([Command(t=0.0, cmd="well", args=args)], where=lambda: "s:3")


def test_picking_from_an_empty_well_is_counted_and_skipped() -> None:
    # a state, not a malformed command: `station send well pick` is checked on a scratch
    # player whose well is always empty, and a live well may hold paint
    p = SessionPlayer(create_backend("numpy", 16, 16), 16, 16)
    before = p.brush.settings
    p.play([Command(t=0.0, cmd="well", args={"pick": True})], where=lambda: "s:3")
    assert p.counters.skipped_commands["well"] == 1 and p.brush.settings == before


def test_the_well_holds_eight_pigments() -> None:
    w = MixingWell(SimParams())
    names = ["French Ultramarine", "Cerulean Blue", "Hansa Yellow", "Cadmium Yellow",
             "Quinacridone Rose", "Cadmium Red", "Indian Red", "Burnt Umber"]
    p = SessionPlayer(create_backend("numpy", 16, 16), 16, 16)
    p.well = w
    for n in names:
        p.command(Command(t=0.0, cmd="well", args={"add": n, "amount": 0.1, "settle": 0}))
    with pytest.raises(BadInput, match="8 pigments"):
        p.command(Command(t=0.0, cmd="well", args={"add": "Black", "settle": 0}))
