"""The effects sheet's shared parts: the :class:`Effect` tile, colour science (CIELAB,
Luma, darkness) and playing a scripted session through the brush."""

from __future__ import annotations

import colorsys
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from station.backends.numpy_canvas import NumpyCanvas
from station.canvas.profiles import get_profile
from station.pictures.scenarios import run_until_dry
from station.render.km import linear_to_srgb, to_linear_rgb
from station.render.upscale import render_scaled
from station.sim.player import SessionPlayer
from station.sim.script import Script

F32 = np.float32

_CANVAS: type[NumpyCanvas] = NumpyCanvas
"""What the brush tiles paint on: the numpy reference, or the cpu backend, which paints
the same bits (tests/test_cpu_backend.py) in a fraction of the time."""


def use_backend(name: str) -> None:
    """Paint the brush tiles on ``"numpy"`` (the reference, the default) or ``"cpu"``."""
    global _CANVAS
    if name == "cpu":
        # in the function: numba (about half a second to import) only when asked
        from station.backends.cpu import CpuCanvas
        _CANVAS = CpuCanvas
    elif name == "numpy":
        _CANVAS = NumpyCanvas
    else:
        raise ValueError(f"effects backend {name!r}: numpy or cpu")


def new_canvas(width: int, height: int, **kwargs: Any) -> NumpyCanvas:
    """A canvas of the backend :func:`use_backend` chose (``NumpyCanvas``'s arguments)."""
    return _CANVAS(width, height, **kwargs)


@dataclass
class Effect:
    """One tile: its name, the measured numbers, the checks against the issue's thresholds
    (``{check: passed}``), and the rendered tile (linear RGB, float32 (H, W, 3))."""

    name: str
    numbers: dict[str, float]
    checks: dict[str, bool]
    image: np.ndarray = field(repr=False)
    canvases: tuple[NumpyCanvas, ...] = field(default=(), repr=False)
    """The painted canvases behind ``image`` (left to right), for :meth:`picture`."""
    row: str = "brush"
    """``brush``: painted by pen samples through a brush (the measure, issue 21);
    ``physics``: water and pigment written into the canvas as rectangles (the model's
    physics alone, never the measure)."""

    @property
    def ok(self) -> bool:
        return all(self.checks.values())

    def picture(self, k: int) -> np.ndarray:
        """The tile at ``k`` pixels per cell (linear RGB): the canvases drawn by the
        sub-cell renderer (smooth contours, paper grain), or ``image`` enlarged when the
        tile keeps no canvas."""
        if k == 1 or not self.canvases:
            return np.repeat(np.repeat(self.image, k, 0), k, 1)
        pics = [render_scaled(c.state(), get_profile(c.state().profile).renderer, k)
                for c in self.canvases]
        # long strips one above the other, the rest side by side: the sheet stays compact
        wide = pics[0].shape[1] >= 2 * pics[0].shape[0]
        return np.concatenate(pics, axis=0 if wide else 1)

    def to_json(self) -> dict[str, Any]:
        return {"row": self.row, "numbers": {k: round(v, 4) for k, v in self.numbers.items()},
                "checks": {k: bool(v) for k, v in self.checks.items()}, "ok": self.ok}


# ------------------------------------------------------------------ colour science
_M = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722],
               [0.0193, 0.1192, 0.9505]])
_WHITE = _M.sum(axis=1)


def lab(rgb: np.ndarray) -> np.ndarray:
    """CIELAB (D65) of linear sRGB reflectance (..., 3)."""
    xyz = np.asarray(rgb, np.float64) @ _M.T / _WHITE
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.stack([116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]),
                     200 * (f[..., 1] - f[..., 2])], axis=-1)


def delta_e76(a: np.ndarray, b: np.ndarray) -> float:
    """CIE76 colour difference of two linear sRGB colours."""
    return float(np.linalg.norm(lab(a) - lab(b)))


def hue_deg(rgb: np.ndarray) -> float:
    """Hue angle (HSV, degrees) of a linear sRGB colour: 120 is green, 60 yellow, 240 blue."""
    return colorsys.rgb_to_hsv(*(float(x) for x in rgb))[0] * 360.0




PEN_HZ = 120.0
"""Pen report rate of the scripted painter [samples/s] (a tablet reports 100-200)."""

LUMA = np.array([0.2126, 0.7152, 0.0722])
"""Rec. 709 weights, applied to sRGB-encoded values (as the issue measured the scans)."""

DARK_PIGMENTS = ("French Ultramarine", "Burnt Umber", "Sepia", "Sumi Ink")
PALE_PIGMENTS = ("Hansa Yellow", "Cadmium Yellow", "Titanium White", "Interference Lilac")
"""Whites, yellows and the interference white: no full-strength value floor."""

REAL_MASSTONE_HUE = {
    # HSV hue [deg] of the displayed sRGB of each pigment's full-strength watercolour
    # stroke: French Ultramarine's from the issue (a violet-leaning blue, 240-250); the
    # others approximate painted-swatch hues, not measurements (docs/canvas-model.md).
    "French Ultramarine": 245.0, "Cerulean Blue": 196.0, "Phthalo Green": 165.0,
    "Hookers Green": 110.0, "Quinacridone Rose": 336.0, "Cadmium Red": 8.0,
    "Indian Red": 12.0, "Burnt Umber": 25.0, "Sepia": 28.0, "Brilliant Orange": 28.0,
    "Hansa Yellow": 55.0, "Cadmium Yellow": 48.0,
}


def luma(rgb_linear: np.ndarray) -> np.ndarray:
    """Rec. 709 luma of the sRGB-encoded colour, in [0, 1]."""
    return np.asarray(linear_to_srgb(rgb_linear) @ LUMA)


def darkness_map(c: NumpyCanvas) -> np.ndarray:
    """1 - luma/luma_paper per cell; the paper's luma is the mean over unpainted cells."""
    st = c.live_state
    lum = luma(c.render())
    bare = (st.q.sum(axis=0) + st.p.sum(axis=0)) <= 1e-5
    paper = (float(lum[bare].mean()) if bare.any()
             else float(luma(to_linear_rgb(st.r_composed)).max()))
    return 1.0 - lum / paper


def _played(script: Script, paper: str | None = None, seed: int = 7) -> NumpyCanvas:
    """Play ``script`` through the brush on a fresh canvas (on the paper its header chose,
    as ``station paint`` does, else ``paper``, else the profile's), let it dry on its own,
    then fix the layer (the paper is dry: ``dry`` only deposits what is left)."""
    h = script.header
    paper = h.extra.get("paper", paper)
    c = (new_canvas(h.width, h.height, profile=h.profile, seed=seed) if paper is None
         else new_canvas(h.width, h.height, profile=h.profile, seed=seed, paper=paper))
    SessionPlayer(c, h.width, h.height, h.profile).play(script.records)
    run_until_dry(c, 6000)
    c.dry()
    return c


def _row_mask(c: NumpyCanvas, y: int, half: int, x0: int, x1: int) -> np.ndarray:
    """Cells of the stroke along row ``y``: within ``half`` rows of its path, between the
    columns ``x0:x1`` (the caps left out), where the stroke left pigment."""
    st = c.live_state
    dep = st.q.sum(axis=0) + st.p.sum(axis=0)
    m = np.zeros(dep.shape, bool)
    m[max(0, y - half):y + half + 1, x0:x1] = True
    inside = dep[m]
    return m & (dep > 0.05 * float(np.percentile(inside, 90))) if inside.size else m


def lab_hue_deg(rgb: np.ndarray) -> float:
    """CIELAB hue angle h_ab (degrees) of a linear sRGB colour (yellow ~ 100, green ~ 136)."""
    c = lab(rgb)
    return float(np.degrees(np.arctan2(c[2], c[1])) % 360.0)
