"""Where the station keeps things on this machine (platformdirs, with overrides).

* configuration: ``$STATION_CONFIG_DIR``, else platformdirs' user config dir
  (``$XDG_CONFIG_HOME/station``, ``~/.config/station``): CURVE keys, calibration,
  profiles, the user's own device data (``devices/``);
* system configuration: ``$STATION_SYSTEM_CONFIG_DIR``, else ``/etc/station`` (device
  data an administrator installs for every user: ``devices/``);
* data: ``$STATION_DATA_DIR``, else platformdirs' user data dir
  (``$XDG_DATA_HOME/station``, ``~/.local/share/station``): session logs, galleries;
* runtime: ``$STATION_RUNTIME_DIR``, else ``$XDG_RUNTIME_DIR/station`` where that
  exists, else ``/tmp/station-<uid>`` (ipc sockets; :func:`station.bus.runtime_dir`
  creates and checks it).

A leaf module (no station imports): drivers, calibration and the bus may all use it.
"""

from __future__ import annotations

import os
from pathlib import Path

import platformdirs

APP = "station"
SYSTEM_CONFIG = Path("/etc/station")


def config_dir() -> Path:
    base = os.environ.get("STATION_CONFIG_DIR")
    return Path(base) if base else Path(platformdirs.user_config_dir(APP, appauthor=False))


def xdg_config_dir() -> Path:
    """platformdirs' user config dir (``$XDG_CONFIG_HOME/station``), not moved by
    ``$STATION_CONFIG_DIR``: a painter's own profiles live there (docs/brush.md)."""
    return Path(platformdirs.user_config_dir(APP, appauthor=False))


def system_config_dir() -> Path:
    base = os.environ.get("STATION_SYSTEM_CONFIG_DIR")
    return Path(base) if base else SYSTEM_CONFIG


def data_dir() -> Path:
    base = os.environ.get("STATION_DATA_DIR")
    return Path(base) if base else Path(platformdirs.user_data_dir(APP, appauthor=False))


def runtime_base() -> Path:
    """The runtime directory's path (not created here; see the module docstring).

    Not platformdirs' runtime dir: where ``$XDG_RUNTIME_DIR`` is unset or not 0700 it
    falls back to ``/tmp/runtime-<uid>`` or ``/run/user/<uid>`` (which may not exist)
    on its own, with a warning; the station's sockets have lived in
    ``/tmp/station-<uid>`` there, and systemd units and blueprints name that."""
    base = os.environ.get("STATION_RUNTIME_DIR")
    if base:
        return Path(base)
    xdg = os.environ.get("XDG_RUNTIME_DIR")
    if xdg and Path(xdg).is_dir():
        return Path(xdg) / APP
    return Path(f"/tmp/station-{os.getuid()}")


def device_data_dirs() -> list[tuple[str, Path]]:
    """Where device data beyond the bundled files lives, in override order (a later
    one wins): ``("system", /etc/station/devices)``, ``("user", ~/.config/station/devices)``."""
    return [("system", system_config_dir() / "devices"), ("user", config_dir() / "devices")]
