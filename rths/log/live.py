"""Watch a run live in Foxglove: a WebSocket server speaking the Foxglove protocol
(``foxglove-sdk``), fed with the same JSON messages and JSON schemas the MCAP log gets.

``rths run SCENARIO --live [HOST:PORT]`` starts it; open Foxglove, connect to
``ws://HOST:PORT`` ("Foxglove WebSocket") and import the layout ``foxglove/rths_layout.json``
(target/command/measured, the synchronisation subspace, force-displacement, timing), which opens the
run's MCAP file just as well.

The loop hands the server the same row blocks it hands the recorder; a background thread encodes
them (:func:`rths.log.writer.rowjson.block_messages`: byte for byte the log's JSON) and logs them on
one Foxglove channel per topic, thinned to at most ``max_rate`` rows per second per topic (a plot
needs no more, and the viewer's bandwidth is not the loop's).  Nothing happens on the loop thread
but an enqueue.
"""

from __future__ import annotations

import math
import queue
import threading
import time
from collections.abc import Mapping
from typing import Any

from rths.core.errors import ConfigError, DataError
from rths.log.writer.rowjson import block_messages

__all__ = ["DEFAULT_LIVE", "LiveServer", "parse_where"]

#: Default ``--live`` address.
DEFAULT_LIVE = "127.0.0.1:8765"
#: Seconds between two drains of the queue.
POLL = 0.02


def parse_where(where: str) -> tuple[str, int]:
    """``"HOST:PORT"`` → ``(host, port)``.

    Parameters
    ----------
    where
        The address.

    Raises
    ------
    ConfigError
        If it is not a host and a port in 0..65535 (0: any free port).
    """
    host, _, port = where.rpartition(":")
    try:
        number = int(port)
    except ValueError:
        number = -1
    if not host or not 0 <= number < 65536:
        raise ConfigError(f"--live takes HOST:PORT, e.g. {DEFAULT_LIVE}; got {where!r}")
    return host, number


class LiveServer:
    """A Foxglove WebSocket server for one run.

    Use :meth:`start`; then :meth:`add_topic` and :meth:`put_block` (thread-safe, never block),
    :meth:`close` at the end.

    Parameters
    ----------
    server
        The running ``foxglove.WebSocketServer``.
    context
        Its ``foxglove.Context`` (channels are created in it).
    max_rate
        Largest rows per second logged per topic [Hz] (simulated time).
    """

    def __init__(self, server: Any, context: Any, max_rate: float) -> None:
        self.server = server
        self.context = context
        self.max_rate = max_rate
        self.port: int = int(server.port)
        self.sent = 0  #: messages logged to the viewer
        #: set once a viewer has subscribed to a topic (the SDK's ``on_subscribe``)
        self.subscribed = threading.Event()
        self._channels: dict[str, Any] = {}
        self._schemas: dict[str, Mapping[str, Any]] = {}
        self._next_ns: dict[str, int] = {}
        self._templates: dict[tuple[str, ...], bytes] = {}
        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name="rths-live", daemon=True)
        self._thread.start()

    @classmethod
    def start(cls, where: str = DEFAULT_LIVE, max_rate: float = 500.0) -> LiveServer:
        """Start serving on ``where`` (``HOST:PORT``; port 0 picks a free one).

        Parameters
        ----------
        where
            ``HOST:PORT`` to listen on.
        max_rate
            Largest rows per second logged per topic [Hz].

        Raises
        ------
        ConfigError
            If ``where`` is malformed or the port cannot be bound.
        """
        import foxglove

        host, port = parse_where(where)
        if not (isinstance(max_rate, int | float) and max_rate > 0):
            raise ConfigError(f"live max_rate must be positive [Hz]; got {max_rate!r}")
        from foxglove.websocket import ServerListener

        subscribed = threading.Event()

        class _Listener(ServerListener):
            def on_subscribe(self, client: Any, channel: Any) -> None:
                subscribed.set()

        context = foxglove.Context()
        try:
            server = foxglove.start_server(
                name="rths", host=host, port=port, context=context, server_listener=_Listener()
            )
        except Exception as exc:  # the SDK raises its own error types for a taken port
            raise ConfigError(f"cannot serve Foxglove on {where}: {exc}") from None
        live = cls(server, context, float(max_rate))
        live.subscribed = subscribed
        return live

    def add_topic(self, topic: str, schema: Mapping[str, Any]) -> None:
        """Advertise ``topic`` with its JSON schema (the MCAP log's).

        Parameters
        ----------
        topic
            Topic name, e.g. ``"rths/loop"``.
        schema
            Its JSON schema.
        """
        self._queue.put(("s", topic, schema))

    def put_block(self, topic: str, block: Any) -> None:
        """Queue a block of rows (the recorder's); returns at once.

        Parameters
        ----------
        topic
            Topic name.
        block
            A filled :class:`rths.core.channels.RowBlock` (not changed afterwards).
        """
        self._queue.put(("b", topic, block))

    def _channel(self, topic: str, block: Any = None) -> Any:
        import foxglove

        channel = self._channels.get(topic)
        if channel is None:
            schema = self._schemas.get(topic)
            if schema is None and block is not None:
                from rths.log.recorder import block_schema

                schema = block_schema(topic, block)
            channel = foxglove.Channel(topic, schema=dict(schema or {}), context=self.context)
            self._channels[topic] = channel
        return channel

    def _run(self) -> None:
        while True:
            time.sleep(POLL)
            while True:
                try:
                    item = self._queue.get_nowait()
                except queue.Empty:
                    break
                if item is None:
                    return
                try:
                    self._handle(item)
                except (DataError, ValueError, TypeError):  # a viewer problem never stops a run
                    continue

    def _handle(self, item: tuple[Any, ...]) -> None:
        if item[0] == "s":
            self._schemas[item[1]] = item[2]
            self._channel(item[1])
            return
        _, topic, block = item
        channel = self._channel(topic, block)
        step = math.floor(1e9 / self.max_rate)
        next_ns = self._next_ns.get(topic, 0)
        for _k, t, data, _ok in block_messages(block, self._templates):
            if t < next_ns:
                continue
            channel.log(data, log_time=t)
            self.sent += 1
            next_ns = t + step
        self._next_ns[topic] = next_ns

    def close(self) -> None:
        """Log what is queued, then stop the server."""
        self._queue.put(None)
        self._thread.join()
        self.server.stop()
