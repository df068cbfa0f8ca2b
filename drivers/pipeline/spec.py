"""Device SPEC strings: ``scheme:target?key=value&…`` (see docs/drivers.md).

Parsing only: :class:`DeviceSpec` checks the scheme and reads options; opening
what a SPEC names is :mod:`station.drivers.pipeline.opening`'s job.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from station.drivers.transport.base import DeviceSpecError, parse_query

SCHEMES = ("mock", "mock-hidraw", "mock-usb", "mock-evdev", "mock-uclogic", "trace", "evdev",
           "hidraw", "hidapi", "usb", "serial", "serial-mock", "auto")
HAPTIC_SCHEMES = ("serial", "serial-mock")  # drivers/haptic/source.py (docs/haptic-protocol.md)


@dataclass(frozen=True)
class DeviceSpec:
    """A parsed SPEC: ``scheme:target?key=value&…``."""

    scheme: str
    target: str
    options: dict[str, str]
    text: str

    @classmethod
    def parse(cls, text: str) -> DeviceSpec:
        scheme, sep, rest = text.partition(":")
        if not sep or scheme not in SCHEMES:
            schemes = ", ".join(s + ":" for s in SCHEMES)
            raise DeviceSpecError(f"device {text!r}: use one of {schemes} (see docs/drivers.md)",
                                  "--device")
        target, _, query = rest.partition("?")
        if not target and scheme == "serial-mock":
            target = "pen"  # the mock haptic device needs no name
        if not target:
            raise DeviceSpecError(f"device {text!r} names nothing after {scheme}:", "--device")
        return cls(scheme, target, dict(parse_query(query, "--device")), text)

    def speed(self, default: float | None) -> float | None:
        value = self.options.get("speed")
        if value is None:
            return default
        if value == "max":
            return None
        try:
            speed = float(value)
        except ValueError:
            raise DeviceSpecError(f"speed {value!r} must be a number or max", "--device") from None
        if not 0.01 <= speed <= 1000:
            raise DeviceSpecError(f"speed {speed} must be 0.01..1000 or max", "--device")
        return speed

    def flag(self, key: str) -> bool:
        return self.options.get(key, "0").lower() in ("1", "true", "yes", "on")

    def number(self, key: str, default: float, lo: float, hi: float) -> float:
        value = self.options.get(key)
        if value is None:
            return default
        try:
            x = float(value)
        except ValueError:
            raise DeviceSpecError(f"{key}={value!r} must be a number", "--device") from None
        if not lo <= x <= hi:
            raise DeviceSpecError(f"{key}={x} must be in {lo}..{hi}", "--device")
        return x



def vid_pid(target: str) -> tuple[int, int]:
    m = re.fullmatch(r"([0-9a-fA-F]{1,4}):([0-9a-fA-F]{1,4})", target)
    if not m:
        raise DeviceSpecError(f"{target!r} is not VID:PID in hex (e.g. 056a:0315)", "--device")
    return int(m.group(1), 16), int(m.group(2), 16)

