"""``station bench …``: performance measurements printed as JSON.

Each benchmark is a module ``station/bench/<name>.py`` with ``register(sub)``;
they are found by name, so adding one never touches this file.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil

import station.bench as pkg


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="performance benchmarks (JSON)")
    bsub = p.add_subparsers(dest="bench_command", metavar="WHAT", required=True,
                            parser_class=type(p))
    for m in sorted(pkgutil.iter_modules(pkg.__path__), key=lambda m: m.name):
        if m.name.startswith("_"):
            continue
        # the bench's command registry: every module of station/bench/ is a command
        importlib.import_module(f"station.bench.{m.name}").register(bsub)
