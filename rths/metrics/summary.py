"""All tracking metrics of one record in one frozen summary (:func:`summarize`)."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from numpy.typing import ArrayLike
from threadpoolctl import threadpool_limits

from rths.core.errors import check_positive
from rths.metrics._records import _pair
from rths.metrics.indicators import (
    energy_error,
    energy_error_ratio,
    frequency_evaluation_index,
    tracking_indicator,
)
from rths.metrics.tracking import (
    DEFAULT_MAX_DELAY,
    normalised_peak_error,
    normalised_rms_error,
    tracking_delay,
)

__all__ = ["TrackingSummary", "summarize"]


@dataclass(frozen=True, slots=True)
class TrackingSummary:
    """All tracking metrics of one record; :meth:`to_dict` gives a JSON-ready ``dict``.

    Attributes
    ----------
    n_samples, dt
        Record length and sampling step [s].
    sync_rmse, j2
        Sync-subspace RMSE and J2, identical by definition [-].
    j1_delay
        J1 delay of measured behind target [s].
    j3
        Peak tracking error ratio [-].
    tracking_indicator
        Final tracking indicator [m^2].
    fei_amplitude, fei_phase, fei_frequency, fei_delay
        Frequency evaluation index: ``|FEI|`` [-], ``arg FEI`` [rad], ``f_eq`` [Hz], delay [s].
    energy_error, energy_error_ratio
        Final energy error [J] and its ratio to the gross target work [-]; ``None`` without a
        force record.
    """

    n_samples: int
    dt: float
    sync_rmse: float
    j1_delay: float
    j2: float
    j3: float
    tracking_indicator: float
    fei_amplitude: float
    fei_phase: float
    fei_frequency: float
    fei_delay: float
    energy_error: float | None
    energy_error_ratio: float | None

    def to_dict(self) -> dict[str, Any]:
        """The fields as plain Python numbers (``json.dumps`` accepts the result)."""
        return asdict(self)


def summarize(
    target: ArrayLike,
    measured: ArrayLike,
    force: ArrayLike | None,
    dt: float,
    *,
    max_delay: float = DEFAULT_MAX_DELAY,
    weight_exponent: float = 2.0,
) -> TrackingSummary:
    """Every metric of this module for one record.

    Parameters
    ----------
    target, measured
        Displacements [m], shape ``(n,)``.
    force
        Specimen restoring force [N], shape ``(n,)``, or ``None`` to skip the energy error.
    dt
        Sampling step [s].
    max_delay
        Half-width [s] of the J1 lag search (see :func:`tracking_delay`).
    weight_exponent
        FEI weight exponent (see :func:`frequency_evaluation_index`).
    """
    # one BLAS thread: the correlations' sums then do not depend on the machine's thread
    # count, and on a busy machine OpenBLAS's spinning threads made this 0.5-2.9 s of a 10 s
    # fast run instead of milliseconds
    with threadpool_limits(limits=1, user_api="blas"):
        return _summarize(target, measured, force, dt, max_delay, weight_exponent)


def _summarize(
    target: ArrayLike,
    measured: ArrayLike,
    force: ArrayLike | None,
    dt: float,
    max_delay: float,
    weight_exponent: float,
) -> TrackingSummary:
    x_t, x_m = _pair(target, measured)
    dt = check_positive(dt, "sampling step dt")
    rmse = normalised_rms_error(x_t, x_m)
    fei = frequency_evaluation_index(x_t, x_m, dt, weight_exponent)
    e_final: float | None = None
    e_ratio: float | None = None
    if force is not None:
        e_final = float(energy_error(x_t, x_m, force)[-1])
        e_ratio = energy_error_ratio(x_t, x_m, force)
    return TrackingSummary(
        n_samples=int(x_t.size),
        dt=dt,
        sync_rmse=rmse,
        j1_delay=tracking_delay(x_t, x_m, dt, max_delay),
        j2=rmse,
        j3=normalised_peak_error(x_t, x_m),
        tracking_indicator=float(tracking_indicator(x_t, x_m)[-1]),
        fei_amplitude=fei.amplitude,
        fei_phase=fei.phase,
        fei_frequency=fei.frequency,
        fei_delay=fei.delay,
        energy_error=e_final,
        energy_error_ratio=e_ratio,
    )
