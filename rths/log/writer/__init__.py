"""How a log file gets written: the MCAP writer behind :class:`rths.log.recorder.Recorder`.

:mod:`~rths.log.writer.mcap_writer` (the writer thread: JSON rows into zstd chunks, counts,
finishing the file), :mod:`~rths.log.writer.block_writer` (``mcap``'s writer with a batched path:
a block of rows in one call, the same bytes), :mod:`~rths.log.writer.rowjson` (rows and messages
as JSON bytes), :mod:`~rths.log.writer.rowpack` (a row block packed into Message records by one
numba kernel: the in-process writer's path, the same bytes),
:mod:`~rths.log.writer.summary` (what a recording wrote), :mod:`~rths.log.writer.logfile`
(disk-space reserve, a readable end after a failed write), and the same writer in a process of
its own at ordinary priority for real-time runs: :mod:`~rths.log.writer.writer_process` (the
coordinator's side) and :mod:`~rths.log.writer.writer_child` (the child, ``python -m``).

May import: :mod:`rths.core`, :mod:`rths.wire.codec` (the record codec), the schemas of
:mod:`rths.log.schemas`; numba only in :mod:`~rths.log.writer.rowpack`; never zenoh.
"""
