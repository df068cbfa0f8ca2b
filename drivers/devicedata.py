"""The device data record: one ``drivers/devices/*.json`` file as the station reads it;
and what an open pen source says about itself (:class:`SourceInfo`).

``devices.schema.json`` is the contract (``additionalProperties`` false, so these keys are
all there are); :func:`station.drivers.registry.parse_device_data` validates a file
against it before anything reads it as a :class:`DeviceModel`.  The registry adds the
three keys that start with ``_`` (where the record came from); the parsers and the scan
read the rest.  Pure types, no I/O.
"""

from __future__ import annotations

from typing import Literal, NotRequired, TypedDict

BusName = Literal["usb", "bluetooth", "i2c"]


class Resolution(TypedDict):
    """Device units per millimetre."""

    x: float
    y: float


class IgnoredInterfaceEntry(TypedDict):
    interface: int
    kind: Literal["touch", "pad", "other"]
    note: NotRequired[str]


class Stylus(TypedDict):
    """A pen the model supports (libwacom): the tool id as the tablet reports it."""

    vendor_id: str
    tool_id: str
    name: str
    type: NotRequired[str]
    eraser: NotRequired[Literal["invert", "button", "none"]]
    buttons: NotRequired[int]
    axes: NotRequired[list[str]]


class UclogicSetup(TypedDict):
    init: Literal["huion", "v1", "ugee-v2", "fixed-descriptor"]


class SourceRef(TypedDict):
    repo: str
    commit: str
    path: str
    entry: NotRequired[str]


class Provenance(TypedDict):
    generator: str
    sources: list[SourceRef]
    measured: NotRequired[str]


class DeviceModel(TypedDict, total=False):
    """One device id's facts (the schema's ``required`` keys are always there in a file;
    a model the scan or a mock makes in code may leave some out)."""

    id: str
    name: str
    vendor_id: str  # 4 hex digits
    product_id: str  # 4 hex digits
    bus: BusName
    parser: str
    max_x: int  # device units
    max_y: int
    max_pressure: int
    max_distance: int
    resolution: Resolution
    drawing_area_mm: list[float]  # [width, height]
    init_feature_reports: list[str]  # hex
    ignore_interfaces: list[IgnoredInterfaceEntry]
    pad_report_ids: list[int]
    screen_tablet: bool
    tilt: bool
    report_rate_hz: float
    notes: str
    family: str
    kernel_type: str
    kernel_name: str
    protocol_quirks: list[str]
    offsets: dict[str, int]  # left, right, top, bottom [device units]
    touch_max: int
    pad_buttons: int
    integrated_in: list[str]
    physical_size_mm: list[float]  # [width, height]
    styli: list[Stylus]
    hid_names: list[str]
    models: list[str]
    libwacom_class: str
    uclogic: UclogicSetup
    provenance: Provenance
    udev_unbind_from: Literal["hid-generic"]
    # added in code, never in a file: where the registry read the record, and which
    # synthetic descriptor a mock model's tablet sends (drivers/mock/tablet.py)
    _source: str  # "bundled", "user", "system" …
    _path: str  # the file it was read from
    _overrides: str  # the bundled file this one replaces
    descriptor: str  # mock models only: "huion", "ntrig"


class SourceInfo(TypedDict, total=False):
    """What an open pen source says about itself (``PenSource.describe``): the driver's
    status and ``--jsonl`` header carry it.  Every source gives the first twelve keys."""

    name: str  # the device name samples carry
    source: str  # "hid", "evdev", "serial"
    path: str
    product: str
    vid: int
    pid: int
    usb_id: str  # "vvvv:pppp"
    bus: int  # BUS_USB, BUS_BLUETOOTH …
    parser: str
    generic: bool  # read through its descriptor alone (no device data)
    model: str  # the device data's id ("" without one)
    can_map_mm: bool  # the ranges have a resolution
    features_sent: list[str]  # hid: init feature reports sent, hex
    syn_dropped: int  # evdev: SYN_DROPPED seen
    resyncs: int  # evdev: state re-read after a drop
    serial: str  # serial haptic device: its serial number
    protocol: str  # serial haptic device: "major.minor"
    rate_hz: int  # serial haptic device: pose rate [Hz]
    max_force_n: list[float]  # serial haptic device: per axis [N]
    limits_n: list[float] | None  # serial haptic device: the limits in force [N]
    haptic: dict[str, object]  # serial haptic device: its session's status
