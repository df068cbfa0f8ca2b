"""The UC-Logic set-up sequence (as the kernel's uclogic_params_init() performs it).

Kinds, from the device data (``uclogic.init``):

- ``huion``: read the firmware name (string 201); unless it is the transition
  firmware ``HUION_T153_160607``, read v2 parameters (string 200, 18..32
  bytes, not plain text); if there are none, read v1 parameters (string 100).
- ``v1``: read v1 parameters (string 100, exactly 12 bytes).
- ``ugee-v2`` (XP-Pen Deco 01 v2, Deco L/M/Pro …): send ``02 b0 04 00 …``
  (10 bytes) to interrupt OUT endpoint 3, then read string 100 (12 bytes).
- ``fixed-descriptor``: nothing to send; the device's own reports are used.

Reading the parameter descriptor is what switches the tablet to its
full-resolution reports.  Only the pen interface (interface 0; 2 for
ugee-v2) is set up; a device that stalls (no such descriptor) keeps its
compatibility reports and is read through its report descriptor.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Protocol, runtime_checkable

from station.drivers.uclogic.params import (
    FIRMWARE_INDEX,
    UGEE_V2_LENGTH,
    V1_INDEX,
    V1_LENGTH,
    V2_INDEX,
    V2_MAX,
    ParamsError,
    UclogicParams,
    parse_ugee_v2,
    parse_v1,
    parse_v2,
)

log = logging.getLogger(__name__)

TRANSITION_FIRMWARE = "HUION_T153_160607"
UGEE_V2_PROBE = bytes([0x02, 0xB0, 0x04]) + bytes(7)
UGEE_V2_ENDPOINT = 0x03
KINDS = ("huion", "v1", "ugee-v2", "fixed-descriptor")


@runtime_checkable
class UclogicControl(Protocol):
    """What the set-up needs from a transport (pyusb has it; hidraw cannot)."""

    def get_string_descriptor(self, index: int, length: int) -> bytes | None:
        """The raw descriptor (bLength, 0x03, payload), at most ``length`` bytes; None: stall."""
        ...

    def write_interrupt(self, endpoint: int, data: bytes) -> None:
        """Send ``data`` to an interrupt OUT endpoint."""
        ...


def _text(buf: bytes | None) -> str:
    if not buf or len(buf) < 2:
        return ""
    return buf[2:].decode("utf-16-le", errors="replace").rstrip("\0")


def initialise(control: UclogicControl, kind: str) -> UclogicParams | None:
    """Run the set-up; the parameters found, or None (the device keeps its own reports)."""
    if kind not in KINDS:
        raise ValueError(f"unknown UC-Logic init kind {kind!r}")
    if kind == "fixed-descriptor":
        return None
    if kind == "ugee-v2":
        control.write_interrupt(UGEE_V2_ENDPOINT, UGEE_V2_PROBE)
        buf = control.get_string_descriptor(V1_INDEX, UGEE_V2_LENGTH)
        return _try(parse_ugee_v2, buf)
    if kind == "huion":
        name_length = 2 + 2 * (len(TRANSITION_FIRMWARE) + 1)
        firmware = _text(control.get_string_descriptor(FIRMWARE_INDEX, name_length))
        if firmware != TRANSITION_FIRMWARE:
            found = _try(parse_v2, control.get_string_descriptor(V2_INDEX, V2_MAX))
            if found is not None:
                return found
    return _try(parse_v1, control.get_string_descriptor(V1_INDEX, V1_LENGTH))


def _try(parse: Callable[[bytes], UclogicParams], buf: bytes | None) -> UclogicParams | None:
    if buf is None:
        return None
    try:
        return parse(buf)
    except ParamsError as exc:
        log.info("UC-Logic parameters not usable: %s", exc)
        return None
