"""Per-device usage quirks of descriptor-driven pens (the kernel fixes these with HID-BPF).

Some pens declare a usage for a different thing than it says.  On kernels without
the matching HID-BPF program the hidraw node (and so a hid-recorder trace) carries
the original descriptor and reports; these tables say what such a usage means.
An override applies only to a report that does not already declare the usage it
stands in for, so a descriptor already fixed by the kernel is read as it is.

Sources: the kernel's HID selftests (tools/testing/selftests/hid/tests/test_tablet.py)
and udev-hid-bpf's XPPen/Huion programs describe the firmware behaviour.
"""

from __future__ import annotations

from station.drivers.hid import usages as U

HUION_VID = 0x256C

# (vid, pid) -> {usage: role}: roles are those of station.drivers.hid.pen.ROLE_USAGES.
PEN_USAGE_QUIRKS: dict[tuple[int, int], dict[int, str]] = {
    # XP-Pen Artist Pro 16 (Gen2): the second barrel button sets Eraser; the eraser end
    # is Invert (hovering) and Invert + Tip Switch (touching).
    (0x28BD, 0x095B): {U.DG_ERASER: "barrel2"},
    # XP-Pen Artist 24: no eraser end; the second barrel button sets Eraser.
    (0x28BD, 0x093A): {U.DG_ERASER: "barrel2"},
}
# vendor -> {usage: role}: Huion firmware-mode descriptors say Secondary Tip Switch for
# the second barrel button (Kamvas Pro 19 256c:006b, Kamvas 16 Gen3 256c:2009).
VENDOR_USAGE_QUIRKS: dict[int, dict[int, str]] = {
    HUION_VID: {U.DG_SECONDARY_TIP_SWITCH: "barrel2"},
}


def pen_usage_quirks(vid: int, pid: int) -> dict[int, str]:
    """Usage -> role overrides for one device (empty for well-behaved pens)."""
    out = dict(VENDOR_USAGE_QUIRKS.get(vid, {}))
    out.update(PEN_USAGE_QUIRKS.get((vid, pid), {}))
    return out
