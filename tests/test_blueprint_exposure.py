"""The bundled kiosk blueprint serves the gallery on loopback; a blueprint that puts
the page on the network without its hardening options gets a warning from
`station blueprint check` and `station doctor` (issue 25 item 1)."""

from __future__ import annotations

from pathlib import Path

import pytest

from station.blueprint.doctor import run_checks
from station.blueprint.exposure import gallery_exposure, is_loopback
from station.blueprint.load import bundled, load
from station.blueprint.plan import resolve
from station.cli import main


def test_the_bundled_kiosk_serves_loopback() -> None:
    bp = load(str(bundled("kiosk")))
    (kiosk,) = [c for c in bp.components if c.kind == "kiosk"]
    assert kiosk.get("serve") == "127.0.0.1:8080"
    assert gallery_exposure(bp) == []
    argv = next(p.argv for p in resolve(bp, Path("/nonexistent-run"), Path.cwd()).processes
                if p.id == "kiosk")
    assert argv[argv.index("--serve") + 1] == "127.0.0.1:8080"


@pytest.mark.parametrize("sets, warned", [
    (["kiosk.serve=0.0.0.0:8080"], ["keep-days"]),
    (["kiosk.serve=192.168.1.20:8080", "kiosk.keep-days=30"], []),
    (["kiosk.serve=192.168.1.20:8080", "kiosk.keep-days=30", "kiosk.gallery-index=true",
      "kiosk.gallery-logs=true"], ["gallery-index", "gallery-logs"]),
    (["kiosk.serve=localhost:8080", "kiosk.gallery-index=true"], []),
])
def test_a_page_on_the_network_without_hardening_is_warned(
        sets: list[str], warned: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    words = [w for s in sets for w in ("--set", s)]
    assert main(["blueprint", "check", "kiosk", *words]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    warnings = [ln for ln in err if "warning:" in ln]
    assert len(warnings) == (1 if warned else 0), err
    for name in warned:
        assert name in warnings[0] and "serves the gallery on" in warnings[0], warnings
    bp = load(str(bundled("kiosk")), sets)
    plan = resolve(bp, Path("/nonexistent-run"), Path.cwd())
    argv = next(p.argv for p in plan.processes if p.id == "kiosk")
    if "kiosk.keep-days=30" in sets:
        assert argv[argv.index("--keep-days") + 1] == "30"
    assert ("--gallery-index" in argv) == ("kiosk.gallery-index=true" in sets)
    gallery = [c for c in run_checks(plan, gl=False) if c.name == "gallery"]
    assert [c.status for c in gallery] == (["warn"] if warned else [])


def test_bad_hardening_values_are_refused_with_one_line(
        capsys: pytest.CaptureFixture[str]) -> None:
    for bad in ("kiosk.keep-days=-3", "kiosk.per-client=0", "kiosk.gallery-index=yes"):
        assert main(["blueprint", "check", "kiosk", "--set", bad]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and bad.split(".")[1].split("=")[0] in err[0], (bad, err)


def test_loopback_is_this_machine_only() -> None:
    assert all(map(is_loopback, ("127.0.0.1", "127.1.2.3", "::1", "[::1]", "localhost")))
    assert not any(map(is_loopback, ("", "0.0.0.0", "::", "192.168.1.20", "kiosk.local")))
