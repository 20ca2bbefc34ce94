"""A block of rows packed into MCAP Message records by one numba kernel (the in-process writer).

:func:`rths.log.writer.rowjson.block_json` gives each row of a
:class:`rths.core.channels.RowBlock` as its own ``bytes`` (``{"seq": k, <channel>: value, ...}``)
and :meth:`rths.log.writer.block_writer.BlockWriter.add_messages` then heads each with its
31-byte Message record header: splitting ``orjson``'s output into one ``bytes`` per number and
formatting every row costs ~2.5 µs of interpreted work per row, more than the fast clock's loop
step.  :func:`block_records` writes the same bytes -- the records of the whole block back to
back, each the header and the row's JSON -- in one compiled pass over ``orjson``'s output: the
numbers are still formatted by ``orjson`` (shortest round trip, ``null`` for a non-finite value),
the kernel only copies them between the channel names.  The kernel releases the interpreter lock.

It is used by the writer thread of the process that runs the loop
(:class:`rths.log.writer.mcap_writer.WriterThread` with ``compiled=True``), which has numba loaded
anyway; the writer process of real-time runs keeps the interpreted path, so that it starts
without numba.  ``tests/test_block_writer.py`` holds the two paths to the same file.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import orjson
from numba import njit
from numpy.typing import NDArray

__all__ = ["HEADER_SIZE", "RowPacker", "block_records"]

#: Bytes of a Message record before its data: opcode, length, channel, sequence, two times.
HEADER_SIZE = 31
_SEQ_DIGITS = 20  # the longest decimal int64
_OPEN = np.frombuffer(b'{"seq":', dtype=np.uint8)


@njit(cache=True, nogil=True)
def _pack(
    numbers: NDArray[np.uint8],
    seq: NDArray[np.int64],
    t_ns: NDArray[np.int64],
    channel_id: int,
    opening: NDArray[np.uint8],
    keys: NDArray[np.uint8],
    key_ends: NDArray[np.int64],
    out: NDArray[np.uint8],
    ends: NDArray[np.int64],
) -> int:
    """Write the Message records of ``len(seq)`` rows into ``out``; return the bytes written.

    ``numbers`` is ``orjson``'s ``[[a,b,...],[c,d,...],...]`` of the rows' values; ``keys`` the
    concatenated ``,"<name>":`` of the channels, ``key_ends`` where each ends; ``ends[i]`` gets
    the end of record ``i`` in ``out``.
    """
    digits = np.empty(_SEQ_DIGITS, dtype=np.uint8)
    p = 2  # past "[["
    o = 0
    for i in range(seq.size):
        start = o
        out[o] = 0x05  # Opcode.MESSAGE; the length follows once known
        o += 9
        out[o] = channel_id & 0xFF
        out[o + 1] = (channel_id >> 8) & 0xFF
        o += 2
        k = seq[i] & 0xFFFFFFFF
        for b in range(4):
            out[o + b] = (k >> (8 * b)) & 0xFF
        o += 4
        t = t_ns[i]
        for b in range(8):
            out[o + b] = (t >> (8 * b)) & 0xFF
            out[o + 8 + b] = (t >> (8 * b)) & 0xFF
        o += 16
        for b in range(opening.size):
            out[o + b] = opening[b]
        o += opening.size
        k, d = seq[i], 0
        while True:  # the row's step counter in decimal (>= 0)
            digits[d] = 48 + k % 10
            d += 1
            k //= 10
            if k == 0:
                break
        for b in range(d):
            out[o + b] = digits[d - 1 - b]
        o += d
        q = 0
        for j in range(key_ends.size):
            e = key_ends[j]
            out[o : o + e - q] = keys[q:e]
            o += e - q
            q = e
            c = numbers[p]
            while c != 44 and c != 93:  # up to the "," or "]" after the number
                out[o] = c
                o += 1
                p += 1
                c = numbers[p]
            p += 1
        p += 2  # past ",[" between two rows
        out[o] = 125  # "}"
        o += 1
        length = o - start - 9
        for b in range(8):
            out[start + 1 + b] = (length >> (8 * b)) & 0xFF
        ends[i] = o
    return o


class RowPacker:
    """Packs row blocks into Message records (:func:`block_records`), keeping each channel
    list's names and a scratch buffer between calls."""

    def __init__(self) -> None:
        self._keys: dict[tuple[str, ...], tuple[NDArray[np.uint8], NDArray[np.int64]]] = {}
        self._out = np.empty(0, dtype=np.uint8)

    def pack(self, block: Any, channel_id: int) -> tuple[memoryview, NDArray[np.int64], int] | None:
        """The block's rows as records (:func:`block_records`); None when it has no channels
        (the interpreted path writes those).

        The returned view is into a buffer the next call overwrites.

        Raises
        ------
        ValueError
            If a row's step counter or log time is negative.
        """
        n = block.count
        names = block.names
        if not names or not n:
            return None
        if min(block.seq[:n].min(), block.t_ns[:n].min()) < 0:
            raise ValueError("a row's step counter or log time is negative")
        keys = self._keys.get(names)
        if keys is None:
            pieces = [f',"{name}":'.encode() for name in names]
            keys = self._keys[names] = (
                np.frombuffer(b"".join(pieces), dtype=np.uint8),
                np.cumsum([len(p) for p in pieces]).astype(np.int64),
            )
        values = np.ascontiguousarray(block.values[:n])
        numbers = orjson.dumps(values, option=orjson.OPT_SERIALIZE_NUMPY)
        size = len(numbers) + n * (HEADER_SIZE + _OPEN.size + _SEQ_DIGITS + 1 + keys[0].size)
        if self._out.size < size:
            self._out = np.empty(size, dtype=np.uint8)
        seq = np.ascontiguousarray(block.seq[:n], dtype=np.int64)
        t_ns = np.ascontiguousarray(block.t_ns[:n], dtype=np.int64)
        ends = np.empty(n, dtype=np.int64)
        used = _pack(
            np.frombuffer(numbers, dtype=np.uint8), seq, t_ns, channel_id, _OPEN,
            keys[0], keys[1], self._out, ends,
        )  # fmt: skip
        nonfinite = n - int(np.isfinite(values).all(axis=1).sum())
        return self._out.data[:used], ends, nonfinite


def block_records(block: Any, channel_id: int) -> tuple[bytes, NDArray[np.int64], int]:
    """The filled rows of a :class:`rths.core.channels.RowBlock` as MCAP Message records.

    Record ``i`` is the row's Message record on ``channel_id``: sequence ``seq & 0xFFFFFFFF``,
    log and publish time ``t_ns`` [ns], data ``{"seq": k, <channel>: value, ...}`` -- the bytes
    :func:`rths.log.writer.rowjson.block_json` gives, ``null`` for a non-finite value.

    Parameters
    ----------
    block
        A :class:`rths.core.channels.RowBlock` with at least one channel and one row.
    channel_id
        The records' channel.

    Returns
    -------
    records : bytes
        The records, back to back.
    ends : numpy.ndarray
        End of each record within ``records`` [B] (int64, shape ``(count,)``).
    nonfinite : int
        Rows holding a NaN or an infinity.

    Raises
    ------
    ValueError
        If the block has no channel or no row, or a negative step counter or log time.
    """
    packed = RowPacker().pack(block, channel_id)
    if packed is None:
        raise ValueError("block_records: a block with no channels or no rows")
    view, ends, nonfinite = packed
    return bytes(view), ends, nonfinite
