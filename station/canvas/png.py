"""Minimal PNG writer (8- and 16-bit RGB) with zlib and struct only.

Pixels are written as given (no gamma chunk): callers convert linear reflectance
to sRGB first (``render.to_srgb8`` / ``to_srgb16``).
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

from station.errors import StationError

_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _chunk(kind: bytes, data: bytes) -> bytes:
    crc = zlib.crc32(kind + data) & 0xFFFFFFFF
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)


def encode_png(pixels: np.ndarray) -> bytes:
    """PNG bytes of ``pixels``: uint8 or uint16 array (H, W, 3) (RGB)."""
    if pixels.ndim != 3 or pixels.shape[2] != 3:
        raise StationError("PNG pixels must have shape (H, W, 3)")
    if pixels.dtype == np.uint8:
        depth = 8
        raw = np.ascontiguousarray(pixels)
    elif pixels.dtype == np.uint16:
        depth = 16
        raw = np.ascontiguousarray(pixels.astype(">u2"))
    else:
        raise StationError(f"PNG pixels must be uint8 or uint16, not {pixels.dtype}")
    h, w, _ = pixels.shape
    rows = raw.reshape(h, -1).view(np.uint8)
    filt = np.zeros((h, 1), np.uint8)  # filter type 0 (None) on every row
    data = np.concatenate([filt, rows], axis=1).tobytes()
    ihdr = struct.pack(">IIBBBBB", w, h, depth, 2, 0, 0, 0)
    return (_SIGNATURE + _chunk(b"IHDR", ihdr) + _chunk(b"IDAT", zlib.compress(data, 6))
            + _chunk(b"IEND", b""))


def write_png(path: str | Path, pixels: np.ndarray) -> None:
    """Write ``pixels`` (uint8 or uint16 (H, W, 3)) to ``path``."""
    Path(path).write_bytes(encode_png(pixels))
