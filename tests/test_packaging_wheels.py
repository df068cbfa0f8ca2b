"""A newcomer's machine has no compiler: every dependency installs from a binary wheel.

The proof on a bare Debian is ``shared/tools/fresh-machine.sh`` (README commands in a
debootstrap chroot); these tests hold the pieces that make it pass: the Makefile asks
pip for wheels only and installs no toolchain or headers, and nothing in this
environment was compiled locally (a locally built wheel is tagged ``linux_<arch>``,
PyPI's binary wheels ``manylinux…``/``musllinux…`` or ``none-any``).
"""

from __future__ import annotations

import re
import sys
from importlib import metadata
from pathlib import Path

import pytest
from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parents[1]
TOOLCHAIN = ("gcc", "g++", "clang", "build-essential", "python3-dev", "linux-libc-dev",
             "libc6-dev", "libevdev-dev", "pkg-config", "cmake")


def _makefile_var(name: str) -> list[str]:
    text = (ROOT / "Makefile").read_text(encoding="utf-8").replace("\\\n", " ")
    m = re.search(rf"^{name}\s*:?=(.*)$", text, re.M)
    assert m, f"{name} not in the Makefile"
    return m.group(1).split()


def test_makefile_installs_no_toolchain_and_asks_for_wheels_only() -> None:
    assert not set(_makefile_var("SYS_PKGS")) & set(TOOLCHAIN)
    text = (ROOT / "Makefile").read_text(encoding="utf-8")
    installs = [ln for ln in text.splitlines() if "pip install" in ln and "-e " in ln]
    assert installs and all("--only-binary=:all:" in ln for ln in installs)


def test_evdev_comes_as_the_binary_wheel() -> None:
    # the project's tables only: [tool.*] lists quoted module names too (mypy's overrides);
    # no tomllib, which Python 3.10 lacks
    text = (ROOT / "pyproject.toml").read_text(encoding="utf-8").split("\n[tool.", 1)[0]
    names = {Requirement(r).name for r in re.findall(r'^\s*"([^"]+)",?\s*$', text, re.M)}
    assert "evdev-binary" in names
    assert "evdev" not in names  # the sdist needs gcc and kernel headers


def _tags(dist: metadata.Distribution) -> list[str]:
    wheel = dist.read_text("WHEEL") or ""
    return [ln.split(":", 1)[1].strip() for ln in wheel.splitlines() if ln.startswith("Tag:")]


def _dependency_closure() -> dict[str, metadata.Distribution]:
    """The installed distributions painting-station[test] needs, recursively."""
    env = {"extra": "test"}
    seen: dict[str, metadata.Distribution] = {}
    todo = ["painting-station"]
    while todo:
        name = todo.pop()
        key = name.lower().replace("_", "-")
        if key in seen:
            continue
        try:
            dist = metadata.distribution(name)
        except metadata.PackageNotFoundError:
            continue  # an optional dependency's own optional one, not installed here
        seen[key] = dist
        for spec in dist.requires or []:
            req = Requirement(spec)
            if req.marker is None or req.marker.evaluate(env if key == "painting-station"
                                                         else {"extra": ""}):
                todo.append(req.name)
    return seen


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="wheel tags checked on Linux")
def test_no_installed_dependency_was_compiled_here() -> None:
    closure = _dependency_closure()
    assert {"numpy", "evdev-binary", "pillow", "scipy", "tqdm"} <= set(closure)
    local = {name: tags for name, dist in closure.items() if name != "painting-station"
             for tags in [_tags(dist)] if any(re.search(r"-linux_\w+$", t) for t in tags)}
    assert not local, f"built from source on this machine (needs a compiler): {local}"
