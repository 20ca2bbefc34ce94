"""Baseline compensators to compare against: no compensation and polynomial extrapolation over a
fixed delay (:mod:`~.extrapolation`), adaptive time series (:mod:`~.ats`, compiled step in
:mod:`~._ats_kernel`) and the vRTHS benchmark's PI + phase-lead sample controller
(:mod:`~.pi_lead`, compiled step in :mod:`~._pi_lead_kernel`)."""
