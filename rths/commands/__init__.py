"""Sub-commands of the ``rths`` CLI, one module each, grouped by concern: a run (``run``,
``specimen``) and the references (``kinds``, ``damping``) here, what reads a log in :mod:`~.logs`,
campaigns in :mod:`~.campaigns`.  :mod:`rths.cli` discovers them in every sub-package; modules
whose name starts with ``_`` are helpers, not commands."""
