"""Replay a recorded run on zenoh at its recorded pace (``rths replay``).

Records are published on the keys a live run uses, as :class:`rths.wire.codec.LogRecord` s: the loop
record (MCAP topic ``rths/loop``) on ``rths/<run-id>/loop``, the other streams (e.g.
``rths/specimen``) on ``rths/<run-id>/log/<stream>``; so a monitor written against a live run works
unchanged on a replay.  Pacing keeps the recorded
``log_time`` spacing divided by ``speed`` on the monotonic clock.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path

from rths.core.errors import DataError
from rths.log.reader import iter_messages, list_topics, read_loop, read_metadata
from rths.wire.codec import LogRecord
from rths.wire.transport import RunKeys, ZenohEndpoints, new_run_id, open_session

__all__ = ["paced", "prepare", "replay", "replay_records"]

DEFAULT_TOPICS = ("rths/loop", "rths/specimen")


def replay_records(path: Path, topics: Sequence[str]) -> list[tuple[str, int, dict]]:
    """``(topic, log_time_ns, message)`` of ``topics`` in log-time order (a truncated log is read
    up to its cut).

    Parameters
    ----------
    path : pathlib.Path
        The MCAP log.
    topics : Sequence[str]
        Topics to read, e.g. ``("rths/loop",)``.

    Raises
    ------
    DataError
        If a message is not a JSON object.
    """
    records = []
    for topic, log_time, data in iter_messages(path, topics):
        try:
            message = json.loads(data)
        except ValueError:
            message = None
        if not isinstance(message, dict):
            raise DataError(f"'{path}': a message on {topic!r} is not a JSON object")
        records.append((topic, log_time, message))
    records.sort(key=lambda r: r[1])  # stable: streams stay in their own order at equal times
    return records


def prepare(
    path: Path, topics: Sequence[str] | None = None
) -> tuple[list[str], list[tuple[str, int, dict]], str | None]:
    """Check a log before anything is published: the topics to replay (default ``rths/loop``
    and ``rths/specimen`` when present), their records (:func:`replay_records`; ``rths/loop``
    must also keep the log contract, :func:`rths.log.reader.read_loop`) and the recorded run id.

    Parameters
    ----------
    path : pathlib.Path
        The MCAP log.
    topics : Sequence[str] or None
        Topics to replay; None or empty (default): ``rths/loop`` and ``rths/specimen``, those
        present.

    Raises
    ------
    DataError
        If a topic is missing or a record is unusable.
    """
    available = list_topics(path)
    wanted = list(topics) if topics else [t for t in DEFAULT_TOPICS if t in available]
    missing = [t for t in wanted if t not in available]
    if missing or not wanted:
        raise DataError(
            f"'{path}' has no topic {missing[0] if missing else 'rths/loop'!r}; "
            f"it has {sorted(available)}"
        )
    if "rths/loop" in wanted:
        read_loop(path)
    recorded = read_metadata(path).get("rths", {}).get("run_id")
    return wanted, replay_records(path, wanted), recorded


def paced(
    records: Iterable[tuple[str, int, dict]],
    speed: float,
    now_ns: Callable[[], int] = time.monotonic_ns,
    sleep: Callable[[float], None] = time.sleep,
) -> Iterator[tuple[str, int, dict]]:
    """Yield ``(topic, log_time_ns, message)`` no earlier than its recorded time divided by
    ``speed`` after the first one (clock and sleep injectable for tests).

    Parameters
    ----------
    records : Iterable[tuple[str, int, dict]]
        ``(topic, log_time_ns, message)`` in log-time order; ``log_time_ns`` [ns].
    speed : float
        Replay speed [-], > 0 (checked by the caller): 1 is the recorded pace, 2 twice as fast.
    now_ns : Callable[[], int]
        Monotonic clock [ns] (default :func:`time.monotonic_ns`).
    sleep : Callable[[float], None]
        Waits the given time [s] (default :func:`time.sleep`).
    """
    start: int | None = None
    first = 0
    for topic, log_time, message in records:
        if start is None:
            start, first = now_ns(), log_time
        pause = start + round((log_time - first) / speed) - now_ns()
        if pause > 0:
            sleep(pause * 1e-9)
        yield topic, log_time, message


def replay(
    path: Path,
    endpoints: ZenohEndpoints,
    *,
    speed: float = 1.0,
    run_id: str | None = None,
    topics: Sequence[str] | None = None,
    wait: float = 0.0,
) -> int:
    """Publish the records of ``path``; return how many were published.

    Parameters
    ----------
    path
        MCAP log written by ``rths run``.
    endpoints
        zenoh endpoints of this publisher.
    speed
        Pace multiplier (> 0).
    run_id
        Key prefix ``rths/<run_id>/``; default the recorded run id (or a new one).
    topics
        MCAP topics to replay (default ``rths/loop`` and ``rths/specimen`` when present).
    wait
        Seconds to wait before publishing (for subscribers to connect).
    """
    if not (speed > 0 and wait >= 0):
        raise DataError(f"replay needs speed > 0 and wait >= 0; got speed={speed!r}, wait={wait!r}")
    wanted, records, recorded = prepare(path, topics)
    keys = RunKeys(run_id or recorded or new_run_id())
    count = 0
    with open_session(endpoints) as session:
        publishers = {
            t: session.declare_publisher(
                keys.loop if t == "rths/loop" else keys.log(t.removeprefix("rths/"))
            )
            for t in wanted
        }
        seqs = dict.fromkeys(wanted, 0)
        time.sleep(wait)
        for topic, log_time, message in paced(records, speed):
            publishers[topic].put(LogRecord(seqs[topic], log_time, message).encode())
            seqs[topic] += 1
            count += 1
        for pub in publishers.values():
            pub.undeclare()
    return count
