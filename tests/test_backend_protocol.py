"""The seams of the house: the backend protocol, tool operations run through
``edit_state``, and the brush's reservoir lifting paint through ``WetSurface``."""

from __future__ import annotations

import numpy as np
import pytest

from station.backends.factory import create_backend
from station.backends.numpy_canvas import NumpyCanvas
from station.backends.protocol import CanvasBackend, LiveStateBackend, edit_state
from station.brush.reservoir import Reservoir, pickup
from station.canvas.removal import StateSurface
from station.canvas.state import CanvasState


class _NoLiveState:
    """A backend that keeps its state elsewhere (as GL does): only state()/load_state()."""

    def __init__(self, inner: NumpyCanvas) -> None:
        self.inner = inner
        self.loads = 0

    def __getattr__(self, name: str) -> object:
        if name == "live_state":
            raise AttributeError(name)
        return getattr(self.inner, name)

    def load_state(self, state: CanvasState) -> None:
        self.loads += 1
        self.inner.load_state(state)


def _wet(c: NumpyCanvas) -> None:
    c.add_sources(np.full((8, 8), 0.5, np.float32),
                  {"Burnt Umber": np.full((8, 8), 0.2, np.float32)}, y0=4, x0=4)


def test_the_backends_here_are_canvas_backends() -> None:
    c = create_backend("numpy", 16, 12)
    assert isinstance(c, CanvasBackend) and isinstance(c, LiveStateBackend)
    assert not isinstance(_NoLiveState(NumpyCanvas(16, 12)), LiveStateBackend)


def test_edit_state_edits_in_place_where_the_state_lives() -> None:
    c = NumpyCanvas(16, 12, tiling=False)
    _wet(c)
    live = c.live_state
    seen = edit_state(c, lambda st: st)
    assert seen is live  # no copy: the tool changed the backend's own arrays


def test_edit_state_round_trips_a_backend_without_a_live_state() -> None:
    inner = NumpyCanvas(16, 12, tiling=False)
    _wet(inner)
    c = _NoLiveState(inner)

    def dry_a_corner(st: CanvasState) -> float:
        took = float(st.w[4:8, 4:8].sum())
        st.w[4:8, 4:8] = 0.0
        return took

    took = edit_state(c, dry_a_corner)  # type: ignore[arg-type]
    assert took == pytest.approx(16 * 0.5)
    assert c.loads == 1  # the edited copy went back
    assert float(inner.live_state.w[4:8, 4:8].sum()) == 0.0
    assert float(inner.live_state.w[8:12, 8:12].sum()) == pytest.approx(16 * 0.5)


def test_the_reservoir_lifts_paint_through_the_surface_the_player_hands_it() -> None:
    c = NumpyCanvas(16, 12, tiling=False)
    _wet(c)
    st = c.live_state
    water_before = float(st.w.sum(dtype=np.float64))
    res = Reservoir(capacity=100.0)
    got = pickup(StateSurface(st), res, np.ones((8, 8), np.float32), 4, 4, 0.5)
    lifted = water_before - float(st.w.sum(dtype=np.float64))
    # what left the canvas is what the brush holds, and the canvas booked it
    assert res.volume == pytest.approx(lifted, rel=1e-5) and lifted > 0.0
    assert float(st.removed_w.sum(dtype=np.float64)) == pytest.approx(lifted, rel=1e-5)
    k = st.slot_of("Burnt Umber")
    assert got["Burnt Umber"] > 0.0
    assert got["Burnt Umber"] == pytest.approx(res.mass["Burnt Umber"])
    assert float(st.removed_p[k].sum(dtype=np.float64)) == pytest.approx(got["Burnt Umber"],
                                                                       rel=1e-5)
