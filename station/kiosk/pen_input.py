"""The kiosk's input: the mouse or a touchscreen as a pen, the pen's samples mapped
through the view (panel or canvas), commands for the window, the drivers' status.

Functions of the app (:class:`~station.kiosk.app.KioskApp`), by job."""

from __future__ import annotations

import logging
import math
import time
from typing import TYPE_CHECKING, Any

from station.errors import BadInput
from station.events import Command, PenSample, Tool
from station.kiosk import mouse
from station.kiosk.commands import MESSAGE_MAX, check_kiosk_command, is_kiosk_command
from station.kiosk.config import (
    DRIVER_SILENT_S,
)
from station.kiosk.views import input_camera

if TYPE_CHECKING:  # the functions take the app; no import at run time (app imports us)
    from station.kiosk.app import KioskApp

log = logging.getLogger(__name__)


def mouse_time(app: KioskApp) -> tuple[float, float]:
    now = time.monotonic()
    return now - app.session.started_mono, now


def on_cursor(app: KioskApp, window: Any, x: float, y: float) -> None:
    """glfw: the pointer moved to window pixel (x, y)."""
    app.mouse.move(float(x), float(y), *mouse_time(app))


def on_mouse_button(app: KioskApp, window: Any, button: int, action: int, mods: int) -> None:
    """glfw: a button went down or up (the left one, or a touchscreen's finger)."""
    if button == app.glfw.MOUSE_BUTTON_LEFT:
        app.mouse.button(action == app.glfw.PRESS, *mouse_time(app))


def on_cursor_enter(app: KioskApp, window: Any, entered: int) -> None:
    if not entered:
        app.mouse.leave(*mouse_time(app))


def feed_mouse(app: KioskApp) -> bool:
    """The mouse's samples to the painting, as a pen's (``auto``: not while a pen is
    heard); ``True`` if any went."""
    samples = app.mouse.take()
    if not samples or (app.cfg.input == "auto"
                       and time.monotonic() - app._pen_heard < mouse.PEN_WINS_S):
        return False
    for sample in samples:
        app.session.handle("pen", sample)
    return True


def map_pen(app: KioskApp, s: PenSample) -> PenSample | None:
    """Screen-space sample → the canvas's sample (``None``: the panel has it)."""
    now = time.monotonic()
    w, h = app.size
    px, py = s.x * w, s.y * h
    app._pen_received = now
    if s.device != mouse.DEVICE:
        app._pen_heard = now
    app._pen_read = s.t_mono if s.t_mono > 0.0 else now
    app.predictor.add(s.t, px, py, s.proximity, s.touching and s.proximity)
    if app.pen_log is not None:
        app.pen_log.append((s.t_mono if s.t_mono > 0.0 else now, s.t, px, py,
                             s.touching and s.proximity))
    app.panel.eraser = s.tool is Tool.ERASER
    if s.proximity:
        app.idle.activity(now)
    touching = s.touching and s.proximity
    if touching:
        app._last_touch = now
    if touching and not app.touching:
        app.capture = "ui" if px < app.panel_w else "canvas"
    app.touching = touching
    capture = app.capture
    if not touching:
        app.capture = None
    cam = input_camera(app.panel.view, app.area, app.aspect)
    uv = cam.screen_to_canvas(px, py) if px >= app.panel_w else None
    inside = uv is not None and 0.0 <= uv[0] <= 1.0 and 0.0 <= uv[1] <= 1.0
    app.hover = uv if (s.proximity and inside) else None
    if inside and uv is not None:
        app.follow_at = uv
    near = s.proximity
    if capture == "ui" or (capture is None and px < app.panel_w):
        app.gui.pointer(px if near else None, py if near else None, touching)
        return None
    # over the canvas ImGui still follows the pen (a drag released there ends there)
    app.gui.pointer(px if near else None, py if near else None, False)
    if not inside or uv is None:  # off the canvas: the stroke lifts
        last = app.session.last_canvas_pen if hasattr(app, "session") else None
        if last is None or not last.touching:
            return None
        return s.with_(x=last.x, y=last.y, touching=False, pressure=0.0)
    return s.with_(x=float(uv[0]), y=float(uv[1]))


def sync_panel(app: KioskApp) -> None:
    """Show the brush the painting really has (an operator's ``brush`` command on the
    bus changes it too)."""
    b = app.session.player.brush.settings
    key = (b.kind, b.size, b.water, tuple(sorted(b.pigment.items())))
    if key == app._brush_key:
        return
    app._brush_key = key
    p = app.panel
    mine = p.brush_args()
    if (mine["kind"] == b.kind and math.isclose(mine["size"], b.size)
            and math.isclose(mine["water"], b.water)
            and mine["pigment"].keys() == b.pigment.keys()
            and all(math.isclose(v, b.pigment[k]) for k, v in mine["pigment"].items())):
        return  # the panel's own brush: keep its parts as the visitor mixed them
    p.kind, p.size, p.water = b.kind, float(b.size), float(b.water)
    total = sum(b.pigment.values())
    if total > 0:
        p.strength = float(total)
        p.mix = {name: float(v / total) for name, v in b.pigment.items()}
    else:
        p.mix = {}


def kiosk_command(app: KioskApp, cmd: Command) -> bool:
    """Commands for the window (:mod:`station.kiosk.commands`: ``view``, ``fresh``,
    ``screenshot``, ``message``) and the gallery's ``save`` and ``stop``; ``False``:
    the painting's.  A bad one is logged and dropped (it came from the bus)."""
    if cmd.cmd == "save":
        app.save_now()
        return True
    if cmd.cmd == "stop":
        app.stop_requested = True
        return True
    if not is_kiosk_command(cmd.cmd):
        return False
    try:
        check_kiosk_command(cmd, where="bus")
    except BadInput as exc:
        log.warning("kiosk command refused: %s", exc)
        return True
    if cmd.cmd == "view":
        app.panel.set_view(str(cmd.args["name"]))
    elif cmd.cmd == "fresh":
        app._fresh_requested = True
    elif cmd.cmd == "message":  # an operator's note on the panel (blueprint show-message)
        app.panel.message = " ".join(str(cmd.args["text"]).split())[:MESSAGE_MAX]
    elif cmd.cmd == "screenshot":
        if app.cfg.screenshot_dir is None:
            log.warning("screenshot refused: the kiosk runs without --screenshot-dir")
        else:
            app.screenshots.append(app.cfg.screenshot_dir / f"{cmd.args['name']}.png")
    return True


def commands(app: KioskApp) -> None:
    """Commands sent to the kiosk's own endpoint (``station send``)."""
    if app.cmd_sub is None:
        return
    answerer = app.session.sim.answerer
    answerer.upstream = app.cmd_sub.send_upstream  # a "peer" answer goes back here
    try:
        msg = app.cmd_sub.recv(0)
        while msg is not None:
            app.session.handle(msg.kind, msg.value, msg.topic, msg.replay)
            msg = app.cmd_sub.recv(0)
    finally:
        answerer.upstream = None


def driver_status(app: KioskApp) -> None:
    msg = app.driver_sub.recv(0)
    while msg is not None:
        v = msg.value
        if isinstance(v, dict) and v.get("kind") == "driver":
            state = str(v.get("state", "unknown"))
            if state != app.driver_state:
                app.driver_events.append(state)
            app.driver_state = state
            app.driver_seen = time.monotonic()
        msg = app.driver_sub.recv(0)


def pen_missing(app: KioskApp) -> bool:
    """Whether to show "the pen is unplugged": a driver said so, or went silent."""
    if app.driver_state in ("gone", "waiting", "failed"):
        return True
    return (app.driver_state == "running"
            and time.monotonic() - app.driver_seen > DRIVER_SILENT_S)
