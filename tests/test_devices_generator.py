"""tools/gen_wacom_devices.py on small source texts written here, and the checked-in data."""

from __future__ import annotations

import importlib.util
import json
import os
import sys
from pathlib import Path

import pytest
from station.drivers import registry
from station.drivers import synth as S
from station.drivers.scan import _parser_name

from station.cli import main

ROOT = Path(__file__).resolve().parent.parent
GEN = ROOT / "tools/gen_wacom_devices.py"
spec = importlib.util.spec_from_file_location("gen_wacom_devices", GEN)
gen = importlib.util.module_from_spec(spec)
assert spec.loader is not None
sys.modules[spec.name] = gen  # dataclasses look their module up
spec.loader.exec_module(gen)

WAC_H = """
#define WACOM_REPORT_PENABLED 2
enum {
	PENPARTNER = 0,
	GRAPHIRE,
	INTUOS,
	INTUOS3,
	BAMBOO_PT,
	WACOM_24HDT,
	TABLETPC,
	HID_GENERIC,
	MAX_TYPE
};
"""
WAC_C = """
#define WACOM_INTUOS_RES\t100
#define WACOM_INTUOS3_RES\t200
#define WACOM_CINTIQ_OFFSET\t400
static const struct wacom_features wacom_features_0x41 =
\t{ "Wacom Intuos2 4x5", 12700, 10600, 1023, 31,
\t  INTUOS, WACOM_INTUOS_RES, WACOM_INTUOS_RES };
static const struct wacom_features wacom_features_0xB1 =
\t{ "Wacom Intuos3 6x8", 40640, 30480, 1023, 63, /* a comment */
\t  INTUOS3, WACOM_INTUOS3_RES, WACOM_INTUOS3_RES, 8,
\t  WACOM_CINTIQ_OFFSET, WACOM_CINTIQ_OFFSET, 0, 0 };
static const struct wacom_features wacom_features_0xF6 =
\t{ "Wacom Cintiq 24HD touch", .type = WACOM_24HDT,
\t  .oVid = USB_VENDOR_ID_WACOM, .oPid = 0xf8, .touch_max = 10 };
static const struct wacom_features wacom_features_0xD3 =
\t{ "Wacom Bamboo 2FG 6x8", 21648, 13700, 1023, 31,
\t  BAMBOO_PT, WACOM_INTUOS_RES, WACOM_INTUOS_RES, .touch_max = 2 };
static const struct wacom_features wacom_features_HID_ANY_ID =
\t{ "Wacom HID", .type = HID_GENERIC, .oVid = HID_ANY_ID, .oPid = HID_ANY_ID };
const struct hid_device_id wacom_ids[] = {
\t{ USB_DEVICE_WACOM(0x41) },
\t{ USB_DEVICE_WACOM(0xB1) },
\t{ BT_DEVICE_WACOM(0xB1) },
\t{ USB_DEVICE_WACOM(0xD3) },
\t{ USB_DEVICE_WACOM(0xF6) },
\t{ USB_DEVICE_WACOM(HID_ANY_ID) },
\t{ }
};
"""
TABLET = """[Device]
Name=Wacom Intuos3 6x8
ModelName=PTZ-630
DeviceMatch=usb|056a|00b1;
Width=203  # a comment
Height=152
IntegratedIn=
Styli=@intuos3;0x56a:0x999;

[Features]
Stylus=true
"""
HUION = """[Device]
Name=Huion H420
DeviceMatch=usb|256c|006e|HUION H420;
Styli=@generic-no-eraser;
Width=102
Height=57
"""
HUION2 = HUION.replace("H420", "H640P")
STYLUS = """[0x822]
Name=Grip Pen
Group=intuos3
Type=General
Buttons=2
Axes=Tilt;Pressure;Distance;

[0x56a:0x999]
AliasOf=0x822

[0x0:0xffffd]
Name=General Pen with no Eraser
Group=generic-no-eraser
Buttons=2
Axes=Pressure;
"""
UC_CORE = """static const struct hid_device_id uclogic_devices[] = {
\t{ HID_USB_DEVICE(USB_VENDOR_ID_HUION,
\t\t\t\tUSB_DEVICE_ID_HUION_TABLET) },
\t{ }
};"""
UC_PARAMS = """int uclogic_params_init(void) {
\tswitch (VID_PID(hdev->vendor, hdev->product)) {
\tcase VID_PID(USB_VENDOR_ID_HUION,
\t\t     USB_DEVICE_ID_HUION_TABLET):
\t\trc = uclogic_params_huion_init(&p, hdev);
\t\tbreak;
\t}
}"""
UC_IDS = "#define HID_IDS_H_FILE\n#define USB_VENDOR_ID_HUION\t\t0x256c\n" \
         "#define USB_DEVICE_ID_HUION_TABLET\t0x006e\n"


def make_cache(root: Path) -> Path:
    (root / "input-wacom/4.18").mkdir(parents=True)
    (root / "input-wacom/4.18/wacom_wac.c").write_text(WAC_C)
    (root / "input-wacom/4.18/wacom_wac.h").write_text(WAC_H)
    (root / "libwacom/data").mkdir(parents=True)
    (root / "libwacom/data/intuos3-6x8.tablet").write_text(TABLET)
    (root / "libwacom/data/huion-h420.tablet").write_text(HUION)
    (root / "libwacom/data/huion-h640p.tablet").write_text(HUION2)
    (root / "libwacom/data/wacom.stylus").write_text(STYLUS)
    (root / "digimend").mkdir()
    (root / "digimend/hid-uclogic-core.c").write_text(UC_CORE)
    (root / "digimend/hid-uclogic-params.c").write_text(UC_PARAMS)
    (root / "digimend/hid-ids.h").write_text(UC_IDS)
    for sub, c in (("input-wacom", "a"), ("libwacom", "b"), ("digimend", "c")):
        (root / sub / "COMMIT").write_text(c * 40 + "\n")
    return root


def test_c_initialisers_are_read_with_c_rules():
    feats = gen.parse_features(gen.strip_c_comments(WAC_C), gen.c_defines(WAC_C))
    assert feats["0x41"]["x_resolution"] == 100 and feats["0x41"]["type"] == "INTUOS"
    assert feats["0xB1"]["offset_left"] == 400 and feats["0xB1"]["numbered_buttons"] == 8
    assert feats["0xF6"] == {"name": "Wacom Cintiq 24HD touch", "type": "WACOM_24HDT",
                             "oVid": 0x056A, "oPid": 0xF8, "touch_max": 10}  # fmt: skip
    # a positional value after a designator continues from the designated member
    text = ('static const struct wacom_features wacom_features_0x1 =\n'
            '\t{ "P", 1, 2, .type = PL, 7, 8 };')
    assert gen.parse_features(text, {})["0x1"]["x_resolution"] == 7


def test_generator_writes_one_file_per_pen_id(tmp_path):
    cache = make_cache(tmp_path / "cache")
    out = tmp_path / "devices"
    out.mkdir()
    (out / "curated.json").write_text(json.dumps({"id": "curated", "name": "X", "bus": "usb",
                                                  "vendor_id": "056a", "product_id": "00d3"}))
    (out / "stale.json").write_text(json.dumps({"id": "stale", "bus": "usb", "vendor_id": "056a",
                                                "product_id": "0fff", "provenance": {}}))
    assert gen.main(["--cache", str(cache), "--out", str(out)]) == 0
    files = {p.stem: json.loads(p.read_text()) for p in out.glob("*.json")}
    assert not (out / "stale.json").exists() and "curated" in files
    i2 = files["wacom-0041-intuos2-4x5"]
    assert (i2["parser"], i2["max_x"], i2["max_y"], i2["max_pressure"], i2["max_distance"]) == (
        "wacom-intuos1", 12700, 10600, 1023, 31)
    assert i2["resolution"] == {"x": 100, "y": 100} and i2["drawing_area_mm"] == [127.0, 106.0]
    assert i2["init_feature_reports"] == ["0202"]
    i3 = files["wacom-00b1-intuos3-6x8"]
    assert i3["name"] == "Wacom Intuos3 6x8 (PTZ-630)" and i3["physical_size_mm"] == [203.0, 152.0]
    assert i3["offsets"] == {"left": 400, "right": 400, "top": 0, "bottom": 0}
    assert i3["protocol_quirks"] == ["no-lens"] and i3["pad_report_ids"] == [3, 12, 17]
    assert [s["tool_id"] for s in i3["styli"]] == ["0x822", "0x999"]
    assert i3["styli"][1]["name"] == "Grip Pen"  # an alias has its original's facts
    assert [s["entry"] for s in i3["provenance"]["sources"]] == ["wacom_features_0xB1",
                                                                 "intuos3-6x8.tablet"]
    assert i3["provenance"]["sources"][0]["commit"] == "a" * 40
    bt = files["wacom-bt-00b1-intuos3-6x8"]
    assert bt["bus"] == "bluetooth" and bt["init_feature_reports"] == []
    assert not any(f.get("product_id") == "00f6" for f in files.values())  # touch-only half
    assert not any(f.get("product_id") == "00d3" and "provenance" in f for f in files.values())
    huion = files["huion-006e-shared"]
    assert huion["parser"] == "uclogic" and huion["uclogic"] == {"init": "huion"}
    assert huion["models"] == ["Huion H420", "Huion H640P"]
    assert huion["udev_unbind_from"] == "hid-generic"
    # regenerating changes nothing; --check agrees; an edit is caught
    assert gen.main(["--cache", str(cache), "--out", str(out), "--check"]) == 0
    (out / "huion-006e-shared.json").write_text("{}")
    assert gen.main(["--cache", str(cache), "--out", str(out), "--check"]) == 1


CACHE = Path(os.environ.get("STATION_DEVICES_CACHE", ROOT.parent / "devices-cache"))


@pytest.mark.skipif(not (CACHE / "input-wacom/4.18/wacom_wac.c").exists(),
                    reason="source texts not fetched (docs/devices.md)")
def test_checked_in_data_is_what_the_generator_writes():
    assert gen.main(["--cache", str(CACHE), "--check"]) == 0


@pytest.mark.skipif(not (CACHE / "input-wacom/4.18/wacom_wac.c").exists(),
                    reason="source texts not fetched (docs/devices.md)")
def test_curated_files_agree_with_the_kernel_table():
    # The one difference is deliberate: the Bluetooth Graphire's mouse distance is clamped
    # to 0..31 by the kernel's own formula although its table says 32.
    assert gen.curated_disagreements(CACHE, registry.DEVICES_DIR) == [
        "wacom-graphire-bt.json: max_distance 31, kernel distance_max 32"]


def test_checked_in_data_has_provenance_and_breadth():
    models = registry.load_devices()
    generated = [m for m in models if "provenance" in m]
    assert len(models) >= 150 and len(generated) >= 500
    wacom_kernel = [m for m in generated if m.get("kernel_type")]
    assert len(wacom_kernel) >= 130
    for m in generated:
        for src in m["provenance"]["sources"]:
            assert len(src["commit"]) == 40 and src["repo"] in (
                "linuxwacom/input-wacom", "linuxwacom/libwacom", "DIGImend/digimend-kernel-drivers")
    families = {m["parser"] for m in models}
    assert {"wacom-intuos1", "wacom-intuos", "wacom-intuos4wl", "wacom-intuos-bt", "wacom-bamboo",
            "wacom-graphire", "wacom-graphire-bt", "wacom-dtu", "wacom-dtus", "wacom-pl",
            "wacom-ptu", "wacom-penpartner", "wacom-tpc", "hid-generic", "uclogic"} <= families


def test_devices_list_shows_every_model_with_its_protocol(capsys):
    assert main(["devices", "--list"]) == 0
    out = capsys.readouterr().out
    rows = [ln for ln in out.splitlines() if ln[:4].isalnum() and ":" in ln[:10]]
    assert len(rows) >= 150
    assert any("056a:00bd" in r and "wacom-intuos4wl" in r for r in rows)
    assert any("256c:006d" in r and "uclogic" in r for r in rows)
    assert main(["devices", "--list", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert len(data["models"]) == len(registry.load_devices())
    assert data["pen_models"] >= 150
    one = next(m for m in data["models"] if m["id"] == "wacom-0044-intuos2-12x12")
    assert one["protocol"] == "wacom-intuos1"
    assert one["file"].endswith("wacom-0044-intuos2-12x12.json")


def test_devices_says_per_node_which_file_and_protocol_or_why_none():


    known = _parser_name(0x056A, 0x00B1, S.wacom_protocol_descriptor(9), 3)
    assert known["parser"] == "wacom-intuos" and known["family"] == "Intuos3"
    assert known["data_file"] == "devices/wacom-00b1-intuos3-6x8.json" and "note" not in known
    touch = _parser_name(0x056A, 0x00B1, S.touch_descriptor(), 3)
    assert touch["is_pen"] is False and touch["note"].startswith("not a pen: touch")
    unknown_wacom = _parser_name(0x056A, 0x0FF0, S.pth660_like_descriptor(), 3)
    assert unknown_wacom["data_file"] is None and "please report it" in unknown_wacom["note"]
    other = _parser_name(0x1234, 0x0001, S.ntrig_like_descriptor(), 0x18)
    assert other["parser"] == "hid-generic" and "descriptor" in other["note"]
    refused = _parser_name(0x1234, 0x0002, S.touch_descriptor(), 3)
    assert refused["parser"] is None and refused["note"].startswith("no parser: ")
    uc = _parser_name(0x256C, 0x006D, bytes.fromhex("06 00 ff 09 01 a1 01 85 08 75 68 95 01 09 01"
                                                    " 81 02 c0"), 3)
    assert uc["data_file"] == "devices/huion-006d-shared.json" and "UC-Logic set-up" in uc["note"]
