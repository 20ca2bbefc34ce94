"""Identification and selection: fit models globally, score them on held-out data, pick effects.

identify    variable projection; global grid over orders of magnitude, refinement, held-out
            scoring with per-record offsets
floors      the noise floor a model would leave if it were exact (per model)
calibrated  the actuator's effects judged against the root-by-root calibration of its
            nominal (a delay the common factors absorbed; a mis-calibration that is no effect)
pricing     the share of the remaining gap an effect closes and whether it buys its parameters;
            which of a set's model structures is taken
pruning     backward elimination of an effect a later step made redundant
decomposed  a fit's held-out residual against its channel's noise floor
coverage    a specimen gap that is only the identification records' coverage (calibrated on
            every record's time blocks, the baseline reaches the floor)
spectral    a rattling contact no replay follows, named by its held-out spectrum
selection   greedy addition of effects per channel; ``unexplained`` when they do not close
            half of a significant gap (nor, for the force, of its spectral distance)
"""

from rths.diagnose.search.floors import noise_floor
from rths.diagnose.search.identify import RIDGE, Fit, fit_model
from rths.diagnose.search.selection import (
    MIN_CLOSED,
    PRICE,
    Candidate,
    ChannelResult,
    held_parts,
    held_runs,
    select,
)

__all__ = [
    "MIN_CLOSED",
    "PRICE",
    "RIDGE",
    "Candidate",
    "ChannelResult",
    "Fit",
    "fit_model",
    "held_parts",
    "held_runs",
    "noise_floor",
    "select",
]
