"""Fuzzing every reader of outside input (issue 8 item 5, issue 25 item 5).

The fuzzer lives in :mod:`station.bench.fuzz` (``station bench fuzz`` runs it over
100,000+ inputs); here it runs over about 14,000, seeded, with the same rule:
every reader returns a clean result or raises :class:`~station.errors.BadInput`,
never another exception, never a hang, never a silent acceptance (an oracle
checks what an accepted input made).  A sample of fuzzed files also goes
through the CLI in process: exit 0 or 2, and one line on stderr when 2.
"""

from __future__ import annotations

import json
import random
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from station.calibration.files import loads
from station.drivers.registry import parse_device_data
from station.drivers.traces.libinput_record import parse_libinput_record

from station.bench import fuzz
from station.bench.fuzz import (
    ALARM_S,
    SUITE_ROUNDS,
    alarm,
    calibration_seeds,
    evdev_seeds,
    hid_seeds,
    mutate_text,
    quiet_logs,
    run_fuzz,
    session_seeds,
)
from station.cli import main
from station.errors import BadInput


@pytest.fixture(autouse=True)
def quiet() -> Iterator[None]:
    with quiet_logs():
        yield


def test_every_reader_gives_a_result_or_bad_input_never_a_crash_or_hang() -> None:
    import time

    t0 = time.monotonic()
    tally = run_fuzz(SUITE_ROUNDS)
    elapsed = time.monotonic() - t0
    total = sum(c["inputs"] for c in tally.counts.values())
    print(f"\nfuzzed {total} inputs in {elapsed:.1f} s: {json.dumps(tally.counts)}")
    print("seconds per reader:", {k: round(v, 2) for k, v in tally.seconds.items()})
    assert not tally.failures, "\n\n".join(tally.failures)
    assert tally.kinds == {}
    assert total >= 10_000 and set(tally.counts) == set(SUITE_ROUNDS)
    for name, c in tally.counts.items():  # the mutations reach both outcomes
        assert c["ok"] > 0 and c["bad_input"] > 0, (name, c)


def test_the_oracles_catch_a_silent_acceptance(monkeypatch: pytest.MonkeyPatch) -> None:
    """A reader that accepted NaN (as the profile reader did) is counted, not missed."""
    real = fuzz.parse_profile

    def lenient(data: bytes, where: str) -> Any:
        prof = real(data.replace(b'radius="NaN"', b'radius="6.0"'), where)
        if b'radius="NaN"' in data:
            object.__setattr__(prof.brush, "radius", float("nan"))
        return prof

    monkeypatch.setattr(fuzz, "parse_profile", lenient)
    tally = fuzz.Tally()
    seed = fuzz.profile_seeds()[0].replace('radius="6.0"', 'radius="NaN"')
    tally.run("profile", fuzz.read_profile, seed, 0)
    assert tally.kinds == {"silent": 1}
    urls = fuzz.GalleryUrls()
    try:
        tally.run("gallery-url", urls.get, f"/p/{urls.pid}", 0)
        assert tally.counts["gallery-url"]["ok"] == 1
        urls.allowed.clear()  # as if the page should not have been served
        tally.run("gallery-url", urls.get, f"/p/{urls.pid}", 1)
        assert tally.kinds == {"silent": 2}
    finally:
        urls.close()


def test_bench_fuzz_prints_the_counts(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "fuzz", "--inputs", "400", "--salt", "t"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["inputs"] >= 400 and len(out["readers"]) == len(SUITE_ROUNDS)
    assert (out["tracebacks"], out["hangs"], out["silent_acceptances"]) == (0, 0, 0)


# -- the CLI on a sample of fuzzed files ---------------------------------------------------
def cli_cases(tmp: Path) -> Iterator[tuple[list[str], str]]:
    cal = calibration_seeds()
    evemu, yaml_ = evdev_seeds()
    kinds: list[tuple[str, list[str], Callable[[Path], list[str]]]] = [
        (".jsonl", session_seeds(), lambda p: ["log", "stats", str(p)]),
        (".jsonl", session_seeds(), lambda p: ["log", "cat", str(p)]),
        (".hid", hid_seeds(), lambda p: ["replay", str(p), "--jsonl", str(p) + ".out"]),
        (".evemu", evemu, lambda p: ["replay", str(p), "--json"]),
        (".yaml", yaml_, lambda p: ["replay", str(p), "--json"]),
        (".csv", cal["csv"], lambda p: ["calibrate", "--fit", str(p), "--json"]),
        (".json", cal["json"], lambda p: ["calibrate", "--check", str(p)]),
    ]
    for index, (suffix, seeds, argv) in enumerate(kinds):
        for k in range(12):
            rng = random.Random(f"cli-{index}-{k}")
            path = tmp / f"fuzz-{index}-{k}{suffix}"
            path.write_text(mutate_text(rng, rng.choice(seeds), seeds), encoding="utf-8")
            yield argv(path), f"cli-{index}-{k}"


def test_the_cli_on_fuzzed_files_exits_0_or_2_with_one_line(tmp_path: Path, capsys) -> None:
    codes: dict[int, int] = {}
    for argv, seed in cli_cases(tmp_path):
        try:
            with alarm(60.0):  # a paint of a fuzzed log on a loaded machine
                rc = main(argv)
        except SystemExit as exc:  # argparse usage errors
            rc = int(exc.code or 0)
        err = capsys.readouterr().err
        codes[rc] = codes.get(rc, 0) + 1
        assert rc in (0, 2), (seed, argv, err)
        assert "Traceback" not in err, (seed, err)
        if rc == 2:
            errors = [ln for ln in err.splitlines() if "WARNING" not in ln]
            assert len(errors) == 1, (seed, argv, err)
    print(f"\nCLI exit codes over {sum(codes.values())} fuzzed files: {codes}")
    assert codes.get(0, 0) > 0 and codes.get(2, 0) > 0


@pytest.mark.parametrize("payload", [
    "[" * 50_000, "{\"a\":" * 50_000, "- " * 50_000, "&a [*a, *a, *a, *a, *a, *a, *a, *a]",
])
def test_pathological_yaml_and_json_are_bad_input(payload: str) -> None:
    with alarm(ALARM_S), pytest.raises(BadInput):
        parse_libinput_record("devices:\n  - " + payload, "deep.yaml")
    with alarm(ALARM_S), pytest.raises(BadInput):
        loads(payload, "deep.json")
    with alarm(ALARM_S), pytest.raises(BadInput):
        parse_device_data(payload, "deep.json")
