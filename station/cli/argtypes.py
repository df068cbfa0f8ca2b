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


def seconds_or_zero(text: str) -> float:
    """A finite duration >= 0 s: 0 means "stop at once" (``sim --recover … --duration 0``)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number of seconds >= 0")
    return value


def auto_or_ms(text: str) -> float | None:
    """``auto`` (``None``) or a finite number of milliseconds 0..200 (``--predict-ms``)."""
    if text == "auto":
        return None
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of ms or 'auto'") from None
    if not (math.isfinite(value) and 0 <= value <= 200):
        raise argparse.ArgumentTypeError(f"{text!r} must be auto, or 0 (off) to 200 ms")
    return value
