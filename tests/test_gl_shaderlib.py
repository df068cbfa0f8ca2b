"""The GLSL #include preprocessor: expansion, #line bookkeeping, errors, and the driver's
compile log mapped back to file:line."""

from __future__ import annotations

import re
from importlib import resources

import pytest

from station.glkit.shaderlib import ShaderError, compile_compute, map_log, preprocess

FILES = {
    "main.comp": '#version 430\nlayout(local_size_x = 1) in;\n#include "a.glsl"\n'
                 '#include "b.glsl"\nvoid main() {\n    float x = fa() + fb();\n}\n',
    "a.glsl": '// a\n#include "c.glsl"\nfloat fa() { return C; }\n',
    "b.glsl": '#include "c.glsl"\nfloat fb() {\n    return 2.0 * C;\n}\n',
    "c.glsl": '// constants\nconst float C = 1.5;\n',
}


def lookup(files: dict[str, str]):
    def read(name: str) -> str:
        try:
            return files[name]
        except KeyError:
            raise ShaderError(f"shader file {name!r} not found") from None
    return read


def origin_of_lines(text: str, files: list[str]) -> list[tuple[str, int, str]]:
    """Replay the #line directives: (file, line, text) of every non-directive line."""
    out = []
    src, line = 0, 1
    for raw in text.splitlines():
        m = re.match(r"#line (\d+) (\d+)$", raw)
        if m:
            line, src = int(m.group(1)), int(m.group(2))
            continue
        out.append((files[src], line, raw))
        line += 1
    return out


def test_every_line_maps_back_to_its_file_and_line() -> None:
    src = preprocess("main.comp", {"NPL": 2}, lookup(FILES))
    assert src.files == ["main.comp", "a.glsl", "c.glsl", "b.glsl"]
    assert src.text.count("const float C") == 1  # included once
    for fname, line, raw in origin_of_lines(src.text, src.files):
        if raw.startswith("#define NPL") or raw.startswith("// c.glsl already"):
            continue
        assert FILES[fname].splitlines()[line - 1] == raw, (fname, line, raw)
    assert src.text.splitlines()[0] == "#version 430"
    assert "#define NPL 2" in src.text.splitlines()[1]


def test_errors_name_the_problem() -> None:
    with pytest.raises(ShaderError, match="cycle"):
        preprocess("x.comp", None, lookup({"x.comp": '#version 430\n#include "y.glsl"\n',
                                           "y.glsl": '#include "x.comp"\n'}))
    with pytest.raises(ShaderError, match="not found"):
        preprocess("x.comp", None, lookup({"x.comp": '#version 430\n#include "nope.glsl"\n'}))
    with pytest.raises(ShaderError, match="#version"):
        preprocess("x.comp", None, lookup({"x.comp": "void main() {}\n"}))
    with pytest.raises(ShaderError, match="#version in an included"):
        preprocess("x.comp", None, lookup({"x.comp": '#version 430\n#include "v.glsl"\n',
                                           "v.glsl": "#version 430\n"}))
    with pytest.raises(ShaderError, match="bad define"):
        preprocess("main.comp", {"1BAD": 1}, lookup(FILES))
    with pytest.raises(ShaderError, match="plain file name"):
        preprocess("../etc/passwd", None)


def test_map_log_rewrites_mesa_and_nvidia_locations() -> None:
    files = ["main.comp", "common.glsl"]
    assert map_log("1:12(5): error: x", files) == "common.glsl:12(5): error: x"
    assert map_log("0(7) : error C1008: y", files) == "main.comp:7 : error C1008: y"


def test_packaged_shaders_are_plain_files_with_version_and_includes() -> None:
    names = [p.name for p in resources.files("station.shaders").iterdir()
             if p.name.endswith((".comp", ".glsl"))]
    assert "common.glsl" in names and "jacobi.comp" in names
    for name in names:
        if name.endswith(".comp"):
            src = preprocess(name, {"NPL": 2, "TILE": 32, "LX": 32, "LY": 8})
            assert src.text.startswith("#version 430")
            assert "#include" not in "\n".join(
                line for line in src.text.splitlines() if not line.startswith("//"))


def test_compile_error_is_reported_at_the_included_file_and_line() -> None:
    gl = pytest.importorskip("station.backends.gl")
    try:
        ctx = gl.create_context()
    except gl.GLUnavailable as exc:
        pytest.skip(f"no OpenGL 4.3 context: {exc}")
    try:
        files = dict(FILES)
        files["c.glsl"] = "// constants\n\nconst float C = ;\n"  # error on line 3
        with pytest.raises(ShaderError) as info:
            compile_compute(ctx, "main.comp", {}, lookup(files))
        assert "c.glsl:3" in str(info.value)
        prog = compile_compute(ctx, "main.comp", {}, lookup(FILES))  # the good one compiles
        assert prog is not None
    finally:
        ctx.release()
