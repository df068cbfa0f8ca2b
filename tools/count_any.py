#!/usr/bin/env python3
"""Count the uses of ``typing.Any`` in the station's source (issue 23's measure).

A use is one ``Any`` node in a module's syntax tree: a ``Name`` ``Any`` or an attribute
``typing.Any``, anywhere (annotations, ``cast``, aliases, generic arguments), and inside
string annotations; the ``import`` that brings it in is not a use.  Tests are not counted.

    python tools/count_any.py [--top N] [FOLDER ...]

(default folders: station drivers calibration tools)
"""

from __future__ import annotations

import argparse
import ast
import collections
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FOLDERS = ("station", "drivers", "calibration", "tools")


def _names(node: ast.AST) -> int:
    return sum(1 for sub in ast.walk(node)
               if (isinstance(sub, ast.Name) and sub.id == "Any")
               or (isinstance(sub, ast.Attribute) and sub.attr == "Any"))


def _annotations(tree: ast.AST) -> list[ast.expr]:
    out: list[ast.expr] = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            a = node.args
            out += [x.annotation for x in (*a.posonlyargs, *a.args, *a.kwonlyargs,
                                           a.vararg, a.kwarg) if x is not None and x.annotation]
            if node.returns is not None:
                out.append(node.returns)
        elif isinstance(node, ast.AnnAssign):
            out.append(node.annotation)
    return out


def uses(tree: ast.AST) -> int:
    """``Any`` nodes in ``tree``, and in the string annotations it holds."""
    n = _names(tree)
    for ann in _annotations(tree):
        for sub in ast.walk(ann):
            if isinstance(sub, ast.Constant) and isinstance(sub.value, str):
                try:
                    n += _names(ast.parse(sub.value, mode="eval"))
                except SyntaxError:
                    pass  # a Literal's string, not a type
    return n


def count(folders: list[str]) -> collections.Counter[str]:
    per: collections.Counter[str] = collections.Counter()
    for folder in folders:
        for path in sorted((ROOT / folder).rglob("*.py")):
            per[str(path.relative_to(ROOT))] = uses(ast.parse(path.read_text(encoding="utf-8")))
    return per


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="*", default=list(FOLDERS))
    ap.add_argument("--top", type=int, default=0, help="list the N files with the most")
    args = ap.parse_args()
    per = count(args.folders)
    print(f"{sum(per.values())} uses of Any in {', '.join(args.folders)}")
    for path, n in per.most_common(args.top):
        if n:
            print(f"{n:5d}  {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
