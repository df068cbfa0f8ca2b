#!/usr/bin/env python3
"""List the functions and methods of the station's source that run over N lines (issue 23:
"functions over 80 lines broken up where a reader gains from it").

    python tools/long_functions.py [--over 80] [FOLDER ...]

(default folders: station drivers calibration tools)

A function's length is its ``def`` line to its last line, decorators and docstring
included, nested functions counted in their parent too.
"""

from __future__ import annotations

import argparse
import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FOLDERS = ("station", "drivers", "calibration", "tools")


def long_functions(folders: list[str], over: int) -> list[tuple[int, str, int, str]]:
    """(lines, path, first line, qualified name) of every function longer than ``over``."""
    out: list[tuple[int, str, int, str]] = []
    for folder in folders:
        for path in sorted((ROOT / folder).rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"))
            rel = str(path.relative_to(ROOT))

            def visit(node: ast.AST, prefix: str, rel: str = rel) -> None:
                for child in ast.iter_child_nodes(node):
                    if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                        name = f"{prefix}{child.name}"
                        first = min([child.lineno] + [d.lineno for d in child.decorator_list])
                        lines = (child.end_lineno or child.lineno) - first + 1
                        if lines > over:
                            out.append((lines, rel, child.lineno, name))
                        visit(child, name + ".")
                    elif isinstance(child, ast.ClassDef):
                        visit(child, f"{prefix}{child.name}.")

            visit(tree, "")
    return sorted(out, reverse=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="*", default=list(FOLDERS))
    ap.add_argument("--over", type=int, default=80, help="list functions longer than this")
    args = ap.parse_args()
    found = long_functions(args.folders, args.over)
    for lines, rel, line, name in found:
        print(f"{lines:5d}  {rel}:{line}  {name}")
    print(f"{len(found)} functions over {args.over} lines")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
