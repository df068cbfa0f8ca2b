"""How wet the paper is, in the status's words: wet, damp or dry."""

from __future__ import annotations

from dataclasses import dataclass

#: Capillary water (the paper's ``wc``) above which a cell without surface water is
#: damp, not dry: after a wash the surface water is gone in seconds while the paper
#: holds water for a minute more (the status read "wet 0.0%" all that time).
DAMP_WATER = 1e-4


@dataclass(frozen=True)
class Moisture:
    """Shares of the canvas's cells (0..1): with surface water (wet), with water only
    in the paper (damp); the rest is dry."""

    wet: float
    damp: float

    @property
    def word(self) -> str:
        """``wet``, ``damp`` or ``dry``: the wettest state any cell is in."""
        return "wet" if self.wet > 0 else ("damp" if self.damp > 0 else "dry")

    def line(self) -> str:
        """The status line's words: ``wet 3.1%  damp 8.0%``, ``damp 8.0%`` or ``dry``."""
        parts = []
        if self.wet > 0:
            parts.append(f"wet {100 * self.wet:.1f}%")
        if self.damp > 0:
            parts.append(f"damp {100 * self.damp:.1f}%")
        return "  ".join(parts) or "dry"
