"""PNG output, 8- and 16-bit RGB, through Pillow and pypng.

Pixels are written as given (no gamma chunk): callers convert linear reflectance
to sRGB first (``render.to_srgb8`` / ``to_srgb16``).  Both depths are lossless: a
file decodes to exactly the array that was written.

8-bit goes through Pillow.  16-bit goes through pypng because Pillow has no
48-bit RGB image mode (Pillow 13: ``Image.fromarray`` of an (H, W, 3) uint16 array
raises "Cannot handle this data type"; its PNG writer only knows 16-bit grey).
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import IO

import numpy as np
import png as pypng
from PIL import Image

from station.errors import StationError

COMPRESS_LEVEL = 6
"""zlib level of both writers (6: zlib's default balance of size and speed)."""


def _check(pixels: np.ndarray) -> None:
    if pixels.ndim != 3 or pixels.shape[2] != 3:
        raise StationError("PNG pixels must have shape (H, W, 3)")
    if pixels.dtype not in (np.uint8, np.uint16):
        raise StationError(f"PNG pixels must be uint8 or uint16, not {pixels.dtype}")


def _write(stream: IO[bytes], pixels: np.ndarray) -> None:
    _check(pixels)
    h, w, _ = pixels.shape
    if pixels.dtype == np.uint8:
        Image.fromarray(np.ascontiguousarray(pixels)).save(  # (H, W, 3) uint8 is RGB
            stream, format="PNG", compress_level=COMPRESS_LEVEL)
    else:
        writer = pypng.Writer(w, h, greyscale=False, bitdepth=16, compression=COMPRESS_LEVEL)
        writer.write_array(stream, np.ascontiguousarray(pixels).reshape(-1))


def encode_png(pixels: np.ndarray) -> bytes:
    """PNG bytes of ``pixels``: uint8 or uint16 array (H, W, 3) (RGB)."""
    buf = io.BytesIO()
    _write(buf, pixels)
    return buf.getvalue()


def write_png(path: str | Path, pixels: np.ndarray) -> None:
    """Write ``pixels`` (uint8 or uint16 (H, W, 3)) to ``path``."""
    # encoded first: a bad array or a failing encoder leaves no half-written file behind
    Path(path).write_bytes(encode_png(pixels))
