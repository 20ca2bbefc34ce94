"""Readiness handshake and stop signal between coordinator and specimen (private; import
:class:`Presence` from :mod:`rths.wire.transport`).
"""

from __future__ import annotations

import json
import os
import threading
import time
from collections.abc import Sequence
from typing import Protocol

import zenoh

from rths.core.errors import ParameterError, TransportError, check_positive
from rths.wire.auth import RunSecret
from rths.wire.keys import ROLES, Role

__all__ = ["ROLES", "WARMUP_BYTES", "Presence", "Role", "wait_matched"]

#: Size [bytes] of the warm-up frame each side sends once the handshake is done.  It must fit
#: one batch of the low-latency transport (``RTHS_ZENOH_LOWLATENCY=1``): 48 000 bytes do, 56 000
#: and the 60 000 used before did not (the frame never arrived and every such run failed its
#: handshake); still far above the 13 kB frame that stalled a session the first time.
WARMUP_BYTES = 48_000


def wait_matched(publisher: zenoh.Publisher, timeout: float | None) -> bool:
    """Block until a subscriber matches ``publisher`` (woken by zenoh's matching listener).

    Parameters
    ----------
    publisher
        A declared zenoh publisher.
    timeout
        Longest wait [s]; None waits as long as it takes.

    Returns
    -------
    bool
        True once matched, False on timeout.
    """
    matched = threading.Event()
    listener = publisher.declare_matching_listener(
        lambda status: matched.set() if status.matching else None
    )
    try:
        # a match made before the listener existed is not reported to it: check after declaring
        matched_now: bool = publisher.matching_status.matching  # type: ignore[attr-defined]
        return matched_now or matched.wait(timeout)
    finally:
        listener.undeclare()


class _ControlKeys(Protocol):
    """The keys a :class:`Presence` needs (:class:`rths.wire.transport.RunKeys` provides them)."""

    @property
    def stop(self) -> str: ...

    def ready(self, role: Role) -> str: ...

    def warmup(self, role: Role) -> str: ...


class Presence:
    """This process's readiness, its peer's, and the stop signal.

    Declare the links first, then create the :class:`Presence` and call :meth:`wait_for_peer`:
    it declares this side's liveliness token (``control/ready/<role>``), waits for the peer's,
    and waits until every given hot publisher is matched by the peer's subscriber, so step 0
    cannot be lost.  Then both sides *warm the link up*: each sends one large frame
    (:data:`WARMUP_BYTES`, on ``control/warmup/<role>``, with the side streams' settings) and
    waits for the peer's.  The first large message a zenoh session sends or receives stalls the
    process for 10-20 ms: measured again with the FIFO-channel specimen (seed scenario, 2048 Hz,
    quiet VM), the specimen's first 64-row block of its log at step 63 held every measurement
    back for 14-16 ms (lag rising to 28-30 steps from step 69-71, in 2 of 3 runs), tripping the
    watchdogs of real-time runs within 0.02-0.13 s; paid here, before step 0, it costs nothing.
    The frame's content is ignored, so it is not sealed: a forged one can only end the wait
    early.  :attr:`stop` is set when the peer publishes a stop request or its token
    disappears (process ended or crashed); :attr:`stop_reason` says which.

    Parameters
    ----------
    session, keys
        Open session and the run's keys.
    role
        ``"coordinator"`` or ``"specimen"``; the peer is the other one.
    where
        Endpoint description for error messages (e.g. ``endpoints.describe()``).
    secret
        The run's secret: stop requests are sealed, and the peer's are honoured only if they
        verify (:mod:`rths.wire.auth`; forged and replayed ones are counted in
        :attr:`refused`).  None: plain stop requests (tests).
    """

    def __init__(
        self,
        session: zenoh.Session,
        keys: _ControlKeys,
        role: Role,
        where: str,
        secret: RunSecret | None = None,
    ) -> None:
        if role not in ROLES:
            raise ParameterError(f"role must be one of {ROLES}; got {role!r}")
        self.role: Role = role
        self.peer: Role = ROLES[1 - ROLES.index(role)]
        self._sealer = None if secret is None else secret.sealer(f"stop/{role}")
        self._opener = None if secret is None else secret.opener(f"stop/{self.peer}")
        self.where = where
        self.stop = threading.Event()
        self.stop_reason = ""
        #: True once the peer's token went away without a stop request first (it died)
        self.peer_gone = False
        self._session = session
        self._keys = keys
        self._peer_up = threading.Event()
        self._token: zenoh.LivelinessToken | None = None
        liveliness = session.liveliness()
        self._watch = liveliness.declare_subscriber(
            keys.ready(self.peer),
            zenoh.handlers.Callback(self._on_liveliness, indirect=False),
            history=True,
        )
        self._stop_sub = session.declare_subscriber(
            keys.stop,
            zenoh.handlers.Callback(self._on_stop, indirect=False),
            allowed_origin=zenoh.Locality.REMOTE,
        )
        self._warmed = threading.Event()
        self._warm_sent = False
        self._warm_sub = session.declare_subscriber(
            keys.warmup(self.peer),
            zenoh.handlers.Callback(self._on_warmup, indirect=False),
            allowed_origin=zenoh.Locality.REMOTE,
        )
        # the side streams' settings (reliable, blocking, batched, default priority)
        self._warm_pub = session.declare_publisher(
            keys.warmup(role),
            congestion_control=zenoh.CongestionControl.BLOCK,
            reliability=zenoh.Reliability.RELIABLE,
        )

    def _on_warmup(self, sample: zenoh.Sample) -> None:
        self._warmed.set()

    def _on_liveliness(self, sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.PUT:
            self._peer_up.set()
        elif self._peer_up.is_set():
            self._peer_up.clear()
            if not self.stop.is_set():
                self.peer_gone = True
            self._set_stop(f"{self.peer} process went away")

    @property
    def refused(self) -> int:
        """Stop requests dropped because they did not verify (forged or replayed)."""
        return 0 if self._opener is None else self._opener.forged + self._opener.replayed

    def _on_stop(self, sample: zenoh.Sample) -> None:
        payload: bytes | None = sample.payload.to_bytes()
        if self._opener is not None:
            payload = self._opener.open(payload)  # type: ignore[arg-type]
            if payload is None:
                return  # forged or replayed: counted by the opener, never obeyed
        try:
            reason = str(json.loads(payload).get("reason", "stop requested"))  # type: ignore[arg-type]
        except (ValueError, AttributeError):
            reason = "stop requested"
        self._set_stop(f"{self.peer} requested stop: {reason}")

    def _set_stop(self, reason: str) -> None:
        if not self.stop.is_set():
            self.stop_reason = reason
            self.stop.set()

    @property
    def peer_alive(self) -> bool:
        """Whether the peer's readiness token is currently present."""
        return self._peer_up.is_set()

    def announce(self) -> None:
        """Declare this side's readiness token (idempotent; :meth:`wait_for_peer` calls it)."""
        if self._token is None:
            self._token = self._session.liveliness().declare_token(self._keys.ready(self.role))

    def wait_for_peer(
        self, timeout: float = 10.0, publishers: Sequence[zenoh.Publisher] = ()
    ) -> None:
        """Announce readiness, block until the peer is up and matches ``publishers``, then warm
        the link up (see the class docstring).

        Parameters
        ----------
        timeout
            Longest wait [s] for the peer's token, for every subscriber match and for the
            peer's warm-up frame.
        publishers
            This side's hot publishers; each must be matched by a subscriber of the peer
            before the first message is sent on it.

        Raises
        ------
        TransportError
            ``"specimen process did not come up within 10 s on listen tcp/..."`` or, if it came
            up but never subscribed, which key is unmatched, or that it sent no warm-up frame.
        """
        check_positive(timeout, "handshake timeout")
        self.announce()
        deadline = time.monotonic() + timeout
        if not self._peer_up.wait(timeout):
            raise TransportError(
                f"{self.peer} process did not come up within {timeout:g} s on {self.where}"
            )
        for pub in (*publishers, self._warm_pub):
            if not wait_matched(pub, max(deadline - time.monotonic(), 0.0)):
                raise TransportError(
                    f"{self.peer} process is up but did not subscribe to '{pub.key_expr}' "
                    f"within {timeout:g} s on {self.where}"
                )
        if not self._warm_sent:  # once, however many slices the caller waits in
            self._warm_pub.put(bytes(WARMUP_BYTES))
            self._warm_sent = True
        if not self._warmed.wait(max(deadline - time.monotonic(), 0.0)):
            raise TransportError(
                f"{self.peer} process is up but sent no link warm-up frame within {timeout:g} s "
                f"on {self.where}"
            )

    def request_stop(self, reason: str = "done") -> None:
        """Ask the peer to stop (it sees ``"<role> requested stop: <reason>"``)."""
        payload = json.dumps({"reason": reason, "pid": os.getpid()}).encode()
        if self._sealer is not None:
            payload = self._sealer.seal(payload)
        # express at the hot path's priority: sent at once, so it cannot be overtaken by the
        # withdrawal of this side's token when the process ends right after (the peer would
        # then report "went away" instead of the reason)
        self._session.put(
            self._keys.stop,
            payload,
            congestion_control=zenoh.CongestionControl.BLOCK,
            priority=zenoh.Priority.REAL_TIME,
            express=True,
        )

    def close(self) -> None:
        """Withdraw the token and undeclare the subscribers and the warm-up publisher."""
        if self._token is not None:
            self._token.undeclare()
            self._token = None
        self._watch.undeclare()
        self._stop_sub.undeclare()
        self._warm_sub.undeclare()
        self._warm_pub.undeclare()

    def __enter__(self) -> Presence:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
