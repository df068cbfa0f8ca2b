"""What ``station COMMAND --help`` shows besides the flags: a description and examples.

Kept in one table so every command (and every action of ``bench``, ``blueprint``
and ``log``) has at least one example a newcomer can paste, and a test walks them
all (tests/test_cli_help.py).  A command module may set its own description;
the table fills in one that is missing, and the examples go in the epilog.
"""

from __future__ import annotations

import argparse
import re

DESCRIPTIONS: dict[str, str] = {
    "bench": "Measure the station's speed; each benchmark prints one JSON object.",
    "blueprint": "Blueprints describe a whole station (drivers, sim, kiosk, gallery): list "
                 "the bundled ones, check one, show its wiring, or write systemd units.",
    "devices": "List the pen devices this machine has (evdev, hidraw, USB), what each can "
               "be opened as, and why one cannot; --list shows every supported model and "
               "where its device data comes from.",
    "doctor": "Check this machine can run a station (OpenGL, devices and permissions, udev "
              "rules, calibration files, the bus, free disk) and say what to fix. WARN is "
              "worth knowing, FAIL stops a station; exit 1 only on a FAIL.",
    "driver": "Read one pen device (or a mock or a trace) and publish its normalised pen "
              "samples on the bus, calibrated when a calibration file is found.",
    "keys": "Make the CURVE key pairs a station needs for tcp endpoints (ipc needs none).",
    "log": "Look into a session log: print its records or summarise it as JSON.",
    "record": "Record a device's raw reports to a trace file (hid-recorder or evemu "
              "format), or what the bus carries to a session log.",
    "replay": "Play a device trace (hid-recorder, evemu, libinput record) through the real "
              "driver path: onto the bus, or as JSON lines.",
    "udev": "Print or write the udev rules that give the station's group access to every "
            "supported pen tablet (never 0666), or check an installed file is current.",
}

EXAMPLES: dict[str, list[str]] = {
    "bench": ["station bench parse", "station bench bus --json"],
    "bench brush": ["station bench brush"],
    "bench bus": ["station bench bus"],
    "bench distributed": ["mpiexec -n 2 station bench distributed"],
    "bench fuzz": ["station bench fuzz", "station bench fuzz --inputs 10000 --salt 2"],
    "bench haptic": ["station bench haptic"],
    "bench latency": ["station bench latency"],
    "bench parse": ["station bench parse"],
    "bench peer": ["station bench peer --peer-src Open-Watercolor-Sim/src",
                   "station bench peer --peer-src Open-Watercolor-Sim/src --sizes 512 --pairs 1"],
    "bench render": ["station bench render"],
    "bench sim": ["station bench sim --json"],
    "bench send": ["station bench send --calls 20"],
    "blueprint": ["station blueprint list", "station blueprint check kiosk"],
    "blueprint list": ["station blueprint list"],
    "blueprint check": ["station blueprint check my-station.xml"],
    "blueprint show": ["station blueprint show kiosk --set pen.device=mock-user:circle"],
    "blueprint systemd": ["station blueprint systemd kiosk -o units/"],
    "brush-sheet": ["station brush-sheet -o brush-sheet.png"],
    "bus": ["station bus", "station bus --pub tcp://:5555 --sub tcp://:5556"],
    "calibrate": ["station calibrate --device mock-user:good -o cal.json",
                  "station calibrate --fit points.csv --json",
                  "station calibrate --export libinput --calibration cal.json"],
    "demo": ["station demo", "station demo -o landscape.png --scale 2"],
    "devices": ["station devices", "station devices --list"],
    "doctor": ["station doctor", "station doctor kiosk --no-gl"],
    "driver": ["station driver --device mock-user:circle",
               "station driver --device evdev:/dev/input/event7 --calibration auto"],
    "effects": ["station effects -o effects.png"],
    "gallery": ["station gallery serve --root gallery/ --serve 127.0.0.1:8080",
                "station gallery make 20261127-051200-a1b2c3 --root gallery/"],
    "gallery make": ["station gallery make 20261127-051200-a1b2c3 --root gallery/"],
    "gallery serve": ["station gallery serve --root gallery/"],
    "gallery expire": ["station gallery expire --root gallery/ --keep-days 30"],
    "keys": ["station keys", "station keys --client tablet-2"],
    "kiosk": ["station kiosk --windowed 1280x800",
              "station run kiosk  # the kiosk with its driver and gallery"],
    "log": ["station log cat session.jsonl", "station log stats session.jsonl"],
    "log cat": ["station log cat session.jsonl"],
    "log stats": ["station log stats session.jsonl"],
    "paint": ["station paint session.jsonl -o out.png",
              "station paint trace.hid -o out.png --size 400x300 --stats stats.json"],
    "record": ["station record --device hidraw:/dev/hidraw3 -o pen.hid",
               "station record --device mock:intuos-pro-m?script=line -o line.hid -q"],
    "replay": ["station replay pen.hid --jsonl -", "station replay pen.hid --decode",
               "station replay pen.hid --speed 1.0"],
    "run": ["station run headless-demo --once", "station run kiosk"],
    "send": ["station send brush size=12", "station send --to kiosk stop"],
    "tablet-test": ["station tablet-test --device auto:pen",
                    "station tablet-test --device mock:intuos-pro-m --terminal"],
    "sim": ["station sim", "station sim --size 640x480 --backend cpu --png live.png"],
    "tools-sheet": ["station tools-sheet -o tools-sheet.png"],
    "udev": ["station udev -o 70-painting-station.rules", "station udev --check"],
}

_LITERAL = re.compile(r"``([^`]+)``")


def plain(text: str) -> str:
    """reStructuredText literals (````x````) in a docstring used as help, as plain text."""
    return _LITERAL.sub(r"\1", text)


def finish(parser: argparse.ArgumentParser, name: str) -> None:
    """Give ``parser`` (the command ``name``, e.g. ``"bench parse"``) its description
    and examples, then do the same for its own sub-commands."""
    if not parser.description:
        parser.description = DESCRIPTIONS.get(name)
    if parser.description:
        parser.description = plain(parser.description)
    examples = EXAMPLES.get(name)
    if examples and "examples:" not in (parser.epilog or ""):
        block = "examples:\n" + "\n".join(f"  {e}" for e in examples)
        parser.epilog = f"{parser.epilog}\n\n{block}" if parser.epilog else block
        if parser.formatter_class is argparse.HelpFormatter:
            # keep the examples' lines as written (descriptions still wrap)
            parser.formatter_class = _EpilogAsIs
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub_name, sub in action.choices.items():
                if not sub.description:
                    helps = {a.dest: a.help for a in action._choices_actions}
                    sub.description = helps.get(sub_name)
                finish(sub, f"{name} {sub_name}")


class _EpilogAsIs(argparse.HelpFormatter):
    """Wraps the description as argparse does; prints the epilog's lines unchanged."""

    def add_text(self, text: str | None) -> None:
        if text and (text.startswith("examples:") or "\nexamples:\n" in text):
            self._add_item(lambda t: t + "\n", [text])
        else:
            super().add_text(text)
