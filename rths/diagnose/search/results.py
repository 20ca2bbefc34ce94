"""What the selection of :mod:`rths.diagnose.search.selection` returns: every candidate model
tried on a channel with its held-out scores, and the channel's result (baseline, decomposition,
selected effects, verdict); and the held-out samples of a channel's records.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from rths.diagnose.channels.channel import Channel
from rths.diagnose.residuals import Decomposition
from rths.diagnose.search.identify import Fit

__all__ = ["Candidate", "ChannelResult", "held_parts", "held_runs"]


@dataclass(frozen=True)
class Candidate:
    """A model tried on a channel, scored on held-out data.

    Attributes
    ----------
    fit
        The identified model.
    floor
        Its held-out noise floor [unit^2].
    closed
        Share of the channel's reducible gap it closes (``rho``).
    gain
        Share of the then remaining gap it closed when tried as the next addition.
    accepted
        Whether the selection took it.
    physical
        Whether its parameters are physical.
    """

    fit: Fit = field(repr=False)
    floor: float
    closed: float
    gain: float
    accepted: bool
    physical: bool

    @property
    def name(self) -> str:
        """The model's name (its effects joined by ``+``)."""
        return self.fit.name


@dataclass(frozen=True)
class ChannelResult:
    """One channel's baseline, decomposition and selected effects.

    Attributes
    ----------
    channel
        The channel (its records' segments, noise levels and nominal).
    baseline
        The re-calibrated nominal's fit.
    floor_mse
        Noise floor of the held-out residual's mean square [unit^2].
    decomposition
        Where the baseline's residual lies: significance, band, phase of the cycle.
    candidates
        Every candidate model tried, with its held-out scores.
    effects
        The selected effects, in the order they were added.
    final
        The fit of the baseline with the selected effects.
    closed
        Share of the reducible held-out gap the selected effects close [-].
    verdict
        The channel's verdict: its first effect, ``none`` or ``unexplained``.
    resolution_mse
        Held-out mean square a one-sample shift of the fitted motion leaves [unit^2] (the
        model-form allowance of the actuator channel; 0 where not used).
    evidence
        What named the effects: ``replay`` (they close the time-domain gap), ``spectrum``
        (a contact no replay follows: :mod:`rths.diagnose.search.spectral`) or ``paired``
        (a delay the calibration absorbed to the noise floor, named by a paired test of
        held-out predictions: :func:`rths.diagnose.search.calibrated.hidden_delay`) or
        ``lag bound`` (a delay the calibration took to its lag bound, named with the nominal's
        own poles: :func:`rths.diagnose.search.lag.delay_at_lag_bound`); or, with
        verdict ``none``, ``coverage`` (a held-out gap the baseline calibrated on every
        record's time blocks closes to the floor: :mod:`rths.diagnose.search.coverage`).
    """

    channel: Channel = field(repr=False)
    baseline: Fit = field(repr=False)
    floor_mse: float
    decomposition: Decomposition
    candidates: list[Candidate]
    effects: tuple[str, ...]
    final: Fit = field(repr=False)
    closed: float
    verdict: str
    resolution_mse: float = 0.0
    evidence: str = "replay"

    @property
    def model_form(self) -> bool:
        """Whether the channel's significant gap was put down to the baseline's model form (not
        to the identification records' coverage, ``evidence = "coverage"``)."""
        return (
            self.verdict == "none"
            and self.decomposition.significant
            and self.evidence != "coverage"
        )

    @property
    def excess(self) -> float:
        """``J_0 - N_0`` (held-out) [unit^2]."""
        return self.baseline.held_mse - self.floor_mse

    @property
    def relative_gap(self) -> float:
        """Reducible gap as a fraction of the held-out observation's mean square."""
        return max(self.excess, 0.0) / max(self.observed_ms, 1e-300)

    @property
    def observed_ms(self) -> float:
        """Mean square of the held-out observation."""
        return float(
            np.mean(
                np.concatenate(
                    held_parts(self.channel, [s.observed for s in self.channel.segments])
                )
                ** 2
            )
        )

    def nrmse(self, mse: float) -> float:
        """Held-out NRMSE of a mean squared residual."""
        return math.sqrt(max(mse, 0.0) / max(self.observed_ms, 1e-300))


def held_runs(mask: NDArray[np.bool_]) -> list[slice]:
    """Contiguous runs of a boolean mask as slices.

    Parameters
    ----------
    mask
        One record's held-out (or any) mask.
    """
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return [slice(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def held_parts(channel: Channel, arrays: list[NDArray]) -> list[NDArray]:
    """The held-out samples of per-record arrays, one part per contiguous run.

    Parameters
    ----------
    channel
        The channel whose segments' held-out masks apply.
    arrays
        One array per record, aligned with the channel's segments.
    """
    return [
        a[run] for s, a in zip(channel.segments, arrays, strict=True) for run in held_runs(s.held)
    ]
