"""Indicators beyond the tracking errors: the tracking indicator (Mercan & Ricles), the frequency
evaluation index (Guo et al.) and the energy error (Mosqueda et al.).

References
----------
Mercan & Ricles (2007), Earthquake Eng. Struct. Dyn. 36(11), 1523-1543 (tracking indicator).
Guo, Chen, Xu & Sanchez (2014), Smart Mater. Struct. 23, 045042 (frequency evaluation index).
Mosqueda, Stojadinovic & Mahin (2007), J. Struct. Eng. 133(8), 1100-1108 (energy error).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rths.core.errors import DataError, check_positive
from rths.metrics._records import _pair, _record

__all__ = [
    "FrequencyEvaluation",
    "energy_error",
    "energy_error_ratio",
    "frequency_evaluation_index",
    "tracking_indicator",
]


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
