"""The file under an MCAP log: disk space reserved ahead of the data, and a readable end after
a write failed (private to :mod:`rths.log.writer.mcap_writer`).

A full disk must not cost the log.  :class:`LogFile` keeps :data:`RESERVE` bytes allocated past
the end of the data (``posix_fallocate``), so the writes of a run never need new space; when the
reserve can no longer be renewed, or less than another reserve is free on the disk (another
process may be filling it), the disk is *nearly* full and :attr:`LogFile.low_space` tells the
recorder to have the run stopped, while the reserve still holds the last seconds, the summary
metadata and the MCAP footer.  Should a write fail anyway (no ``fallocate`` on this file system,
an I/O error), :meth:`LogFile.close_salvaged` cuts the file back to the end of the last whole
write -- every chunk before it intact -- and ends it with a minimal MCAP tail (metadata,
``DataEnd``, a ``Footer`` without summary section and the magic), which the plain ``mcap``
reader reads linearly.  The reserve shows as zero bytes past the data while the file is open;
:meth:`LogFile.close_finished` trims them, and a killed run leaves them for ``rths recover``.
"""

from __future__ import annotations

import errno
import math
import os
import time
from collections.abc import Mapping
from pathlib import Path

from mcap.data_stream import RecordBuilder
from mcap.records import DataEnd, Footer, Metadata
from mcap.stream_reader import MAGIC_SIZE

__all__ = ["CHECK_EVERY", "RESERVE", "LogFile"]

#: Bytes kept allocated past the end of the data [B]: seconds of a 2 kHz run's log plus the
#: summary section, renewed when half of it is used.
RESERVE = 8 << 20
#: Seconds between two checks of the disk's free space.
CHECK_EVERY = 0.5
_MAGIC = b"\x89MCAP0\r\n"
_NO_SPACE = (errno.ENOSPC, errno.EDQUOT)
assert len(_MAGIC) == MAGIC_SIZE


class LogFile:
    """Binary output stream for ``mcap.writer.Writer`` (see the module docstring).

    Parameters
    ----------
    path
        File to create (or overwrite).
    reserve
        Bytes to keep allocated past the data (0: none).

    Raises
    ------
    OSError
        If the file cannot be created, or the first reserve cannot be allocated because the
        disk is full (``errno.ENOSPC``).
    """

    #: The system calls, as attributes so that a test can make them fail (a full disk).
    os_write = staticmethod(os.write)
    os_fallocate = staticmethod(os.posix_fallocate)

    def __init__(self, path: str | os.PathLike[str], reserve: int = RESERVE) -> None:
        self.path = Path(path)
        self._fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o666)
        self.pos = 0  #: bytes written [B]
        self.good = 0  #: end of the last whole write [B]: a record boundary
        self.allocated = 0  #: end of the reserved space [B]
        self.reserve = reserve
        self.low_space = False  #: the reserve could not be renewed: stop writing soon
        self.error: OSError | None = None  #: the write that failed
        self._checked = -math.inf
        try:
            self.renew()
        except BaseException:
            os.close(self._fd)
            raise
        if self.low_space:
            os.close(self._fd)
            self.path.unlink(missing_ok=True)
            raise OSError(
                errno.ENOSPC,
                f"not enough free space for the log's {reserve >> 20} MiB reserve",
                str(self.path),
            )

    # ------------------------------------------------------------------ stream protocol
    def write(self, data: bytes | bytearray | memoryview) -> int:
        """Write all of ``data`` at the end; a failure is kept in :attr:`error` and raised.

        Parameters
        ----------
        data
            Bytes of whole MCAP records (the writer hands over whole records per call).
        """
        view = memoryview(data)
        try:
            while view:
                n = self.os_write(self._fd, view)
                self.pos += n
                view = view[n:]
        except OSError as exc:
            self.error = self.error or exc
            raise
        self.good = self.pos
        return len(data)

    def tell(self) -> int:
        """Bytes written so far."""
        return self.pos

    def flush(self) -> None:
        """Nothing to do: every write goes straight to the operating system."""

    # ------------------------------------------------------------------ space
    def free_space(self) -> int:
        """Bytes free for this file's folder (what an unprivileged writer may still use)."""
        st = os.statvfs(self.path.parent)
        return st.f_bavail * st.f_frsize

    def renew(self) -> bool:
        """Extend the reserve to :attr:`reserve` bytes past the data when half of it is used,
        and check (every :data:`CHECK_EVERY` seconds) that another reserve's worth is still free
        on the disk -- which also notices another process filling it.

        Returns False (and sets :attr:`low_space`) when the disk is nearly full; a file system
        without ``fallocate`` disables the reserve.
        """
        if self.reserve <= 0 or self.low_space:
            return not self.low_space
        now = time.monotonic()
        if now - self._checked >= CHECK_EVERY:
            self._checked = now
            if self.free_space() < self.reserve:
                self.low_space = True
                return False
        if self.allocated - self.pos > self.reserve // 2:
            return True
        end = self.pos + self.reserve
        try:
            self.os_fallocate(self._fd, self.allocated, end - self.allocated)
        except OSError as exc:
            if exc.errno in _NO_SPACE:
                self.low_space = True
                return False
            self.reserve = 0  # EOPNOTSUPP, EINVAL: no reserve on this file system
            return True
        self.allocated = end
        return True

    # ------------------------------------------------------------------ closing
    def close_finished(self) -> None:
        """Trim the reserve and close (the writer has written its footer)."""
        try:
            os.ftruncate(self._fd, self.pos)
        finally:
            os.close(self._fd)

    def close_salvaged(self, metadata: Mapping[str, Mapping[str, str]]) -> None:
        """End the file readably after :attr:`error`: cut it back to the last whole write and
        write ``metadata``, ``DataEnd``, an index-less ``Footer`` and the magic there (without
        the metadata if even that does not fit).  Never raises.

        Parameters
        ----------
        metadata
            ``{record name: {key: value}}`` to write before the footer.
        """
        start = self.good
        try:
            for tail in (_tail(metadata), _tail({})):
                # the tail lands where the failed write or the reserve already holds blocks
                os.lseek(self._fd, start, os.SEEK_SET)
                self.pos = self.good = start
                try:
                    self.write(tail)
                    break
                except OSError:
                    continue
            os.ftruncate(self._fd, self.good)
        except OSError:
            pass
        finally:
            os.close(self._fd)


def _tail(metadata: Mapping[str, Mapping[str, str]]) -> bytes:
    """Metadata records, ``DataEnd``, a summary-less ``Footer`` and the closing magic."""
    builder = RecordBuilder()
    for name, data in metadata.items():
        Metadata(name=name, metadata=dict(data)).write(builder)
    DataEnd(data_section_crc=0).write(builder)
    Footer(summary_start=0, summary_offset_start=0, summary_crc=0).write(builder)
    return bytes(builder.end()) + _MAGIC
