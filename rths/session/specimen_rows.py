"""The specimen's log rows that ride on its measurements (the ``realtime`` clock), gathered on
the coordinator into blocks for the recorder.

In real time the specimen process sends its lab's row for each step with the step's measurement
(:func:`rths.wire.codec.pack_reply`) instead of on a side stream, so no other thread of either
process wakes while the loop runs (see :mod:`rths.session.specimen`).  The link's client hands
the rows of every reply it reads -- on time or late -- to :meth:`SpecimenRows.add` on the loop
thread; a full block of :data:`BLOCK_ROWS` goes to the sink (the recorder's ``put_block``, which
only enqueues) as MCAP topic ``rths/specimen`` when the link's wait for the step's measurement
is over (:meth:`SpecimenRows.handover`), the rest at :meth:`SpecimenRows.flush`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from rths.core.channels import Channel, RowBlock
from rths.core.errors import DataError
from rths.wire.codec import Rows

__all__ = ["BLOCK_ROWS", "SpecimenRows"]

#: Rows per block handed to the sink.
BLOCK_ROWS = 256


class SpecimenRows:
    """Gather rows into blocks of :data:`BLOCK_ROWS` for ``sink(topic, block)``.

    Parameters
    ----------
    channels
        The lab's channels (:meth:`plants.lab.EmulatedLab.channels`: what each row holds).
    topic
        The MCAP topic (``rths/specimen``).
    sink
        ``sink(topic, block)``; the block is the sink's from then on.
    """

    def __init__(
        self,
        channels: Sequence[Channel],
        topic: str,
        sink: Callable[[str, RowBlock], None],
    ) -> None:
        self.channels = tuple(channels)
        self.topic, self.sink = topic, sink
        self.block = RowBlock(self.channels, BLOCK_ROWS)
        self.rows = 0  #: rows gathered so far
        self._ready: list[RowBlock] = []  # full blocks not handed over yet

    def add(self, rows: Rows) -> None:
        """Take the rows of one reply (their ``seq``, ``t_ns`` and values).

        Raises
        ------
        DataError
            If the rows do not have the lab's channel count.
        """
        seq, t_ns, values = rows
        if values.shape[1] != len(self.channels):
            raise DataError(
                f"specimen rows of {values.shape[1]} channels; the lab has {len(self.channels)}"
            )
        for j in range(seq.size):
            b = self.block
            i = b.count
            b.values[i] = values[j]
            b.seq[i], b.t_ns[i] = seq[j], t_ns[j]
            b.count = i + 1
            self.rows += 1
            if b.count == BLOCK_ROWS:
                self._ready.append(b)
                self.block = RowBlock(self.channels, BLOCK_ROWS)

    def handover(self) -> None:
        """Hand the full blocks to the sink (the link calls it when a step's wait for its
        measurement is over, not in the middle of it: the sink wakes the recorder's thread,
        which then takes its share of the interpreter lock in the step's idle time)."""
        for b in self._ready:
            self.sink(self.topic, b)
        self._ready.clear()

    def flush(self) -> None:
        """Hand over every row gathered (full blocks, then the rest)."""
        self.handover()
        if self.block.count:
            self.sink(self.topic, self.block)
            self.block = RowBlock(self.channels, BLOCK_ROWS)
