"""The wire: Eclipse Zenoh transport between the coordinator and the specimen process.

:mod:`~rths.wire.codec` (binary messages), :mod:`~rths.wire.transport` (sessions, run keys,
handshake), :mod:`~rths.wire.links` (lockstep and free-running links),
:mod:`~rths.wire.sync_link` (the synchronous realtime link), :mod:`~rths.wire.inbox`
(mailboxes), :mod:`~rths.wire.presence` (peer liveness), :mod:`~rths.wire.sidestreams` (log
records and live copies that cross the wire).

May import: :mod:`rths.core` and :mod:`rths.runtime` (the link protocol).  Plants know nothing of
it.
"""
