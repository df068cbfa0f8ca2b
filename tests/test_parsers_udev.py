"""udev rules: regenerated from device data, equal to the committed file, no world access."""

from __future__ import annotations

import re

from station.drivers.registry import load_devices
from station.udev import generate as G

from station.cli import main


def test_committed_rules_match_the_device_data():
    assert G.RULES_PATH.read_text(encoding="utf-8") == G.generate()
    assert G.check()[0]


def test_no_rule_grants_world_access():
    text = G.generate()
    modes = re.findall(r'MODE="(\d+)"', text)
    assert modes, "rules set a mode"
    for mode in modes:
        assert int(mode, 8) & 0o007 == 0, mode  # nothing for "others"
    assert "0666" not in text and "0664" not in text
    for line in text.splitlines():
        if line and not line.startswith(("#", "ACTION", "LABEL")):
            assert 'TAG+="uaccess"' in line and 'GROUP="station"' in line
            assert 'MODE="0660"' in line


def test_every_model_has_hidraw_and_event_rules():
    text = G.generate()
    for m in load_devices():
        bus = {"usb": "0003", "bluetooth": "0005", "i2c": "0018"}[m["bus"]]
        name = f'{bus}:{m["vendor_id"].upper()}:{m["product_id"].upper()}.*'
        assert f'SUBSYSTEM=="hidraw", KERNELS=="{name}"' in text
        assert f'SUBSYSTEM=="input", KERNEL=="event*", KERNELS=="{name}"' in text
        if m["bus"] == "usb":
            assert f'ATTR{{idProduct}}=="{m["product_id"]}"' in text
    assert text.count('GOTO="painting_station_end"') == 1 and text.endswith(
        'LABEL="painting_station_end"\n')


def test_rules_for_one_model():
    lines = G.rules_for({"name": "X", "vendor_id": "256C", "product_id": "006d", "bus": "bluetooth",
                         "parser": "hid-generic", "screen_tablet": True})  # fmt: skip
    assert lines[0].startswith("# X (256c:006d, bluetooth, screen tablet")
    assert len(lines) == 3 and 'KERNELS=="0005:256C:006D.*"' in lines[1]


def test_cli_udev_check_and_output(tmp_path, capsys):
    out = tmp_path / "rules"
    assert main(["udev", "-o", str(out)]) == 0
    assert out.read_text() == G.generate()
    assert main(["udev", "--check", "-o", str(out)]) == 0
    out.write_text(out.read_text() + "# edited\n")
    assert main(["udev", "--check", "-o", str(out)]) == 1
    assert "stale" in capsys.readouterr().err
    assert main(["udev"]) == 0
    assert capsys.readouterr().out == G.generate()
    assert G.main(["--check", "-o", str(out)]) == 1


def test_rules_cover_every_model_scoped_by_vendor_and_product():
    text = G.generate()
    models = load_devices()
    assert len(models) >= 150
    for line in text.splitlines():
        if line.startswith("SUBSYSTEM==\"usb\""):
            assert "ATTR{idVendor}==" in line and "ATTR{idProduct}==" in line
        elif line.startswith(("SUBSYSTEM", "ACTION==\"bind\"")):
            assert re.search(r'KERNELS?=="00(03|05|18):[0-9A-F]{4}:[0-9A-F]{4}\.\*"', line), line


def test_unbind_rule_only_where_the_user_space_path_needs_the_raw_device():
    text = G.generate()
    unbind = [ln for ln in text.splitlines() if "usbhid/unbind" in ln]
    wanted = {(m["vendor_id"].upper(), m["product_id"].upper()) for m in load_devices()
              if m.get("udev_unbind_from")}  # fmt: skip
    assert wanted and len(unbind) == len(wanted)
    for line in unbind:
        assert line.startswith('ACTION=="bind", SUBSYSTEM=="hid", DRIVER=="hid-generic"')
        vid, pid = re.search(r'0003:([0-9A-F]{4}):([0-9A-F]{4})', line).groups()
        assert (vid, pid) in wanted
    # every such model is a UC-Logic tablet that needs the set-up over raw USB
    for m in load_devices():
        if m.get("udev_unbind_from"):
            assert m["parser"] == "uclogic" and m["uclogic"]["init"] != "fixed-descriptor"


def test_rules_regenerate_identically():
    assert G.generate() == G.generate()
    assert G.RULES_PATH.read_text(encoding="utf-8") == G.generate()
