"""Package discovery for the mapped layout (see pyproject.toml's package-dir).

The top-level folders ``drivers/``, ``calibration/``, ``shaders/`` and ``udev/``
install as ``station.drivers`` … so no generic top-level names reach
site-packages; every folder below them with an ``__init__.py`` is a package.
"""

import os

from setuptools import setup

ROOTS = {
    "station": "station",
    "station.drivers": "drivers",
    "station.calibration": "calibration",
    "station.shaders": "shaders",
    "station.udev": "udev",
}


def discover() -> list[str]:
    found = []
    for package, folder in ROOTS.items():
        for here, dirs, files in os.walk(folder):
            dirs[:] = [d for d in dirs if not d.startswith((".", "__"))]
            if "__init__.py" in files:
                rel = os.path.relpath(here, folder)
                found.append(package if rel == "." else package + "." + rel.replace(os.sep, "."))
    return sorted(found)


setup(packages=discover())
