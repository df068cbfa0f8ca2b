"""The bead a loaded tuft lets go into standing water (issue 21 item 4).

A loaded round brush holds far more paint than one stamp lays on dry paper: the stamp is
what the tip leaves where the paper must take the liquid in.  Where the tip touches down in
standing water (a wet wash still shining), the liquid in the tuft joins the film and runs
out of the brush into it, so a charge of colour put into a wet wash carries the brush's
bead with it: ``bead`` times the touch-down stamp's water, at the paint's own concentration
(the stamp's pigment per water: the brush holds much denser paint than the wash).

The bead cannot stand on top of the film under the brush (the fluid layer holds at most
``w_max``): it spreads along the film until it has room, the nearest cells first, as a
liquid poured into a full dish spreads from where it lands.  So its reach follows from its
volume and the film's depth, ``R^2 ~ r^2 + V / (pi (w_max - w))``: a shallow film takes it
far, a deep one keeps it near; it runs only through cells that hold standing water and is
bounded by the film's own edges.  On dry paper there is no film to join: the tip leaves
its stamp and nothing more.

Damp paper draws the bead out too (issue 21 item 4, backruns): a wash that has lost its
sheen but whose paper is still damp (saturation ``wc / c`` at least the profile's
``damp_sat`` under the tip) sucks the loaded tuft's liquid out by capillarity, which is why
a wet brush touched into a drying wash makes a bloom several times the brush's size.  The
bead then runs out through the damp paper (and any film) connected to the footprint, the
nearest room first, as into a film.  That liquid is a fresh wet phase (Curtis et al. 1997:
each glaze has its own wet-area mask): :func:`fresh_phase_box` bounds where the damp
wash's faded wet-area memory is dropped (on paper drier than :data:`FRESH_SAT`), so the
flow-outward term acts at the fresh water's own edge and carries the wash's suspended
pigment out to a crusted front shaped by how damp the paper is, cell by cell.

The brush does not read the canvas (brushes stay below the canvas): it queues a
:class:`BeadRequest` at touch-down and the session player hands :func:`bead_sources` the
canvas's water heights before the next step (:meth:`station.sim.player.SessionPlayer.step`),
so a live session and a replay of its log release the same bead at the same step.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from station.brush.sources import Sources

FILM = 0.05
"""Standing water [height] a cell needs for the bead to run through it (a film, not the
dampness of the capillary layer)."""

FRESH_SAT = 1.01
"""Capillary saturation ``wc / c`` below which a damp wash's paper meets a bead run out
into it as a new wet phase (its faded wet-area memory is dropped, so the fresh water's
front crusts against it: a bloom); paper fuller than that would stay one with the wash's
own wet phase.  Above 1: a bead run out into a damp wash is a new wet phase in its whole
window (session 15).  With the damp paper's exposure rule (``damp_exposure``) a cell that
kept the wash's memory reads as the inside of a wet area, sheltered, and the fresh water
never enters it: at 0.93 the sheet's bloom shrank to 4.5 cells.  Before that rule (session
9), measured on the sheet's bloom, paper seeds 21-24: dropping the memory everywhere gave
radius CV 0.144-0.163 (a round front), from 0.95 up 0.154-0.192, 0.93 0.13-0.18."""

TOUCH_FILM = 0.1
"""Mean standing water [height] under the footprint at which the tip is in a film (the
reservoir's ``W_WET``: wet paint comes along)."""


@dataclass(frozen=True, slots=True)
class BeadRequest:
    """The bead of one touch-down: where [cells], the footprint's radius [cells], the
    liquid [height * cells], its pigment per unit of water (name -> area fraction per
    height), the water the touch-down stamp itself laid per cell [height] (it is not
    the film the tip touches), and the stamp's painting time ``tau`` [steps]: the bead runs
    out before the first step its stamp reaches (``station.brush.sources.due_share``)."""

    cx: float
    cy: float
    radius: float
    volume: float
    concentration: Mapping[str, float]
    stamp_water: float
    tau: float = -math.inf

    def due(self, step: int) -> bool:
        """Whether the bead runs out before step ``step`` (with its stamp's first share)."""
        return step + 1.0 > self.tau


def bead_reach(req: BeadRequest, w_max: float) -> float:
    """The farthest [cells] a bead can run from its touch-down: into a film at least a
    tenth as deep as it holds."""
    r = max(req.radius, 0.5)
    return math.sqrt(r * r + req.volume / (math.pi * 0.1 * max(w_max, 1e-6))) + 1.0


def fresh_phase_box(req: BeadRequest, w_max: float, blur_reach: int, height: int,
                    width: int) -> tuple[int, int, int, int]:
    """(y0, y1, x0, x1): the cells whose faded wet-area memory a bead run out into damp
    paper drops: its reach, plus ``blur_reach`` (how far the flow-outward blur reads the
    mask), clipped to the canvas."""
    far = bead_reach(req, w_max) + float(blur_reach)
    return (max(0, int(req.cy - far)), min(height, int(math.ceil(req.cy + far)) + 1),
            max(0, int(req.cx - far)), min(width, int(math.ceil(req.cx + far)) + 1))


def bead_sources(req: BeadRequest, w: np.ndarray, mask: np.ndarray, w_max: float,
                 saturation: np.ndarray | None = None, damp_sat: float = 1.0
                 ) -> Sources | None:
    """The water and pigment of ``req`` spread through the standing water ``w`` [height]
    (``mask`` nonzero: masked cells take nothing), nearest cells first, each filled to
    ``w_max``; ``None`` when the tip is neither in a film nor on damp paper, or there is
    no room.  ``saturation``: the capillary layer's ``min(wc / c, 1)`` (None: damp paper
    draws nothing); paper at ``damp_sat`` or more counts as damp: a tip whose footprint is
    that damp on average lets the bead go into it, through the damp cells and films
    connected to the footprint."""
    if req.volume <= 0.0:
        return None
    height, width = w.shape
    r = max(req.radius, 0.5)
    reach = bead_reach(req, w_max)
    y0, y1 = max(0, int(req.cy - reach)), min(height, int(math.ceil(req.cy + reach)) + 1)
    x0, x1 = max(0, int(req.cx - reach)), min(width, int(math.ceil(req.cx + reach)) + 1)
    if y0 >= y1 or x0 >= x1:
        return None
    ww = np.asarray(w[y0:y1, x0:x1], np.float64)
    free = np.asarray(mask[y0:y1, x0:x1]) == 0
    dy = np.arange(y0, y1, dtype=np.float64)[:, None] + 0.5 - req.cy
    dx = np.arange(x0, x1, dtype=np.float64)[None, :] + 0.5 - req.cx
    dist = np.sqrt(dy * dy + dx * dx)
    under = (dist <= r) & free
    if not under.any():
        return None
    film = (ww > FILM) & free
    if float(ww[under].mean()) - req.stamp_water < TOUCH_FILM:
        if saturation is None:
            return None
        ss = np.asarray(saturation[y0:y1, x0:x1], np.float64)
        if float(ss[under].mean()) < damp_sat:
            return None
        film = film | ((ss >= damp_sat) & free)
    labels, _ = ndimage.label(film | under)
    joined = np.unique(labels[under])
    joined = joined[joined > 0]
    path = np.isin(labels, joined) & (dist <= reach)
    room = np.where(path, np.maximum(w_max - ww, 0.0), 0.0)
    order = np.argsort(dist, axis=None, kind="stable")
    cum = np.cumsum(room.ravel()[order])
    if cum.size == 0 or cum[-1] <= 0.0:
        return None
    # the cells up to the one the bead's volume reaches, that one partly
    k = int(np.searchsorted(cum, req.volume))
    fill = np.zeros(room.size)
    if k >= cum.size:
        fill[order] = room.ravel()[order]
    else:
        fill[order[:k]] = room.ravel()[order[:k]]
        fill[order[k]] = req.volume - (cum[k - 1] if k > 0 else 0.0)
    dw = fill.reshape(room.shape)
    f32 = np.float32
    dp = {name: (dw * c).astype(f32) for name, c in req.concentration.items() if c > 0.0}
    zero = np.zeros(dw.shape, f32)
    return Sources(y0, x0, dw.astype(f32), dp, zero, zero.copy())
