"""``station bench parse`` runs and counts right (no timing asserted: figures live in the bench)."""

from __future__ import annotations

import json

from station.bench.parse import measure
from station.cli import main


def test_measure_parses_every_report_of_every_workload():
    results = measure(60, 1)
    names = {"wacom-intuos", "wacom-bamboo", "wacom-graphire", "hid-generic/pth660-like",
             "hid-generic/huion-like", "hid-generic/ntrig-like"}  # fmt: skip
    assert names <= set(results)
    for name in names:
        r = results[name]
        assert r["reports"] == 60 and r["samples"] == 60, name  # one sample per report
        assert r["reports_per_s"] > 0 and r["us_per_report"] > 0
    bundled = {"wacom-intuos4wl", "wacom-intuos-bt"}  # Bluetooth: 2 pen packets a report
    for name in {"wacom-intuos1", "wacom-tpc", "uclogic-v2"} | bundled:
        r = results[name]
        assert r["samples"] == (2 * r["reports"] if name in bundled else r["reports"]), name
        assert r["samples_per_s"] >= r["reports_per_s"] > 0
    # what a report is, printed beside its figure: a bundle of two packets counts once
    assert results["wacom-intuos4wl"]["report_bytes"] == [22, 22]
    assert results["wacom-intuos-bt"]["report_bytes"] == [109, 109]
    for name in bundled:
        assert results[name]["pen_packets_per_report"] == 2.0
        assert "one report" in results[name]["what"]
    assert results["wacom-intuos"]["report_bytes"] == [10, 10]
    assert results["wacom-intuos"]["pen_packets_per_report"] == 1.0
    for name, r in results.items():
        if name != "normaliser":  # the target is on reports, never on packets
            assert r["meets_target"] == (r["reports_per_s"] >= 300_000), name
    norm = results["normaliser"]
    assert "skipped" in norm or norm["raw_samples"] == 60


def test_cli_prints_json(capsys):
    assert main(["bench", "parse", "--json", "--reports", "40", "--repeat", "1", "--no-pin"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["benchmark"] == "parse" and out["target_reports_per_s"] == 300_000
    assert out["pinned_cpu"] is None
    assert out["slowest_parser_reports_per_s"] == min(
        r["reports_per_s"] for k, r in out["results"].items() if k != "normaliser")
    assert "counts once" in out["counting"]
    assert out["slowest_reports_per_s"] == min(
        r["reports_per_s"] for r in out["results"].values() if "reports_per_s" in r)
