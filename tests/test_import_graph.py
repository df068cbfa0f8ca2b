"""The house stands: every internal import runs downhill (docs/architecture.md, "The house").

The graph is read from the source with ``ast`` (nothing is imported), through the
package mapping of pyproject.toml (``drivers/`` installs as ``station.drivers``,
``calibration/`` as ``station.calibration``), and counts imports at module level,
inside functions (lazy) and ``importlib.import_module("station....")`` calls.
Imports under ``if TYPE_CHECKING:`` are for the type checker only and are not edges.

Run ``python tests/test_import_graph.py`` for the figures (imports, lazy share, rooms).
"""

from __future__ import annotations

import ast
import sys
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

PACKAGES = {"station": "station", "station.drivers": "drivers",
            "station.calibration": "calibration", "station.shaders": "shaders",
            "station.udev": "udev"}
"""Installed package -> folder of the repository (pyproject.toml's package-dir)."""

LAZY_LIMIT = 0.10
"""Largest share of internal imports that may sit inside functions."""

IMPORTLIB_ALLOWED = ("station.cli",)
"""Rooms that may name internal modules by string: the CLI's command registry."""

UNCOMMENTED_PENDING: tuple[str, ...] = ()
"""Files (path prefixes) whose in-function imports need not be commented yet: none left
since the pipeline and kiosk app splits landed."""

# The rooms, lowest first. A module may import its own room and any room listed in
# its entry of UPHILL_FREE (what lies below it); anything else is an upward or
# sideways arrow. Longest prefix wins.
ROOMS: dict[str, str] = {
    "station": "floor",
    "station.errors": "floor",
    "station.events": "floor",
    "station.durable": "floor",
    "station.progress": "floor",
    "station.sessionlog": "floor",
    "station.sizes": "floor",
    "station.wire": "floor",
    "station.shaders": "floor",
    "station.udev": "udev",
    "station.cli.argtypes": "floor",  # argparse value types, shared by the CLI and bench
    "station.drivers": "drivers",
    "station.calibration": "calibration",
    "station.bus": "bus",
    "station.glkit": "glkit",
    "station.canvas": "canvas",
    "station.brush": "brush",
    "station.arttools": "tools",  # the artistic tools (seed ch. 8)
    "station.render": "render",
    "station.backends": "backends",
    "station.sim": "sim",
    "station.pictures": "pictures",
    "station.calibrate": "calibrate",
    "station.kiosk": "kiosk",
    "station.blueprint": "blueprint",
    "station.bench": "bench",
    "station.cli": "cli",
    "station.__main__": "cli",
}

BELOW: dict[str, set[str]] = {
    "floor": set(),
    "drivers": {"floor", "calibration", "bus", "brush", "glkit"},
    "udev": {"floor", "drivers"},
    "calibration": {"floor"},
    "bus": {"floor"},
    "glkit": {"floor"},
    "canvas": {"floor"},
    "brush": {"floor", "glkit"},
    "tools": {"floor", "canvas", "render"},
    "render": {"floor", "canvas"},
    "backends": {"floor", "glkit", "canvas", "render"},
    "sim": {"floor", "drivers", "calibration", "bus", "glkit", "canvas", "brush", "tools",
            "render", "backends"},
    "pictures": {"floor", "glkit", "canvas", "brush", "tools", "render", "backends", "sim"},
    "calibrate": {"floor", "drivers", "calibration", "bus", "glkit"},
    "kiosk": {"floor", "drivers", "calibration", "bus", "glkit", "canvas", "brush", "tools",
              "render", "backends", "sim", "pictures", "udev"},
    "blueprint": {"floor", "drivers", "calibration", "bus", "glkit", "canvas", "brush", "tools",
                  "render", "backends", "sim", "udev"},
    "bench": {"floor", "drivers", "calibration", "bus", "glkit", "canvas", "brush", "tools",
              "render", "backends", "sim", "pictures", "kiosk", "udev", "blueprint"},
    "cli": set(),  # the top: everything below it (filled in below)
}
BELOW["cli"] = set(BELOW) - {"cli"}

# The Never rules of docs/architecture.md: (name, importer prefixes, imported prefixes).
# They hold transitively for the drivers and for the ``station driver`` command (a driver
# process must not load the canvas or the sim through anything it imports) and directly
# for the others.
PARSERS = ("station.drivers.wacom", "station.drivers.hid", "station.drivers.uclogic",
           "station.drivers.evdev", "station.drivers.serial.protocol")
TRANSPORTS = ("station.drivers.transport", "station.drivers.serial.transport")
BUS = ("station.bus",)
FACES = ("station.kiosk", "station.calibrate", "station.cli", "station.__main__")
CANVAS = ("station.canvas", "station.render", "station.backends")
MODEL = ("station.events", "station.errors")
NEVER: list[tuple[str, tuple[str, ...], tuple[str, ...]]] = [
    ("parsers -> transports or bus", PARSERS, TRANSPORTS + BUS),
    ("canvas -> bus, transports, face", CANVAS, BUS + TRANSPORTS + FACES),
    ("calibration -> transports or bus", ("station.calibration",), TRANSPORTS + BUS),
    ("model -> anything of the station", MODEL, ("station",)),
]
NEVER_REACH = [("drivers -> canvas or sim", ("station.drivers", "station.cli.cmd_driver"),
                ("station.canvas", "station.render", "station.backends", "station.sim"))]
MODEL_MAY = {"station.events": {"station.errors"}, "station.errors": set()}
"""The event model may import only itself (events raise the errors of station.errors)."""


@dataclass(frozen=True)
class Edge:
    src: str
    dst: str
    path: str
    line: int
    lazy: bool  # inside a function
    by_string: bool  # importlib.import_module("...")


def _under(name: str, prefixes: tuple[str, ...]) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def room_of(module: str) -> str:
    best = ""
    for prefix in ROOMS:
        if _under(module, (prefix,)) and len(prefix) > len(best):
            best = prefix
    return ROOMS[best]


def modules(root: Path = ROOT) -> dict[str, Path]:
    """Every internal module, by its installed name."""
    out: dict[str, Path] = {}
    for package, folder in PACKAGES.items():
        base = root / folder
        for path in base.rglob("*.py"):
            rel = path.relative_to(base).with_suffix("")
            parts = [p for p in rel.parts if p != "__init__"]
            if any(p.startswith(".") or p == "__pycache__" for p in rel.parts):
                continue
            out[".".join([package, *parts])] = path
    return out


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _imports(tree: ast.Module) -> Iterator[tuple[ast.AST, bool]]:
    """Import nodes and importlib calls with whether they sit inside a function."""
    def walk(node: ast.AST, lazy: bool) -> Iterator[tuple[ast.AST, bool]]:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child.test):
                for sub in child.orelse:
                    yield from walk(sub, lazy)
                continue
            if isinstance(child, (ast.Import, ast.ImportFrom, ast.Call)):
                yield child, lazy
            inner = lazy or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef,
                                               ast.Lambda))
            yield from walk(child, inner)
    yield from walk(tree, False)


def _resolve(name: str, known: dict[str, Path]) -> str | None:
    """The internal module ``name`` runs (a name inside a module: that module)."""
    while name:
        if name in known:
            return name
        name = name.rpartition(".")[0]
    return None


def edges(root: Path = ROOT) -> list[Edge]:
    known = modules(root)
    out: list[Edge] = []
    for mod, path in known.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        is_pkg = path.name == "__init__.py"
        rel_path = str(path.relative_to(root))
        for node, lazy in _imports(tree):
            targets: list[str] = []
            by_string = False
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = mod if is_pkg else mod.rpartition(".")[0]
                    for _ in range(node.level - 1):
                        base = base.rpartition(".")[0]
                    stem = f"{base}.{node.module}" if node.module else base
                else:
                    stem = node.module or ""
                targets = [f"{stem}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Call):
                f = node.func
                called = (f.attr if isinstance(f, ast.Attribute) else
                          f.id if isinstance(f, ast.Name) else "")
                if (called == "import_module" and node.args
                        and isinstance(node.args[0], ast.Constant)
                        and isinstance(node.args[0].value, str)):
                    targets, by_string = [node.args[0].value], True
                elif (called == "import_module" and node.args
                      and isinstance(node.args[0], ast.JoinedStr)):
                    parts = node.args[0].values
                    if parts and isinstance(parts[0], ast.Constant):
                        targets, by_string = [str(parts[0].value).rstrip(".")], True
            dsts = {_resolve(t, known) for t in targets} - {None, mod}
            for dst in sorted(d for d in dsts if d is not None):
                out.append(Edge(mod, dst, rel_path, node.lineno, lazy, by_string))
    return out


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []
    counter = 0
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph.get(start, ()))))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on.add(start)
        while work:
            node, it = work[-1]
            nxt = next(it, None)
            if nxt is not None:
                if nxt not in index:
                    index[nxt] = low[nxt] = counter
                    counter += 1
                    stack.append(nxt)
                    on.add(nxt)
                    work.append((nxt, iter(sorted(graph.get(nxt, ())))))
                elif nxt in on:
                    low[node] = min(low[node], index[nxt])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                comp = []
                while True:
                    m = stack.pop()
                    on.discard(m)
                    comp.append(m)
                    if m == node:
                        break
                if len(comp) > 1:
                    found.append(sorted(comp))
    return found


def _is_package_init(src: str, dst: str, known: dict[str, Path]) -> bool:
    """A package's ``__init__`` importing its own submodule (or a submodule its parent)
    is how a package exports its names, not a circle."""
    return _under(src, (dst,)) and known[dst].name == "__init__.py"


def _has_reason(lines: list[str], i: int) -> bool:
    """A comment on the import's line, or above it through the import block it is in."""
    if "#" in lines[i]:
        return True
    for j in range(i - 1, -1, -1):
        text = lines[j].strip()
        if text.startswith("#"):
            return True
        if not (text.startswith(("from ", "import ")) or text == ")" or text.endswith(",")):
            return False
        if "#" in text:
            return True
    return False


def problems(root: Path = ROOT) -> dict[str, list[str]]:
    """Every way the house at ``root`` breaks its rules, by rule."""
    known = modules(root)
    all_edges = edges(root)
    out: dict[str, list[str]] = {"upward": [], "never": [], "importlib": [], "circles": [],
                                 "lazy share": [], "lazy without a reason": []}
    texts: dict[str, list[str]] = {}
    for e in all_edges:
        where = f"{e.path}:{e.line}: {e.src} -> {e.dst}"
        a, b = room_of(e.src), room_of(e.dst)
        if a != b and b not in BELOW[a]:
            out["upward"].append(f"{where} ({a} -> {b})")
        for rule, srcs, dsts in NEVER:
            if _under(e.src, srcs) and _under(e.dst, dsts):
                allowed = MODEL_MAY.get(e.src) if rule.startswith("model") else None
                if allowed is None or e.dst not in allowed:
                    out["never"].append(f"{where} (never {rule})")
        if e.by_string and not _under(e.src, IMPORTLIB_ALLOWED):
            out["importlib"].append(f"{where} (importlib outside the CLI registry)")
        if e.lazy and not e.path.startswith(UNCOMMENTED_PENDING):
            lines = texts.setdefault(e.path, (root / e.path).read_text("utf-8").splitlines())
            if not _has_reason(lines, e.line - 1):
                out["lazy without a reason"].append(
                    f"{where} (an import in a function says why in a comment)")
    graph: dict[str, set[str]] = {}
    for e in all_edges:
        if not _is_package_init(e.src, e.dst, known):
            graph.setdefault(e.src, set()).add(e.dst)
        # importing a.b.c runs the __init__ of a.b first (unless e.src is inside it)
        parent = e.dst.rpartition(".")[0]
        while parent and parent in known and not _under(e.src, (parent,)):
            graph.setdefault(e.src, set()).add(parent)
            parent = parent.rpartition(".")[0]
    out["circles"] = [" <-> ".join(c) for c in _cycles(graph)]
    for rule, srcs, dsts in NEVER_REACH:
        for mod in sorted(m for m in known if _under(m, srcs)):
            seen, todo, parent = {mod}, [mod], {mod: ""}
            while todo:
                cur = todo.pop()
                for nxt in graph.get(cur, ()):
                    if nxt in seen:
                        continue
                    seen.add(nxt)
                    parent[nxt] = cur
                    if _under(nxt, dsts):
                        chain = [nxt]
                        while parent[chain[-1]]:
                            chain.append(parent[chain[-1]])
                        out["never"].append(f"never {rule}: {' -> '.join(reversed(chain))}")
                    else:
                        todo.append(nxt)
    lazy = [e for e in all_edges if e.lazy]
    if all_edges and len(lazy) / len(all_edges) > LAZY_LIMIT:
        worst = Counter(e.path for e in lazy).most_common(5)
        out["lazy share"].append(
            f"{len(lazy)} of {len(all_edges)} internal imports inside functions "
            f"({100 * len(lazy) / len(all_edges):.0f} % > {100 * LAZY_LIMIT:.0f} %); most in "
            + ", ".join(f"{p} ({n})" for p, n in worst))
    return out


def figures(root: Path = ROOT) -> dict[str, object]:
    """The numbers the issue asks for: imports, lazy ones, importlib edges, problems."""
    all_edges = edges(root)
    lazy = sum(e.lazy for e in all_edges)
    per_file = Counter(e.path for e in all_edges if e.lazy).most_common(8)
    return {"lazy_by_file": per_file, "internal_imports": len(all_edges), "in_functions": lazy,
            "importlib": sum(e.by_string for e in all_edges),
            "lazy_share": round(lazy / max(len(all_edges), 1), 3),
            "problems": {k: len(v) for k, v in problems(root).items()}}


# ------------------------------------------------------------------------- tests

@pytest.fixture(scope="module")
def found() -> dict[str, list[str]]:
    return problems()


@pytest.mark.parametrize("rule", ["upward", "never", "importlib", "circles", "lazy share",
                                  "lazy without a reason"])
def test_the_house_keeps_its_rule(found: dict[str, list[str]], rule: str) -> None:
    assert not found[rule], f"{len(found[rule])} breaks of '{rule}':\n" + "\n".join(found[rule])


def test_the_graph_reads_the_package_mapping_and_lazy_imports(tmp_path: Path) -> None:
    """A small tree with one of each break: the reader must see every one of them."""
    for folder in ("station/canvas", "station/sim", "drivers/transport", "drivers/wacom",
                   "calibration", "shaders", "udev"):
        (tmp_path / folder).mkdir(parents=True, exist_ok=True)
        for part in range(1, len(Path(folder).parts) + 1):
            init = tmp_path.joinpath(*Path(folder).parts[:part], "__init__.py")
            init.touch()
    (tmp_path / "station/errors.py").write_text("")
    (tmp_path / "station/canvas/state.py").write_text(
        "from station.errors import x\n"
        "def f():\n    from station.sim import player  # up, lazily\n")
    (tmp_path / "station/sim/player.py").write_text(
        "import importlib\nfrom station.canvas.state import S\n"
        "def g():\n    importlib.import_module('station.sim.other')\n")
    (tmp_path / "station/sim/other.py").write_text("from . import player\n")
    (tmp_path / "drivers/wacom/parse.py").write_text(
        "from station.drivers.transport import usb\n")
    (tmp_path / "drivers/transport/usb.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
        "    from station.sim import player\n")
    (tmp_path / "calibration/fit.py").write_text("from ..drivers import x\n")
    got = problems(tmp_path)
    assert any("station.canvas.state -> station.sim.player" in p for p in got["upward"])
    assert any("station.drivers.wacom.parse -> station.drivers.transport.usb" in p
               for p in got["never"])
    assert any("importlib" in p for p in got["importlib"])
    assert got["circles"] == [
        "station.canvas.state <-> station.sim.other <-> station.sim.player"]
    assert any("station.calibration.fit -> station.drivers (calibration -> drivers)" in p
               for p in got["upward"])  # a relative import, through the mapping
    assert [p.split(":")[0] for p in got["lazy without a reason"]] == ["station/sim/player.py"]
    assert not any("transport.usb -> station.sim" in p for p in got["upward"])  # typing only
    e = {(x.src, x.dst): x for x in edges(tmp_path)}
    assert e[("station.canvas.state", "station.sim.player")].lazy
    assert not e[("station.sim.player", "station.canvas.state")].lazy
    assert e[("station.sim.other", "station.sim.player")]  # relative, in a package
    assert got["lazy share"]  # 2 lazy of 7


if __name__ == "__main__":
    import json

    where = Path(sys.argv[1]).resolve() if len(sys.argv) > 1 else ROOT
    print(json.dumps(figures(where), indent=1))
    for rule, items in problems(where).items():
        for item in items:
            print(f"{rule}: {item}")
