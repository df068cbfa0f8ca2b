"""Every `station` command explains itself: a description and examples that run (issue 24.6)."""

from __future__ import annotations

import argparse
import json
import shlex

import pytest

from station.cli import build_parser, helptext


def _walk(parser: argparse.ArgumentParser,
          name: str = "") -> list[tuple[str, argparse.ArgumentParser]]:
    out = [(name, parser)] if name else []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub_name, sub in action.choices.items():
                out += _walk(sub, f"{name} {sub_name}".strip())
    return out


COMMANDS = _walk(build_parser())


def test_the_walk_sees_every_command() -> None:
    names = {n for n, _ in COMMANDS}
    assert len([n for n in names if " " not in n]) >= 22
    assert {"send", "calibrate", "bench parse", "blueprint check", "log cat"} <= names


@pytest.mark.parametrize("name", [n for n, _ in COMMANDS])
def test_help_has_a_description_and_an_example(name: str) -> None:
    parser = dict(COMMANDS)[name]
    text = parser.format_help()
    assert parser.description and len(parser.description) > 20, name
    assert "``" not in text, f"{name}: raw reStructuredText in --help"
    examples = text.split("examples:\n", 1)
    assert len(examples) == 2, f"{name}: no examples in --help"
    lines = [ln.strip() for ln in examples[1].splitlines() if ln.strip()]
    assert lines and all("station " in ln for ln in lines), name
    assert any(ln.startswith(f"station {name}") or f"station {name}" in ln for ln in lines)


@pytest.mark.parametrize("name", sorted(helptext.EXAMPLES))
def test_every_example_parses(name: str) -> None:
    """An example a newcomer pastes must at least get past the flags."""
    for example in helptext.EXAMPLES[name]:
        words = shlex.split(example, comments=True)
        words = words[words.index("station") + 1:]
        try:
            build_parser(words).parse_args(words)
        except SystemExit as exc:  # a bad flag: argparse exits 2
            pytest.fail(f"{example!r} does not parse (exit {exc.code})")


def test_demo_help_says_the_size_it_paints() -> None:
    from station.pictures.demo import DEMO_FILE

    canvas = json.loads(DEMO_FILE.read_text().splitlines()[0])["canvas"]
    assert f"{canvas['width']}x{canvas['height']}" in dict(COMMANDS)["demo"].format_help()


def test_the_summaries_table_is_every_commands_own_help() -> None:
    """`station --help` lists the commands from a table instead of importing them all:
    it must say what their own help says (regenerate: station.cli.write_summaries)."""
    from station.cli import _registered_help, summaries

    assert summaries() == _registered_help(build_parser()), \
        "python -c 'from station.cli import write_summaries; write_summaries()'"


def test_help_and_send_start_without_the_heavy_modules() -> None:
    """`station --help` imports no command module (over a second of CPU when it did)
    and `station send` (≤ 0.3 s a call) no numpy, canvas or sim."""
    import subprocess
    import sys

    probe = ("import sys\n"
             "from station.cli import build_parser\n"
             "p = build_parser(['--help'])\n"
             "help_text = p.format_help()\n"
             "heavy = sorted(m for m in sys.modules if m.startswith('station.cli.cmd_')\n"
             "               or m in ('numpy', 'station.sim', 'station.canvas'))\n"
             "import station.cli.cmd_send\n"
             "send = sorted(m for m in sys.modules if m == 'numpy' or m.startswith(\n"
             "    ('station.canvas', 'station.sim', 'station.kiosk.views')))\n"
             "print(heavy, send, 'send' in help_text and 'tablet-test' in help_text)\n")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         timeout=120, check=True).stdout.strip()
    assert out == "[] [] True", out
