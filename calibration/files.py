"""Calibration files: one JSON file per device, validated by a JSON schema.

Location: ``$STATION_CONFIG_DIR/calibration/`` when that variable is set,
else ``$XDG_CONFIG_HOME/station/calibration/`` (``~/.config/station/calibration/``).
Name: ``<vid>-<pid>[-<serial>].json`` in lower-case hex (``056a-00fa.json``);
a serial-specific file wins over the generic one.

Loading validates the JSON against ``calibration.schema.json`` and then the
values (a singular matrix, threshold ≥ maximum …); a corrupt file, another
format or version, or a file for another device raises a
:class:`CalibrationFileError` / :class:`DeviceMismatch` (exit 2).
:class:`CalibrationStore` keeps the last good calibration: it swaps only on a
successful load.  Floats are written with Python's shortest round-trip repr,
so write → read is exact.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import threading
from collections.abc import Sequence
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

import jsonschema
from station.calibration.area import AreaSettings, DeviceGeometry
from station.calibration.errors import CalibrationError, CalibrationFileError, DeviceMismatch
from station.calibration.model import Calibration, DeviceId, FitInfo
from station.calibration.pressure import PressureSettings, TiltSettings, check_curve

from station import boundedio
from station.events import PenSample

FORMAT = "station-calibration"
VERSION = 1
MAX_FILE_BYTES = 1 << 20


@lru_cache(maxsize=1)
def schema() -> dict[str, Any]:
    """The JSON schema of calibration files (package data)."""
    text = resources.files("station.calibration").joinpath("calibration.schema.json").read_text(
        encoding="utf-8"
    )
    data: dict[str, Any] = json.loads(text)
    return data


def config_dir() -> Path:
    """Where calibration files live (see the module docstring)."""
    root = os.environ.get("STATION_CONFIG_DIR")
    if root:
        return Path(root) / "calibration"
    xdg = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(xdg) / "station" / "calibration"


def _folder(directory: str | os.PathLike[str] | None) -> Path:
    return Path(directory) if directory is not None else config_dir()


def to_json(cal: Calibration) -> dict[str, object]:
    """The file's JSON object."""
    d = cal.device
    g = cal.geometry
    f = cal.fit
    rec: dict[str, object] = {
        "format": FORMAT,
        "version": VERSION,
        "created": cal.created or _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "device": {"vid": d.vid, "pid": d.pid, "serial": d.serial, "name": d.name},
        "geometry": {
            "x_min": g.x_min, "x_max": g.x_max, "y_min": g.y_min, "y_max": g.y_max,
            "resolution_x": g.resolution_x, "resolution_y": g.resolution_y,
        },
        "mapping": {
            "model": f.model,
            "matrix": [list(row) for row in f.matrix],
            "parallax": {"x": f.parallax[0], "y": f.parallax[1]},
            "rms": f.rms, "max": f.max, "loo_rms": f.loo_rms, "points": f.points,
        },
        "area": cal.area.to_json(),
        "pressure": {
            "threshold": cal.pressure.threshold,
            "maximum": cal.pressure.maximum,
            "curve": list(cal.pressure.curve),
        },
        "tilt": {"offset_x": cal.tilt.offset_x, "offset_y": cal.tilt.offset_y},
    }
    if cal.notes:
        rec["notes"] = cal.notes
    return rec


def dumps(cal: Calibration) -> str:
    return json.dumps(to_json(cal), indent=2, allow_nan=False) + "\n"


def from_json(rec: Any, where: str = "<calibration>") -> Calibration:
    """Validate (schema, then values) and build a :class:`Calibration`."""
    if isinstance(rec, dict) and rec.get("format") not in (None, FORMAT):
        raise CalibrationFileError(f"not a calibration file (format {rec.get('format')!r})", where)
    if isinstance(rec, dict) and rec.get("format") == FORMAT and rec.get("version") != VERSION:
        raise CalibrationFileError(
            f"calibration file version {rec.get('version')!r} is not supported (this station "
            f"reads version {VERSION})",
            where,
        )
    validator = jsonschema.Draft202012Validator(schema())
    errors = sorted(validator.iter_errors(rec), key=lambda e: list(e.absolute_path))
    if errors:
        e = errors[0]
        path = "/".join(str(p) for p in e.absolute_path) or "(top level)"
        more = f" (+{len(errors) - 1} more)" if len(errors) > 1 else ""
        raise CalibrationFileError(f"schema: at {path}: {e.message}{more}", where)
    try:
        dev = rec["device"]
        g = rec.get("geometry")
        m = rec["mapping"]
        par = m.get("parallax", {"x": 0.0, "y": 0.0})
        p = rec.get("pressure", {})
        t = rec.get("tilt", {})
        return Calibration(
            device=DeviceId(dev["vid"], dev["pid"], dev.get("serial"), dev.get("name")),
            geometry=DeviceGeometry(**g) if g else DeviceGeometry(),
            fit=FitInfo(
                model=m["model"],
                matrix=tuple(tuple(float(v) for v in row) for row in m["matrix"]),
                parallax=(float(par["x"]), float(par["y"])),
                rms=m.get("rms"), max=m.get("max"), loo_rms=m.get("loo_rms"),
                points=m.get("points", 0),
            ),
            area=AreaSettings.from_json(rec.get("area", {})),
            pressure=PressureSettings(
                threshold=float(p.get("threshold", 0.0)),
                maximum=float(p.get("maximum", 1.0)),
                curve=tuple(p.get("curve", (0.0, 0.0, 1.0, 1.0))),
            ),
            tilt=TiltSettings(float(t.get("offset_x", 0.0)), float(t.get("offset_y", 0.0))),
            created=rec.get("created"),
            notes=rec.get("notes"),
        )
    except CalibrationFileError:
        raise
    except CalibrationError as exc:
        raise CalibrationFileError(str(exc), where) from None
    except OverflowError:  # an integer of hundreds of digits passes the schema's "number"
        raise CalibrationFileError("a number in the file is too large", where) from None


def _reject_constant(name: str) -> float:
    raise ValueError(f"{name} is not a JSON number")


def loads(text: str, where: str = "<calibration>") -> Calibration:
    try:
        rec = json.loads(text, parse_constant=_reject_constant)
    except ValueError as exc:
        raise CalibrationFileError(f"not valid JSON ({exc})", where) from None
    except RecursionError:  # "[[[[…": the decoder recurses per level
        raise CalibrationFileError("not valid JSON (nested too deeply)", where) from None
    return from_json(rec, where)


def read_file(path: str | os.PathLike[str], expect: DeviceId | None = None) -> Calibration:
    """Read and validate a calibration file; with ``expect``, refuse another device's."""
    p = Path(path)
    try:
        if p.stat().st_size > MAX_FILE_BYTES:
            raise CalibrationFileError("larger than 1 MiB: not a calibration file", str(p))
        text = boundedio.read_text(p, MAX_FILE_BYTES, str(p))
    except OSError as exc:
        raise CalibrationFileError(f"cannot read ({exc.strerror})", str(p)) from None
    except UnicodeDecodeError:
        raise CalibrationFileError("not UTF-8 text", str(p)) from None
    cal = loads(text, str(p))
    if expect is not None and not cal.device.matches(expect):
        raise DeviceMismatch(
            f"this calibration is for device {cal.device.describe()}, not {expect.describe()}",
            str(p),
        )
    return cal


def write_file(cal: Calibration, path: str | os.PathLike[str]) -> Path:
    """Write atomically (temp file + rename) so a crash never leaves half a file."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    tmp = p.with_name(p.name + ".tmp")
    tmp.write_text(dumps(cal), encoding="utf-8")
    os.replace(tmp, p)
    return p


def default_path(device: DeviceId, directory: str | os.PathLike[str] | None = None) -> Path:
    return _folder(directory) / f"{device.key}.json"


def find_for_device(
    vid: int, pid: int, serial: str | None = None,
    directory: str | os.PathLike[str] | None = None,
) -> Path | None:
    """The device's calibration file: serial-specific first, then the generic one."""
    dev = DeviceId(vid, pid, serial)
    folder = _folder(directory)
    candidates = []
    if serial:
        candidates.append(folder / f"{dev.key}.json")
    candidates.append(folder / f"{DeviceId(vid, pid).key}.json")
    for c in candidates:
        if c.is_file():
            return c
    return None


def load_for_device(
    vid: int, pid: int, serial: str | None = None,
    directory: str | os.PathLike[str] | None = None,
) -> Calibration | None:
    """The device's calibration from the config dir, ``None`` if it has none.

    A file that exists but is corrupt or belongs to another device raises
    (the caller keeps whatever calibration it had; see :class:`CalibrationStore`).
    """
    path = find_for_device(vid, pid, serial, directory)
    if path is None:
        return None
    return read_file(path, expect=DeviceId(vid, pid, serial))


class CalibrationStore:
    """Holds a device's current calibration; swaps only on a valid load.

    Usable as the normaliser's ``transform`` hook (``store.apply``): a reload
    in another thread takes effect on the next sample, and a bad file never
    replaces a good calibration.
    """

    def __init__(self, device: DeviceId, current: Calibration | None = None) -> None:
        self.device = device
        self._current = current
        self._lock = threading.Lock()
        self.last_error: CalibrationError | None = None
        self.loads = 0
        self._curve: tuple[float, float, float, float] | None = None
        self._shaped: tuple[Calibration, Calibration] | None = None  # (loaded, with _curve)

    @property
    def current(self) -> Calibration | None:
        return self._current

    def load(self, path: str | os.PathLike[str]) -> Calibration:
        """Load ``path``; on any error keep the current calibration and re-raise."""
        try:
            cal = read_file(path, expect=self.device)
        except CalibrationError as exc:
            self.last_error = exc
            raise
        with self._lock:
            self._current = cal
            self.last_error = None
            self.loads += 1
        return cal

    def try_load(self, path: str | os.PathLike[str]) -> bool:
        """:meth:`load` that reports failure as ``False`` (error in ``last_error``)."""
        try:
            self.load(path)
        except CalibrationError:
            return False
        return True

    def set(self, cal: Calibration) -> None:
        if not cal.device.matches(self.device):
            raise DeviceMismatch(
                f"calibration for {cal.device.describe()} offered to {self.device.describe()}"
            )
        with self._lock:
            self._current = cal

    def set_curve(self, curve: Sequence[float] | None) -> None:
        """Shape pressure with ``curve`` instead of the file's curve (its threshold and
        maximum stay): a curve the driver was given replaces the file's, so a device
        gets one curve, never two in a row.  ``None`` goes back to the file's."""
        self._curve = None if curve is None else check_curve(curve)
        self._shaped = None

    def _calibration(self) -> Calibration | None:
        cal = self._current
        if cal is None or self._curve is None:
            return cal
        shaped = self._shaped
        if shaped is None or shaped[0] is not cal:  # built once per loaded calibration
            pressure = PressureSettings(cal.pressure.threshold, cal.pressure.maximum,
                                        self._curve)
            shaped = self._shaped = (cal, cal.with_(pressure=pressure))
        return shaped[1]

    def apply(self, sample: PenSample) -> PenSample:
        cal = self._calibration()
        return sample if cal is None else cal.apply(sample)

    __call__ = apply
