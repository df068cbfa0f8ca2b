"""The ``station`` command.

Subcommands live one per module, ``station/cli/cmd_<name>.py``, each with a
``register(subparsers)`` function that adds its parser and sets ``func``
(``func(args) -> int``).  They are found by name, so adding a command never
touches this file.  Exit codes (interfaces.md): 0 success, 1 failure, 2 bad input.
"""

from __future__ import annotations

import argparse
import importlib
import json
import logging
import pkgutil
import sys
from collections.abc import Sequence
from pathlib import Path

from station import __version__
from station.cli import helptext
from station.errors import BadInput, StationError

EXIT_OK, EXIT_FAIL, EXIT_BAD_INPUT = 0, 1, 2
SUMMARIES_FILE = Path(__file__).resolve().parent.parent / "data" / "cli-summaries.json"


class OneLineParser(argparse.ArgumentParser):
    """argparse that reports a wrong flag in one line and exit code 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"{self.prog}: error: {message} (see --help)\n")
        raise SystemExit(EXIT_BAD_INPUT)


def _command_modules() -> list[str]:
    return sorted(
        m.name for m in pkgutil.iter_modules(__path__) if m.name.startswith("cmd_")
    )


def _modules_for(argv: Sequence[str] | None) -> list[str]:
    """The command modules a command line needs: only its command's own when the first
    word that is not a global flag names one (``station driver …`` need not import the
    simulation, about 0.5 s of a driver's start), else every one (``--help``, a typo)."""
    names = _command_modules()
    for word in argv or ():
        if word.startswith("-"):
            continue  # the global flags (-v, -q, --version, -h) take no value
        wanted = "cmd_" + word.replace("-", "_")
        return [wanted] if wanted in names else names
    return names


def summaries() -> dict[str, str] | None:
    """Each command's one-line help from :data:`SUMMARIES_FILE`, or ``None`` when it does
    not name exactly the command modules there are (a new one: import them all)."""
    try:
        table = json.loads(SUMMARIES_FILE.read_text())
    except (OSError, ValueError):
        return None
    names = sorted(m[len("cmd_"):].replace("_", "-") for m in _command_modules())
    if not isinstance(table, dict) or sorted(table) != names:
        return None
    return {str(k): str(v) for k, v in table.items()}


def write_summaries() -> None:
    """Write :data:`SUMMARIES_FILE` from the commands' own ``help=`` (after adding a
    command or changing its help; tests/test_cli_help.py says when)."""
    table = _registered_help(build_parser())
    SUMMARIES_FILE.write_text(json.dumps(table, indent=1, sort_keys=True) + "\n")


def _registered_help(parser: argparse.ArgumentParser) -> dict[str, str]:
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {a.dest: str(a.help) for a in sub._choices_actions}


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser with every command, or with only the one ``argv`` runs.  A command
    line that names none (``station --help``, a typo) gets every command's one-line
    help from :func:`summaries` instead of importing every command module."""
    parser = OneLineParser(
        prog="station",
        description="The painting station: pen input, watery-paint simulation, tools.",
    )
    parser.add_argument("--version", action="version", version=f"station {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output")
    parser.add_argument("-q", "--quiet", action="store_true", help="only errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=OneLineParser)
    modules = _modules_for(argv)
    table = summaries() if argv is not None and len(modules) > 1 else None
    if table is not None:
        for name, text in table.items():
            sub.add_parser(name, help=text)
        return parser
    for name in modules:
        module = importlib.import_module(f"station.cli.{name}")
        module.register(sub)
    for name, command in sub.choices.items():
        helptext.finish(command, name)
    return parser


MAX_MESSAGE = 500


def one_line(exc: BaseException) -> str:
    """The message of ``exc`` as one line of at most :data:`MAX_MESSAGE` characters:
    hostile input quoted in a message (a 100 kB token, a YAML error's own line
    breaks) must not turn the promised one line into a screenful."""
    text = " ".join(str(exc).split())
    return text if len(text) <= MAX_MESSAGE else text[:MAX_MESSAGE - 1] + "…"


def main(argv: Sequence[str] | None = None) -> int:
    words = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(words)
    args = parser.parse_args(words)
    level = logging.ERROR if args.quiet else (logging.DEBUG if args.verbose > 1 else
                                              logging.INFO if args.verbose else logging.WARNING)
    logging.basicConfig(level=level, format="station: %(levelname)s: %(message)s")
    if not getattr(args, "func", None):
        parser.print_help(sys.stderr)
        return EXIT_BAD_INPUT
    try:
        return int(args.func(args) or 0)
    except BadInput as exc:
        sys.stderr.write(f"station {args.command}: {one_line(exc)}\n")
        return EXIT_BAD_INPUT
    except StationError as exc:
        sys.stderr.write(f"station {args.command}: error: {one_line(exc)}\n")
        return EXIT_FAIL
    except KeyboardInterrupt:
        sys.stderr.write(f"station {args.command}: interrupted\n")
        return 130
    except BrokenPipeError:
        return EXIT_OK


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
