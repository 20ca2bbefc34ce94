"""What a recording wrote: per-topic counts and the run's :class:`RecordingSummary`.

The writer (:mod:`rths.log.writer.mcap_writer`) keeps the counts;
:meth:`rths.log.recorder.Recorder.close` returns them; the same counts are written to the log as the
``rths.recording`` metadata record.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from rths.core.errors import RunFault

__all__ = ["COUNTS", "RecordingFailed", "RecordingSummary", "TopicStats"]

#: The per-topic counts, as fields of :class:`TopicStats` and keys of ``rths.recording``.
COUNTS = ("written", "missing", "reordered", "first_seq", "last_seq", "nonfinite", "rejected")


@dataclass(frozen=True, slots=True)
class TopicStats:
    """What was written on one topic.

    Attributes
    ----------
    written
        Messages written.
    missing
        Sequence numbers skipped (sum of the sizes of all gaps).
    reordered
        Messages whose sequence number was not above the previous one (repeats, reordering).
    first_seq, last_seq
        First and last sequence numbers seen (-1 if none).
    nonfinite
        Messages in which a NaN or infinity was written as ``null``.
    rejected
        Payloads from another process that were not valid log records (not written).
    """

    written: int = 0
    missing: int = 0
    reordered: int = 0
    first_seq: int = -1
    last_seq: int = -1
    nonfinite: int = 0
    rejected: int = 0

    @property
    def complete(self) -> bool:
        """No gap, no reordering, no rejected payload."""
        return self.missing == 0 and self.reordered == 0 and self.rejected == 0


@dataclass(frozen=True, slots=True)
class RecordingSummary:
    """Returned by :meth:`Recorder.close`: per-topic counts, events, largest queue backlog,
    messages lost after a failed write and what endangered the log (None: nothing).

    Attributes
    ----------
    path : pathlib.Path
        The MCAP file written.
    topics : Mapping[str, TopicStats]
        Per-topic counts, by topic name.
    events : int
        Number of events written.
    max_backlog : int
        Largest number of items queued for the writer thread at once (a row block counts as one).
    lost : int
        Messages that could not be written after a failed write (default 0).
    fault : str or None
        The message of what endangered the log (disk nearly full, a failed write); None
        (default) if nothing did.
    """

    path: Path
    topics: Mapping[str, TopicStats]
    events: int
    max_backlog: int
    lost: int = 0
    fault: str | None = None

    @property
    def complete(self) -> bool:
        """True if every topic is complete (no sample lost, repeated or rejected)."""
        return self.lost == 0 and all(s.complete for s in self.topics.values())


class RecordingFailed(RunFault):
    """The log could not be written to the end (a full disk, an I/O error); the file holds
    everything written before the failure and is readable."""
