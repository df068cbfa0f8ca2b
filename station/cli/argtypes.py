"""Argument types shared by commands: a wrong value is a one-line usage error (exit 2)."""

from __future__ import annotations

import argparse
import math


def positive_seconds(text: str) -> float:
    """A finite duration > 0 s (``--duration -1``, ``nan`` and ``inf`` are refused)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number of seconds > 0")
    return value
