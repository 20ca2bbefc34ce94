"""Tracking-performance metrics of an RTHS record.

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

References
----------
Silva, Gomez, Maghareh, Dyke & Spencer (2020), "Benchmark control problem for real-time hybrid
simulation", Mech. Syst. Signal Process. 135, 106381 (J1-J3).
Mercan & Ricles (2007), Earthquake Eng. Struct. Dyn. 36(11), 1523-1543 (tracking indicator).
Guo, Chen, Xu & Sanchez (2014), Smart Mater. Struct. 23, 045042 (frequency evaluation index).
Mosqueda, Stojadinovic & Mahin (2007), J. Struct. Eng. 133(8), 1100-1108 (energy error).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import signal

from rths.core.errors import DataError, ParameterError, check_positive

__all__ = [
    "DEFAULT_MAX_DELAY",
    "MIN_SAMPLES",
    "FrequencyEvaluation",
    "TrackingSummary",
    "energy_error",
    "energy_error_ratio",
    "frequency_evaluation_index",
    "normalised_peak_error",
    "normalised_rms_error",
    "summarize",
    "sync_subspace_rmse",
    "tracking_delay",
    "tracking_indicator",
]

#: Fewest samples a record (and the overlap left by the J1 lag search) may have.
MIN_SAMPLES: int = 16

#: Default half-width [s] of the J1 lag search; servo-hydraulic delays are a few to 30 ms.
DEFAULT_MAX_DELAY: float = 0.05


def _record(values: ArrayLike, name: str, n: int | None = None) -> NDArray[np.float64]:
    """``values`` as a finite 1-D float array of at least MIN_SAMPLES (and ``n``) samples."""
    try:
        x = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise DataError(f"{name} must be a numeric 1-D array; got {values!r:.60}") from None
    if x.ndim != 1:
        raise DataError(f"{name} must be a 1-D array; got shape {x.shape}")
    if n is not None and x.size != n:
        raise DataError(f"{name} must have the target's length {n}; got {x.size}")
    if x.size < MIN_SAMPLES:
        raise DataError(f"{name} must have at least {MIN_SAMPLES} samples; got {x.size}")
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        raise DataError(
            f"{name} must be finite; got {float(x[bad[0]])!r} at index {bad[0]} "
            f"({bad.size} non-finite samples)"
        )
    return x


def _pair(
    target: ArrayLike, measured: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Validated (target, measured); the target must not be identically zero."""
    x_t = _record(target, "target")
    x_m = _record(measured, "measured", x_t.size)
    if not np.any(x_t):
        raise DataError("target must not be identically zero (its RMS normalises the errors)")
    return x_t, x_m


def _rms(x: NDArray[np.float64]) -> float:
    return float(np.sqrt(np.mean(x * x)))


def normalised_rms_error(target: ArrayLike, measured: ArrayLike) -> float:
    """Benchmark criterion J2: normalised RMS tracking error [-].

    .. math:: J_2 = \\sqrt{\\textstyle\\sum_i (x_{m,i} - x_{t,i})^2 \\big/ \\sum_i x_{t,i}^2}

    By definition the same number as :func:`sync_subspace_rmse`.  The benchmark's released
    MATLAB evaluation divides standard deviations (means removed) instead of RMS values; the two
    agree for zero-mean records, as RTHS records that start and end at rest are.

    Parameters
    ----------
    target, measured
        Displacements [m], shape ``(n,)``.
    """
    x_t, x_m = _pair(target, measured)
    return _rms(x_m - x_t) / _rms(x_t)


def sync_subspace_rmse(target: ArrayLike, measured: ArrayLike) -> float:
    """RMS of measured minus target displacement over the target RMS [-].

    The index S0 reports beside its synchronisation subspace plot (1.13 %, S0 Fig. 33).
    Identical by definition to J2 (:func:`normalised_rms_error`); both names are in use.

    Parameters
    ----------
    target, measured
        Displacements [m], shape ``(n,)``.
    """
    return normalised_rms_error(target, measured)


def normalised_peak_error(target: ArrayLike, measured: ArrayLike) -> float:
    """Benchmark criterion J3: peak tracking error over peak target [-].

    .. math:: J_3 = \\max_i |x_{m,i} - x_{t,i}| \\big/ \\max_i |x_{t,i}|

    Parameters
    ----------
    target, measured
        Displacements [m], shape ``(n,)``.
    """
    x_t, x_m = _pair(target, measured)
    return float(np.max(np.abs(x_m - x_t)) / np.max(np.abs(x_t)))


def tracking_delay(
    target: ArrayLike, measured: ArrayLike, dt: float, max_delay: float = DEFAULT_MAX_DELAY
) -> float:
    """Benchmark criterion J1: delay [s] of the measured behind the target displacement.

    The lag ``k`` (samples, ``|k| <= L = ceil(max_delay/dt)``) maximising the Pearson
    correlation of the fixed window ``x_m[L : n-L]`` with the shifted window
    ``x_t[L-k : n-L-k]`` is found, as in the benchmark's evaluation (which searches
    ``0 <= k < 50``).  A parabola through the correlation at ``k-1, k, k+1`` refines it to a
    fraction of a sample: for a sine of ``P`` samples per period its bias is below
    ``(2 pi / P)^2 / 12`` of the fractional part.  The correlation is mean-removed and
    normalised, so offsets and amplitude errors do not move the estimate.

    Parameters
    ----------
    target, measured
        Displacements [m], shape ``(n,)``.
    dt
        Sampling step [s].
    max_delay
        Half-width [s] of the lag search.  Keep it below half the shortest significant period
        of the target, or a periodic record may lock onto a neighbouring cycle.

    Returns
    -------
    float
        Delay [s]; positive when the measured displacement lags, negative when it leads.

    Raises
    ------
    DataError
        Invalid records, a constant window, or a correlation peak at the search limit (the
        delay exceeds ``max_delay`` or the records are unrelated).
    ParameterError
        ``dt`` or ``max_delay`` not positive, or ``max_delay`` leaves too short an overlap.
    """
    x_t, x_m = _pair(target, measured)
    dt = check_positive(dt, "sampling step dt")
    max_delay = check_positive(max_delay, "max_delay")
    n = x_t.size
    lags = math.ceil(max_delay / dt - 1e-9)
    m = n - 2 * lags
    if m < MIN_SAMPLES:
        raise ParameterError(
            f"max_delay must leave at least {MIN_SAMPLES} overlapping samples; got "
            f"{max_delay!r} s = {lags} samples for a record of {n} samples"
        )
    window = x_m[lags : n - lags] - np.mean(x_m[lags : n - lags])
    shifted = x_t - np.mean(x_t)
    # cross[j] = sum_i shifted[i + j] * window[i] is lag k = lags - j: reverse to index by k.
    cross = signal.correlate(shifted, window, mode="valid")[::-1]
    csum = np.concatenate(([0.0], np.cumsum(shifted)))
    csq = np.concatenate(([0.0], np.cumsum(shifted * shifted)))
    start = np.arange(2 * lags, -1, -1)  # first target index of the segment for k = -L..L
    seg_sum = csum[start + m] - csum[start]
    seg_var = np.maximum(csq[start + m] - csq[start] - seg_sum**2 / m, 0.0)
    norm = np.sqrt(seg_var * float(window @ window))
    if not np.all(norm > 0.0):
        raise DataError("target and measured must vary within the J1 window; one is constant")
    rho = cross / norm
    i = int(np.argmax(rho))
    if i == 0 or i == 2 * lags:
        raise DataError(
            f"J1 correlation peak lies at the search limit {(i - lags) * dt:+.6g} s; the delay "
            f"exceeds max_delay={max_delay!r} s or the records are unrelated"
        )
    before, peak, after = rho[i - 1], rho[i], rho[i + 1]
    curvature = before - 2.0 * peak + after
    offset = 0.5 * (before - after) / curvature if curvature < 0.0 else 0.0
    return float((i - lags + offset) * dt)


def tracking_indicator(target: ArrayLike, measured: ArrayLike) -> NDArray[np.float64]:
    """Tracking indicator TI (Mercan & Ricles 2007): cumulative area [m^2] in the sync subspace.

    With the target on the horizontal and the measured displacement on the vertical axis of the
    synchronisation subspace plot, and trapezoidal areas

    .. math::

        A_i  &= A_{i-1} + \\tfrac12 (x_{t,i} + x_{t,i-1})(x_{m,i} - x_{m,i-1}),\\\\
        TA_i &= TA_{i-1} + \\tfrac12 (x_{m,i} + x_{m,i-1})(x_{t,i} - x_{t,i-1}),\\\\
        TI_i &= \\tfrac12 (A_i - TA_i),

    TI is the signed area swept by the point ``(x_t, x_m)``: each step adds
    ``(x_{t,i-1} x_{m,i} - x_{t,i} x_{m,i-1}) / 2`` (shoelace formula).  A lagging measurement
    traces its loop counter-clockwise, so TI grows for a lag and falls for a lead; over a cycle
    of a sine it grows by the loop's area ``pi A^2 sin(omega tau)``.  A pure amplitude error
    encloses no area and leaves TI at zero.

    Parameters
    ----------
    target, measured
        Displacements [m], shape ``(n,)``.

    Returns
    -------
    numpy.ndarray
        ``TI_i`` [m^2], shape ``(n,)``, with ``TI_0 = 0``.
    """
    x_t, x_m = _pair(target, measured)
    swept = 0.5 * (x_t[:-1] * x_m[1:] - x_t[1:] * x_m[:-1])
    return np.concatenate(([0.0], np.cumsum(swept)))


@dataclass(frozen=True, slots=True)
class FrequencyEvaluation:
    """Frequency evaluation index of a record (Guo et al. 2014).

    Attributes
    ----------
    amplitude
        ``|FEI|`` [-]; 1 for perfect amplitude tracking.
    phase
        ``arg FEI`` [rad] in ``(-pi, pi]``; negative for a lag.
    frequency
        Equivalent frequency ``f_eq`` [Hz] of the target's spectral content.
    delay
        Equivalent delay ``-phase / (2 pi f_eq)`` [s]; positive for a lag.
    """

    amplitude: float
    phase: float
    frequency: float
    delay: float


def frequency_evaluation_index(
    target: ArrayLike, measured: ArrayLike, dt: float, weight_exponent: float = 2.0
) -> FrequencyEvaluation:
    """Frequency evaluation index (Guo et al. 2014): amplitude ratio and equivalent delay.

    With ``X_t``, ``X_m`` the DFTs of the records at the positive frequencies ``f_j``
    (``j = 1 .. n//2``; the mean, ``j = 0``, is left out) and weights ``w_j = |X_t(f_j)|^l``:

    .. math::

        \\mathrm{FEI} = \\frac{\\sum_j (X_m/X_t)_j\\, w_j}{\\sum_j w_j}, \\quad
        f_{eq} = \\frac{\\sum_j f_j\\, w_j}{\\sum_j w_j}, \\quad
        A_0 = |\\mathrm{FEI}|, \\quad \\varphi = \\arg \\mathrm{FEI}, \\quad
        \\delta = -\\frac{\\varphi}{2\\pi f_{eq}}.

    The weights put the index on the dominant frequency content; with the default ``l = 2`` it
    is ``sum X_m conj(X_t) / sum |X_t|^2`` (cross- over auto-spectrum); bins where the target is
    exactly empty are left out.  ``arg`` is the four-quadrant angle (Guo et al. write
    ``arctan(Im/Re)``, equal for ``|phase| < pi/2``); the delay is meaningful while
    ``|2 pi f_eq delay| < pi``.  Whole periods of a sine give the exact amplitude ratio and
    delay; leakage from partial periods biases both slightly.

    Parameters
    ----------
    target, measured
        Displacements [m], shape ``(n,)``.
    dt
        Sampling step [s].
    weight_exponent
        ``l > 0``; 2 weights each frequency by the target's power.
    """
    x_t, x_m = _pair(target, measured)
    dt = check_positive(dt, "sampling step dt")
    weight_exponent = check_positive(weight_exponent, "weight_exponent")
    spec_t = np.fft.rfft(x_t)[1:]
    spec_m = np.fft.rfft(x_m)[1:]
    freqs = np.fft.rfftfreq(x_t.size, dt)[1:]
    power = np.abs(spec_t) ** 2
    used = power > 0.0
    if not np.any(used):
        raise DataError("target has no content above 0 Hz; the FEI needs a varying target")
    weights = power[used] ** (0.5 * weight_exponent)
    index = complex(np.sum(spec_m[used] / spec_t[used] * weights) / np.sum(weights))
    frequency = float(np.sum(freqs[used] * weights) / np.sum(weights))
    phase = math.atan2(index.imag, index.real)
    return FrequencyEvaluation(
        amplitude=abs(index),
        phase=phase,
        frequency=frequency,
        delay=-phase / (2.0 * math.pi * frequency),
    )


def _work_increments(force: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Trapezoidal work [J] of ``force`` along ``x`` in each step, shape ``(n-1,)``."""
    return 0.5 * (force[1:] + force[:-1]) * np.diff(x)


def energy_error(target: ArrayLike, measured: ArrayLike, force: ArrayLike) -> NDArray[np.float64]:
    """Cumulative energy error [J] introduced by imperfect tracking (after Mosqueda et al. 2007).

    .. math:: E_{err}(t) = \\int_0^t F\\,(\\dot x_m - \\dot x_t)\\,dt' = \\int F\\,d(x_m - x_t)

    evaluated as a trapezoidal Stieltjes sum along the tracking error ``x_m - x_t``, so no
    velocity is differentiated from noisy records and ``dt`` is not needed.  ``int F dx_m`` is
    the work the specimen really absorbed; ``int F dx_t`` is what the numerical substructure,
    which moved by ``x_t`` while receiving ``-F``, accounts for.  ``E_err > 0`` is energy the
    test injects spuriously into the numerical substructure: for a spring ``k`` and a lagging
    actuator it grows by ``k pi A^2 sin(omega tau)`` per cycle (negative damping).

    Parameters
    ----------
    target, measured
        Displacements [m], shape ``(n,)``.
    force
        Specimen restoring force [N] at the same samples, shape ``(n,)``.

    Returns
    -------
    numpy.ndarray
        ``E_err`` [J] at each sample, shape ``(n,)``, with ``E_err[0] = 0``.
    """
    x_t, x_m = _pair(target, measured)
    f = _record(force, "force", x_t.size)
    return np.concatenate(([0.0], np.cumsum(_work_increments(f, x_m - x_t))))


def energy_error_ratio(target: ArrayLike, measured: ArrayLike, force: ArrayLike) -> float:
    """Final energy error over the gross work of the force along the target [-].

    .. math:: \\epsilon_E = E_{err}(T) \\big/ \\int_0^T |F\\,\\dot x_t|\\,dt

    with the denominator summed from the absolute trapezoidal work increments along ``x_t``.
    For a sine force in phase with a sine target and a delay ``tau`` it is
    ``(pi/2) sin(omega tau)`` over whole cycles.  Raises :class:`DataError` when the force does
    no work along the target.

    Parameters
    ----------
    target, measured
        Displacements [m], shape ``(n,)``.
    force
        Specimen restoring force [N], shape ``(n,)``.
    """
    x_t, x_m = _pair(target, measured)
    f = _record(force, "force", x_t.size)
    gross = float(np.sum(np.abs(_work_increments(f, x_t))))
    if gross == 0.0:
        raise DataError("force does no work along the target; the energy error ratio is undefined")
    return float(np.sum(_work_increments(f, x_m - x_t))) / gross


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
