"""The CURVE flags every bus command shares: ``--keys DIR`` and ``--client-key NAME``.

The bus is ipc by default; a ``tcp://`` endpoint is always CURVE-authenticated
(station.bus).  A command checks the keys of each tcp endpoint it was given before
it starts anything (no log, no window, no socket yet), so a missing or unreadable
key is bad input: exit 2 with one line naming the flag, the endpoint and the key
directory.  On ipc endpoints the keys are not used (as for ``station driver``).
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from pathlib import Path

from station.bus import load_keys, resolve_endpoint
from station.errors import BadInput, BusConfigError


def add_key_flags(p: argparse.ArgumentParser) -> None:
    p.add_argument("--keys", type=Path, default=None, metavar="DIR",
                   help="CURVE key directory for tcp endpoints (default "
                        "~/.config/station/keys; not used on ipc)")
    p.add_argument("--client-key", metavar="NAME",
                   help="connect over tcp with this key pair of its own (made by `station "
                        "keys --client NAME`) instead of the shared client key")


def check_keys(keys: Path | None, client_key: str | None,
               endpoints: Iterable[tuple[str, str | None, bool]]) -> None:
    """Refuse, before anything starts, a tcp endpoint whose CURVE keys cannot be loaded.

    ``endpoints``: ``(flag, spec, binds_by_default)``; a spec of ``None`` or
    ``"none"`` is skipped.  A binding endpoint needs the server key pair, a
    connecting one the server's public key and the client's key pair.
    """
    for flag, spec, bind in endpoints:
        if spec is None or spec == "none" or not spec.lstrip("@>").startswith("tcp://"):
            continue
        try:
            ep = resolve_endpoint(spec, bind)
            if ep.bind:
                load_keys(keys, "server")
            else:
                load_keys(keys, "client", client_key)
        except BusConfigError as exc:
            hint = "" if keys is not None else " (or pass --keys DIR)"
            raise BadInput(f"{spec}: tcp needs CURVE keys: {exc}{hint}", flag) from None
