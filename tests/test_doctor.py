"""``station doctor``: each check says what is wrong and what to fix; exit 1 on a failure."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from station.udev.generate import RULES_NAME, generate

from station.blueprint import doctor
from station.cli import main


def run_doctor(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, dict]:
    code = main(["doctor", "--no-gl", "--json", *args])
    return code, json.loads(capsys.readouterr().out)


def by_name(result: dict, name: str) -> list[dict]:
    return [c for c in result["checks"] if c["name"] == name]


def test_udev_rules_missing_stale_and_installed(tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(doctor, "UDEV_DIRS", (tmp_path,))
    # no tablet here: the station runs (mocks, traces), the rules are only worth a warning
    code, result = run_doctor(capsys)
    (udev,) = by_name(result, "udev")
    (dev,) = by_name(result, "devices")
    assert dev["status"] == "warn" and dev["detail"] == "no pen tablet found"
    assert code == 0 and result["ok"]
    assert udev["status"] == "warn" and "not needed until a pen tablet" in udev["detail"]
    assert f"station udev -o {RULES_NAME}" in udev["fix"]
    # a tablet plugged in (or named by a blueprint) needs them
    fail = doctor.check_udev(needed=True)
    assert fail.status == "fail" and f"station udev -o {RULES_NAME}" in fail.fix
    (tmp_path / RULES_NAME).write_text("# an old version\n")
    assert doctor.check_udev().status == "warn"
    (tmp_path / RULES_NAME).write_text(generate())
    code, result = run_doctor(capsys)
    assert by_name(result, "udev")[0]["status"] == "ok"
    assert code == (1 if any(c["status"] == "fail" for c in result["checks"]) else 0)


def test_blueprint_problems_are_named_with_fixes(tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(doctor, "UDEV_DIRS", (tmp_path,))
    (tmp_path / RULES_NAME).write_text(generate())
    bp = tmp_path / "bp.xml"
    bp.write_text("""<?xml version="1.0"?>
<station name="doc" version="1">
  <calibration id="cal" file="missing-cal.json"/>
  <driver id="pen" device="evdev:/dev/input/event99">
    <requires interface="calibration" from="cal"/>
  </driver>
  <gallery id="gallery" dir="gallery" min-free="1000TiB"/>
  <sim id="sim"><requires interface="pen" from="pen"/></sim>
  <on event="idle" after="5min"><save-to-gallery/></on>
</station>
""")
    code, result = run_doctor(capsys, str(bp))
    assert code == 1
    (dev,) = by_name(result, "devices")
    assert dev["status"] == "fail" and "/dev/input/event99 does not exist" in dev["detail"]
    (cal,) = by_name(result, "calibration")
    assert cal["status"] == "fail" and "missing-cal.json" in cal["detail"]
    assert "station calibrate" in cal["fix"]
    (disk,) = by_name(result, "disk")
    assert disk["status"] == "fail" and "needs 1024000.0" in disk["detail"] and disk["fix"]
    assert all(c["fix"] for c in result["checks"] if c["status"] == "fail")
    bus = by_name(result, "bus")
    assert bus[0]["status"] == "ok" and "not running" in bus[1]["detail"]


def test_text_report(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                     capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(doctor, "UDEV_DIRS", (tmp_path,))
    assert main(["doctor", "--no-gl"]) == 0  # no tablet: warnings, no failure
    out = capsys.readouterr().out
    assert "WARN  devices: no pen tablet found" in out
    assert "WARN  udev: no 70-painting-station.rules" in out
    assert "      fix: before plugging one in: station udev" in out
    assert out.rstrip().endswith("all good: this machine can run a station (3 warning(s) above)")


def test_gl_check_names_vendor_and_renderer() -> None:
    check = doctor.check_gl()
    if check.status == "fail":
        assert "no EGL OpenGL context" in check.detail and "--backend cpu" in check.fix
    else:
        assert check.detail.startswith("EGL: ") and " / " in check.detail
        assert "OpenGL " in check.detail
