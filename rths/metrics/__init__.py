"""Tracking-performance metrics of an RTHS record (pure functions; may import rths.core only).

Pure functions of uniformly sampled records: the *target* displacement ``x_t`` [m] the numerical
substructure asked for, the *measured* displacement ``x_m`` [m] of the specimen end (both shape
``(n,)``, ``n >= MIN_SAMPLES``), the specimen restoring *force* ``F`` [N] and the sampling step
``dt`` [s].  Ratios are fractions (0.0113, not 1.13 %).

* sync-subspace RMSE = J2 = ``RMS(x_m - x_t) / RMS(x_t)`` [-] (S0 reports 1.13 %, S0 Fig. 33)
* J1 = delay of ``x_m`` behind ``x_t`` [s] from the cross-correlation peak
* J3 = ``max|x_m - x_t| / max|x_t|`` [-]
* tracking indicator = signed area enclosed in the synchronisation subspace plot [m^2]
* frequency evaluation index = weighted spectrum ratio -> amplitude ratio [-], delay [s]
* energy error = ``int F (dx_m/dt - dx_t/dt) dt`` [J]
* damping ratios and frequencies of the modes in a free decay (:func:`free_decay`, matrix pencil)

The vRTHS benchmark's own criteria J1-J9, exactly as its ``F4_evaluation.m`` computes them (std
instead of RMS, integer lags 0-49, rounding, percent), are in :mod:`rths.metrics.vrths`; they are
reported beside these under upper-case names (``J1`` ... ``J9``).

References
----------
Silva, Gomez, Maghareh, Dyke & Spencer (2020), "Benchmark control problem for real-time hybrid
simulation", Mech. Syst. Signal Process. 135, 106381 (J1-J3).
Mercan & Ricles (2007), Earthquake Eng. Struct. Dyn. 36(11), 1523-1543 (tracking indicator).
Guo, Chen, Xu & Sanchez (2014), Smart Mater. Struct. 23, 045042 (frequency evaluation index).
Mosqueda, Stojadinovic & Mahin (2007), J. Struct. Eng. 133(8), 1100-1108 (energy error).
"""

from rths.metrics._records import MIN_SAMPLES
from rths.metrics.decay import DecayMode, free_decay
from rths.metrics.indicators import (
    FrequencyEvaluation,
    energy_error,
    energy_error_ratio,
    frequency_evaluation_index,
    tracking_indicator,
)
from rths.metrics.summary import TrackingSummary, summarize
from rths.metrics.tracking import (
    DEFAULT_MAX_DELAY,
    normalised_peak_error,
    normalised_rms_error,
    sync_subspace_rmse,
    tracking_delay,
)

__all__ = [
    "DEFAULT_MAX_DELAY",
    "MIN_SAMPLES",
    "DecayMode",
    "FrequencyEvaluation",
    "TrackingSummary",
    "energy_error",
    "energy_error_ratio",
    "free_decay",
    "frequency_evaluation_index",
    "normalised_peak_error",
    "normalised_rms_error",
    "summarize",
    "sync_subspace_rmse",
    "tracking_delay",
    "tracking_indicator",
]
