"""The station bus: ZeroMQ publish/subscribe of pen samples, commands, status.

Topics: ``pen.<device>`` (pen samples), ``cmd`` (commands to the simulation),
``status`` (JSON status of any process), ``haptic.<device>`` (force
back-channel).  Payloads use :mod:`station.wire`.

Endpoints (``EndpointSpec``): ``ipc`` (the default, ``ipc://<runtime>/bus``),
``ipc:NAME`` (``ipc://<runtime>/NAME``), ``ipc:///abs/path``, ``tcp://HOST:PORT``
(always CURVE-authenticated; ``tcp://:PORT`` binds loopback only).  A leading
``@`` forces bind, ``>`` forces connect (the CZMQ convention); by default
publishers bind and subscribers connect.  ``station bus`` runs a proxy for
many-to-many set-ups: publishers connect to its ``pub`` endpoint, subscribers
to its ``sub`` endpoint.

Late joiners: publishers use XPUB and see each new subscription; they then
re-send the samples of the current proximity period (flagged *replayed*) so a
subscriber that starts mid-stroke still sees the stroke from its first sample.
Subscribers drop replayed messages they already have (by sequence number) and
count gaps in the per-publisher, per-topic sequence as lost samples.

Truth about who is there: binding an endpoint that a live process already
holds fails (:class:`EndpointInUse`, exit 2) instead of taking it over (an ipc
socket file whose process died is replaced); a publisher created with
``heartbeat=S`` sends a heartbeat per device every ``S`` seconds on
``hb.<device>`` (:meth:`Publisher.tick`), so a subscriber notices a publisher
that stopped, and samples lost at the very end of its stream.
"""

from station.bus.endpoints import (
    DEFAULT_NAME,
    RELEASE_WAIT_S,
    Endpoint,
    EndpointInUse,
    config_dir,
    ipc_in_use,
    keys_dir,
    resolve_endpoint,
    runtime_dir,
    secure_dir,
)
from station.bus.keys import (
    HANDSHAKE_FAILED,
    CurveKeys,
    HandshakeWatch,
    KeyCheck,
    add_client_key,
    check_private,
    client_key_name,
    generate_keys,
    load_keys,
)
from station.bus.proxy import run_proxy
from station.bus.pubsub import (
    HEARTBEAT_S,
    REPLAY_LIMIT,
    Message,
    Publisher,
    Subscriber,
    SubscriberStats,
)
from station.bus.sockets import HWM

__all__ = [
    "DEFAULT_NAME",
    "HANDSHAKE_FAILED",
    "HEARTBEAT_S",
    "HWM",
    "RELEASE_WAIT_S",
    "REPLAY_LIMIT",
    "CurveKeys",
    "Endpoint",
    "EndpointInUse",
    "HandshakeWatch",
    "KeyCheck",
    "Message",
    "Publisher",
    "Subscriber",
    "SubscriberStats",
    "add_client_key",
    "check_private",
    "client_key_name",
    "config_dir",
    "generate_keys",
    "ipc_in_use",
    "keys_dir",
    "load_keys",
    "resolve_endpoint",
    "run_proxy",
    "runtime_dir",
    "secure_dir",
]
