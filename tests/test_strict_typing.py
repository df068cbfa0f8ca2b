"""The --strict promise of issue 23 stays kept without running mypy in the suite.

`mypy --strict station/canvas station/brush station/sim station/kiosk` checks those
packages and every module they import.  The suite cannot afford that run (a minute and
more on a loaded machine), so it checks the two things that make the everyday
`mypy station drivers calibration` (and `make lint`) equivalent to it: pyproject's
strict override lists every --strict flag, and it covers every station module those
four packages reach through imports, including ones under ``TYPE_CHECKING`` and inside
functions (mypy follows both).
"""

from __future__ import annotations

import ast
import fnmatch
from pathlib import Path

import tomllib
from test_import_graph import ROOT, modules

STRICT_ROOTS = ("station.canvas", "station.brush", "station.sim", "station.kiosk")
# mypy --strict, less the global-only flags (warn_unused_configs) and those the
# [tool.mypy] section already sets for every module
STRICT_FLAGS = {
    "disallow_any_generics", "disallow_subclassing_any", "disallow_untyped_calls",
    "disallow_untyped_defs", "disallow_incomplete_defs", "disallow_untyped_decorators",
    "warn_return_any", "no_implicit_reexport", "strict_equality", "extra_checks",
}  # fmt: skip
GLOBAL_FLAGS = {"check_untyped_defs", "warn_unused_ignores", "warn_redundant_casts"}


def _resolve(name: str, known: dict[str, Path]) -> str | None:
    while name:
        if name in known:
            return name
        name = name.rpartition(".")[0]
    return None


def imported(mod: str, path: Path, known: dict[str, Path]) -> set[str]:
    """Every internal module ``mod`` imports anywhere in its file (``from x import y``
    counts x.y when that is a module, and x's package ``__init__`` as Python runs it)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    is_pkg = path.name == "__init__.py"
    out: set[str] = set()
    for node in ast.walk(tree):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            stem = node.module or ""
            if node.level:
                base = mod if is_pkg else mod.rpartition(".")[0]
                for _ in range(node.level - 1):
                    base = base.rpartition(".")[0]
                stem = f"{base}.{stem}" if stem else base
            names = [stem] + [f"{stem}.{a.name}" for a in node.names]
        for name in names:
            parts = name.split(".")
            for k in range(1, len(parts) + 1):  # packages run on the way down
                found = _resolve(".".join(parts[:k]), known)
                if found is not None:
                    out.add(found)
    return out - {mod}


# mypy finds station.drivers.* and station.calibration.* nowhere (the installed mapping
# drivers/ -> station.drivers is setuptools', not a folder mypy walks), so with
# ignore_missing_imports it reads them as Any and --strict on the four packages never
# enters them: the closure stops there as mypy's does.
UNSEEN_BY_MYPY = ("station.drivers", "station.calibration")


def strict_closure(root: Path = ROOT) -> set[str]:
    known = {m: p for m, p in modules(root).items()
             if not any(m == u or m.startswith(u + ".") for u in UNSEEN_BY_MYPY)}
    todo = [m for m in known if any(m == r or m.startswith(r + ".") for r in STRICT_ROOTS)]
    seen = set(todo)
    while todo:
        mod = todo.pop()
        for dst in imported(mod, known[mod], known):
            if dst not in seen:
                seen.add(dst)
                todo.append(dst)
    return seen


def _matches(module: str, pattern: str) -> bool:
    if pattern.endswith(".*"):
        return module == pattern[:-2] or module.startswith(pattern[:-1])
    return fnmatch.fnmatchcase(module, pattern)


def strict_override(root: Path = ROOT) -> dict[str, object]:
    config = tomllib.loads((root / "pyproject.toml").read_text(encoding="utf-8"))
    overrides = config["tool"]["mypy"]["overrides"]
    strict = [o for o in overrides if {k for k, v in o.items() if v is True} >= STRICT_FLAGS]
    assert len(strict) == 1, "one override carries the --strict flags"
    return dict(strict[0])


def test_the_strict_override_covers_what_the_four_packages_import() -> None:
    override = strict_override()
    patterns = override["module"]
    assert isinstance(patterns, list)
    closure = strict_closure()
    # the four packages reach the bus, the events and the session log: a real closure
    assert {"station.bus.pubsub", "station.events", "station.canvas.state"} <= closure
    uncovered = sorted(m for m in closure if not any(_matches(m, p) for p in patterns))
    assert uncovered == [], (
        f"imported by canvas/brush/sim/kiosk but not under pyproject's strict override "
        f"(mypy --strict would check them): {uncovered}")


def test_the_global_section_sets_the_rest_of_strict() -> None:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    mypy = config["tool"]["mypy"]
    assert all(mypy.get(flag) is True for flag in GLOBAL_FLAGS), GLOBAL_FLAGS


def test_the_closure_follows_lazy_and_type_checking_imports(tmp_path: Path) -> None:
    (tmp_path / "station" / "sim").mkdir(parents=True)
    for folder in ("drivers", "calibration", "shaders", "udev"):
        (tmp_path / folder).mkdir()
    (tmp_path / "station" / "__init__.py").write_text("")
    (tmp_path / "station" / "sim" / "__init__.py").write_text("")
    (tmp_path / "station" / "sim" / "a.py").write_text(
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n    from station import typed_only\n"
        "def f():\n    from station.lazy import thing\n")
    (tmp_path / "station" / "typed_only.py").write_text("")
    (tmp_path / "station" / "lazy.py").write_text("from . import deeper\n")
    (tmp_path / "station" / "deeper.py").write_text("")
    (tmp_path / "station" / "unrelated.py").write_text("")
    closure = strict_closure(tmp_path)
    assert {"station.typed_only", "station.lazy", "station.deeper"} <= closure
    assert "station.unrelated" not in closure
    assert _matches("station.bus", "station.bus.*")
    assert _matches("station.bus.keys", "station.bus.*")
    assert not _matches("station.busy", "station.bus.*")
