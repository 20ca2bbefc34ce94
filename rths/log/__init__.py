"""The log: MCAP recording and reading -- the log contract users and CI rely on.

:mod:`~rths.log.recorder` (the recorder fed off the loop thread), :mod:`~rths.log.schemas`
(topics and their JSON schemas), :mod:`~rths.log.rowjson` (rows and messages as JSON bytes),
:mod:`~rths.log.mcap_writer` (the writer thread), :mod:`~rths.log.writer_process` and
:mod:`~rths.log.writer_child` (the same writer in a process of its own at ordinary priority,
for real-time runs), :mod:`~rths.log.summary` (what a recording wrote),
:mod:`~rths.log.logfile` (disk-space reserve, a readable end after a failed write),
:mod:`~rths.log.reader` (reading logs back), :mod:`~rths.log.recover`,
:mod:`~rths.log.replay` (republishing a log on zenoh), :mod:`~rths.log.live` (Foxglove).

May import: :mod:`rths.core`, :mod:`rths.wire` (the record codec; zenoh only for replay).
"""
