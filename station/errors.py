"""Typed exceptions of the station, one family per layer.

The CLI maps :class:`BadInput` (and subclasses) to exit code 2 with a one-line
message, and every other :class:`StationError` to exit code 1.
"""

from __future__ import annotations


class StationError(Exception):
    """Base of every error the station raises on purpose."""


class BadInput(StationError):
    """Input from outside (a file, a report, a message, a flag) is malformed.

    ``where`` names the place (``file:line``, ``report 17``, ``--size``) so the
    one-line message tells the user what to fix.
    """

    def __init__(self, message: str, where: str | None = None) -> None:
        self.where = where
        super().__init__(f"{where}: {message}" if where else message)


class EventError(BadInput):
    """A pen sample or command does not satisfy the event model."""


class SessionLogError(BadInput):
    """A session log line is malformed."""


class WireError(BadInput):
    """A bus message is not in the station wire format (or another version)."""


class BusError(StationError):
    """The bus cannot be set up (endpoint, permissions, keys)."""


class BusConfigError(BadInput):
    """An endpoint or key specification given by the user is wrong."""
