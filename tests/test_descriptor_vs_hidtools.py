"""Why the station keeps its own report-descriptor parser beside hid-tools (issue 24.8).

hid-tools' ``ReportDescriptor`` decodes the real-world quirks the station's parser
was fixed for (Push/Pop around X/Y, a 64-bit USI serial, Report Count 2 with one
usage) exactly as the station does, and parses faster.  It is kept for the cases
below, measured here: hid-tools accepts descriptors the kernel refuses, and fails on
truncated or unbalanced ones with a bare IndexError where the station must say
"bad input, this item, this offset" (exit 2) and keep running.  If hid-tools changes,
this test fails and the reason is gone: then parse with hid-tools (drivers/hid/
descriptor.py's module docstring says the same).
"""

from __future__ import annotations

import pytest
from hidtools.hid import ReportDescriptor
from station.drivers.hid.descriptor import parse_descriptor
from station.drivers.hid.errors import DescriptorError

CASES = [
    # Report Count 16384 bytes: past the kernel's 16 KiB report buffer (HID_MAX_BUFFER_SIZE)
    ("75 08 97 00 40 00 00 81 02", "accepted", "grows past 16383 bytes"),
    # Report Size 257 bits: the kernel refuses sizes over 256
    ("76 01 01", "accepted", "Report Size 257 bits is absurd"),
    # truncated in the middle of a Report ID item (a damaged file, a hostile trace)
    ("05 0d 09 02 a1 01 85", "IndexError", "byte 6: item 0x85 declares 1 data bytes"),
    # Pop without Push
    ("b4 05 0d", "IndexError", "byte 0: Pop without a matching Push"),
]


@pytest.mark.parametrize("hexd, hidtools_does, station_says", CASES)
def test_hidtools_accepts_or_crashes_where_the_station_refuses(
        hexd: str, hidtools_does: str, station_says: str) -> None:
    data = bytes.fromhex(hexd)
    try:
        ReportDescriptor.from_bytes(data)
        got = "accepted"
    except IndexError:
        got = "IndexError"
    assert got == hidtools_does
    with pytest.raises(DescriptorError, match=station_says):
        parse_descriptor(data)
