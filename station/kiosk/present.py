"""Putting a frame on the screen: the whole back buffer swapped, or only its damaged
rectangles copied to the window.

``swap_buffers`` presents every pixel of the window.  On a GPU that is a page
flip or a blit the GPU does, synchronised with the vertical blank.  On a
software rasteriser (Mesa's llvmpipe, what a machine without a GPU runs), it
is the CPU copying the whole window to the X server — 1–2 ms at 1024×768 on
the 2-core development machine, and as much again to fill the back buffer
first — every frame, while a visitor's stroke changes a brush-sized part of it.
There is no vertical blank to wait for there either.

So where the GLX extension ``GLX_MESA_copy_sub_buffer`` exists (Mesa's GLX,
software or not), the kiosk can present a frame by copying only the damaged
rectangles of the back buffer to the window (``glXCopySubBufferMESA``): the
back buffer needs to be right only inside them.  ``auto`` does this on a
software rasteriser and swaps on a GPU (tear-free, vsync); ``partial`` and
``swap`` force one or the other.  A partial present does not wait for the
vertical blank, so on a GPU with vsync it can tear — hence not the default
there.

The X server keeps the window's pixels between copies.  Where it may have
lost them (an expose: the window was covered, mapped again, resized), and
anyway once a second, the next frame is presented whole.  While the pen paints,
that once-a-second whole frame would be the slowest frame of all (fill, copy
and swap of every pixel: 60–130 ms at 3840×2160 on llvmpipe, the pen's p99
whenever it fell in a stroke); instead every frame also presents a band of a
few rows, rolling down the window (:meth:`Presenter.rolling_band`), so every
pixel is presented again within :data:`ROLL_PERIOD_S` at the cost of a few
rows a frame.
"""

from __future__ import annotations

import ctypes
import logging
from typing import Any

log = logging.getLogger(__name__)

PRESENT_MODES = ("auto", "swap", "partial")

#: A partial present is followed by a whole one at least this often (seconds): the
#: window is right even if the X server lost pixels without telling.
FULL_EVERY_S = 1.0

#: While the pen paints, the rolling band presents every row of the window again within
#: this long (seconds) instead (see the module docstring).
ROLL_PERIOD_S = 10.0
#: ... counting at most this long (s) a frame: the first frame after a pause (a quiet
#: window draws four times a second, and is presented whole every second anyway) takes
#: a band of a few rows, not a tenth of the window.
ROLL_FRAME_MAX_S = 0.02

#: Whole frames presented after the window is resized (see Presenter.resized).
RESIZE_WHOLE_FRAMES = 8

#: Renderers that rasterise on the CPU (no vertical blank, swap copies the window).
SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swrast", "lavapipe", "swr")

Rect = tuple[int, int, int, int]  # window pixels x0, y0, x1, y1 (origin top-left, exclusive)


class Presenter:
    """Presents frames of one glfw window (see the module docstring)."""

    def __init__(self, glfw: Any, window: Any, renderer: str, size: tuple[int, int],
                 mode: str = "auto", vsync: bool = True) -> None:
        if mode not in PRESENT_MODES:
            raise ValueError(f"present mode {mode!r} (one of {', '.join(PRESENT_MODES)})")
        self.glfw = glfw
        self.window = window
        self.size = size
        self.whole_next = True  # the first frame is presented whole
        self._whole_left = 0  # whole frames still owed to a resize
        self.partial_frames = 0
        self.whole_frames = 0
        self._roll_y = 0.0  # the rolling band's next row
        self._roll_t: float | None = None  # when the last band was taken
        self._copy_sub: Any = None
        self._dpy: Any = None
        self._drawable = 0
        software = any(name in renderer.lower() for name in SOFTWARE_RENDERERS)
        want = mode == "partial" or (mode == "auto" and (software or not vsync))
        if want:
            self._copy_sub = self._find_copy_sub_buffer()
            if self._copy_sub is None and mode == "partial":
                log.warning("partial present asked for, but GLX_MESA_copy_sub_buffer is "
                            "not there: every frame is swapped whole")
        self.mode = "partial" if self._copy_sub is not None else "swap"
        # an expose (the window covered and shown again): the next frame goes whole
        glfw.set_window_refresh_callback(window, lambda w: self.lost())

    def _find_copy_sub_buffer(self) -> Any:
        """``glXCopySubBufferMESA`` for this window, or ``None`` (not GLX, no extension)."""
        glfw = self.glfw
        try:
            dpy = glfw.get_x11_display()
            drawable = glfw.get_glx_window(self.window)
        except Exception:  # glfw on Wayland, or an EGL context: no GLX here
            return None
        if not dpy or not drawable:
            return None
        try:
            x11 = ctypes.CDLL("libX11.so.6")
            glx = ctypes.CDLL("libGL.so.1")
        except OSError:
            return None
        x11.XDefaultScreen.restype = ctypes.c_int
        x11.XDefaultScreen.argtypes = [ctypes.c_void_p]
        glx.glXQueryExtensionsString.restype = ctypes.c_char_p
        glx.glXQueryExtensionsString.argtypes = [ctypes.c_void_p, ctypes.c_int]
        extensions = (glx.glXQueryExtensionsString(dpy, x11.XDefaultScreen(dpy)) or b"").split()
        if b"GLX_MESA_copy_sub_buffer" not in extensions:
            return None
        addr = glfw.get_proc_address("glXCopySubBufferMESA")
        if not addr:
            return None
        proto = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int,
                                 ctypes.c_int, ctypes.c_int, ctypes.c_int)
        self._dpy = ctypes.c_void_p(dpy)
        self._drawable = int(drawable)
        return proto(addr)

    def lost(self) -> None:
        """The window's pixels may be gone: present the next frame whole."""
        self.whole_next = True

    def resized(self, size: tuple[int, int]) -> None:
        """The window changed size: whole frames for a while.  The driver's buffers take
        the new size at a swap of its own choosing (Mesa's software GLX: a swap or two
        later); a rectangle copied before that lands on the old buffers' place, and
        the window showed the old picture shifted, black along its right and bottom."""
        self.size = size
        self.whole_next = True
        self._whole_left = RESIZE_WHOLE_FRAMES

    def owes_whole(self) -> bool:
        """Whether frames are owed to a resize (drawn even if nothing else changed)."""
        return self._whole_left > 0

    def needs_whole(self, now: float, last_whole: float, painting: bool = False) -> bool:
        """Whether the next frame must fill and present the whole window (``painting``:
        the pen is at work; the rolling band is the safety net then, not whole frames)."""
        return (self._copy_sub is None or self.whole_next or self._whole_left > 0
                or (not painting and now - last_whole >= FULL_EVERY_S))

    def rolling_band(self, now: float) -> Rect | None:
        """The rows (a whole-width rectangle) a partial frame at ``now`` presents besides
        its damage: as many as keep the band going down the window once every
        :data:`ROLL_PERIOD_S` (frames at least 50 a second), from where the last frame's
        ended (``None``: the first)."""
        w, h = self.size
        last, self._roll_t = self._roll_t, now
        if last is None or h <= 0:
            return None
        rows = h * min(max(now - last, 0.0), ROLL_FRAME_MAX_S) / ROLL_PERIOD_S
        y0 = self._roll_y
        y1 = min(y0 + rows, float(h))
        self._roll_y = 0.0 if y1 >= h else y1
        # whole rows, each once: a row is presented by the frame whose band ends past it
        top, bottom = int(y0), (h if y1 >= h else int(y1))
        return (0, top, w, bottom) if bottom > top else None

    def present_whole(self) -> None:
        self.glfw.swap_buffers(self.window)
        self.whole_next = False
        self._whole_left = max(0, self._whole_left - 1)
        self.whole_frames += 1

    def present_rects(self, rects: list[Rect]) -> int:
        """Copy ``rects`` of the back buffer to the window (merged where they overlap
        enough to matter: the caller's choice); returns the pixels copied.
        Each is clipped to the window first: a rectangle reaching outside it is an X
        protocol error, which ends the process."""
        w, h = self.size
        pixels = 0
        for x0, y0, x1, y1 in rects:  # merged by the caller
            x0, y0, x1, y1 = max(int(x0), 0), max(int(y0), 0), min(int(x1), w), min(int(y1), h)
            if x1 <= x0 or y1 <= y0:
                continue
            # GLX counts y from the bottom of the window
            self._copy_sub(self._dpy, self._drawable, x0, h - y1, x1 - x0, y1 - y0)
            pixels += (x1 - x0) * (y1 - y0)
        self.partial_frames += 1
        return pixels

