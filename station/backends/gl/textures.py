"""GPU storage of the canvas state: float32 textures, allocated once.

Layout (every texture W x H texels, texel ``(x=j, y=i)`` is cell ``(i, j)``,
float32 per channel; "pp" marks ping-pong pairs, the others are updated in
place because only point-wise passes write them):

==========  ==========  =====  ===========================================
texture     format      pp     channels
==========  ==========  =====  ===========================================
``vel``     RG32F       yes    vx, vy  [cell/s]
``water``   RGBA32F     yes    w, wc [height], evaporated, removed_w (accumulators)
``paper``   RGBA32F     no     h, mask, block, block_time
``pig``     RGBA32F[L]  yes    suspended pigment p, 4 slots per layer (L = S/4)
``dep``     RGBA32F[L]  no     deposited pigment q, 4 slots per layer
``rem``     RGBA32F[L]  no     removed pigment (tool accumulator)
``rcomp``   RGBA32F[R]  no     r_composed per render band, 4 bands per layer (R = 1 for
                               RGB, 3 for the 12 spectral bands)
``fibre``   RG32F       no     the paper's fibre texture: along x, along y (static)
``area``    R32F        no     wet_area, Curtis's wet-area mask memory (SimParams.wet_hold)
==========  ==========  =====  ===========================================

With the default 8 slots the pigments of a layer sit in two RGBA32F layers
of a texture array (the seed's "two RGBA textures per layer").
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import moderngl


@dataclass
class Field:
    """One state texture (or a ping-pong pair) with its channel count and layers."""

    name: str
    components: int
    layers: int  # 0: plain 2-D texture; >= 1: texture array with that many layers
    pingpong: bool
    textures: list[moderngl.Texture | moderngl.TextureArray] = field(default_factory=list)
    cur: int = 0

    @property
    def src(self) -> moderngl.Texture | moderngl.TextureArray:
        """The texture holding the current values."""
        return self.textures[self.cur]

    @property
    def dst(self) -> moderngl.Texture | moderngl.TextureArray:
        """The texture a ping-pong pass writes (the current one for in-place fields)."""
        return self.textures[1 - self.cur] if self.pingpong else self.textures[self.cur]

    def swap(self) -> None:
        if self.pingpong:
            self.cur = 1 - self.cur

    @property
    def image_format(self) -> str:
        return {1: "r32f", 2: "rg32f", 4: "rgba32f"}[self.components]

    def nbytes(self, width: int, height: int) -> int:
        return width * height * self.components * max(self.layers, 1) * 4


def allocate(ctx: moderngl.Context, width: int, height: int, n_layers: int,
             rcomp_layers: int = 1) -> dict[str, Field]:
    """Create every state texture of a ``width`` x ``height`` canvas (zeros);
    ``rcomp_layers``: layers of 4 render bands for ``r_composed``."""
    specs = [
        Field("vel", 2, 0, True),
        Field("water", 4, 0, True),
        Field("paper", 4, 0, False),
        Field("pig", 4, n_layers, True),
        Field("dep", 4, n_layers, False),
        Field("rem", 4, n_layers, False),
        Field("rcomp", 4, rcomp_layers, False),
        Field("fibre", 2, 0, False),
        Field("area", 1, 0, False),
    ]
    out: dict[str, Field] = {}
    for f in specs:
        for _ in range(2 if f.pingpong else 1):
            tex: moderngl.Texture | moderngl.TextureArray
            if f.layers:
                tex = ctx.texture_array((width, height, f.layers), f.components, dtype="f4")
            else:
                tex = ctx.texture((width, height), f.components, dtype="f4")
            tex.filter = (ctx.NEAREST, ctx.NEAREST) if hasattr(ctx, "NEAREST") else tex.filter
            f.textures.append(tex)
        out[f.name] = f
    return out


def pack_planes(*planes: np.ndarray) -> np.ndarray:
    """(H, W) planes → (H, W, C) float32 interleaved texel data."""
    return np.ascontiguousarray(np.stack(planes, axis=-1), dtype=np.float32)


def pack_stack(stack: np.ndarray, n_layers: int) -> np.ndarray:
    """(S, H, W) slots → (L, H, W, 4) texture-array data, zero-padded to 4·L slots."""
    s, h, w = stack.shape
    padded = np.zeros((4 * n_layers, h, w), np.float32)
    padded[:s] = stack
    return np.ascontiguousarray(padded.reshape(n_layers, 4, h, w).transpose(0, 2, 3, 1))


def unpack_stack(data: bytes, n_slots: int, n_layers: int, height: int,
                 width: int) -> np.ndarray:
    """Inverse of :func:`pack_stack`: texture-array bytes → (S, H, W) float32."""
    a = np.frombuffer(data, np.float32).reshape(n_layers, height, width, 4)
    return np.ascontiguousarray(a.transpose(0, 3, 1, 2).reshape(4 * n_layers, height,
                                                                 width)[:n_slots])


def unpack_planes(data: bytes, components: int, height: int, width: int) -> list[np.ndarray]:
    """Texture bytes → ``components`` (H, W) float32 planes."""
    a = np.frombuffer(data, np.float32).reshape(height, width, components)
    return [np.ascontiguousarray(a[..., c]) for c in range(components)]
