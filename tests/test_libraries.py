"""Well-kept libraries instead of hand-written code (issue 8 item 11).

PNG: Pillow (8-bit) and pypng (16-bit; Pillow has no 48-bit RGB mode); the calibration
solver: SciPy's ``least_squares``; evdev codes: python-evdev's ``ecodes``; HID usage
names: hid-tools' HID Usage Tables.  Each keeps its callers' behaviour exact.
"""

from __future__ import annotations

import importlib.util
import io
import subprocess
import sys
import zlib

import numpy as np
import pytest
from PIL import Image
from scipy.optimize import least_squares
from station.calibration.fit import fit_mapping
from station.calibration.pointset import PointSet
from station.drivers.evdev import codes as c
from station.drivers.hid import usages as U

from station.render.png import encode_png, write_png


def _gradient(h: int = 240, w: int = 320) -> np.ndarray:
    y, x = np.mgrid[0:h, 0:w]
    return np.stack([x * 255 // (w - 1), y * 255 // (h - 1), (x + y) * 255 // (w + h - 2)],
                    axis=-1).astype(np.uint8)


def test_png_8_bit_is_exact_and_filtered() -> None:
    img = _gradient()
    data = encode_png(img)
    with Image.open(io.BytesIO(data)) as im:
        assert im.mode == "RGB" and np.array_equal(np.asarray(im), img)
    # PNG's row filters (Pillow picks them per row) make a smooth painting small; the
    # unfiltered writer this replaces needed 177 kB for this 230 kB gradient
    assert len(data) < 0.05 * img.nbytes


def test_png_16_bit_is_exact(tmp_path) -> None:
    img = np.random.default_rng(1).integers(0, 65536, (21, 34, 3), dtype=np.uint16)
    write_png(tmp_path / "a.png", img)
    data = (tmp_path / "a.png").read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[24] == 16 and data[25] == 2
    # decoded with zlib alone, independent of the writers: all IDAT chunks, undo filter 0
    idat, pos = b"", 8
    while pos < len(data):
        n = int.from_bytes(data[pos:pos + 4], "big")
        if data[pos + 4:pos + 8] == b"IDAT":
            idat += data[pos + 8:pos + 8 + n]
        pos += 12 + n
    rows = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(21, 1 + 34 * 6)
    assert (rows[:, 0] == 0).all()
    assert np.array_equal(rows[:, 1:].copy().view(">u2").reshape(21, 34, 3), img)


def test_hand_written_solver_is_gone_and_scipy_fit_is_the_optimum() -> None:
    assert importlib.util.find_spec("station.calibration.lm") is None
    rng = np.random.default_rng(5)
    h_true = np.array([[0.9, 0.05, 10.0], [-0.03, 1.1, 5.0], [1e-4, -5e-5, 1.0]])
    dev = rng.uniform(0, 1000, (12, 2))
    hom = np.c_[dev, np.ones(12)] @ h_true.T
    can = hom[:, :2] / hom[:, 2:] + rng.normal(0, 0.5, (12, 2))
    mapping, _cond = fit_mapping(PointSet(dev, can), "homography")

    def resid(theta: np.ndarray) -> np.ndarray:
        m = np.append(theta, 1.0).reshape(3, 3)
        p = np.c_[dev, np.ones(12)] @ m.T
        return (p[:, :2] / p[:, 2:] - can).ravel()

    # an independent fit of the same geometric error in raw units lands on the same
    # optimum, ours no worse (the station fits in normalised units, better conditioned)
    ref = least_squares(resid, h_true.ravel()[:8], method="lm", xtol=1e-15, ftol=1e-15)
    ours = (mapping.matrix / mapping.matrix[2, 2]).ravel()[:8]
    assert np.allclose(ours, ref.x, rtol=1e-5, atol=1e-9)
    assert float(resid(ours) @ resid(ours)) <= float(ref.fun @ ref.fun) * (1 + 1e-9)


@pytest.mark.skipif(sys.platform != "linux", reason="python-evdev is Linux only")
def test_evdev_codes_are_python_evdevs() -> None:
    from evdev import ecodes

    assert c.EV is ecodes.EV  # the kernel's tables, not a copy
    for name in c.__all__:
        if hasattr(ecodes, name):
            assert getattr(c, name) == getattr(ecodes, name), name
    assert c.TYPE_NAMES[c.EV_ABS] == "EV_ABS"
    assert c.PEN_TOOL_KEYS[ecodes.BTN_TOOL_RUBBER].name == "ERASER"


@pytest.mark.skipif(sys.platform != "linux", reason="compares with python-evdev")
def test_evdev_fallback_off_linux_has_the_kernels_numbers() -> None:
    code = ("import sys, importlib; import station.drivers.evdev.codes as c;"
            "real = {n: getattr(c, n) for n in c.__all__}; sys.platform = 'darwin';"
            "importlib.reload(c); print(sorted(n for n in real if real[n] != getattr(c, n)))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "['EV']"  # the full table vs the subset the readers name


def test_hid_usage_names_come_from_the_usage_tables() -> None:
    # usages the hand-written table never listed now have their HUT names
    assert U.usage_name(U.u(U.PAGE_DIGITIZER, 0x3B)) == "Battery Strength"
    assert U.usage_name(U.u(U.PAGE_GENERIC_DESKTOP, 0x39)) == "Hat switch"
    assert U.usage_name(U.DG_TIP_PRESSURE) == "Tip Pressure"
    assert U.usage_name(0xFF0D0042) == "Tip Switch"  # Wacom's mirror of the Digitizer page
    assert U.usage_name(U.WD_BARREL_SWITCH3) == "Wacom Barrel Switch 3"  # the kernel's meaning
    assert U.usage_name(U.u(U.PAGE_BUTTON, 7)) == "Button 7"
    assert U.usage_name(0xFF420001) == "0xff42:0001"
    assert not hasattr(U, "_NAMES")
