"""Wacom mode switching: the feature reports that take a tablet out of mouse mode.

Wacom tablets power up in a mouse-compatible mode (report ID 1, a boot mouse).
A driver that opens them through HID (not through the kernel's wacom driver)
sends feature report 2 with value 2 to get the pen protocol.
"""

from __future__ import annotations

PEN_MODE_FEATURE = bytes([0x02, 0x02])  # report ID 2, mode 2 (pen reports)
MOUSE_MODE_REPORT_ID = 1  # reports sent before the switch: recognised and skipped


def parse_feature_hex(text: str) -> bytes:
    """``"0202"`` or ``"02 02"`` -> bytes; raises ValueError on bad hex."""
    return bytes.fromhex(text.replace(" ", ""))
