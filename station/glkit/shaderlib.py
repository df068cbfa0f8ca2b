"""GLSL sources of the canvas: loading, ``#include`` resolution and error mapping.

Shaders live as package data in ``station.shaders`` (the top-level ``shaders/``
folder).  Shared code (constants, pigment packing, sampling helpers) sits in
``*.glsl`` files that pass programs pull in with::

    #include "common.glsl"

GLSL has no include directive, so :func:`preprocess` resolves it here, before
the source reaches the driver.  Every file gets a *source-string number* (the
main file 0, included files 1, 2, … in order of first inclusion) and the
expanded text carries ``#line N S`` directives, so the driver reports errors at
the right line of the right file; :func:`map_log` rewrites those numbers back
into file names (Mesa's ``0:12(5):`` and NVIDIA's ``0(12) :`` forms).

Each file is included at most once per program (an implicit include guard),
a cycle is reported as an error, and ``defines`` are injected right after the
``#version`` line without shifting any line numbers.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from importlib import resources

from station.errors import StationError

_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*(//.*)?$')
_VERSION = re.compile(r"^\s*#\s*version\b")
# Mesa: "0:12(5): error: …"; NVIDIA: "0(12) : error C1008: …".
_MESA_LOC = re.compile(r"\b(\d+):(\d+)\((\d+)\)")
_NV_LOC = re.compile(r"^(\d+)\((\d+)\)", re.MULTILINE)


class ShaderError(StationError):
    """A shader source is missing, malformed, or does not compile/link."""


@dataclass
class ShaderSource:
    """A fully expanded GLSL source plus the file names of its source-string numbers."""

    name: str
    text: str
    files: list[str] = field(default_factory=list)

    def map_log(self, log: str) -> str:
        """Rewrite a driver's compile log so locations name files (``advect.comp:12(5)``)."""
        return map_log(log, self.files)


def read_package_shader(name: str) -> str:
    """Text of ``name`` from the ``station.shaders`` package (raises ShaderError if absent)."""
    if "/" in name or "\\" in name or name.startswith("."):
        raise ShaderError(f"shader name {name!r} must be a plain file name in station.shaders")
    try:
        return (resources.files("station.shaders") / name).read_text(encoding="utf-8")
    except (FileNotFoundError, OSError) as exc:
        raise ShaderError(f"shader file {name!r} not found in station.shaders") from exc


def preprocess(
    name: str,
    defines: Mapping[str, object] | None = None,
    reader: Callable[[str], str] = read_package_shader,
) -> ShaderSource:
    """Expand ``#include`` directives of shader ``name`` and inject ``defines``.

    ``reader`` maps a file name to its text (the package loader by default; the
    tests pass a dict lookup).  Returns the expanded source with ``#line``
    directives that keep every line attributable to its file.
    """
    files: list[str] = []
    numbers: dict[str, int] = {}

    def number_of(fname: str) -> int:
        if fname not in numbers:
            numbers[fname] = len(files)
            files.append(fname)
        return numbers[fname]

    out: list[str] = []
    included: set[str] = set()
    version_seen = False

    def expand(fname: str, stack: tuple[str, ...]) -> None:
        nonlocal version_seen
        if fname in stack:
            raise ShaderError("#include cycle: " + " -> ".join((*stack, fname)))
        text = reader(fname)
        src = number_of(fname)
        included.add(fname)
        if stack:  # an included file starts at its own line 1
            out.append(f"#line 1 {src}")
        for lineno, line in enumerate(text.splitlines(), start=1):
            m = _INCLUDE.match(line)
            if m:
                target = m.group(1)
                if not version_seen:
                    raise ShaderError(f"{fname}:{lineno}: #include before #version")
                if target in included and target not in stack:
                    out.append(f"// {target} already included")
                else:
                    expand(target, (*stack, fname))
                    out.append(f"#line {lineno + 1} {src}")  # back here, next line
                continue
            if _VERSION.match(line):
                if stack:
                    raise ShaderError(f"{fname}:{lineno}: #version in an included file")
                if version_seen:
                    raise ShaderError(f"{fname}:{lineno}: second #version")
                version_seen = True
                out.append(line)
                for key, value in (defines or {}).items():
                    if not re.fullmatch(r"[A-Za-z_]\w*", key):
                        raise ShaderError(f"bad define name {key!r}")
                    out.append(f"#define {key} {value}")
                out.append(f"#line {lineno + 1} {src}")
                continue
            out.append(line)

    expand(name, ())
    if not version_seen:
        raise ShaderError(f"{name}: no #version line")
    return ShaderSource(name=name, text="\n".join(out) + "\n", files=files)


def map_log(log: str, files: list[str]) -> str:
    """Replace source-string numbers in a compile log by the file names they stand for."""

    def fname(num: str) -> str:
        i = int(num)
        return files[i] if 0 <= i < len(files) else f"<source {i}>"

    log = _MESA_LOC.sub(lambda m: f"{fname(m.group(1))}:{m.group(2)}({m.group(3)})", log)
    return _NV_LOC.sub(lambda m: f"{fname(m.group(1))}:{m.group(2)}", log)


def compile_compute(ctx: object, name: str, defines: Mapping[str, object] | None = None,
                    reader: Callable[[str], str] = read_package_shader) -> object:
    """Compile compute shader ``name`` (expanded) on moderngl context ``ctx``.

    A compile or link failure raises :class:`ShaderError` whose message names
    the files and lines of the original sources.
    """
    import moderngl

    source = preprocess(name, defines, reader)
    try:
        return ctx.compute_shader(source.text)  # type: ignore[attr-defined]
    except moderngl.Error as exc:
        raise ShaderError(f"{name} does not compile:\n{source.map_log(str(exc))}") from exc


def compile_program(ctx: object, vertex: str, fragment: str,
                    defines: Mapping[str, object] | None = None,
                    reader: Callable[[str], str] = read_package_shader) -> object:
    """Compile and link a vertex + fragment program (both expanded) on ``ctx``.

    Errors are reported like :func:`compile_compute`; the log names the stage's
    files (the vertex and fragment sources each number their own files).
    """
    import moderngl

    vs = preprocess(vertex, defines, reader)
    fs = preprocess(fragment, defines, reader)
    try:
        return ctx.program(vertex_shader=vs.text, fragment_shader=fs.text)  # type: ignore[attr-defined]
    except moderngl.Error as exc:
        log = str(exc)
        mapped = fs.map_log(log) if "fragment_shader" in log else vs.map_log(log)
        raise ShaderError(f"{vertex} + {fragment} does not compile:\n{mapped}") from exc
