"""``station devices [--json] [--list]``: what pen devices this machine has, and who serves them.

The scan itself is :mod:`station.drivers.scan` (the blueprint doctor runs it too); this
command prints it.  A machine with no tablet says so plainly.  ``--list`` prints
every model in the device data with its protocol instead.
"""

from __future__ import annotations

import argparse
import json
import sys

from station.drivers.scan import SCAN_KINDS, ModelList, model_list, scan


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("devices", help="list pen devices (evdev, hidraw, USB, mock)")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument("--list", action="store_true",
                   help="list every supported pen model (device data) with its protocol")
    p.set_defaults(func=run)


def print_list(data: ModelList) -> None:
    w = sys.stdout.write
    w(f"{data['device_ids']} device ids, {data['pen_models']} pen models "
      "(ids shared by several products count each product):\n")
    w(f"{'vid:pid':<10}{'bus':<10}{'protocol':<18}{'from':<9}{'family':<34}name\n")
    for r in data["models"]:
        more = f" [{r['models']} models]" if r["models"] > 1 else ""
        own = f" ({r['path']}" + (", replaces the bundled data)" if "overrides" in r
                                   else ")") if r["from"] != "bundled" else ""
        w(f"{r['vid']}:{r['pid']} {r['bus']:<9} {r['protocol']:<17} {r['from']:<8} "
          f"{r['family'][:33]:<33} {r['name']}{more}{own}\n")
    dirs = data["directories"]
    w(f"Your own device data: {dirs['user']}/*.json (for everyone: {dirs['system']}/*.json); "
      "see docs/devices.md.\n")
    for bad in data["bad_files"]:
        w(f"skipped: {bad}\n")


def run(args: argparse.Namespace) -> int:
    if args.list:
        data = model_list()
        if args.json:
            json.dump(data, sys.stdout, indent=2)
            sys.stdout.write("\n")
        else:
            print_list(data)
        return 0
    result = scan()
    if args.json:
        json.dump(result, sys.stdout, indent=2)
        sys.stdout.write("\n")
        return 0
    w = sys.stdout.write
    if result["found"] == 0:
        w("No pen tablet found on this machine.\n")
    titles = {"evdev": "evdev (kernel driver)", "hidraw": "hidraw", "usb": "USB (pyusb)",
              "hidapi": "hidapi"}
    for key in SCAN_KINDS:
        title = titles[key]
        for d in result[key]:
            parser = d.get("parser") or "none"
            extra = f" — {d['problem']}" if "problem" in d else (
                f" ({d['note']})" if d.get("note") else "")
            file = f"  data={d['data_file']}" if d.get("data_file") else "  data=none"
            w(f"{title}: {d['spec']}  {d.get('name', '')}  parser={parser}{file}{extra}\n")
    for note in result["notes"]:
        w(f"  note: {note}\n")
    for problem in result["problems"]:
        w(f"  problem: {problem}\n")
    w("Supported models: `station devices --list`.\n")
    w("Mock devices (for testing without a tablet; add ?script=demo&rate=200):\n")
    for m in result["mock"]:
        w(f"  {m['spec']:<34} {m['name']}  parser={m['parser']}\n")
    return 0
