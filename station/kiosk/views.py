"""The three views of the canvas (dissertation 6.4) and screen ↔ canvas mapping.

World coordinates: the canvas lies on a table in the plane z = 0, centred on
the origin, ``aspect`` wide and 1 deep; canvas (u, v) in [0, 1]² (u right,
v down the painting) is world ``((u - ½)·aspect, ½ - v, 0)``, so the top of
the painting is +y, away from a visitor standing at −y.

* ``2d``: orthographic from above, the canvas fitted into the canvas area;
  the brush is shown only by its shadow.
* ``3d``: perspective of the canvas lying on a table, seen by someone standing
  in front of it; the pen paints where its screen position meets the table.
* ``follow``: a camera that follows the brush (low, close, tilted).  The pen
  maps onto the canvas as in ``2d`` (a camera steered by the pen it follows
  would chase itself); the view is for watching the brush, as in WaterVerve.

Every view is a 4×4 view-projection matrix ``vp`` (world → clip) and the
viewport rectangle it draws into; :func:`screen_to_canvas` inverts it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# the view command's names, defined with the command (re-exported for the window)
from station.kiosk.commands import VIEWS as VIEWS


def perspective(fovy_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    f = 1.0 / math.tan(math.radians(fovy_deg) / 2.0)
    return np.array([[f / aspect, 0, 0, 0], [0, f, 0, 0],
                     [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)],
                     [0, 0, -1, 0]])


def ortho(left: float, right: float, bottom: float, top: float, near: float = -1.0,
          far: float = 1.0) -> np.ndarray:
    return np.array([[2 / (right - left), 0, 0, -(right + left) / (right - left)],
                     [0, 2 / (top - bottom), 0, -(top + bottom) / (top - bottom)],
                     [0, 0, -2 / (far - near), -(far + near) / (far - near)],
                     [0, 0, 0, 1]])


def look_at(eye: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    f = target - eye
    f = f / np.linalg.norm(f)
    s = np.cross(f, up)
    s = s / np.linalg.norm(s)
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    return m


@dataclass(frozen=True)
class Viewport:
    """A rectangle of the window in pixels, origin top-left."""

    x: int
    y: int
    w: int
    h: int

    def gl(self, window_h: int) -> tuple[int, int, int, int]:
        """The same rectangle for ``glViewport`` (origin bottom-left)."""
        return (self.x, window_h - self.y - self.h, self.w, self.h)


@dataclass
class Camera:
    """A view: its name, matrix and viewport (see module docstring)."""

    name: str
    vp: np.ndarray
    viewport: Viewport
    aspect: float

    def canvas_to_world(self, u: float, v: float) -> np.ndarray:
        return np.array([(u - 0.5) * self.aspect, 0.5 - v, 0.0])

    def world_to_screen(self, p: np.ndarray) -> tuple[float, float] | None:
        """Window pixel (x, y) of a world point, or ``None`` behind the camera."""
        c = self.vp @ np.append(p, 1.0)
        if c[3] <= 1e-9:
            return None
        ndc = c[:3] / c[3]
        vp = self.viewport
        return (vp.x + (ndc[0] + 1) / 2 * vp.w, vp.y + (1 - ndc[1]) / 2 * vp.h)

    def screen_to_world(self, x: float, y: float) -> np.ndarray | None:
        """Where the window pixel (x, y) meets the table plane z = 0 (``None``: it
        does not, looking above the horizon)."""
        vp = self.viewport
        nx = (x - vp.x) / vp.w * 2 - 1
        ny = 1 - (y - vp.y) / vp.h * 2
        inv = np.linalg.inv(self.vp)
        a = inv @ np.array([nx, ny, -1.0, 1.0])
        b = inv @ np.array([nx, ny, 1.0, 1.0])
        a, b = a[:3] / a[3], b[:3] / b[3]
        dz = b[2] - a[2]
        if abs(dz) < 1e-12:
            return None
        s = -a[2] / dz
        if s < 0:
            return None
        out: np.ndarray = a + s * (b - a)
        return out

    def screen_to_canvas(self, x: float, y: float) -> tuple[float, float] | None:
        """Canvas (u, v) under window pixel (x, y) (may lie outside [0, 1])."""
        p = self.screen_to_world(x, y)
        if p is None:
            return None
        return (p[0] / self.aspect + 0.5, 0.5 - p[1])


def fit_2d(area: Viewport, aspect: float, margin: float = 0.04) -> Camera:
    """Orthographic view from above, the canvas fitted into ``area`` with a margin."""
    avail_w, avail_h = area.w * (1 - 2 * margin), area.h * (1 - 2 * margin)
    scale = min(avail_w / aspect, avail_h)  # pixels per world unit
    half_w, half_h = area.w / scale / 2, area.h / scale / 2
    return Camera("2d", ortho(-half_w, half_w, -half_h, half_h, -10, 10), area, aspect)


def table_3d(area: Viewport, aspect: float) -> Camera:
    """The canvas on a table, seen by a standing visitor in front of it."""
    eye = np.array([0.0, -1.75, 1.45])
    target = np.array([0.0, 0.02, 0.0])
    proj = perspective(42.0, area.w / area.h, 0.05, 20.0)
    view = look_at(eye, target, np.array([0.0, 0.0, 1.0]))
    return Camera("3d", proj @ view, area, aspect)


def follow(area: Viewport, aspect: float, u: float, v: float) -> Camera:
    """A camera that follows the brush at canvas (u, v): close, low, tilted."""
    target = np.array([(u - 0.5) * aspect, 0.5 - v, 0.0])
    eye = target + np.array([0.0, -0.22, 0.28])
    proj = perspective(50.0, area.w / area.h, 0.02, 10.0)
    view = look_at(eye, target, np.array([0.0, 0.0, 1.0]))
    return Camera("follow", proj @ view, area, aspect)


def make_camera(name: str, area: Viewport, aspect: float,
                brush: tuple[float, float] = (0.5, 0.5)) -> Camera:
    if name == "2d":
        return fit_2d(area, aspect)
    if name == "3d":
        return table_3d(area, aspect)
    if name == "follow":
        return follow(area, aspect, *brush)
    raise ValueError(f"unknown view {name!r} (one of {', '.join(VIEWS)})")


def input_camera(name: str, area: Viewport, aspect: float) -> Camera:
    """The camera the pen paints through in view ``name`` (``follow`` paints as ``2d``)."""
    return table_3d(area, aspect) if name == "3d" else fit_2d(area, aspect)
