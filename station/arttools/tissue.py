"""The textured tissue (seed 8.4.1): a height texture pressed into wet paint blots it.

Under the tissue's footprint each cell gives up ``absorb * pressure * T`` of its fluid
water and of its suspended pigment (pigment leaves with the water that carries it), ``T``
in [0, 1] the tissue's height texture there: its raised fibres touch the paint, its
hollows do not, so dabbing wet paint leaves the tissue's imprint. A press (touch to lift)
blots each cell once: cells blotted in this press are marked and skipped by its later
samples. Dry paint, and cells the tissue did not touch, lose nothing.

Textures: ``"crepe"`` (random fibres: Worley cells of ``scale`` cells, like paper
towel), ``"weave"`` (a woven cloth of period ``scale``), ``"flat"`` (a smooth pad), or a
grayscale image (Pillow) tiled over the canvas. Everything removed is booked.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from station.arttools.footprint import F32, check, window
from station.canvas.errors import CanvasInputError
from station.canvas.paper import worley_f1
from station.canvas.state import CanvasState

KINDS = ("crepe", "weave", "flat")


def texture(kind: str, height: int, width: int, scale: float = 4.0, seed: int = 0,
            image: str | None = None) -> np.ndarray:
    """The tissue's height texture over the canvas, float32 (H, W) in [0, 1]."""
    if image is not None:
        return _image_texture(image, height, width)
    if kind == "flat":
        return np.ones((height, width), F32)
    if kind == "weave":
        yy, xx = np.mgrid[0:height, 0:width].astype(np.float64)
        a = np.sin(np.pi * xx / scale) ** 2
        b = np.sin(np.pi * yy / scale) ** 2
        over = ((np.floor(xx / scale) + np.floor(yy / scale)) % 2) == 0
        out: np.ndarray = np.where(over, a, b).astype(F32)
        return out
    if kind == "crepe":
        f1 = worley_f1(height, width, scale, np.random.default_rng(seed))
        t = 1.0 - np.clip(f1 / scale, 0.0, 1.0)
        out = ((t - t.min()) / max(float(t.max() - t.min()), 1e-6)).astype(F32)
        return out
    raise CanvasInputError(f"tissue kind {kind!r} must be one of {', '.join(KINDS)}", "tissue")


def _image_texture(path: str, height: int, width: int) -> np.ndarray:
    try:
        from PIL import Image, UnidentifiedImageError  # optional extra: image tissues only
    except ImportError:
        raise CanvasInputError("tissue images need Pillow (pip install pillow)", path) from None
    try:
        with Image.open(Path(path)) as im:
            g = np.asarray(im.convert("L"), dtype=np.float64) / 255.0
    except (OSError, UnidentifiedImageError, ValueError) as exc:
        raise CanvasInputError(f"cannot read tissue image ({exc.__class__.__name__})",
                               path) from None
    if g.size == 0:
        raise CanvasInputError("empty tissue image", path)
    reps = (-(-height // g.shape[0]), -(-width // g.shape[1]))
    return np.tile(g, reps)[:height, :width].astype(F32)


@dataclass(frozen=True)
class Tissue:
    """kind, scale [cells], seed, image (path); radius [cells]; absorb: share of the
    fluid water a fibre of height 1 drinks at full pressure [1]."""

    kind: str = "crepe"
    scale: float = 4.0
    seed: int = 0
    image: str | None = None
    radius: float = 12.0
    absorb: float = 0.9

    def __post_init__(self) -> None:
        check("scale", self.scale, 1.0, 256.0, "tissue")
        check("radius", self.radius, 0.5, 512.0, "tissue")
        check("absorb", self.absorb, 0.0, 1.0, "tissue")
        if self.image is None and self.kind not in KINDS:
            raise CanvasInputError(f"tissue kind {self.kind!r} must be one of "
                                   f"{', '.join(KINDS)}", "tissue")


def blot(state: CanvasState, tissue: Tissue, tex: np.ndarray, cx: float, cy: float,
         pressure: float = 1.0, blotted: np.ndarray | None = None) -> tuple[float, np.ndarray]:
    """Press the tissue at (cx, cy) [cells]. ``tex`` is :func:`texture` over the canvas;
    ``blotted`` the cells already blotted in this press (updated copy returned).

    Returns (water taken [height * cells], blotted map)."""
    done = np.zeros((state.height, state.width), bool) if blotted is None else blotted.copy()
    win = window(state, cx, cy, tissue.radius)
    if win is None:
        return 0.0, done
    ys, xs, d2 = win
    inside = (d2 <= tissue.radius * tissue.radius) & ~done[ys, xs]
    share = np.where(inside, tex[ys, xs] * F32(tissue.absorb * min(max(pressure, 0.0), 1.0)),
                     F32(0)).astype(F32)
    share = np.where(state.mask[ys, xs] > 0, F32(0), share)  # the mask is not blotted
    done[ys, xs] |= inside
    ns = len(state.slots)
    tw = state.w[ys, xs] * share
    state.w[ys, xs] -= tw
    state.removed_w[ys, xs] += tw
    if ns:
        tp = state.p[:ns, ys, xs] * share
        state.p[:ns, ys, xs] -= tp
        state.removed_p[:ns, ys, xs] += tp
    return float(tw.sum(dtype=np.float64)), done
