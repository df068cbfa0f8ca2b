"""The tool commands a session plays (``dry``, ``hairdryer``, ``new_layer``, ``clear``,
``mask``, ``mask_remove``, ``eraser``, ``tissue``, ``tilt``, ``diffusion``, ``undo``,
``redo``, ``well``): each validates its arguments (:class:`PlayerError`, bad input) and
acts on the :class:`~station.sim.player.SessionPlayer` it is given; the player's command
table (``station.sim.player._HANDLERS``) dispatches to them."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

from station.arttools import diffusion as diffusion_tool
from station.arttools import eraser as eraser_tool
from station.arttools import mask as mask_tool
from station.arttools import tissue as tissue_tool
from station.arttools import well as well_tool
from station.backends.protocol import edit_state
from station.brush.stamp import BrushSettings
from station.canvas.profiles import get_profile
from station.canvas.removal import HairDryer
from station.canvas.state import CanvasState
from station.errors import BadInput

if TYPE_CHECKING:
    from station.sim.player import SessionPlayer

log = logging.getLogger(__name__)

MAX_WAIT_SECONDS = 3600.0
"""Longest ``wait`` (and hair dryer) a command may ask for [s]."""


class PlayerError(BadInput):
    """A command the player executes has wrong arguments."""


def _dry(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    p.flush_sources(whole=True)
    p.backend.dry()


def _number(args: Mapping[str, object], key: str, default: float, lo: float, hi: float,
            where: str | None) -> float:
    v = args.get(key, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
            or not lo <= v <= hi:
        raise PlayerError(f"hairdryer {key} {v!r} must be a number in [{lo:g}, {hi:g}]", where)
    return float(v)


def _hairdryer(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    """Hold a hair dryer over (x, y) (canvas-normalised) for ``seconds`` of painting time
    from now (0 switches it off): ``radius`` [cells of the session's canvas],
    ``temperature`` [C] and ``airflow`` [1] of its air at the sheet."""
    x = _number(args, "x", 0.5, 0.0, 1.0, where)
    y = _number(args, "y", 0.5, 0.0, 1.0, where)
    seconds = _number(args, "seconds", 10.0, 0.0, MAX_WAIT_SECONDS, where)
    radius = _number(args, "radius", 60.0, 1.0, 2048.0, where) * p.brush_scale
    temp = _number(args, "temperature", 40.0, -10.0, 60.0, where)
    flow = _number(args, "airflow", 2.0, 0.0, 200.0, where)
    p.flush_sources(whole=True)
    p.dryer = HairDryer(cx=x * (p.width - 1), cy=y * (p.height - 1),
                        radius=max(1.0, min(radius, 2048.0)), temperature=temp, airflow=flow)
    p.dryer_until = p.counters.steps + int(round(seconds * p.rate))
    if seconds == 0:
        p.dryer = None


def _new_layer(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    p.flush_sources(whole=True)
    try:
        p.backend.new_layer()
    except BadInput as exc:
        raise PlayerError(str(exc), where) from None
    p.layer_pigments.clear()


def _clear(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    p.brush.take()  # stamps not yet simulated are cleared with the rest
    p.backend.clear()
    p.layer_pigments.clear()


def _tool_number(tool: str, args: Mapping[str, object], key: str, default: float, lo: float,
                 hi: float, where: str | None) -> float:
    v = args.get(key, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
            or not lo <= v <= hi:
        raise PlayerError(f"{tool} {key} {v!r:.40} must be a number in [{lo:g}, {hi:g}]",
                          where)
    return float(v)


def _check_keys(tool: str, args: Mapping[str, object], known: set[str], where: str | None) -> None:
    extra = sorted(set(args) - known)
    if extra:
        raise PlayerError(f"{tool}: unknown argument {extra[0]!r} (known: "
                          f"{', '.join(sorted(known))})", where)


_AT = {"x", "y", "pressure"}


def _pick_up(p: SessionPlayer, tool: str, args: Mapping[str, object], where: str | None) -> None:
    """Take ``tool`` in hand; with ``x``/``y`` (canvas-normalised) also dab once there."""
    p.flush_sources(whole=True)
    p.tool = tool
    p._dab = None
    p._tool_last = None
    if "x" in args or "y" in args:
        x = _tool_number(tool, args, "x", 0.5, 0.0, 1.0, where)
        y = _tool_number(tool, args, "y", 0.5, 0.0, 1.0, where)
        pr = _tool_number(tool, args, "pressure", 1.0, 0.0, 1.0, where)
        try:
            p._dab_at(tool, x * p.width, y * p.height, pr)
        except BadInput as exc:
            raise PlayerError(str(exc), where) from None
        p._dab = None


def _mask(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    """Masking fluid: ``size`` (diameter, cells of the session's canvas)."""
    _check_keys("mask", args, {"size"} | _AT, where)
    if "size" in args:
        p.mask_radius = _tool_number("mask", args, "size", 12, 1, 1024, where) * \
            p.brush_scale / 2.0
    _pick_up(p, "mask", args, where)


def _mask_remove(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    _check_keys("mask_remove", args, set(), where)
    p.flush_sources(whole=True)
    edit_state(p.backend, mask_tool.rub_off)


def _eraser(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    """The selective eraser: ``fields`` (list), ``fraction``, ``size`` (diameter)."""
    _check_keys("eraser", args, {"fields", "fraction", "size"} | _AT, where)
    e = p.eraser
    fields = args.get("fields", list(e.fields))
    if not isinstance(fields, list) or not all(isinstance(f, str) for f in fields):
        raise PlayerError("eraser fields must be a list of strings", where)
    frac = _tool_number("eraser", args, "fraction", e.fraction, 0.0, 1.0, where)
    size = _tool_number("eraser", args, "size", 2 * e.radius / p.brush_scale, 1, 1024, where)
    try:
        p.eraser = eraser_tool.Eraser(tuple(fields), frac, size * p.brush_scale / 2.0)
    except BadInput as exc:
        raise PlayerError(str(exc).removeprefix("eraser: "), where) from None
    _pick_up(p, "eraser", args, where)


def _tissue(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    """The textured tissue: ``kind`` (crepe, weave, flat), ``scale`` cells, ``seed``,
    ``size`` (diameter), ``absorb``."""
    _check_keys("tissue", args, {"kind", "scale", "seed", "size", "absorb"} | _AT, where)
    t = p.tissue
    kind = args.get("kind", t.kind)
    if kind not in tissue_tool.KINDS:
        raise PlayerError(f"tissue kind {kind!r:.40} must be one of "
                          f"{', '.join(tissue_tool.KINDS)}", where)
    seed = args.get("seed", t.seed)
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**32:
        raise PlayerError(f"tissue seed {seed!r:.40} must be an integer in [0, 2^32)", where)
    scale = _tool_number("tissue", args, "scale", t.scale, 1, 256, where)
    size = _tool_number("tissue", args, "size", 2 * t.radius / p.brush_scale, 1, 1024, where)
    absorb = _tool_number("tissue", args, "absorb", t.absorb, 0, 1, where)
    # a session painted at a smaller size scales the texture with it, but no finer
    # than a cell: the texture lives on the canvas grid
    new = tissue_tool.Tissue(kind, max(1.0, scale * p.brush_scale), seed, None,
                             size * p.brush_scale / 2.0, absorb)
    if (new.kind, new.scale, new.seed) != (t.kind, t.scale, t.seed):
        p._tissue_tex = None
    p.tissue = new
    _pick_up(p, "tissue", args, where)


def _tilt(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    """Tilt the canvas: ``angle`` from the horizontal [deg, 0 ... 90], ``direction`` of
    the downhill slope on the canvas [deg from +x towards +y; 90 = towards the bottom]."""
    _check_keys("tilt", args, {"angle", "direction"}, where)
    angle = _tool_number("tilt", args, "angle", 0.0, 0.0, 90.0, where)
    direction = _tool_number("tilt", args, "direction", 90.0, 0.0, 359.999, where)
    p.flush_sources(whole=True)
    p.tilt = (angle, direction)
    apply_tilt(p)


def apply_tilt(p: SessionPlayer) -> None:
    angle, direction = p.tilt

    def put(st: CanvasState) -> None:
        st.params = st.params.replace(tilt=angle, tilt_direction=direction)

    edit_state(p.backend, put)


def _diffusion(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    """The diffusion controller: while on, the brush writes ``pattern`` (``stripes``,
    ``rings``, ``dots``, ``checks``; ``off`` stops it) of ``period`` cells at ``angle``
    degrees with ``strength`` every ``interval`` touching samples along its strokes."""
    _check_keys("diffusion", args, {"pattern", "period", "angle", "strength", "interval",
                                    "fade"}, where)
    if "fade" in args:  # how long a written pattern takes to age back to free [s]
        fade = _tool_number("diffusion", args, "fade", 2.0, 0.0, 3600.0, where)
        p.flush_sources(whole=True)

        def put(st: CanvasState) -> None:
            st.params = st.params.replace(block_fade=fade)

        edit_state(p.backend, put)
    pattern = args.get("pattern", "stripes")
    if pattern == "off":
        p.controller = None
        return
    interval = args.get("interval", 1)
    if isinstance(interval, bool) or not isinstance(interval, int) or not 1 <= interval <= 1000:
        raise PlayerError(f"diffusion interval {interval!r:.40} must be an integer in "
                          "[1, 1000]", where)
    if pattern not in diffusion_tool.PATTERNS:
        raise PlayerError(f"diffusion pattern {pattern!r:.40} must be off or one of "
                          f"{', '.join(diffusion_tool.PATTERNS)}", where)
    period = _tool_number("diffusion", args, "period", 4.0, 2.0, 512.0, where) * p.brush_scale
    p.controller = diffusion_tool.Controller(
        pattern, max(period, 2.0), _tool_number("diffusion", args, "angle", 0.0, -360, 360, where),
        _tool_number("diffusion", args, "strength", 1.0, 0.0, 1.0, where), interval)
    p._controller_field = None
    p._controller_count = 0


def _undo(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    """Undo the newest stroke or dab (``station.sim.undo``); nothing to undo: counted."""
    _check_keys("undo", args, set(), where)
    if p.history is None or not p.history.undo():
        p.counters.skipped_commands["undo"] = p.counters.skipped_commands.get("undo", 0) + 1
        if p.history is not None and any(p.history.dropped.values()) and (
                "undo-let-go" not in p._warned):
            p._warned.add("undo-let-go")  # once: the history's status keeps the counts
            log.warning("%s%s", f"{where}: " if where else "", p.history.last)


def _redo(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    _check_keys("redo", args, set(), where)
    if p.history is None or not p.history.redo():
        p.counters.skipped_commands["redo"] = p.counters.skipped_commands.get("redo", 0) + 1


def _well(p: SessionPlayer, args: Mapping[str, object], where: str | None) -> None:
    """The palette's mixing well: ``add`` a pigment (``amount`` of tube strength, ``water``,
    ``settle`` seconds of mixing), ``pick`` the mix up with the brush, or ``clear`` it."""
    _check_keys("well", args, {"add", "amount", "water", "settle", "pick", "clear"}, where)
    if p.well is None:
        prof = get_profile(p.profile)
        p.well = well_tool.MixingWell(prof.params, prof.brush.pigment_load)
    well = p.well
    if args.get("clear") is True:
        well.clear()
    name = args.get("add")
    if name is not None:
        if not isinstance(name, str):
            raise PlayerError(f"well add {name!r:.40} must be a pigment name", where)
        amount = _tool_number("well", args, "amount", 0.5, 0.0, 1.0, where)
        water = _tool_number("well", args, "water", 0.6, 0.05, 1.0, where)
        settle = _tool_number("well", args, "settle", 2.0, 0.0, 60.0, where)
        try:
            well_tool.check_room(well, name)
            well.add(name, amount, water, settle)
        except BadInput as exc:
            raise PlayerError(str(exc).removeprefix("well: ").removeprefix("pigment: "),
                              where) from None
    if args.get("pick") is True:
        mix = well.mix()
        if not mix:  # a state, not a malformed command (like undo with nothing to undo)
            p.counters.skipped_commands["well"] = p.counters.skipped_commands.get("well", 0) + 1
            if "well-empty" not in p._warned:
                p._warned.add("well-empty")
                log.warning("%sthe well is empty: nothing to pick up (skipped)",
                            f"{where}: " if where else "")
            return
        b = p.brush.settings
        p._use(BrushSettings(b.kind, b.size, b.water, mix))
        p.tool = None


TOOL_HANDLERS: dict[str, Callable[[SessionPlayer, Mapping[str, object], str | None], None]] = {
    "well": _well,
    "undo": _undo,
    "redo": _redo,
    "diffusion": _diffusion,
    "tilt": _tilt,
    "mask": _mask,
    "mask_remove": _mask_remove,
    "eraser": _eraser,
    "tissue": _tissue,
    "dry": _dry,
    "hairdryer": _hairdryer,
    "new_layer": _new_layer,
    "clear": _clear,
}
"""The tool commands by name (the player adds ``brush``, ``profile`` and ``wait``)."""
