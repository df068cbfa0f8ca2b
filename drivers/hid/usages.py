"""HID usage pages and the usages the station cares about (32-bit: page << 16 | id).

Numbers are from the HID Usage Tables; the Wacom vendor page 0xFF0D mirrors the
Digitizer page (see :func:`equivalent_usage`).
"""

from __future__ import annotations

PAGE_GENERIC_DESKTOP = 0x01
PAGE_KEYBOARD = 0x07
PAGE_BUTTON = 0x09
PAGE_CONSUMER = 0x0C
PAGE_DIGITIZER = 0x0D
PAGE_WACOM_DIGITIZER = 0xFF0D  # Wacom's vendor copy of the Digitizer page


def u(page: int, usage_id: int) -> int:
    """The 32-bit extended usage of ``usage_id`` on ``page``."""
    return (page << 16) | usage_id


# Generic Desktop
GD_POINTER = u(0x01, 0x01)
GD_MOUSE = u(0x01, 0x02)
GD_KEYBOARD = u(0x01, 0x06)
GD_KEYPAD = u(0x01, 0x07)
GD_X = u(0x01, 0x30)
GD_Y = u(0x01, 0x31)
GD_Z = u(0x01, 0x32)
GD_WHEEL = u(0x01, 0x38)

# Digitizer page applications and collections
DG_DIGITIZER = u(0x0D, 0x01)
DG_PEN = u(0x0D, 0x02)
DG_LIGHT_PEN = u(0x0D, 0x03)
DG_TOUCH_SCREEN = u(0x0D, 0x04)
DG_TOUCH_PAD = u(0x0D, 0x05)
DG_WHITEBOARD = u(0x0D, 0x06)
DG_STYLUS = u(0x0D, 0x20)
DG_PUCK = u(0x0D, 0x21)
DG_FINGER = u(0x0D, 0x22)
DG_DEVICE_CONFIG = u(0x0D, 0x0E)
DG_TABLET_FUNCTION_KEYS = u(0x0D, 0x39)

# Digitizer page fields
DG_TIP_PRESSURE = u(0x0D, 0x30)
DG_BARREL_PRESSURE = u(0x0D, 0x31)
DG_IN_RANGE = u(0x0D, 0x32)
DG_TOUCH = u(0x0D, 0x33)
DG_CONFIDENCE = u(0x0D, 0x47)
DG_INVERT = u(0x0D, 0x3C)
DG_X_TILT = u(0x0D, 0x3D)
DG_Y_TILT = u(0x0D, 0x3E)
DG_AZIMUTH = u(0x0D, 0x3F)
DG_ALTITUDE = u(0x0D, 0x40)
DG_TWIST = u(0x0D, 0x41)
DG_TIP_SWITCH = u(0x0D, 0x42)
DG_SECONDARY_TIP_SWITCH = u(0x0D, 0x43)
DG_BARREL_SWITCH = u(0x0D, 0x44)
DG_ERASER = u(0x0D, 0x45)
DG_CONTACT_ID = u(0x0D, 0x51)
DG_CONTACT_COUNT = u(0x0D, 0x54)
DG_SECONDARY_BARREL_SWITCH = u(0x0D, 0x5A)
DG_TRANSDUCER_SERIAL = u(0x0D, 0x5B)

# Wacom vendor usages that have no standard equivalent
# (values from the kernel's wacom_wac.h: WACOM_HID_WD_*)
WD_SENSE = u(0xFF0D, 0x36)
WD_SERIAL_HI = u(0xFF0D, 0x5C)
WD_BARREL_SWITCH3 = u(0xFF0D, 0x5D)
WD_TOOL_TYPE = u(0xFF0D, 0x77)
WD_DISTANCE = u(0xFF0D, 0x132)
WD_TOUCHSTRIP = u(0xFF0D, 0x136)
WD_TOUCHSTRIP2 = u(0xFF0D, 0x137)
WD_TOUCHRING = u(0xFF0D, 0x138)
WD_TOUCHRING_STATUS = u(0xFF0D, 0x139)
WD_REPORT_VALID = u(0xFF0D, 0x1D0)
WD_SEQUENCE_NUMBER = u(0xFF0D, 0x220)

# Usages the kernel's wacom_equivalent_usage() keeps on the vendor page.
_WACOM_KEEP = frozenset({WD_SENSE, WD_SERIAL_HI, WD_BARREL_SWITCH3, WD_TOOL_TYPE, WD_DISTANCE,
                         WD_TOUCHSTRIP, WD_TOUCHSTRIP2, WD_TOUCHRING, WD_TOUCHRING_STATUS,
                         WD_REPORT_VALID, WD_SEQUENCE_NUMBER})
# Sub-pages of 0xFF0D that are Wacom-specific and kept as is (WACOM_HID_SP_*):
# pad 0x04, button 0x09, digitizer 0x0D, digitizer info 0x10.
_WACOM_KEEP_SUBPAGES = frozenset({0x04, 0x09, 0x0D, 0x10})


def equivalent_usage(usage: int) -> int:
    """Map a Wacom vendor digitizer usage to its standard equivalent.

    Wacom's page 0xFF0D encodes a standard usage as ``0xFF0D_SSUU``: sub-page
    ``SS`` (0 meaning the Digitizer page) and usage ``UU``; e.g. 0xFF0D0042
    is Tip Switch and 0xFF0D0130 is Generic Desktop X.  Wacom-only usages
    (sense, serial high word, tool type, distance …) are returned unchanged,
    as is every usage of any other page.
    """
    if usage >> 16 != PAGE_WACOM_DIGITIZER or usage in _WACOM_KEEP:
        return usage
    subpage = (usage >> 8) & 0xFF
    if subpage in _WACOM_KEEP_SUBPAGES:
        return usage
    page = PAGE_DIGITIZER if subpage == 0 else subpage
    return u(page, usage & 0xFF)


_KERNEL_NAMES = {WD_BARREL_SWITCH3: "Wacom Barrel Switch 3"}
"""Where hid-tools' table disagrees with the kernel: hid-tools mirrors the Digitizer page
on 0xFF0D and calls 0xFF0D005D "Preferred Color is Locked"; wacom_wac.h has it as
WACOM_HID_WD_BARRELSWITCH3 (the third stylus button), and that is what Wacom pens send."""


def usage_name(usage: int) -> str:
    """A readable name from the HID Usage Tables (hid-tools' maintained copy, Wacom's
    vendor page included): ``"Tip Pressure"``, ``"Button 3"``; usages no table names
    read as ``"0xff42:0001"``."""
    # Imported here: hid-tools parses all its tables on import (~55 ms measured), which
    # every driver start would pay for a name only diagnostics ask for.
    from hidtools.hut import HUT

    if usage in _KERNEL_NAMES:
        return _KERNEL_NAMES[usage]
    page, uid = usage >> 16, usage & 0xFFFF
    if page == PAGE_BUTTON and uid:
        return f"Button {uid}"  # the table names only button 0; every other is numbered
    try:
        return str(HUT[page][uid].name)
    except KeyError:
        return f"0x{page:04x}:{uid:04x}"
