"""Your own device data: ~/.config/station/devices and /etc/station/devices (issue 24.2)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest
from station.drivers import registry

from station.cli import main


@pytest.fixture
def dirs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[tuple[Path, Path]]:
    user, system = tmp_path / "config" / "devices", tmp_path / "etc" / "devices"
    user.mkdir(parents=True)
    system.mkdir(parents=True)
    monkeypatch.setenv("STATION_CONFIG_DIR", str(tmp_path / "config"))
    monkeypatch.setenv("STATION_SYSTEM_CONFIG_DIR", str(tmp_path / "etc"))
    registry.reload_devices()
    yield user, system
    monkeypatch.undo()
    registry.reload_devices()


def _intuos_like(**changes: object) -> dict:
    model = {k: v for k, v in registry.find_device(0x056A, 0x0315).items()
             if not k.startswith("_")}
    model.update(changes)
    return model


def test_a_new_model_and_an_override_from_your_own_files(
        dirs: tuple[Path, Path], capsys: pytest.CaptureFixture[str]) -> None:
    user, system = dirs
    new = _intuos_like(id="my-own-tablet", product_id="7777", name="My Own Tablet")
    new.pop("provenance", None)
    (system / "my-own.json").write_text(json.dumps(new))
    fixed = _intuos_like(id="intuos-pro-fixed", max_pressure=4095, name="Intuos Pro (mine)")
    (user / "intuos.json").write_text(json.dumps(fixed))
    registry.reload_devices()
    mine = registry.find_device(0x056A, 0x7777)
    assert mine is not None and mine["_source"] == "system"
    over = registry.find_device(0x056A, 0x0315)
    assert over is not None and over["max_pressure"] == 4095 and over["_source"] == "user"
    assert over["_overrides"].endswith(".json") and "drivers/devices" in over["_overrides"]
    assert main(["devices", "--list", "--json"]) == 0
    rows = {r["id"]: r for r in json.loads(capsys.readouterr().out)["models"]}
    assert rows["my-own-tablet"]["from"] == "system"
    assert rows["intuos-pro-fixed"]["from"] == "user" and "overrides" in rows["intuos-pro-fixed"]
    assert rows["wacom-0057-dtk2241"]["from"] == "bundled"
    assert main(["devices", "--list"]) == 0
    text = capsys.readouterr().out
    assert "Intuos Pro (mine)" in text and str(user / "intuos.json") in text


def test_a_bad_file_is_one_line_naming_file_and_field_and_the_rest_works(
        dirs: tuple[Path, Path], caplog: pytest.LogCaptureFixture,
        capsys: pytest.CaptureFixture[str]) -> None:
    user, _ = dirs
    (user / "broken.json").write_text(json.dumps(_intuos_like(id="broken", max_pressure=-5)))
    (user / "not-json.json").write_text("{nope")
    registry.reload_devices()
    assert registry.find_device(0x056A, 0x0315)["_source"] == "bundled"  # type: ignore[index]
    bad = registry.bad_device_files()
    assert len(bad) == 2
    (broken,) = [b for b in bad if "broken.json" in b]
    assert str(user / "broken.json") in broken and "max_pressure" in broken
    assert "\n" not in broken
    assert any("not JSON" in b for b in bad)
    assert main(["devices", "--list"]) == 0
    assert "skipped: " + str(user / "broken.json") in capsys.readouterr().out


def test_auto_pen_takes_the_first_pen_tablet_found(tmp_path: Path) -> None:
    """The bundled kiosk blueprint says device="auto:pen": any make of tablet works."""
    import errno

    from station.drivers.autodetect import first_pen_spec
    from station.drivers.mock.evdev import MockEvdevNode, touchpad_caps, wacom_like_caps
    from station.drivers.transport.base import TransportError

    root = tmp_path / "input"
    root.mkdir()
    nodes = {"event2": touchpad_caps(), "event3": None, "event9": wacom_like_caps(),
             "event11": wacom_like_caps()}
    for name in nodes:
        (root / name).write_text("")

    def opener(path: str) -> MockEvdevNode:
        caps = nodes[Path(path).name]
        if caps is None:
            raise PermissionError(errno.EACCES, "Permission denied")
        return MockEvdevNode(caps, [], path=path)

    no_hidraw = str(tmp_path / "no-sysfs")
    assert first_pen_spec(str(root), opener, no_hidraw) == f"evdev:{root / 'event9'}"
    del nodes["event9"], nodes["event11"]
    (root / "event9").unlink()
    (root / "event11").unlink()
    with pytest.raises(TransportError, match=r"no pen tablet found \(1 node\(s\) not readable"):
        first_pen_spec(str(root), opener, no_hidraw)
