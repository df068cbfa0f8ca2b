"""Synthetic tablet reports: the exact inverses of the Wacom (Intuos, Bamboo /
Intuos-HT, Graphire) and UC-Logic parsers."""

from __future__ import annotations

from station.events import Button

# -- Wacom Intuos (10-byte report 2) ------------------------------------------------


def _report(report_id: int, n: int) -> bytearray:
    b = bytearray(n)
    b[0] = report_id
    return b


def intuos_prox_in(tool_id: int, serial: int, report_id: int = 2) -> bytes:
    """Proximity-in packet naming the tool (20-bit tool id, 32-bit serial)."""
    if not 0 <= tool_id < 1 << 20 or not 0 <= serial < 1 << 32:
        raise ValueError("tool id is 20 bits, serial 32 bits")
    d = _report(report_id, 10)
    d[1] = 0xC2
    d[2] = (tool_id >> 4) & 0xFF
    d[3] = ((tool_id & 0xF) << 4) | ((serial >> 28) & 0xF)
    d[4] = (serial >> 20) & 0xFF
    d[5] = (serial >> 12) & 0xFF
    d[6] = (serial >> 4) & 0xFF
    d[7] = ((serial & 0xF) << 4) | ((tool_id >> 16) & 0xF)
    d[8] = ((tool_id >> 12) & 0xF) << 4
    return bytes(d)


def intuos_in_range(report_id: int = 2) -> bytes:
    """'In range, no valid data' packet."""
    d = _report(report_id, 10)
    d[1] = 0x20
    return bytes(d)


def intuos_prox_out(report_id: int = 2) -> bytes:
    """Proximity-out packet."""
    d = _report(report_id, 10)
    d[1] = 0x80
    return bytes(d)


def _intuos_xy(d: bytearray, x: int, y: int, distance: int) -> None:
    if not 0 <= x < 1 << 17 or not 0 <= y < 1 << 17 or not 0 <= distance < 64:
        raise ValueError("x, y are 17 bits, distance 6 bits")
    d[2], d[3] = (x >> 9) & 0xFF, (x >> 1) & 0xFF
    d[4], d[5] = (y >> 9) & 0xFF, (y >> 1) & 0xFF
    d[9] = (distance << 2) | ((x & 1) << 1) | (y & 1)


def _tilt_bits(tilt_x: int, tilt_y: int) -> tuple[int, int]:
    if not -64 <= tilt_x <= 63 or not -64 <= tilt_y <= 63:
        raise ValueError("tilt is -64..63")
    tx, ty = tilt_x + 64, tilt_y + 64
    return (tx >> 1) & 0x3F, ((tx & 1) << 7) | (ty & 0x7F)


def intuos_pen(x: int, y: int, pressure: int, tilt_x: int = 0, tilt_y: int = 0,
               distance: int = 0, buttons: int = 0, max_pressure: int = 2047,
               report_id: int = 2) -> bytes:
    """General pen packet (type 0-3).

    ``pressure`` in device units: for devices with ``max_pressure < 2047`` the
    parser halves the 11-bit value, so it is doubled here.
    """
    t = pressure << 1 if max_pressure < 2047 else pressure
    if not 0 <= t < 2048:
        raise ValueError("pressure out of the 11-bit range")
    d = _report(report_id, 10)
    _intuos_xy(d, x, y, distance)
    d[1] = 0xE0 | (t & 1)
    if buttons & Button.STYLUS:
        d[1] |= 0x02
    if buttons & Button.STYLUS2:
        d[1] |= 0x04
    d[6] = t >> 3
    t7, d[8] = _tilt_bits(tilt_x, tilt_y)
    d[7] = (((t >> 1) & 3) << 6) | t7
    return bytes(d)


def rotation_code(rotation: int) -> int:
    """The 11-bit code of an Art Pen rotation (-900..899), inverse of the parser's formula."""
    if not -900 <= rotation <= 899:
        raise ValueError("rotation is -900..899")
    if rotation > 450:
        return 2 * (rotation - 450) + 1
    if rotation >= -573:
        return 2 * (450 - rotation)
    return 2 * (rotation + 1350) + 1


def intuos_rotation(x: int, y: int, rotation: int, distance: int = 0,
                    report_id: int = 2) -> bytes:
    """Art Pen rotation packet (type 5)."""
    d = _report(report_id, 10)
    _intuos_xy(d, x, y, distance)
    d[1] = 0xE0 | (0x5 << 1)
    t = rotation_code(rotation)
    d[6], d[7] = t >> 3, (t & 7) << 5
    return bytes(d)


def intuos_airbrush(x: int, y: int, wheel: int, tilt_x: int = 0, tilt_y: int = 0,
                    distance: int = 0, report_id: int = 2) -> bytes:
    """Airbrush second packet (type 0xa): finger wheel 0..1023 and tilt."""
    if not 0 <= wheel < 1024:
        raise ValueError("wheel is 0..1023")
    d = _report(report_id, 10)
    _intuos_xy(d, x, y, distance)
    d[1] = 0xE0 | (0xA << 1)
    t7, d[8] = _tilt_bits(tilt_x, tilt_y)
    d[6], d[7] = wheel >> 2, ((wheel & 3) << 6) | t7
    return bytes(d)


def intuos_mouse(x: int, y: int, left: bool = False, right: bool = False,
                 middle: bool = False, distance: int = 0, report_id: int = 2) -> bytes:
    """Intuos4 mouse packet (type 6); buttons in d[6]."""
    d = _report(report_id, 10)
    _intuos_xy(d, x, y, distance)
    d[1] = 0xE0 | (0x6 << 1)
    d[6] = (1 if left else 0) | (2 if middle else 0) | (4 if right else 0)
    d[7], d[8] = 0x20, 0x40  # tilt 0, 0
    return bytes(d)


def intuos_lens(x: int, y: int, left: bool = False, right: bool = False,
                middle: bool = False, distance: int = 0, report_id: int = 2) -> bytes:
    """Lens cursor packet (type 8); buttons in d[8]."""
    d = _report(report_id, 10)
    _intuos_xy(d, x, y, distance)
    d[1] = 0xE0 | (0x8 << 1)
    d[8] = (1 if left else 0) | (2 if middle else 0) | (4 if right else 0)
    return bytes(d)


# -- Bamboo / Intuos-HT, Graphire ---------------------------------------------------------


def bamboo_pen(x: int, y: int, pressure: int = 0, tip: bool = False, buttons: int = 0,
               eraser: bool = False, in_range: bool = True, prox: bool = True,
               ready: bool = True, raw_distance: int = 0, length: int = 9) -> bytes:
    """Bamboo/Intuos-HT pen report; ``raw_distance`` is d[8] (the parser reports max - d[8])."""
    if length not in (9, 10):
        raise ValueError("Bamboo pen reports are 9 or 10 bytes")
    d = _report(2, length)
    d[1] = ((0x80 if in_range else 0) | (0x40 if prox else 0) | (0x20 if ready else 0)
            | (0x08 if eraser else 0) | (0x01 if tip else 0)
            | (0x02 if buttons & Button.STYLUS else 0) | (0x04 if buttons & Button.STYLUS2 else 0))
    d[2:4] = x.to_bytes(2, "little")
    d[4:6] = y.to_bytes(2, "little")
    d[6:8] = pressure.to_bytes(2, "little")
    d[8] = raw_distance
    return bytes(d)


GRAPHIRE_PEN, GRAPHIRE_ERASER, GRAPHIRE_WHEEL_MOUSE, GRAPHIRE_MOUSE = 0, 1, 2, 3


def graphire_report(x: int, y: int, pressure: int = 0, tool: int = GRAPHIRE_PEN,
                    tip: bool = False, buttons: int = 0, prox: bool = True,
                    bluetooth: bool = False, mouse_distance: int = 0) -> bytes:
    """Graphire 8-byte report (USB ID 2, Bluetooth ID 3).

    Pressure is 10 bits on USB (d[6], d[7] & 3) and 9 bits on Bluetooth
    (d[6], d[1] & 0x08).  ``mouse_distance`` is d[7] & 0x3f (USB) or, over
    Bluetooth, encoded in d[6] so that ``44 - (d[6] >> 2)`` gives it back.
    """
    d = _report(3 if bluetooth else 2, 8)
    d[1] = (0x80 if prox else 0) | ((tool & 3) << 5)
    d[2:4] = x.to_bytes(2, "little")
    d[4:6] = y.to_bytes(2, "little")
    if tool in (GRAPHIRE_PEN, GRAPHIRE_ERASER):
        d[1] |= (0x01 if tip else 0) | (0x02 if buttons & Button.STYLUS else 0)
        d[1] |= 0x04 if buttons & Button.STYLUS2 else 0
        if bluetooth:
            if not 0 <= pressure < 512:
                raise ValueError("Bluetooth Graphire pressure is 9 bits")
            d[6] = pressure & 0xFF
            d[1] |= 0x08 if pressure & 0x100 else 0
        else:
            if not 0 <= pressure < 1024:
                raise ValueError("Graphire pressure is 10 bits")
            d[6], d[7] = pressure & 0xFF, pressure >> 8
    else:
        d[1] |= (0x01 if buttons & Button.STYLUS else 0) | (0x02 if buttons & Button.STYLUS2 else 0)
        if tool == GRAPHIRE_WHEEL_MOUSE and buttons & Button.STYLUS3:
            d[1] |= 0x04
        if bluetooth:
            d[6] = (44 - mouse_distance) << 2
        else:
            d[7] = mouse_distance & 0x3F
    return bytes(d)



# -- UC-Logic -------------------------------------------------------------------------------
def uclogic_pen_report(kind: str, x: int, y: int, pressure: int, tip: bool = False,
                       buttons: int = 0, in_range: bool = True, tilt_x: int = 0,
                       tilt_y: int = 0) -> bytes:
    """A full-resolution UC-Logic pen report as the tablet sends it (inverse of
    :func:`station.drivers.uclogic.parser.decode`): v1 report 7, v2 report 8, ugee-v2 report 2."""
    flags = (0x01 if tip else 0) | (0x02 if buttons & Button.STYLUS else 0) | (
        0x04 if buttons & Button.STYLUS2 else 0)
    if kind == "v1":
        flags |= 0 if in_range else 0x40  # the in-range bit is inverted
        return bytes([7, flags]) + b"".join(v.to_bytes(2, "little") for v in (x, y, pressure))
    if kind == "v2":
        return bytes([8, flags | 0x80, x & 0xFF, (x >> 8) & 0xFF, y & 0xFF, (y >> 8) & 0xFF,
                      pressure & 0xFF, pressure >> 8, x >> 16, y >> 16, tilt_x & 0xFF,
                      (-tilt_y) & 0xFF])  # fmt: skip
    if kind == "ugee-v2":
        flags |= 0x20 if in_range else 0
        return bytes([2, flags, x & 0xFF, x >> 8, y & 0xFF, y >> 8, pressure & 0xFF,
                      (pressure >> 8) & 0x1F, tilt_x & 0xFF, tilt_y & 0xFF])  # fmt: skip
    raise ValueError(f"unknown UC-Logic report kind {kind!r}")



def uclogic_compat_report(x: int, y: int, pressure: int, tip: bool, in_range: bool) -> bytes:
    """A report of :func:`uclogic_compat_descriptor` (x, y already at compat resolution)."""
    flags = (0x01 if tip else 0) | (0x20 if in_range else 0)
    return bytes([9, flags]) + b"".join(v.to_bytes(2, "little") for v in (x, y, pressure))
