"""The pen-only control panel (Dear ImGui), sized for a kiosk.

:class:`PanelState` holds what the panel controls and turns every control into
what it does (a ``brush``/``dry``/``new_layer``/``clear``/``undo`` command into
the simulation, logged like any command; a view switch; a gallery save) — the
drawing in :func:`draw_panel` only calls it, so tests can check each control by
tapping it with a pen and reading the state.

Targets are large (ImGui scaled ×2, buttons at least 64 px high) for a pen in
a standing visitor's hand.  Clear asks for confirmation.  Undo is offered only
when the painting has a stroke to undo (the live sim's undo history, issue 14);
until then the button is shown disabled.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np

from station.brush.stamp import BrushModel, brush_kinds
from station.canvas.palette import Palette
from station.kiosk.views import VIEWS
from station.render.km import km_layer, linear_to_srgb, on_white, to_linear_rgb
from station.sim import player

MAX_MIX = 4  # pigments in one mix (a layer holds 8; a mix of more is mud anyway)
VIEW_LABELS = {"2d": "Top", "3d": "Table", "follow": "Brush"}


PASS_THICKNESS = 0.8 * BrushModel().load(0.7)
"""Pigment thickness one pass of tube-strength paint leaves inside a dried stroke at a
painter's pressure (0.7): the profiles' ``pigment_load`` (1.0) times the brush's load at
that pressure, less the fifth the rim's outward flow carries to the stroke's edge (measured:
swatch vs brushed stroke dE76 1.1 for Ultramarine, 1.5 for Burnt Umber at 0.8; 10.2 and
8.2 at 1.0). Swatches are drawn at it, so they show what the brush paints (issue 21 item 6)."""


def swatch(palette: Palette, mix: dict[str, float], thickness: float = 0.35
           ) -> tuple[float, float, float]:
    """sRGB colour (0..1) of ``mix`` (name → parts) painted at ``thickness`` over white
    paper, by the canvas's own Kubelka–Munk layer."""
    total = sum(mix.values())
    if total <= 0:
        return (1.0, 1.0, 1.0)
    pigs = [palette.get(n) for n in mix]
    amount = np.array([[[thickness * v / total]] for v in mix.values()], np.float32)
    rgb = on_white(amount, pigs)[0, 0]
    srgb = linear_to_srgb(rgb)
    return (float(srgb[0]), float(srgb[1]), float(srgb[2]))


@lru_cache(maxsize=64)
def _mix_swatch(palette: Palette, mix: tuple[tuple[str, float], ...]
                ) -> tuple[float, float, float]:
    """:func:`swatch` of a mix (as sorted items), cached for the panel's builds."""
    return swatch(palette, dict(mix))


#: The thickness of a swatch's masstone and of its wash, and the dark ground a light
#: pigment's wash is shown on (a white wash on white paper shows nothing).
SWATCH_MASS = PASS_THICKNESS  # the masstone as one brush pass paints it (issue 21 item 6)
SWATCH_WASH = 0.3
LIGHT_LUMA = 0.8
DARK_GROUND = 0.05


@lru_cache(maxsize=256)
def swatch_pair(palette: Palette, name: str) -> tuple[tuple[float, float, float],
                                                      tuple[float, float, float]]:
    """What a pigment's swatch shows (sRGB 0..1): its masstone over white paper, and a
    wash — thin over white paper, or for a light pigment (whites, interference) over a
    dark ground.  Two blacks differ in their washes, two whites over the dark ground.
    Cached (a palette's pigments do not change): the panel is built four times a second
    and its 16 swatches' Kubelka-Munk renders were 5 of its 7 ms, a frame the pen waited
    for every 50."""
    pig = palette.get(name)
    mass = swatch(palette, {name: 1.0}, SWATCH_MASS)
    light = 0.2126 * mass[0] + 0.7152 * mass[1] + 0.0722 * mass[2] > LIGHT_LUMA
    ground = np.full((1, 1, 3), DARK_GROUND if light else 1.0, np.float32)
    amount = np.full((1, 1, 1), SWATCH_WASH, np.float32)
    wash = linear_to_srgb(to_linear_rgb(km_layer(amount, [pig], ground)))[0, 0]
    return mass, (float(wash[0]), float(wash[1]), float(wash[2]))


def mix_words(mix: dict[str, float]) -> str:
    """``French Ultramarine`` or ``2 French Ultramarine + 1 Hansa Yellow`` (``water``)."""
    if not mix:
        return "water"
    if len(mix) == 1:
        return next(iter(mix))
    return " + ".join(f"{v:g} {n}" for n, v in mix.items())


def undo_available() -> bool:
    """Whether the session player executes ``undo`` (issue 14's tools)."""
    return "undo" in getattr(player, "_HANDLERS", {})


def _nothing_to_undo() -> bool:
    return False


@dataclass
class PanelState:
    """What the panel shows and sets.  ``send(cmd, args)`` applies a command to the
    current painting; ``on_view``/``on_save`` are the window's."""

    palette: Palette
    send: Callable[[str, dict[str, Any]], None]
    on_save: Callable[[], object]
    mix: dict[str, float] = field(default_factory=dict)  # pigment -> parts
    # brush pigment amount of the whole mix (1: tube strength, the effects sheet's full
    # pass); 0.8 by default: a loaded brush's mid-to-dark value (a size-34 stroke at
    # pressure 0.7: Hooker's Green darkness 0.38, Burnt Umber 0.53) — at 0.6 a pale wash
    # (0.29) whose rim outshone it, "a felt-tip line with a rim"
    strength: float = 0.8
    size: float = 24.0  # footprint diameter [cells]
    water: float = 0.8
    kind: str = "round"
    view: str = "2d"
    confirm_clear: bool = False
    eraser: bool = False
    message: str = ""
    pressed: list[str] = field(default_factory=list)  # every control used, in order
    # whether the painting has a stroke to undo now (the live sim's UndoHistory.can_undo)
    can_undo: Callable[[], bool] = _nothing_to_undo
    mixing: bool = False  # a tap adds a part to the mix (else it picks the colour)
    hovered: str | None = None  # the swatch under the pen (its name shown; mixing: preview)

    # -- actions -----------------------------------------------------------------
    def brush_args(self) -> dict[str, Any]:
        total = sum(self.mix.values())
        pigment = {n: self.strength * v / total for n, v in self.mix.items()} if total else {}
        return {"kind": self.kind, "size": self.size, "water": self.water, "pigment": pigment}

    def apply_brush(self) -> None:
        self.send("brush", self.brush_args())

    def tap_pigment(self, name: str) -> None:
        """A tap on a swatch: picks that colour, or while mixing adds a part of it."""
        if self.mixing:
            self.add_pigment(name)
        else:
            self.pick_pigment(name)

    def pick_pigment(self, name: str) -> None:
        self.pressed.append(f"pick:{name}")
        self.mix = {name: 1.0}
        self.apply_brush()

    def toggle_mixing(self) -> None:
        """Mixing on (taps add parts to the colour in the brush) or off (taps pick)."""
        self.pressed.append("mixing:off" if self.mixing else "mixing:on")
        self.mixing = not self.mixing

    def preview_mix(self) -> dict[str, float]:
        """The mix the mix button shows: while mixing with the pen over a swatch, the mix
        one more tap would make (a preview); else the brush's."""
        if not (self.mixing and self.hovered):
            return dict(self.mix)
        if self.hovered not in self.mix and len(self.mix) >= MAX_MIX:
            return dict(self.mix)
        out = dict(self.mix)
        out[self.hovered] = out.get(self.hovered, 0.0) + 1.0
        return out

    def add_pigment(self, name: str) -> None:
        self.pressed.append(f"pigment:{name}")
        if name not in self.mix and len(self.mix) >= MAX_MIX:
            self.message = f"a mix holds {MAX_MIX} pigments: start a fresh mix"
            return
        self.mix[name] = self.mix.get(name, 0.0) + 1.0
        self.apply_brush()

    def fresh_mix(self) -> None:
        self.pressed.append("fresh_mix")
        self.mix.clear()
        self.apply_brush()

    def set_size(self, size: float) -> None:
        self.size = float(size)
        self.apply_brush()

    def set_water(self, water: float) -> None:
        self.water = float(water)
        self.apply_brush()

    def set_strength(self, strength: float) -> None:
        self.strength = float(strength)
        self.apply_brush()

    def set_kind(self, kind: str) -> None:
        self.pressed.append(f"kind:{kind}")
        self.kind = kind
        self.apply_brush()

    def simple(self, name: str) -> None:
        """``dry``, ``new_layer``, ``undo``."""
        self.pressed.append(name)
        self.send(name, {})

    def ask_clear(self) -> None:
        self.pressed.append("clear?")
        self.confirm_clear = True

    def answer_clear(self, yes: bool) -> None:
        self.pressed.append("clear:yes" if yes else "clear:no")
        self.confirm_clear = False
        if yes:
            self.send("clear", {})

    def set_view(self, view: str) -> None:
        self.pressed.append(f"view:{view}")
        self.view = view

    def save(self) -> None:
        self.pressed.append("save")
        self.on_save()


# -- drawing ------------------------------------------------------------------------
def _button(imgui: Any, label: str, w: float, h: float, rects: dict[str, Any], key: str,
            color: tuple[float, float, float] | None = None, disabled: bool = False) -> bool:
    if color is not None:
        imgui.push_style_color(imgui.Col_.button, imgui.ImVec4(*color, 1.0))
        imgui.push_style_color(imgui.Col_.button_hovered, imgui.ImVec4(*color, 0.85))
        imgui.push_style_color(imgui.Col_.button_active, imgui.ImVec4(*color, 0.7))
    if disabled:
        imgui.begin_disabled()
    hit = bool(imgui.button(label, imgui.ImVec2(w, h)))
    if disabled:
        imgui.end_disabled()
    if color is not None:
        imgui.pop_style_color(3)
    lo, hi = imgui.get_item_rect_min(), imgui.get_item_rect_max()
    rects[key] = (lo.x, lo.y, hi.x, hi.y)
    return hit and not disabled


def draw_panel(st: PanelState, width: float, height: float, status: str,
               rects: dict[str, Any]) -> None:
    """The panel window at the left edge; fills ``rects`` with each control's rectangle."""
    from imgui_bundle import imgui

    imgui.set_next_window_pos(imgui.ImVec2(0, 0))
    imgui.set_next_window_size(imgui.ImVec2(width, height))
    flags = (imgui.WindowFlags_.no_title_bar | imgui.WindowFlags_.no_move
             | imgui.WindowFlags_.no_resize | imgui.WindowFlags_.no_collapse
             | imgui.WindowFlags_.no_saved_settings)
    imgui.begin("panel", None, flags)
    avail = imgui.get_content_region_avail().x
    gap = imgui.get_style().item_spacing.x
    row_h = 56.0

    # palette: a grid of named swatches (masstone above, wash below); a tap picks the
    # colour, or adds a part of it while mixing
    imgui.text("Mixing: tap colours to add" if st.mixing else "Paint: tap a colour")
    names = list(st.palette.names())
    cols = 5
    sw = (avail - gap * (cols - 1)) / cols
    hovered = None
    draw = imgui.get_window_draw_list()
    for i, name in enumerate(names):
        if i % cols:
            imgui.same_line()
        imgui.push_id(name)
        mass, wash = swatch_pair(st.palette, name)
        if _button(imgui, "##p", sw, sw * 0.8, rects, f"pigment:{name}", color=mass):
            st.tap_pigment(name)
        if imgui.is_item_hovered():
            hovered = name
            imgui.set_tooltip(name)
        x0, y0, x1, y1 = rects[f"pigment:{name}"]
        draw.add_rect_filled(imgui.ImVec2(x0, y0 + (y1 - y0) * 0.62), imgui.ImVec2(x1, y1),
                             imgui.color_convert_float4_to_u32(imgui.ImVec4(*wash, 1.0)))
        imgui.pop_id()
    st.hovered = hovered
    # the colour in the brush (or, mixing over a swatch, what one more tap makes), named
    shown = st.preview_mix()
    # one line, whatever it says: the controls below stay where they are
    imgui.text("Mix: " + mix_words(shown) if st.mixing else (hovered or mix_words(st.mix)))
    label = "Done mixing" if st.mixing else "Mix colours"
    shown_rgb = _mix_swatch(st.palette, tuple(sorted(shown.items())))
    light = 0.2126 * shown_rgb[0] + 0.7152 * shown_rgb[1] + 0.0722 * shown_rgb[2] > 0.6
    if light:  # dark letters on a light mix, or the label is white on white
        imgui.push_style_color(imgui.Col_.text, imgui.ImVec4(0.08, 0.08, 0.1, 1.0))
    if _button(imgui, label, avail * 0.55, row_h, rects, "mix", color=shown_rgb):
        st.toggle_mixing()
    if light:
        imgui.pop_style_color()
    imgui.same_line()
    if _button(imgui, "Water", avail * 0.45 - gap, row_h, rects, "fresh_mix"):
        st.fresh_mix()

    # brush
    # brush kinds (the round stamp brush and the deformable brushes): a drop-down list
    imgui.push_item_width(avail)
    if imgui.begin_combo("##kind", f"{st.kind} brush", imgui.ComboFlags_.height_largest):
        for k in brush_kinds():
            if imgui.selectable(k, st.kind == k, 0, imgui.ImVec2(0, row_h * 0.7))[0]:
                st.set_kind(k)
            rects[f"kind:{k}"] = _rect(imgui)
        imgui.end_combo()
    rects["kind"] = (imgui.get_item_rect_min().x, imgui.get_item_rect_min().y,
                     imgui.get_item_rect_max().x, imgui.get_item_rect_max().y)
    imgui.pop_item_width()
    imgui.push_item_width(avail)
    changed, value = imgui.slider_float("##size", st.size, 4.0, 80.0, "size %.0f")
    rects["size"] = _rect(imgui)
    if changed:
        st.set_size(value)
    changed, value = imgui.slider_float("##water", st.water, 0.0, 1.0, "water %.2f")
    rects["water"] = _rect(imgui)
    if changed:
        st.set_water(value)
    changed, value = imgui.slider_float("##strength", st.strength, 0.05, 1.0, "paint %.2f")
    rects["strength"] = _rect(imgui)
    if changed:
        st.set_strength(value)
    imgui.pop_item_width()

    # canvas operations
    half = (avail - gap) / 2
    if _button(imgui, "Dry", half, row_h, rects, "dry"):
        st.simple("dry")
    imgui.same_line()
    if _button(imgui, "New layer", half, row_h, rects, "new_layer"):
        st.simple("new_layer")
    can_undo = undo_available() and st.can_undo()
    if _button(imgui, "Undo", half, row_h, rects, "undo", disabled=not can_undo):
        st.simple("undo")
    imgui.same_line()
    if _button(imgui, "Clear", half, row_h, rects, "clear"):
        st.ask_clear()
    if st.confirm_clear:
        imgui.text("Clear the painting?")
        if _button(imgui, "Yes, clear", half, row_h, rects, "clear:yes", color=(0.7, 0.2, 0.2)):
            st.answer_clear(True)
        imgui.same_line()
        if _button(imgui, "Keep it", half, row_h, rects, "clear:no"):
            st.answer_clear(False)

    # views
    third = (avail - 2 * gap) / 3
    for i, v in enumerate(VIEWS):
        if i:
            imgui.same_line()
        sel = (0.25, 0.45, 0.75) if st.view == v else None
        if _button(imgui, VIEW_LABELS[v], third, row_h, rects, f"view:{v}", color=sel):
            st.set_view(v)

    if _button(imgui, "Save & take home", avail, row_h, rects, "save", color=(0.2, 0.5, 0.3)):
        st.save()
    imgui.text_wrapped(("ERASER  " if st.eraser else "") + status)
    if st.message:
        imgui.text_wrapped(st.message)
    imgui.end()


def draw_qr(tex_id: int, x: float, y: float, side: float, rects: dict[str, Any]) -> None:
    """The QR code of the visitor's painting, bottom right over the canvas area."""
    from imgui_bundle import imgui

    pad = imgui.get_style().window_padding
    imgui.set_next_window_pos(imgui.ImVec2(x, y))
    imgui.set_next_window_size(imgui.ImVec2(side + 2 * pad.x,
                                            side + 2 * pad.y + imgui.get_text_line_height() + 6))
    flags = (imgui.WindowFlags_.no_title_bar | imgui.WindowFlags_.no_move
             | imgui.WindowFlags_.no_resize | imgui.WindowFlags_.no_inputs
             | imgui.WindowFlags_.no_saved_settings | imgui.WindowFlags_.no_scrollbar)
    imgui.begin("qr", None, flags)
    imgui.text("Take it home:")
    imgui.image(imgui.ImTextureRef(tex_id), imgui.ImVec2(side, side))
    rects["qr"] = _rect(imgui)
    imgui.end()


def _rect(imgui: Any) -> tuple[float, float, float, float]:
    lo, hi = imgui.get_item_rect_min(), imgui.get_item_rect_max()
    return (lo.x, lo.y, hi.x, hi.y)


def draw_banner(text: str, x: float, y: float, w: float, h: float, key: str,
                big: bool = True) -> None:
    """A borderless, centred message window (attract screen, pen unplugged)."""
    from imgui_bundle import imgui

    imgui.set_next_window_pos(imgui.ImVec2(x, y))
    imgui.set_next_window_size(imgui.ImVec2(w, h))
    imgui.set_next_window_bg_alpha(0.82)
    flags = (imgui.WindowFlags_.no_title_bar | imgui.WindowFlags_.no_move
             | imgui.WindowFlags_.no_resize | imgui.WindowFlags_.no_inputs
             | imgui.WindowFlags_.no_saved_settings)
    imgui.begin(key, None, flags)
    if big:
        imgui.push_font(None, imgui.get_style().font_size_base * 1.8)
    tw = imgui.calc_text_size(text).x
    imgui.set_cursor_pos(imgui.ImVec2(max(8.0, (w - tw) / 2), h / 2 - imgui.get_text_line_height()))
    imgui.text(text)
    if big:
        imgui.pop_font()
    imgui.end()


def draw_attract(x: float, y: float, w: float, h: float, text: str,
                 image: tuple[int, tuple[int, int]] | None,
                 stroke: list[tuple[float, float]], rects: dict[str, Any]) -> None:
    """The attract screen over the canvas area (x, y, w, h): a replay's frame (ImGui
    texture id and size) fitted into it, or the demo stroke (area pixels), and one
    line of invitation."""
    from imgui_bundle import imgui

    imgui.set_next_window_pos(imgui.ImVec2(x, y))
    imgui.set_next_window_size(imgui.ImVec2(w, h))
    imgui.set_next_window_bg_alpha(1.0)  # opaque: the canvas showing through read as a glitch
    flags = (imgui.WindowFlags_.no_title_bar | imgui.WindowFlags_.no_move
             | imgui.WindowFlags_.no_resize | imgui.WindowFlags_.no_inputs
             | imgui.WindowFlags_.no_saved_settings | imgui.WindowFlags_.no_scrollbar)
    imgui.begin("attract", None, flags)
    line_h = imgui.get_text_line_height() * 2.2
    if image is not None:
        tex_id, (iw, ih) = image
        scale = min((w - 40) / iw, (h - 60 - 2 * line_h) / ih)
        dw, dh = iw * scale, ih * scale
        imgui.set_cursor_pos(imgui.ImVec2((w - dw) / 2, 20))
        imgui.image(imgui.ImTextureRef(tex_id), imgui.ImVec2(dw, dh))
        rects["attract_image"] = _rect(imgui)
    elif len(stroke) >= 2:
        draw = imgui.get_window_draw_list()
        col = imgui.color_convert_float4_to_u32(imgui.ImVec4(0.16, 0.36, 0.78, 0.85))
        pts: list[Any] = [imgui.ImVec2(x + px, y + py) for px, py in stroke]
        draw.add_polyline(pts, col, max(8.0, h * 0.05), 0)
    # one line, as large as fits the area (at most 1.8 times the panel's text)
    base = imgui.get_style().font_size_base
    fit = (w - 40) / max(imgui.calc_text_size(text).x, 1.0)
    imgui.push_font(None, base * max(0.8, min(1.8, fit)))
    tw = imgui.calc_text_size(text).x
    imgui.set_cursor_pos(imgui.ImVec2(max(8.0, (w - tw) / 2), h - line_h - 10))
    imgui.text(text)
    rects["attract_text"] = _rect(imgui)
    imgui.pop_font()
    imgui.end()
