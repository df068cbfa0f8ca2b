"""The effects sheet (issue 10 item 9): paint each watercolour effect on a small canvas,
measure it, and compare the number with the issue's threshold.

Every tile only adds water/pigment sources, steps the simulation and applies the canvas
tools (dry, new layer, pickup, hair dryer); the numbers come from
:mod:`station.pictures.measure` and from colour science on the rendered reflectance.
:func:`run_effects` returns one :class:`Effect` per tile; ``station effects`` prints them
as JSON and draws the sheet. A tile whose number misses its threshold says so (``ok``
false): the sheet reports, it does not pretend.
"""

from __future__ import annotations

from collections.abc import Callable

from station.pictures.effects_bloom import DROP_S, DROP_SIZE, blooms
from station.pictures.effects_brush import (
    SPECTRUM_WASH,
    STEP_H,
    VALUE_H,
    VALUE_W,
    WASH,
    _hue_off,
    _value_canvas,
    brush_edges,
    brush_glazing,
    edge_position_std,
    flat_wash,
    paper_texture,
    radial_spectrum,
    round_dry_brush,
    spectral_peak,
    step_artefacts,
    value_range,
    value_stats,
)
from station.pictures.effects_core import (
    DARK_PIGMENTS,
    LUMA,
    PALE_PIGMENTS,
    PEN_HZ,
    REAL_MASSTONE_HUE,
    Effect,
    _played,
    _row_mask,
    darkness_map,
    delta_e76,
    hue_deg,
    lab,
    lab_hue_deg,
    luma,
)
from station.pictures.effects_physics import (
    backrun,
    density,
    dry_brush,
    edge_darkening,
    flow_patterns,
    glazing,
    gouache_over_dark,
    granulation,
    ink_bleed,
    ink_flying_white,
    staining_lifting,
    wet_in_wet,
    wet_on_dry_edge,
    wet_window,
)
from station.render.km import linear_to_srgb

__all__ = ["BRUSH_TILES", "DARK_PIGMENTS", "DROP_S", "DROP_SIZE", "LUMA", "PALE_PIGMENTS",
           "PEN_HZ", "PHYSICS_TILES", "REAL_MASSTONE_HUE", "SPECTRUM_WASH", "STEP_H", "TILES",
           "VALUE_H", "VALUE_W",
           "WASH", "Effect", "_hue_off", "_played", "_row_mask", "_value_canvas", "backrun",
           "blooms", "brush_edges", "brush_glazing", "darkness_map", "delta_e76", "density",
           "dry_brush", "edge_darkening", "edge_position_std", "flat_wash", "flow_patterns",
           "glazing", "gouache_over_dark", "granulation", "hue_deg", "ink_bleed",
           "ink_flying_white", "lab", "lab_hue_deg", "linear_to_srgb", "luma", "paper_texture",
           "radial_spectrum", "round_dry_brush", "run_effects", "spectral_peak",
           "staining_lifting", "step_artefacts", "value_range", "value_stats", "wet_in_wet",
           "wet_on_dry_edge", "wet_window"]


BRUSH_TILES: tuple[Callable[[], Effect], ...] = (
    value_range, brush_glazing, paper_texture, brush_edges, blooms, round_dry_brush,
    step_artefacts)
"""The tiles painted through the brush (issue 21): the measure."""


PHYSICS_TILES: tuple[Callable[[], Effect], ...] = (
    edge_darkening, wet_in_wet, backrun, granulation, glazing, staining_lifting, density,
    wet_window, gouache_over_dark, ink_bleed, wet_on_dry_edge, flow_patterns)
"""Tiles that write rectangles of water and pigment into the canvas (the dissertation's
figure 6.1 list): the "physics" row, kept to show the model's physics alone."""

TILES: tuple[Callable[[], Effect], ...] = (*BRUSH_TILES, dry_brush, ink_flying_white,
                                           *PHYSICS_TILES)
"""The tiles of the sheet, in order: through the brush first (dry-brush and the ink's flying
white by the deformable brush), then the physics row."""


def run_effects(names: list[str] | None = None) -> list[Effect]:
    """Paint and measure the tiles (all, or those whose function names are given)."""
    out = []
    for t in TILES:
        if names is not None and t.__name__ not in names:
            continue
        e = t()
        if t in PHYSICS_TILES:
            e.row = "physics"
            e.name = f"physics: {e.name}"
        out.append(e)
    return out
