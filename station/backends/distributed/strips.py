"""The pieces of a :class:`~station.backends.distributed.canvas.DistributedCanvas`'s
state: the replicated *shell* (metadata and tiles, empty per-cell arrays), a rank's
local strip made from it, and the border *bands* an overlapped step steps after the
halo has arrived (the module docstring of ``canvas`` tells the scheme)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any, TypeVar, cast

import numpy as np

from station.backends.distributed import exchange
from station.canvas.state import CanvasState

F32 = np.float32
_T = TypeVar("_T")


def zero_fibre(height: int, width: int) -> np.ndarray:
    """A (2, H, W) view of one zero: the shell's ``fibre`` has the canvas's shape (so
    ``CanvasState`` does not make the sheet's fibres again) and holds no memory."""
    return np.broadcast_to(np.zeros((1, 1, 1), F32), (2, height, width))


def zero_plane(height: int, width: int) -> np.ndarray:
    """A (H, W) view of one zero: the shell's ``wet_area`` (like ``fibre``, so
    ``CanvasState`` does not allocate a whole plane for the replicated part)."""
    return np.broadcast_to(np.zeros((1, 1), F32), (height, width))


def empty_shell(st: CanvasState) -> CanvasState:
    """``st``'s metadata and tiles with empty per-cell arrays (the replicated part)."""
    kw: dict[str, Any] = {}
    for name in st.__dataclass_fields__:
        v = getattr(st, name)
        if name == "tile_ttl":
            v = v.copy()
        elif name == "fibre":
            v = zero_fibre(st.height, st.width)
        elif name == "wet_area":
            v = zero_plane(st.height, st.width)
        elif isinstance(v, np.ndarray):
            v = np.zeros((st.n_slots, 0, 0) if name in exchange.STACKS else
                         (0, 0, v.shape[-1]) if name == "r_composed" else (0, 0), v.dtype)
        elif isinstance(v, (list, dict)):
            v = _deep(v)
        kw[name] = v
    return CanvasState(**kw)


def local_from_shell(shell: CanvasState, rows: int, zeroed: bool = True) -> CanvasState:
    """A strip of ``rows`` rows (zeros, or uninitialised for the caller to fill
    completely) with its own copy of the shell's metadata.

    Its ``tile_ttl`` is private (``operations`` mark it in strip coordinates; nothing
    reads it): the canvas's tiles are the shell's.
    """
    kw: dict[str, Any] = {n: _deep(getattr(shell, n)) for n in shell.__dataclass_fields__}
    kw["height"] = rows
    for n in exchange.ALL_FIELDS:
        shape = ((rows, shell.width, shell.r_composed.shape[-1]) if n == "r_composed" else
                 (shell.n_slots, rows, shell.width) if n in exchange.STACKS else
                 (2, rows, shell.width) if n == "fibre" else (rows, shell.width))
        # free pigment slots are never moved: stacks always start as zeros
        fill = zeroed or n in exchange.STACKS
        kw[n] = np.zeros(shape, F32) if fill else np.empty(shape, F32)
    ts = int(shell.params.tile_size)
    kw["tile_ttl"] = np.zeros((-(-rows // ts), -(-shell.width // ts)), np.int32)
    return CanvasState(**kw)


def _deep(v: _T) -> _T:
    """A copy of nested lists and dicts (the arrays and other values they hold are shared)."""
    if isinstance(v, list):
        return cast(_T, [_deep(x) for x in v])
    if isinstance(v, dict):
        return cast(_T, {k: _deep(x) for k, x in v.items()})
    return v


BAND_FIELDS = tuple(n for n in exchange.ALL_FIELDS if n != "r_composed")
"""Per-cell fields a step reads or writes (a border band copies these)."""


class Band:
    """A copy of canvas rows ``[r0, r1)`` x ``xs`` around a strip border, stepped once
    the halo is in; its rows ``[out0, out1)`` (the owned rows next to the border, at
    least one radius from the band's cut edges) are then right and are written back.

    The owned rows are copied when the band is made (before the interior step changes
    them); the halo rows ``[h0, h1)`` are copied again after the exchange.
    """

    def __init__(self, loc: CanvasState, off: int, r0: int, r1: int, xs: slice,
                 out: tuple[int, int], halo: tuple[int, int]) -> None:
        self.r0, self.r1, self.xs = r0, r1, xs
        self.out0, self.out1 = out
        self.halo = halo
        rows = slice(r0 - off, r1 - off)
        kw: dict[str, Any] = {}
        for n in BAND_FIELDS:
            arr = getattr(loc, n)
            kw[n] = (arr[:, rows, xs] if arr.ndim == 3 else arr[rows, xs]).copy()
        self.state = dataclasses.replace(loc, height=r1 - r0, width=xs.stop - xs.start,
                                         r_composed=np.zeros((0, 0, 3), F32), **kw)

    @property
    def rows(self) -> int:
        return self.r1 - self.r0

    def step(self, loc: CanvasState, off: int, stepper: Callable[[CanvasState, float], None],
             dt: float) -> None:
        """Refresh the halo rows from ``loc``, step the band, write the border rows back."""
        bs = self.state
        a, b = self.halo
        for n in exchange.DYNAMIC_FIELDS:  # only these travel in the halo
            src, dst = getattr(loc, n), getattr(bs, n)
            if n in exchange.STACKS:
                dst[:, a - self.r0:b - self.r0] = src[:, a - off:b - off, self.xs]
            else:
                dst[a - self.r0:b - self.r0] = src[a - off:b - off, self.xs]
        stepper(bs, dt)
        o0, o1 = self.out0 - self.r0, self.out1 - self.r0
        for n in BAND_FIELDS:
            if n == "fibre":
                continue  # static
            src, dst = getattr(bs, n), getattr(loc, n)
            if n in exchange.STACKS:
                dst[:, self.out0 - off:self.out1 - off, self.xs] = src[:, o0:o1]
            else:
                dst[self.out0 - off:self.out1 - off, self.xs] = src[o0:o1]
