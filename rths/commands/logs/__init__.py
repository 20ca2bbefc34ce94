"""Sub-commands that read a recorded run's MCAP log: ``report``, ``check``, ``diagnose``,
``replay`` and ``recover``."""
