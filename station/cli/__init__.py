"""The ``station`` command.

Subcommands live one per module, ``station/cli/cmd_<name>.py``, each with a
``register(subparsers)`` function that adds its parser and sets ``func``
(``func(args) -> int``).  They are found by name, so adding a command never
touches this file.  Exit codes (interfaces.md): 0 success, 1 failure, 2 bad input.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import pkgutil
import sys
from collections.abc import Sequence

from station import __version__
from station.cli import helptext
from station.errors import BadInput, StationError

EXIT_OK, EXIT_FAIL, EXIT_BAD_INPUT = 0, 1, 2


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


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser with every command, or with only the one ``argv`` runs."""
    parser = OneLineParser(
        prog="station",
        description="The painting station: pen input, watery-paint simulation, tools.",
    )
    parser.add_argument("--version", action="version", version=f"station {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output")
    parser.add_argument("-q", "--quiet", action="store_true", help="only errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=OneLineParser)
    for name in _modules_for(argv):
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
