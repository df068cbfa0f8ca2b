"""Typed errors of the HID layer (both are bad input: exit code 2)."""

from __future__ import annotations

from station.errors import BadInput


class DescriptorError(BadInput):
    """A report descriptor is malformed; ``where`` names the byte offset."""

    def __init__(self, message: str, offset: int | None = None) -> None:
        self.offset = offset
        super().__init__(message, None if offset is None else f"descriptor byte {offset}")


class ReportError(BadInput):
    """An input report is malformed (wrong length, unknown report ID, bad bytes)."""
