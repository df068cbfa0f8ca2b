"""The palette with a mixing well (seed 6.4).

Up to 8 pigments (the canvas's slots) go into a small mixing canvas, the well, where they
mix passively by the same three-layer model as the painting (``reference.step``): the well
is a glazed dish, so nothing soaks in or dries (``alpha``, ``eps_*``, flow outward off) and
its floor is flat. Each addition puts a pool of paint at the well's centre; the pigments
spread and interdiffuse for ``settle`` seconds. The active mix is the suspended pigment
under the well's centre, where the brush dips in (:meth:`MixingWell.mix`, as brush
amounts: share of tube strength); :meth:`MixingWell.colour` renders it with Kubelka-Munk
as it will look on white paper, one stroke thick.
"""

from __future__ import annotations

import math

import numpy as np

from station.arttools.footprint import F32, check
from station.canvas import reference
from station.canvas.errors import CanvasInputError
from station.canvas.operations import add_sources
from station.canvas.params import SimParams
from station.canvas.state import CanvasState
from station.render.km import on_white

SIZE = 24
"""Side of the well [cells]."""
DIP = 4.0
"""Radius of the brush's dip at the centre [cells]."""


class MixingWell:
    """A small mixing canvas; ``pigment_load``: area fraction of tube-strength paint (the
    profile's ``brush.pigment_load``), the unit of the brush amounts."""

    def __init__(self, params: SimParams, pigment_load: float = 1.0, slots: int = 8) -> None:
        self.params = params.replace(alpha=0.0, eps_shallow=0.0, eps_cap=0.0,
                                     flow_outward=0.0, paper_relief=0.0, tilt=0.0,
                                     block_paper=0.0, advance_height=0.0)
        self.pigment_load = float(pigment_load)
        self.state = CanvasState.blank(SIZE, SIZE, self.params,
                                       np.full((SIZE, SIZE), 0.5, np.float32), n_slots=slots,
                                       tiling=False)
        yy, xx = np.mgrid[0:SIZE, 0:SIZE] + 0.5
        self._r2 = (yy - SIZE / 2) ** 2 + (xx - SIZE / 2) ** 2

    def add(self, pigment: str, amount: float, water: float = 0.6, settle: float = 2.0) -> None:
        """Put a pool of ``pigment`` at ``amount`` of tube strength [0, 1] in ``water``
        [height] into the well and let it mix for ``settle`` seconds."""
        check("amount", amount, 0.0, 1.0, "well")
        check("water", water, 0.05, 1.0, "well")
        check("settle", settle, 0.0, 60.0, "well")
        pool = (self._r2 <= (SIZE * 0.3) ** 2).astype(F32)
        add_sources(self.state, water * pool,
                    {pigment: F32(amount * self.pigment_load) * pool})
        self.settle(settle)

    def settle(self, seconds: float) -> None:
        """Let the well's paint mix for ``seconds`` of simulated time."""
        for _ in range(int(math.ceil(seconds / self.params.dt))):
            reference.step(self.state)

    def mix(self) -> dict[str, float]:
        """The brush amounts of the paint under the dip, per pigment name [0, 1]."""
        st = self.state
        dip = self._r2 <= DIP * DIP
        out: dict[str, float] = {}
        for k, name in enumerate(st.slots):
            c = float(st.p[k][dip].mean()) / self.pigment_load
            if c > 0:
                out[name] = min(c, 1.0)
        return out

    def colour(self) -> tuple[float, float, float]:
        """Linear RGB of the mix as a glaze on white paper (Kubelka-Munk)."""
        st = self.state
        mix = self.mix()
        if not mix:
            return (1.0, 1.0, 1.0)
        pigs = [st.palette.get(n) for n in mix]
        amount = np.array([[[v * self.pigment_load]] for v in mix.values()], F32)
        rgb = on_white(amount, pigs, self.state.r_composed.shape[-1])
        return float(rgb[0, 0, 0]), float(rgb[0, 0, 1]), float(rgb[0, 0, 2])

    def clear(self) -> None:
        """Wash the well out."""
        self.state = CanvasState.blank(SIZE, SIZE, self.params, self.state.h.copy(),
                                       n_slots=self.state.n_slots, tiling=False)

    def pigments(self) -> list[str]:
        return list(self.state.slots)


def check_room(well: MixingWell, pigment: str) -> None:
    """Bad input when a ninth pigment would go into the well."""
    st = well.state
    name = st.palette.get(pigment).name
    if name not in st.slots and len(st.slots) >= st.n_slots:
        raise CanvasInputError(f"the well holds {st.n_slots} pigments; wash it out first",
                               "well")
