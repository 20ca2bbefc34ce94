"""Zenoh transport between the coordinator (``rths run``) and the specimen (``rths specimen``).

The two processes talk peer-to-peer over explicit endpoints: the coordinator *listens*, the
specimen *connects* (on loopback by default; ``--listen``/``--connect`` put the specimen on another
host).  Multicast and gossip scouting are off and no router is involved, so a run only ever talks
to the peer it was pointed at, and :class:`RunKeys` keeps every key under ``rths/<run-id>/`` so
two runs never cross-talk.

Building blocks (all context managers; closing a session undeclares everything on it):

* :func:`open_session` -- a peer session on :class:`ZenohEndpoints`.
* :class:`Inbox` / :class:`Mailbox` -- receive side of a key: every message in order (lockstep)
  or only the newest one and its age (realtime).
* :class:`LockstepClient` / :class:`LockstepServer` -- coordinator and specimen ends of the
  lockstep link: command ``k`` out, measurement ``k`` back, with a timeout.
* :class:`SyncClient` -- the ``realtime`` clock's coordinator end: command ``k`` out,
  measurement ``k`` back until a deadline (the specimen end is the :class:`LockstepServer`).
  :class:`CallbackServer` answers inside zenoh's subscriber callback instead (measured in
  ``tools/bench_zenoh.py``; not used by ``rths specimen``, see :mod:`rths.session.specimen`).
* :class:`RealtimeClient` / :class:`RealtimeServer` -- the same keys for free-running clocks:
  publish without waiting, read the latest sample of the other side.
* :class:`Presence` -- readiness handshake (liveliness tokens plus a check that the peer's hot
  subscriber is matched) and the stop signal.
* :class:`LogPublisher` / :class:`LogBridge` -- JSON side streams (e.g. the specimen's internal
  state) from another process into the coordinator's :class:`rths.log.recorder.Recorder`.

Hot-path choices, measured with ``tools/bench_zenoh.py`` (cross-process round trip, see
there): payloads are the fixed ``struct`` records of :mod:`rths.wire.codec`, sent as ``bytes`` by
publishers declared reliable, express (no batching), congestion control BLOCK (a step is never
dropped) and priority REAL_TIME.  The lockstep receive side (:class:`Inbox`) is a zenoh
``FifoChannel`` read with ``recv()`` on the loop thread: zenoh's thread fills it without the GIL,
so one thread wake-up per message instead of two for a Python callback feeding a
``queue.SimpleQueue`` (cross-process round trip p50 97 / 153 µs vs 136 / 176 µs in two full
benchmark runs on a loaded 2-core machine; a bare FifoChannel without the timeout machinery:
92 / 147 µs).  ``recv()`` cannot time out, so a watchdog thread
wakes an overdue wait with a session-local alarm sample.  The realtime receive side
(:class:`Mailbox`) is a FIFO channel too, drained with ``try_recv`` when the loop reads it: no
Python callback per message competes with the loop for the GIL.  The loop's logged measurement
``age`` is the coordinator's monotonic clock minus the specimen's sample stamp, so it is exact
when both processes run on one host (the default) and meaningless across hosts.
"""

from __future__ import annotations

import json
import os
import re
import socket
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

import zenoh

from rths.core.errors import ParameterError, TransportError
from rths.wire.inbox import Inbox, Latest, Mailbox, declare_hot_publisher
from rths.wire.keys import RunKeys, new_run_id
from rths.wire.links import (
    CallbackServer,
    LockstepClient,
    LockstepServer,
    RealtimeClient,
    RealtimeServer,
)
from rths.wire.presence import Presence, Role, wait_matched
from rths.wire.sidestreams import (
    BackgroundPublisher,
    BlockPublisher,
    LogBridge,
    LogPublisher,
    RecordSink,
)
from rths.wire.sync_link import SyncClient

__all__ = [
    "BackgroundPublisher",
    "BlockPublisher",
    "Inbox",
    "Latest",
    "LockstepClient",
    "CallbackServer",
    "LockstepServer",
    "LogBridge",
    "LogPublisher",
    "Mailbox",
    "Presence",
    "RealtimeClient",
    "RealtimeServer",
    "RecordSink",
    "Role",
    "RunKeys",
    "SyncClient",
    "ZenohEndpoints",
    "declare_hot_publisher",
    "free_loopback_port",
    "loopback_endpoint",
    "new_run_id",
    "open_session",
    "wait_matched",
    "session_config",
]

_ENDPOINT = re.compile(r"^[a-z][a-z0-9+-]*/\S+$")

#: ``RTHS_ZENOH_LOWLATENCY=1`` selects zenoh's low-latency unicast transport (no QoS queues, no tx
#: thread: the caller writes each message to the socket) on both processes (the specimen inherits
#: the variable; a specimen on another host must set it too).  Every message must fit one batch
#: (48 000 bytes did, 56 000 did not, and zenoh drops a larger one silently), so side streams go
#: out in frames of at most 32 kB and the link warm-up frame is 48 000 bytes.  Lockstep gains on
#: it (``python tools/bench_loop.py --rates 4096 --clocks lockstep --duration 10 --repeats 1``,
#: two interleaved pairs, load 5.6-5.9: mean round trip 327 / 320 µs against 384 / 386 µs, loop
#: speed 0.67 / 0.68× against 0.58×), but every ``realtime`` run on it stopped on the measurement
#: watchdog at step 24-27 (5 of 5 at 2048 Hz, ``RTHS_RT_PRIORITY=50``; the standard transport
#: finished 3 of 3 beside them), so it stays off by default.
LOWLATENCY_ENV = "RTHS_ZENOH_LOWLATENCY"


# --------------------------------------------------------------------------- session


def free_loopback_port(host: str = "127.0.0.1") -> int:
    """A TCP port on ``host`` that was free a moment ago (the OS picks it; a race is possible).

    Parameters
    ----------
    host : str
        IPv4 address to bind on (default ``"127.0.0.1"``).
    """
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind((host, 0))
        return int(sock.getsockname()[1])


def loopback_endpoint(port: int | None = None) -> str:
    """``"tcp/127.0.0.1:<port>"``; a free port is picked when ``port`` is None.

    Parameters
    ----------
    port : int or None
        TCP port, 1..65535; None (default) picks a free one (:func:`free_loopback_port`).
    """
    if port is None:
        port = free_loopback_port()
    if isinstance(port, bool) or not isinstance(port, int) or not 0 < port < 65536:
        raise ParameterError(f"TCP port must be an integer in [1, 65535]; got {port!r}")
    return f"tcp/127.0.0.1:{port}"


@dataclass(frozen=True, slots=True)
class ZenohEndpoints:
    """Where a peer session listens and what it connects to.

    Endpoints are zenoh locators ``"<protocol>/<address>"``, e.g. ``"tcp/127.0.0.1:7447"``.
    The coordinator listens, the specimen connects; see :meth:`loopback` and :meth:`peer`.

    Attributes
    ----------
    listen : tuple of str
        Locators this session listens on (default none).
    connect : tuple of str
        Locators this session connects to (default none).
    """

    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        for name in ("listen", "connect"):
            value = getattr(self, name)
            if isinstance(value, str) or not isinstance(value, Sequence):
                raise ParameterError(
                    f"{name} endpoints must be a sequence of strings; got {value!r}"
                )
            for ep in value:
                if not isinstance(ep, str) or not _ENDPOINT.match(ep):
                    raise ParameterError(
                        f"{name} endpoint must look like 'tcp/127.0.0.1:7447'; got {ep!r}"
                    )
                port = re.search(r":(\d+)$", ep)
                if port and int(port.group(1)) > 65535:
                    raise ParameterError(f"{name} endpoint {ep!r}: a port is at most 65535")
            object.__setattr__(self, name, tuple(value))
        if not self.listen and not self.connect:
            raise ParameterError("endpoints need at least one listen or connect locator; got none")

    @classmethod
    def loopback(cls, port: int | None = None) -> ZenohEndpoints:
        """Coordinator default: listen on ``127.0.0.1`` at ``port`` (a free one when None)."""
        return cls(listen=(loopback_endpoint(port),))

    def peer(self) -> ZenohEndpoints:
        """The counterpart: connect to what this side listens on (the specimen's endpoints)."""
        if not self.listen:
            raise ParameterError(f"peer() needs listen endpoints; got {self.describe()}")
        return ZenohEndpoints(connect=self.listen)

    def describe(self) -> str:
        """Human-readable summary used in error messages, e.g. ``"listen tcp/127.0.0.1:7447"``."""
        parts = [f"listen {', '.join(self.listen)}"] if self.listen else []
        parts += [f"connect {', '.join(self.connect)}"] if self.connect else []
        return "; ".join(parts)


def session_config(endpoints: ZenohEndpoints) -> zenoh.Config:
    """Zenoh configuration of an RTHS peer: explicit endpoints, no scouting, quick reconnects.

    Parameters
    ----------
    endpoints
        Locators to listen on and to connect to.

    Returns
    -------
    zenoh.Config
        Mode ``peer``; multicast and gossip scouting off; connect retried every 0.1-0.5 s;
        ``zenoh.open`` returns without waiting for the peer's declarations.
    """
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("scouting/gossip/enabled", "false")
    config.insert_json5("listen/endpoints", json.dumps(list(endpoints.listen)))
    config.insert_json5("connect/endpoints", json.dumps(list(endpoints.connect)))
    # A specimen may start before the coordinator listens: retry every 0.1-0.5 s, forever (the
    # readiness handshake, not the session, owns the timeout and its error message).
    config.insert_json5("connect/retry", "{period_init_ms: 100, period_max_ms: 500}")
    # open() need not wait (up to 0.5 s) for the peer's initial declarations: Presence does.
    config.insert_json5("open/return_conditions/declares", "false")
    if os.environ.get(LOWLATENCY_ENV, "") == "1":  # both sides must agree (see LOWLATENCY_ENV)
        config.insert_json5("transport/unicast/lowlatency", "true")
        config.insert_json5("transport/unicast/qos/enabled", "false")
    return config


@contextmanager
def open_session(endpoints: ZenohEndpoints) -> Iterator[zenoh.Session]:
    """Open a zenoh peer session on ``endpoints``; it is closed on exit, also on error.

    Parameters
    ----------
    endpoints
        Listen/connect locators (see :func:`session_config`).

    Yields
    ------
    zenoh.Session
        The open session; closing it undeclares everything declared on it.

    Raises
    ------
    TransportError
        If zenoh refuses the configuration or cannot listen (e.g. the port is taken).
    """
    try:
        session = zenoh.open(session_config(endpoints))
    except zenoh.ZError as exc:
        raise TransportError(f"cannot open zenoh session ({endpoints.describe()}): {exc}") from None
    try:
        yield session
    finally:
        session.close()
