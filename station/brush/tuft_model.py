"""The deformable brush's canvas-facing constants (:class:`TuftModel`) and its requests to
lift wet paint (:class:`PickupRequest`), for :mod:`station.brush.deformable`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class TuftModel:
    """Canvas-facing constants of the deformable brush (cells).

    Attributes:
        tooth: depth of the paper's tooth: a cell of height ``h`` lies
            ``tooth·(1-h)`` below the plane the spines rest on.
        ramp: depth over which a bristle's contact weight goes from 0 to 1.
        min_bristle_radius: thinnest bristle tube drawn, cells.
        spacing: stamp spacing as a fraction of the footprint's half-size.
        dry_lift: as the reservoir empties, the footprint's contact is lifted by
            ``dry_lift · (1 - fill)² · depth_max``: a drying brush gives paint only
            where its bristles press deepest into the paper, so the stroke breaks
            up along the paper's hills.
        ink_reach: how far below the plane the ink a loaded tuft holds wets the
            paper's tooth (cells; the whole tooth by default) under the pressed
            body of the tuft (:func:`~station.brush.footprint.weight`), times
            the wetness below; the contact reaches the deeper of bristles and
            ink.  Where the liquid touches the paper its capillaries draw the ink
            in, so a loaded tuft wets the valleys between the hills its bristles
            rest on.  A property of the ink and the paper, not of the tuft's
            size: without it a tuft of a few cells, whose bristle tubes reach only
            ~0.4 cells below the plane, touches nothing but the hills of a
            1.5-cell tooth and leaves a dotted line (docs/brush.md, "Thin
            strokes").
        film_fill, pendular_fill: the tuft is a porous body: above ``film_fill``
            its ink is one connected liquid that wets the tip (the funicular
            regime); below ``pendular_fill`` only isolated rings of liquid remain
            where bristles cross (the pendular regime) and nothing reaches past the
            bristles: the wetness is ``clip((fill - pendular_fill) / (film_fill -
            pendular_fill), 0, 1)``.  A brush dipped in little
            water, or one that has painted itself below ``pendular_fill``, gives
            paint only where its bristles touch: dry-brush, flying white.
        frame_interval: session seconds between two spine solves while the pen
            moves less than ``frame_reach`` tuft lengths: the samples in between
            (a 1 kHz pen) stamp the last solved tuft along their own path.  Pens at
            ≤ 250 Hz get a solve for every sample.
        frame_reach: how far (tuft lengths) the pen may move from the last solved
            pose before a sample gets its own solve whatever the clock says.
        contact_time: session seconds of contact after which the paper under the
            tuft has drunk the whole film (the transfer grows as ``√t`` up to it): a
            flick that passes a cell faster lays a thinner film and goes further.
        skim, sink: a bristle dragged over the tooth skims from hill to hill: leaving
            one it sinks ``sink`` cells per cell travelled, looked at over ``skim``
            cells behind (:func:`~station.brush.footprint.weight`).  So a dry tuft's
            contact trails along the stroke behind the hills: dry-brush streaks, not
            dots.  0 turns it off (contact only where the paper itself is high).
    """

    tooth: float = 1.5
    ramp: float = 0.6
    min_bristle_radius: float = 0.35
    spacing: float = 0.25
    dry_lift: float = 0.9
    ink_reach: float = 1.5
    film_fill: float = 0.4
    pendular_fill: float = 0.2
    frame_interval: float = 0.004
    frame_reach: float = 0.5
    contact_time: float = 0.02
    skim: int = 8
    sink: float = 0.1

    def wetness(self, fill: float) -> float:
        """How connected the tuft's ink is, 0 (pendular) to 1 (a film down to the tip)."""
        span = self.film_fill - self.pendular_fill
        if span <= 0.0:
            return 1.0 if fill >= self.film_fill else 0.0
        return min(1.0, max(0.0, (fill - self.pendular_fill) / span))

    def split(self, fill: float) -> float:
        """How far the tuft's ink has split into locks: 0 at ``film_fill`` and above
        (one body), 1 at ``pendular_fill`` and below."""
        span = self.film_fill - self.pendular_fill
        if span <= 0.0:
            return 0.0 if fill >= self.film_fill else 1.0
        return min(1.0, max(0.0, (self.film_fill - fill) / span))

    def wetness_map(self, fill: np.ndarray) -> np.ndarray:
        """:meth:`wetness` per cell."""
        span = self.film_fill - self.pendular_fill
        if span <= 0.0:
            out: np.ndarray = (fill >= self.film_fill).astype(np.float32)
            return out
        return np.clip((fill - self.pendular_fill) / span, 0.0, 1.0).astype(np.float32)


@dataclass(slots=True)
class PickupRequest:
    """A footprint weight placed at ``(y0, x0)`` under which wet paint is lifted."""

    y0: int
    x0: int
    weight: np.ndarray
