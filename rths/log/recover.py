"""Rewrite an unfinished or damaged MCAP log as a finished one (``rths recover``).

A run killed with SIGKILL (or a machine that lost power) leaves its log without the MCAP footer
and summary, often followed by the zeros of the disk space the recorder had reserved; the plain
``mcap`` reader refuses such a file.  :func:`recover` reads it linearly
(:class:`rths.log.reader.LogScan`), keeps every whole record -- schemas, channels, messages,
metadata, attachments -- up to the cut, skips a chunk that fails to decompress or its CRC (and
counts it), and writes a new, finished log with a full summary section.  It adds two metadata
records: ``rths.recovered`` (what was read and dropped) and, when the cut cost the run its
``rths.summary``, one computed from the recovered ``rths/loop`` messages with ``stopped`` saying
where the record ends.  The source is never modified; the target is written to a temporary file
and renamed into place.
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from mcap.records import Attachment, Channel, Header, Message, Metadata, Schema
from mcap.writer import CompressionType, Writer

from rths.core.errors import DataError
from rths.log.reader import LogScan
from rths.metrics import summarize

__all__ = ["Recovery", "recover"]


@dataclass(frozen=True)
class Recovery:
    """What :func:`recover` did.

    Attributes
    ----------
    source, target
        The damaged log and the finished copy.
    finished
        The source already ended with its footer and had no bad chunk (nothing was lost).
    messages, chunks, bad_chunks, orphans
        Messages written, chunks read, chunks dropped (corrupt) and messages dropped because
        their channel was defined in a dropped chunk.
    bytes_read, size
        Where reading stopped and the source's size [B].
    last_time
        Log time of the last message recovered [s] (``nan`` if none).
    summary_added
        Whether an ``rths.summary`` was computed (the source had none).
    """

    source: Path
    target: Path
    finished: bool
    messages: int
    chunks: int
    bad_chunks: int
    orphans: int
    bytes_read: int
    size: int
    last_time: float
    summary_added: bool


class _Loop:
    """The ``rths/loop`` columns a summary needs, collected while copying."""

    def __init__(self) -> None:
        self.rows: list[tuple[float, float, float, float]] = []

    def add(self, data: bytes) -> None:
        try:
            row = json.loads(data)
            self.rows.append(
                (
                    float(row["t"]),
                    float(row["target"]),
                    float(row["measured"]),
                    float(row["force"]),
                )
            )
        except (ValueError, KeyError, TypeError):
            pass  # not the contract's record: it is copied, just not summarised

    def summary(self) -> dict[str, str]:
        t, target, measured, force = (np.asarray(c) for c in zip(*self.rows, strict=True))
        out = {"steps": str(t.size)}
        try:
            dt = float(np.median(np.diff(t)))
            metrics = summarize(target, measured, force, dt, max_delay=min(0.1, 0.25 * t[-1]))
            out.update({k: repr(v) for k, v in metrics.to_dict().items()})
        except (DataError, ValueError, ZeroDivisionError) as exc:
            out["notes"] = f"metrics not computed: {exc}"
        return out


def recover(source: str | os.PathLike[str], target: str | os.PathLike[str]) -> Recovery:
    """Copy every whole record of ``source`` into a finished log at ``target``.

    Parameters
    ----------
    source
        An MCAP log, finished or not.
    target
        Where to write the finished copy (replaced if it exists; not the source).

    Raises
    ------
    DataError
        If the source is not an MCAP log at all, or target and source are the same file.
    """
    src, dst = Path(source), Path(target)
    if dst.exists() and src.exists() and os.path.samefile(src, dst):
        raise DataError(f"recover writes a new file; --out must not be the log itself: '{dst}'")
    scan = LogScan(src)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{dst.name}.", dir=dst.parent)
    tmp = Path(tmp_name)
    schemas: dict[int, int] = {}
    channels: dict[int, tuple[int, str]] = {}
    names: set[str] = set()
    loop = _Loop()
    messages = orphans = 0
    last_ns = -1
    try:
        with os.fdopen(fd, "wb") as f:
            writer = Writer(f, compression=CompressionType.ZSTD)
            started = False
            for record in scan.records(skip_bad_chunks=True):
                if isinstance(record, Header):
                    writer.start(profile=record.profile, library=record.library)
                    started = True
                elif isinstance(record, Schema):
                    schemas[record.id] = writer.register_schema(
                        name=record.name, encoding=record.encoding, data=record.data
                    )
                elif isinstance(record, Channel):
                    channels[record.id] = (
                        writer.register_channel(
                            topic=record.topic,
                            message_encoding=record.message_encoding,
                            schema_id=schemas.get(record.schema_id, 0),
                            metadata=dict(record.metadata),
                        ),
                        record.topic,
                    )
                elif isinstance(record, Message):
                    if record.channel_id not in channels:
                        orphans += 1
                        continue
                    channel_id, topic = channels[record.channel_id]
                    writer.add_message(
                        channel_id, record.log_time, record.data, record.publish_time,
                        record.sequence,
                    )  # fmt: skip
                    messages += 1
                    last_ns = max(last_ns, record.log_time)
                    if topic == "rths/loop":
                        loop.add(record.data)
                elif isinstance(record, Metadata):
                    writer.add_metadata(record.name, dict(record.metadata))
                    names.add(record.name)
                elif isinstance(record, Attachment):
                    writer.add_attachment(
                        record.create_time, record.log_time, record.name, record.media_type,
                        record.data,
                    )  # fmt: skip
            if not started:
                raise DataError(f"'{src}' has no MCAP header: nothing to recover")
            finished = scan.complete and scan.bad_chunks == 0 and orphans == 0
            last_time = last_ns * 1e-9 if last_ns >= 0 else float("nan")
            summary_added = "rths.summary" not in names and bool(loop.rows)
            if summary_added:
                summary = loop.summary()
                summary["stopped"] = f"log cut off at t = {last_time:.6f} s (recovered)"
                writer.add_metadata("rths.summary", summary)
            writer.add_metadata(
                "rths.recovered",
                {
                    "source": str(src),
                    "source_finished": str(scan.complete).lower(),
                    "bytes_read": str(scan.stopped_at),
                    "source_size": str(scan.size),
                    "messages": str(messages),
                    "chunks": str(scan.chunks),
                    "bad_chunks": str(scan.bad_chunks),
                    "orphan_messages": str(orphans),
                },
            )
            writer.finish()
        os.replace(tmp, dst)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return Recovery(
        src,
        dst,
        finished,
        messages,
        scan.chunks,
        scan.bad_chunks,
        orphans,
        scan.stopped_at,
        scan.size,
        last_time,
        summary_added,
    )
