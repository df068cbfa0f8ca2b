"""Calibration stays pure maths and file formats (issue 8, item 9).

``station.calibration`` takes pen samples in and knows nothing of transports,
windows or GL: device access and the calibration window live on the
station's face (``station.calibrate``).  Each module is imported alone in a
fresh interpreter and ``sys.modules`` is checked afterwards.
"""

from __future__ import annotations

import json
import pkgutil
import subprocess
import sys

import station.calibration

FORBIDDEN = ("station.drivers", "station.calibrate", "station.bus", "glfw", "moderngl", "zmq",
             "evdev", "hid", "usb", "serial")

MODULES = sorted(m.name for m in pkgutil.walk_packages(station.calibration.__path__,
                                                         "station.calibration."))

PROBE = """
import importlib, json, sys
forbidden = tuple(sys.argv[1].split(","))
found = {}
for name in sys.argv[2:]:  # in order: the first module that pulls a forbidden one is named
    importlib.import_module(name)
    for m in list(sys.modules):
        if m not in found and any(m == f or m.startswith(f + ".") for f in forbidden):
            found[m] = name
print(json.dumps(found))
"""


def test_every_module_of_calibration_is_listed() -> None:
    names = {m.rsplit(".", 1)[1] for m in MODULES}
    assert {"fit", "session", "taps", "files", "points", "export"} <= names
    assert not names & {"interactive", "sources"}  # moved to station.calibrate


def test_no_calibration_module_imports_transports_windows_or_gl() -> None:
    proc = subprocess.run([sys.executable, "-c", PROBE, ",".join(FORBIDDEN),
                           "station.calibration", *MODULES],
                          capture_output=True, text=True, timeout=120, check=True)
    found = json.loads(proc.stdout)
    assert found == {}, "imported by calibration: " + ", ".join(
        f"{m} (via {by})" for m, by in found.items())
    # the probe does see them: the station's face imports the drivers
    proc = subprocess.run([sys.executable, "-c", PROBE, ",".join(FORBIDDEN),
                           "station.calibrate.sources"],
                          capture_output=True, text=True, timeout=120, check=True)
    assert "station.drivers.pipeline" in json.loads(proc.stdout)
