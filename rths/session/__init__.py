"""Sessions: running a scenario end to end on a clock.

:mod:`~rths.session.runner` (one run on ``fast``, ``lockstep`` or ``realtime``),
:mod:`~rths.session.zenoh_run` (the coordinator side over zenoh), :mod:`~rths.session.specimen`
(the specimen process), :mod:`~rths.session.mock` (the fully numerical run of a scenario),
:mod:`~rths.session.batch` (one fast run in process with no log: the unit of a campaign).

May import: everything below it -- config, log, wire, runtime, core, plants, controllers.
"""
