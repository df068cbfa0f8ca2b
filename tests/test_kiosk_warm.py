"""The kiosk warms every compiled kernel before its first frame (station.kiosk.warm): a
visitor then compiles nothing.  Its own module, so that its window test runs in a fresh
process where no other test compiled anything first (tests/test_kiosk_present.py runs all
its window tests in one child)."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.kiosk_harness import child_display, own_process
from tests.test_kiosk_present import _app, _pen

CHILD = "STATION_TEST_WARM_CHILD"
in_own_process = own_process(__file__, CHILD, timeout=900)


@pytest.fixture(scope="module")
def display() -> Iterator[str]:
    yield from child_display(CHILD)


def _compiled() -> dict[str, int]:
    """Every numba kernel of the station's modules: how many compiled versions it holds."""
    from numba.core.registry import CPUDispatcher

    out: dict[str, int] = {}
    for name, mod in list(sys.modules.items()):
        if name.startswith("station.") and mod is not None:
            for attr, obj in vars(mod).items():
                if isinstance(obj, CPUDispatcher):
                    out[f"{name}.{attr}"] = len(obj.signatures)
    return out


@in_own_process
def test_a_visitor_compiles_nothing_the_kiosk_warmed_at_start(
        display: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The kiosk calls every kernel once before its first frame (station.kiosk.warm): a
    visitor's strokes with the round and a deformable brush, the steps, the display's
    tiles and preview and a ``dry`` then compile nothing (on main the first stroke
    compiled the display's kernels: the pen waited 4.3-4.7 s from an empty cache)."""
    app = _app(display, tmp_path, monkeypatch, "auto")
    try:
        before = _compiled()
        for kernel in ("station.kiosk.subcell._steps_kernel", "station.render.km_fast._km",
                       "station.backends.cpu.fused.limit_diffuse_fused"):
            assert before.get(kernel, 0) >= 1, kernel
        assert sum(v for k, v in before.items() if k.startswith("station.brush.")) >= 5
        s, disp, q = app.session, app.display, app.session.sub
        for k, kind in enumerate(("round", "round3d", "flat")):
            s.command("brush", kind=kind, size=12, water=0.9,
                      pigment={"French Ultramarine": 0.6, "Quinacridone Rose": 0.2})
            for i in range(10):
                q.push(_pen(app, 20 * k + i, 0.15 + 0.07 * i, 0.25 + 0.25 * k))
                app.frame(0.016)
                s.step()
            q.push(_pen(app, 20 * k + 11, 0.85, 0.25 + 0.25 * k, touching=False))
            app.frame(0.016)
        for _ in range(10):
            s.step()
            disp.update_tiles()
            app.frame(0.016)
        s.command("dry")
        while disp.update_tiles() or disp.behind():
            pass
        app.frame(0.016)
        after = _compiled()
        grew = {k: (before.get(k, 0), v) for k, v in after.items() if v > before.get(k, 0)}
        assert not grew, grew
    finally:
        app.close()
