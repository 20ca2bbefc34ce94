"""The log: MCAP recording and reading -- the log contract users and CI rely on.

:mod:`~rths.log.recorder` (the recorder fed off the loop thread), :mod:`~rths.log.schemas`
(topics and their JSON schemas), :mod:`~rths.log.contract` (the log contract's names),
:mod:`~rths.log.reader` (reading logs back), :mod:`~rths.log.recover`,
:mod:`~rths.log.replay` (republishing a log on zenoh), :mod:`~rths.log.live` (Foxglove), and
:mod:`rths.log.writer` (how the file gets written: the MCAP writer thread, or the same writer in a
process of its own for real-time runs).

May import: :mod:`rths.core`, :mod:`rths.wire` (the record codec; zenoh only for replay).
"""
