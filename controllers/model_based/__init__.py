"""Model-based compensation (Phillips & Spencer 2013; S0 §5.2): the inverse of a low-order nominal
model as feedforward (:mod:`~.feedforward`), LQG feedback on the nominal model with an integral of
the tracking error (:mod:`~.lqg`, compiled step in :mod:`~._lqg_kernel`) and the two combined
(:mod:`~.ff_lqg`)."""
