"""Synthetic tablets: report encoders, a HID descriptor builder, hid-recorder recordings.

Everything here is the exact inverse of a parser, so tests and mock devices
can write recordings of every supported protocol without third-party
captures:

- report encoders: :func:`intuos_prox_in`, :func:`intuos_pen`,
  :func:`intuos_rotation`, :func:`intuos_airbrush`, :func:`intuos_mouse`,
  :func:`intuos_lens`, :func:`intuos_in_range`, :func:`intuos_prox_out`,
  :func:`bamboo_pen`, :func:`graphire_report`, and :func:`encode_report` for
  any descriptor-defined report;
- :class:`DescriptorBuilder` writes report descriptors item by item, and
  :func:`pth660_like_descriptor`, :func:`huion_like_descriptor`,
  :func:`ntrig_like_descriptor`, :func:`touch_descriptor`,
  :func:`wacom_protocol_descriptor` build typical ones;
- :func:`write_hid_recorder` writes hid-recorder text (``D:``, ``R:``,
  ``N:``, ``P:``, ``I:``, ``E:``) with the format variants seen in the wild.

See docs/drivers-protocols.md for examples.
"""

from station.drivers.synth.descriptors import (
    UNIT_CM,
    UNIT_DEG,
    UNIT_INCH,
    UNIT_RAD,
    DescriptorBuilder,
    encode_report,
    huion_like_descriptor,
    ntrig_like_descriptor,
    pth660_like_descriptor,
    touch_descriptor,
    uclogic_compat_descriptor,
    wacom_protocol_descriptor,
)
from station.drivers.synth.recordings import (
    RecordedDevice,
    SynthDevice,
    stroke_points,
    stroke_recording,
    stroke_reports,
    synth_devices,
    write_hid_recorder,
)
from station.drivers.synth.reports import (
    GRAPHIRE_ERASER,
    GRAPHIRE_MOUSE,
    GRAPHIRE_PEN,
    GRAPHIRE_WHEEL_MOUSE,
    bamboo_pen,
    graphire_report,
    intuos_airbrush,
    intuos_in_range,
    intuos_lens,
    intuos_mouse,
    intuos_pen,
    intuos_prox_in,
    intuos_prox_out,
    intuos_rotation,
    rotation_code,
    uclogic_compat_report,
    uclogic_pen_report,
)

__all__ = [
    "GRAPHIRE_ERASER",
    "GRAPHIRE_MOUSE",
    "GRAPHIRE_PEN",
    "GRAPHIRE_WHEEL_MOUSE",
    "UNIT_CM",
    "UNIT_DEG",
    "UNIT_INCH",
    "UNIT_RAD",
    "DescriptorBuilder",
    "RecordedDevice",
    "SynthDevice",
    "bamboo_pen",
    "encode_report",
    "graphire_report",
    "huion_like_descriptor",
    "intuos_airbrush",
    "intuos_in_range",
    "intuos_lens",
    "intuos_mouse",
    "intuos_pen",
    "intuos_prox_in",
    "intuos_prox_out",
    "intuos_rotation",
    "ntrig_like_descriptor",
    "pth660_like_descriptor",
    "rotation_code",
    "stroke_points",
    "stroke_recording",
    "stroke_reports",
    "synth_devices",
    "touch_descriptor",
    "uclogic_compat_descriptor",
    "uclogic_compat_report",
    "uclogic_pen_report",
    "wacom_protocol_descriptor",
    "write_hid_recorder",
]
