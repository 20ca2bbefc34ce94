"""An ``mcap`` writer that appends a block of messages on one channel in one call (private).

``mcap``'s :meth:`mcap.writer.Writer.add_message` costs ~5 µs of pure Python per message (a
``Message`` record object, five ``struct.pack`` calls, a ``BytesIO`` seek/patch of the record
length, index and statistics bookkeeping); at two rows per step that alone held the fast clock's
writer thread below 25x real time at 2048 Hz.  :meth:`BlockWriter.add_messages` writes the same
Message records for a whole block at once: their 31-byte headers are packed by one numpy
structured array, the records joined into one ``bytes`` and appended to the current chunk with its
message index, time bounds and the file's statistics -- exactly what ``add_message`` would have
done row by row, so the file is **byte-identical** (``tests/test_block_writer.py`` holds the two
paths to that).  :meth:`BlockWriter.add_records` takes records already serialised with their headers
(:mod:`rths.log.writer.rowpack` packs a row block so in one compiled pass).  The message index of a
chunk is kept as arrays, a block at a time, and packed by numpy when the chunk is finished.  Chunk
boundaries fall where ``add_message`` puts them: the message that takes the chunk past
``chunk_size`` goes through ``add_message`` itself, which finishes the chunk.

With ``zstd_level``, chunks are compressed at that zstd level rather than ``mcap``'s fixed 3 (the
same frames, decompressed alike by every reader): ``mcap``'s chunk-finishing code with the level
as the only change (``tests/test_block_writer.py`` holds it to ``mcap``'s bytes at level 3).

Everything else -- header, schemas, channels, compression, chunk and message indexes, summary,
footer -- is ``mcap``'s own code.  The private surface used is two attributes of
:class:`mcap.writer.Writer` (its chunk builder, replaced by a subclass that adds
:meth:`_BlockChunkBuilder.add_records`, and its ``Statistics`` record); if a future ``mcap`` no
longer has them, :attr:`BlockWriter.batched` is False and both methods fall back to
``add_message`` per message (slower, same file).  A chosen zstd level further needs the writer's
stream, record builder, chunk index list, index types, CRC setting and ``__flush``; without any of
them chunks are compressed at ``mcap``'s level (:attr:`BlockWriter.zstd_level` says which).
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Sequence
from typing import Any

import numpy as np
import zstandard
from mcap._chunk_builder import ChunkBuilder
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import Chunk, ChunkIndex, Message, MessageIndex, Statistics
from mcap.writer import CompressionType, IndexType, Writer
from numpy.typing import NDArray

__all__ = ["BlockWriter"]

#: A Message record's opcode, length and fixed fields (MCAP spec, "Message (op=0x05)"): 31 bytes.
_HEADER = np.dtype(
    [
        ("opcode", "u1"),
        ("length", "<u8"),  # of the record's content: 22 bytes of fields + the data
        ("channel_id", "<u2"),
        ("sequence", "<u4"),
        ("log_time", "<u8"),
        ("publish_time", "<u8"),
    ]
)
_HEADER_SIZE = _HEADER.itemsize
_FIELDS = 22  # channel_id, sequence, log_time, publish_time [B]


_MESSAGE_FIELDS = struct.Struct("<HIQQ")  # channel_id, sequence, log_time, publish_time


class _MessageIndex(MessageIndex):
    """``mcap``'s MessageIndex record, its entries kept as arrays a block at a time and packed
    at once when the chunk is finished (``records`` still takes ``mcap``'s ``(log_time,
    offset)`` tuples, one per message added by ``add_message``)."""

    def __init__(self, channel_id: int) -> None:
        super().__init__(channel_id, [])
        self.blocks: list[NDArray[np.uint64]] = []

    def add_block(self, log_times: NDArray[np.int64], offsets: NDArray[np.int64]) -> None:
        """Append the entries of a block of messages (log times and offsets [ns, B])."""
        if self.records:  # the entries added one by one so far come first
            self.blocks.append(np.array(self.records, dtype="<u8"))
            self.records = []
        entries = np.empty((len(log_times), 2), dtype="<u8")
        entries[:, 0] = log_times
        entries[:, 1] = offsets
        self.blocks.append(entries)

    def write(self, stream: RecordBuilder) -> None:
        tail = np.array(self.records, dtype="<u8").reshape(-1, 2)
        data = np.concatenate([*self.blocks, tail]).tobytes()  # (log_time, offset) pairs
        stream.start_record(Opcode.MESSAGE_INDEX)
        stream.write2(self.channel_id)
        stream.write4(len(data))
        stream.write(data)
        stream.finish_record()


class _BlockChunkBuilder(ChunkBuilder):
    """``mcap``'s chunk builder plus :meth:`add_records`; its message indexes are
    :class:`_MessageIndex` (the rest is inherited unchanged)."""

    def add_message(self, message: Message) -> None:
        if message.channel_id not in self.message_indices:
            self.message_indices[message.channel_id] = _MessageIndex(message.channel_id)
        super().add_message(message)

    def add_records(
        self,
        channel_id: int,
        log_times: NDArray[np.int64],
        starts: NDArray[np.int64],
        records: bytes | memoryview,
    ) -> None:
        """Append Message records of one channel, as ``add_message`` would one by one.

        Parameters
        ----------
        channel_id
            Their channel.
        log_times
            Their log times [ns], in order.
        starts
            Offset of each record within ``records`` [B].
        records
            The records, serialised back to back.
        """
        lo, hi = int(log_times.min()), int(log_times.max())
        self.message_start_time = lo if self.num_messages == 0 else min(self.message_start_time, lo)
        self.message_end_time = max(self.message_end_time, hi)
        index = self.message_indices.get(channel_id)
        if not isinstance(index, _MessageIndex):  # none yet (or mcap's own: not expected)
            index = self.message_indices[channel_id] = _MessageIndex(channel_id)
        index.add_block(log_times, starts + self.record_writer.count)
        self.num_messages += len(log_times)
        self.record_writer.write(records)


class BlockWriter(Writer):
    """:class:`mcap.writer.Writer` with :meth:`add_messages` and :meth:`add_records` (see the
    module docstring).

    Parameters
    ----------
    output
        The stream (or file name) to write to.
    chunk_size
        Uncompressed bytes per chunk [B] (as for :class:`mcap.writer.Writer`).
    zstd_level
        zstd compression level of the chunks (with ``compression=CompressionType.ZSTD``);
        None (default): ``mcap``'s (3).
    **options
        Any other keyword of :class:`mcap.writer.Writer` (compression, indexes, ...).

    Attributes
    ----------
    batched : bool
        Whether :meth:`add_messages` takes the batched path (False: ``add_message`` per message,
        for an ``mcap`` whose writer no longer has the attributes this class relies on, or
        without chunking).
    zstd_level : int or None
        The level chunks are compressed at by this class (None: by ``mcap``, at its level).
    """

    def __init__(
        self,
        output: Any,
        chunk_size: int = 1024 * 1024,
        zstd_level: int | None = None,
        **options: Any,
    ) -> None:
        super().__init__(output, chunk_size=chunk_size, **options)
        self._chunk_limit = chunk_size
        builder = getattr(self, "_Writer__chunk_builder", None)
        stats = getattr(self, "_Writer__statistics", None)
        self._stats: Statistics | None = None
        self._chunks: _BlockChunkBuilder | None = None
        if type(builder) is ChunkBuilder and isinstance(stats, Statistics):
            self._chunks = _BlockChunkBuilder()
            self._stats = stats
            setattr(self, "_Writer__chunk_builder", self._chunks)  # its mangled name
        self.zstd_level: int | None = None
        self._compressor: zstandard.ZstdCompressor | None = None
        self._crcs = bool(options.get("enable_crcs", True))
        own = ("flush", "stream", "record_builder", "chunk_indices", "index_types")
        if (
            zstd_level is not None
            and options.get("compression", CompressionType.ZSTD) == CompressionType.ZSTD
            and self._chunks is not None
            and all(hasattr(self, f"_Writer__{name}") for name in own)
            and callable(getattr(self, "_Writer__finalize_chunk", None))
        ):
            self.zstd_level = zstd_level
            self._compressor = zstandard.ZstdCompressor(level=zstd_level)
            setattr(self, "_Writer__finalize_chunk", self._finalize_chunk)  # on this instance

    @property
    def batched(self) -> bool:
        """Whether :meth:`add_messages` takes the batched path (class docstring)."""
        return self._chunks is not None

    def add_messages(
        self,
        channel_id: int,
        sequences: Sequence[int] | NDArray[np.int64],
        log_times: Sequence[int] | NDArray[np.int64],
        publish_times: Sequence[int] | NDArray[np.int64],
        data: Sequence[bytes],
    ) -> None:
        """Add messages on one channel, in order: the file is the one ``add_message`` per
        message would write.

        Parameters
        ----------
        channel_id
            Their channel (registered).
        sequences
            Each message's sequence number, in ``[0, 2**32)``.
        log_times, publish_times
            Each message's log and publish time [ns], in ``[0, 2**63)``.
        data
            Each message's payload.

        Raises
        ------
        ValueError
            If the four sequences differ in length or a number is out of its field's range.
        """
        n = len(data)
        seq = np.asarray(sequences, dtype=np.int64)
        log = np.asarray(log_times, dtype=np.int64)
        pub = np.asarray(publish_times, dtype=np.int64)
        if not seq.shape == log.shape == pub.shape == (n,):
            raise ValueError(
                f"add_messages: {seq.shape}, {log.shape}, {pub.shape} numbers for {n} messages"
            )
        if n == 0:
            return
        if seq.min() < 0 or seq.max() > 0xFFFFFFFF or min(log.min(), pub.min()) < 0:
            raise ValueError("add_messages: a sequence number or time is out of range")
        if self._chunks is None:
            for k, t, p, d in zip(seq.tolist(), log.tolist(), pub.tolist(), data):
                self.add_message(channel_id, t, d, p, k)
            return
        sizes = np.fromiter(map(len, data), dtype=np.int64, count=n)
        head = np.empty(n, dtype=_HEADER)
        head["opcode"] = Opcode.MESSAGE
        head["length"] = sizes + _FIELDS
        head["channel_id"] = channel_id
        head["sequence"] = seq
        head["log_time"] = log
        head["publish_time"] = pub
        packed = head.tobytes()
        pieces: list[bytes] = [b""] * (2 * n)
        pieces[0::2] = [
            packed[i : i + _HEADER_SIZE] for i in range(0, n * _HEADER_SIZE, _HEADER_SIZE)
        ]
        pieces[1::2] = data
        ends = np.cumsum(sizes + _HEADER_SIZE)  # end of each record within the block [B]
        self.add_records(channel_id, log, b"".join(pieces), ends)

    def add_records(
        self,
        channel_id: int,
        log_times: NDArray[np.int64],
        records: bytes | memoryview,
        ends: NDArray[np.int64],
    ) -> None:
        """Add messages of one channel already serialised as Message records (opcode, length,
        fields and data, back to back; :mod:`rths.log.writer.rowpack`): the file is the one
        ``add_message`` per message would write.

        Parameters
        ----------
        channel_id
            Their channel (registered); the records must name it.
        log_times
            Each record's log time [ns], as in the record (int64, shape ``(n,)``).
        records
            The records.
        ends
            End of each record within ``records`` [B] (int64, shape ``(n,)``, increasing).
        """
        view = memoryview(records)
        n = len(ends)
        if self._chunks is None:
            start = 0
            for end in ends.tolist():
                self._add_one(view[start:end])
                start = end
            return
        start = 0
        while start < n:
            # add_message finishes the chunk after the first message that takes it past the limit
            before = int(ends[start - 1]) if start else 0
            room = self._chunk_limit - self._chunks.count + before
            last = max(int(np.searchsorted(ends, room, side="right")), start)
            stop = min(last, n)
            if stop > start:
                end = int(ends[stop - 1])
                self._count(channel_id, log_times[start:stop])
                self._chunks.add_records(
                    channel_id,
                    log_times[start:stop],
                    _starts(ends[start:stop] - before),
                    view[before:end],
                )
            if last < n:
                self._add_one(view[int(ends[last - 1]) if last else 0 : int(ends[last])])
            start = last + 1

    def _add_one(self, record: memoryview) -> None:
        """Add one serialised Message record through ``add_message``."""
        channel_id, sequence, log_time, publish_time = _MESSAGE_FIELDS.unpack_from(record, 9)
        data = bytes(record[_HEADER_SIZE:])
        self.add_message(channel_id, log_time, data, publish_time, sequence)

    def _finalize_chunk(self) -> None:
        """``mcap``'s ``Writer.__finalize_chunk`` (1.6), the chunk compressed at
        :attr:`zstd_level`."""
        chunks, stats, compressor = self._chunks, self._stats, self._compressor
        assert chunks is not None and stats is not None and compressor is not None
        if chunks.num_messages == 0:
            return
        flush = getattr(self, "_Writer__flush")
        stream = getattr(self, "_Writer__stream")
        records: RecordBuilder = getattr(self, "_Writer__record_builder")
        stats.chunk_count += 1
        chunk_data = chunks.end()
        compressed = compressor.compress(chunk_data)
        chunk = Chunk(
            compression="zstd",
            data=compressed,
            message_start_time=chunks.message_start_time,
            message_end_time=chunks.message_end_time,
            uncompressed_crc=zlib.crc32(chunk_data) if self._crcs else 0,
            uncompressed_size=len(chunk_data),
        )
        flush()
        chunk_start = stream.tell()
        chunk.write(records)
        index = ChunkIndex(
            message_start_time=chunk.message_start_time,
            message_end_time=chunk.message_end_time,
            chunk_start_offset=chunk_start,
            chunk_length=records.count,
            message_index_offsets={},
            message_index_length=0,
            compression=chunk.compression,
            compressed_size=len(compressed),
            uncompressed_size=chunk.uncompressed_size,
        )
        flush()
        index_start = stream.tell()
        if getattr(self, "_Writer__index_types") & IndexType.MESSAGE:
            for channel_id, entries in chunks.message_indices.items():
                index.message_index_offsets[channel_id] = index_start + records.count
                entries.write(records)
        index.message_index_length = records.count
        flush()
        getattr(self, "_Writer__chunk_indices").append(index)
        chunks.reset()

    def _count(self, channel_id: int, times: NDArray[np.int64]) -> None:
        """Count ``len(times)`` messages of ``channel_id`` at ``times`` [ns] in the file's
        statistics, as ``add_message`` does."""
        assert self._stats is not None
        count = len(times)
        stats = self._stats
        lo, hi = int(times.min()), int(times.max())
        stats.message_start_time = (
            lo if stats.message_count == 0 else min(stats.message_start_time, lo)
        )
        stats.message_end_time = max(stats.message_end_time, hi)
        stats.channel_message_counts[channel_id] += count
        stats.message_count += count


def _starts(ends: NDArray[np.int64]) -> NDArray[np.int64]:
    """Start of each record from the ends [B] (the first at 0)."""
    starts = np.empty_like(ends)
    starts[0] = 0
    starts[1:] = ends[:-1]
    return starts
