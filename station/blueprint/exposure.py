"""Whether a blueprint puts the gallery's web page on a network, and hardened.

The bundled blueprints serve the gallery on loopback: the page is a public one
(docs/gallery.md), so exposing it to the visitors' network is the operator's
explicit choice (``serve="0.0.0.0:8080"`` or the kiosk's LAN address).  A
blueprint that makes that choice without the options a public page wants —
``keep-days`` (visitors' paintings do not stay on the network for ever), the
index and session logs left off — gets a warning from ``station blueprint
check`` and ``station doctor``; it still runs.
"""

from __future__ import annotations

import ipaddress

from station.blueprint.model import Blueprint

LOOPBACK_NAMES = ("localhost", "ip6-localhost")


def is_loopback(host: str) -> bool:
    """Whether ``host`` (of a ``serve="HOST:PORT"``) is this machine only."""
    host = host.strip("[]")
    if host.lower() in LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False  # a name, a wildcard (empty), or 0.0.0.0: reachable from outside


def gallery_exposure(bp: Blueprint) -> list[str]:
    """One line for each kiosk serving the gallery beyond loopback without hardening."""
    out = []
    for c in bp.components:
        serve = c.get("serve") or "none"
        if c.kind != "kiosk" or serve == "none":
            continue
        host = serve.rpartition(":")[0]
        if is_loopback(host):
            continue
        missing = []
        if not c.get("keep-days"):
            missing.append("keep-days=N (how long visitors' paintings stay on the network)")
        if c.get("gallery-index") == "true":
            missing.append('gallery-index="false" (the index lists every visitor\'s painting)')
        if c.get("gallery-logs") == "true":
            missing.append('gallery-logs="false" (session logs served)')
        if missing:
            where = "every interface" if host in ("", "0.0.0.0", "::") else host
            out.append(f"{c.where}: serves the gallery on {serve} "
                       f"({where}) without the public-page hardening: set "
                       + "; ".join(missing) + " (docs/gallery.md: or serve 127.0.0.1 behind "
                       "a reverse proxy)")
    return out
