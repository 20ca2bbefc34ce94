"""The loop: the fixed-step RTHS coordinator (:mod:`rths.runtime.loop`) and its clocks
(:mod:`rths.runtime.clocks`: pacing, overruns, jitter).

May import: :mod:`rths.core`, the interfaces of ``plants`` and ``controllers``.  Never the wire,
the log, the configuration or an experiment: a link and a sink are handed to the loop.
"""
