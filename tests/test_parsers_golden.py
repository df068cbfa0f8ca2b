"""Today's protocol parsers give, report for report, what they gave before the parse-speed
rework (issue 9): tests/data/parse_golden.json.gz, written by tests/parse_streams.py."""

from __future__ import annotations

import gzip
import json
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from parse_streams import GOLDEN, outputs, streams

with gzip.open(GOLDEN, "rt", encoding="utf-8") as _f:
    _GOLDEN = json.load(_f)
_STREAMS = streams()


def test_the_streams_cover_every_family() -> None:
    assert set(_STREAMS) == set(_GOLDEN)
    assert len(_GOLDEN) == 20


@pytest.mark.parametrize("label", sorted(_GOLDEN))
def test_parser_outputs_match_the_golden_stream(label: str) -> None:
    parser, reports = _STREAMS[label]
    got = json.loads(json.dumps(outputs(parser, reports)))  # tuples -> lists, as stored
    want = _GOLDEN[label]
    assert len(got) == len(want)
    for i, (g, w) in enumerate(zip(got, want, strict=True)):
        assert g == w, f"{label} report {i} ({reports[i].hex() if i < len(reports) else ''})"
    samples = sum(len(x) for x in want[:-1] if isinstance(x, list))
    assert samples > 10  # the stream exercises the parser, not only its error paths
