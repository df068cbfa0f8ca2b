"""UC-Logic parameter string descriptors -> numbers (facts of the kernel's hid-uclogic-params.c).

A UC-Logic tablet answers GET_DESCRIPTOR(string, index) for "magic" indexes with
binary parameters instead of text; reading them is also what switches the
tablet from its low-resolution compatibility reports to full resolution.
``buf`` below is the whole descriptor as the device sends it (bLength,
bDescriptorType 0x03, then the payload), offsets as the kernel uses them.

- v1: string 100 (0x64), 12 bytes: x max le16 @2, y max le16 @4, pressure max
  le16 @8, resolution (lpi) le16 @10; then pen report 7 (in-range bit inverted).
- v2: string 200 (0xc8), 18..32 bytes and not text: x max le24 @2, y max le24 @5,
  pressure max le16 @8, lpi le16 @10; then pen report 8 (x/y high bytes apart, tilt).
- ugee-v2: string 100, 12 bytes: as v1, plus the frame buttons @6; then pen
  report 2 (13-bit pressure, tilt).
"""

from __future__ import annotations

from dataclasses import dataclass

from station.drivers.hid.errors import ReportError

V1_INDEX, V2_INDEX, FIRMWARE_INDEX = 100, 200, 201
V1_LENGTH, V2_MIN, V2_MAX, UGEE_V2_LENGTH = 12, 18, 32, 12
PEN_REPORT_ID = {"v1": 7, "v2": 8, "ugee-v2": 2}
MM_PER_INCH = 25.4


class ParamsError(ReportError):
    """A parameter descriptor that cannot be read as parameters."""


@dataclass(frozen=True, slots=True)
class UclogicParams:
    """Pen parameters of one tablet.

    Attributes:
        kind: ``v1``, ``v2`` or ``ugee-v2`` (the report layout that follows).
        max_x, max_y: largest coordinates (device units).
        max_pressure: largest pressure (device units).
        resolution_lpi: device units per inch (0: unknown).
        frame_buttons: pad buttons (ugee-v2 only, else 0).
    """

    kind: str
    max_x: int
    max_y: int
    max_pressure: int
    resolution_lpi: int
    frame_buttons: int = 0

    @property
    def report_id(self) -> int:
        return PEN_REPORT_ID[self.kind]

    @property
    def resolution_mm(self) -> float | None:
        """Device units per millimetre, ``None`` when the tablet does not say."""
        return self.resolution_lpi / MM_PER_INCH if self.resolution_lpi else None


def _le16(b: bytes, i: int) -> int:
    return b[i] | (b[i + 1] << 8)


def _le24(b: bytes, i: int) -> int:
    return b[i] | (b[i + 1] << 8) | (b[i + 2] << 16)


def parse_v1(buf: bytes) -> UclogicParams:
    if len(buf) != V1_LENGTH:
        raise ParamsError(f"UC-Logic v1 parameters are {len(buf)} bytes, expected {V1_LENGTH}")
    return UclogicParams("v1", _le16(buf, 2), _le16(buf, 4), _le16(buf, 8), _le16(buf, 10))


def looks_like_text(buf: bytes) -> bool:
    """True for a UTF-16LE ASCII string (tablets answer unknown indexes with their name)."""
    body = buf[2:]
    pairs = [body[i:i + 2] for i in range(0, len(body) - 1, 2)]
    return bool(pairs) and all(0x20 <= p[0] < 0x7F and p[1] == 0 for p in pairs)


def parse_v2(buf: bytes) -> UclogicParams:
    if not V2_MIN <= len(buf) <= V2_MAX:
        raise ParamsError(f"UC-Logic v2 parameters are {len(buf)} bytes, "
                          f"expected {V2_MIN}..{V2_MAX}")  # fmt: skip
    if looks_like_text(buf):
        raise ParamsError("UC-Logic v2 parameter descriptor holds only text")
    return UclogicParams("v2", _le24(buf, 2), _le24(buf, 5), _le16(buf, 8), _le16(buf, 10))


def parse_ugee_v2(buf: bytes) -> UclogicParams:
    if len(buf) < UGEE_V2_LENGTH:
        raise ParamsError(f"UGEE v2 parameters are {len(buf)} bytes, "
                          f"expected at least {UGEE_V2_LENGTH}")  # fmt: skip
    return UclogicParams("ugee-v2", _le16(buf, 2), _le16(buf, 4), _le16(buf, 8), _le16(buf, 10),
                         frame_buttons=buf[6])


def string_descriptor(payload: bytes) -> bytes:
    """A string descriptor as a device sends it: bLength, 0x03, payload (for mocks and tests)."""
    return bytes([2 + len(payload), 0x03]) + payload


def encode_v1(max_x: int, max_y: int, max_pressure: int, lpi: int) -> bytes:
    """The v1 parameter descriptor a tablet with these numbers sends (inverse of parse_v1)."""
    body = (max_x.to_bytes(2, "little") + max_y.to_bytes(2, "little") + b"\x00\x00"
            + max_pressure.to_bytes(2, "little") + lpi.to_bytes(2, "little"))  # fmt: skip
    return string_descriptor(body)


def encode_v2(max_x: int, max_y: int, max_pressure: int, lpi: int, tail: bytes = b"") -> bytes:
    """The v2 parameter descriptor (inverse of parse_v2); ``tail`` pads it to 18+ bytes."""
    body = (max_x.to_bytes(3, "little") + max_y.to_bytes(3, "little")
            + max_pressure.to_bytes(2, "little") + lpi.to_bytes(2, "little"))  # fmt: skip
    body += tail or bytes([0x03, 0x0D, 0x10, 0x01, 0x04, 0x3C, 0x3E])
    return string_descriptor(body[:V2_MAX - 2])


def encode_ugee_v2(max_x: int, max_y: int, max_pressure: int, lpi: int, buttons: int) -> bytes:
    """The UGEE v2 parameter descriptor (inverse of parse_ugee_v2)."""
    body = (max_x.to_bytes(2, "little") + max_y.to_bytes(2, "little") + bytes([buttons, 0])
            + max_pressure.to_bytes(2, "little") + lpi.to_bytes(2, "little"))  # fmt: skip
    return string_descriptor(body)
