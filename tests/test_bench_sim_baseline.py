"""``station bench sim --baseline REV``: this tree against a commit in one run (issue 10
item 10). Tiny canvases on the numpy backend (no kernels to compile); not timed."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from station.bench import _sim_baseline as sb
from station.cli import main

ROOT = sb.source_root()


def _git_head() -> str:
    res = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True,
                         text=True, check=False)
    if res.returncode != 0:
        pytest.skip("the station is not a git checkout here")
    return res.stdout.strip()


def test_baseline_against_head_reports_both_figures(tmp_path: Path, monkeypatch,
                                                    capsys) -> None:
    head = _git_head()
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    rc = main(["bench", "sim", "--baseline", "HEAD", "--backends", "numpy",
               "--sizes", "48x40", "--rounds", "2"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["baseline"]["commit"] == head
    assert (tmp_path / "station" / "bench-baseline" / head / "station" / "__init__.py").is_file()
    wash, stroke = out["wash"], out["stroke"]
    assert len(wash["cost_ratios"]) == 2 and wash["cost_ratio"] > 0
    assert wash["goal_cost_ratio"] == 1.25 and isinstance(wash["met"], bool)
    assert stroke["current_steps_per_s"] > 0 and stroke["baseline_steps_per_s"] > 0
    assert stroke["goal_steps_per_s"] == 200.0
    # the same commit simulates the same cells: both sides ran the same scenario
    assert stroke["current_cells_per_step"] == stroke["baseline_cells_per_step"] > 0
    assert len(out["load_average"]) == 3


def test_the_baseline_child_imports_the_extracted_commit(tmp_path: Path,
                                                         monkeypatch) -> None:
    _git_head()
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    _, folder = sb.extract("HEAD")
    child = sb.Child("baseline", folder)  # refuses a child that imported another tree
    try:
        r = child.run("numpy", 32, 24, "stroke", 1, 3)
    finally:
        child.close()
    assert r["steps"] == 3 and r["seconds"] > 0 and r["cells_per_step"] > 0
    # the commit's GL programs go with it (package data of station.shaders), not this tree's
    shader = subprocess.run(["git", "show", "HEAD:shaders/jacobi.comp"], check=True,
                            capture_output=True, cwd=sb.source_root()).stdout.decode()
    assert (folder / "station" / "shaders" / "jacobi.comp").read_text() == shader


@pytest.mark.parametrize("argv, what", [
    (["--baseline", "no-such-rev-xyz"], "not a commit"),
    (["--baseline", "HEAD", "--backends", "cpu,numpy"], "one backend"),
    (["--baseline", "HEAD", "--sizes", "64x48,32x32"], "one size"),
    (["--baseline", "HEAD", "--rounds", "0"], "outside"),
    (["--baseline", "HEAD", "--scenarios", "splash"], "unknown scenario"),
])
def test_bad_baseline_arguments_exit_2(argv: list[str], what: str, capsys) -> None:
    _git_head()
    rc = main(["bench", "sim", *argv])
    assert rc == 2
    assert what in capsys.readouterr().err
