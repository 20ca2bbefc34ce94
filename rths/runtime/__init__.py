"""The loop: the fixed-step RTHS coordinator (:mod:`rths.runtime.loop`), its links
(:mod:`rths.runtime.links`), its clocks (:mod:`rths.runtime.clocks`: pacing, overruns, jitter),
the specimen side's command guard (:mod:`rths.runtime.guard`) and the ``fast`` clock's compiled
path (:mod:`rths.runtime.fastpath` driving :mod:`rths.runtime.fused_kernel`).

May import: :mod:`rths.core`, the interfaces of ``plants`` and ``controllers`` and, for the fused
kernel only, the compiled step kernels of the component families it fuses.  Never the wire,
the log, the configuration or an experiment: a link and a sink are handed to the loop.
"""
