"""The log: MCAP recording and reading -- the log contract users and CI rely on.

:mod:`~rths.log.recorder` (topics, schemas, the recorder fed off the loop thread),
:mod:`~rths.log.mcap_writer` (the writer thread), :mod:`~rths.log.reader` (reading logs back),
:mod:`~rths.log.replay` (republishing a log on zenoh).

May import: :mod:`rths.core`, :mod:`rths.wire` (the record codec; zenoh only for replay).
"""
