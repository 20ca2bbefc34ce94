"""The vRTHS benchmark's evaluation criteria J1-J9, exactly as ``F4_evaluation.m`` computes them.

With ``x_m`` the measured specimen displacement (noise included), ``y_1 .. y_3`` the numerical
substructure's floor displacements (``y_1`` is the target), ``x_1 .. x_3`` the reference
(unpartitioned) frame's, all sampled at ``t_k = k dt`` from ``t = 0``, and ``std`` the sample
standard deviation (``N - 1``; the *mean is removed*, unlike an RMS):

* J1 -- tracking delay [ms]: ``(I - 1) dt`` with
  ``I = argmax_{j = 1..50} corr(x_m[j:], y_1[:n-j+1])``;
* J2 -- ``std(x_m - y_1) / std(y_1)`` [%];
* J3 -- ``max|x_m - y_1| / max|y_1|`` [%];
* J4 -- ``std(x_m - x_1) / std(x_1)`` [%];
* J5 -- ``max|x_m - x_1| / max|x_1|`` [%];
* J6 -- ``std(y_2 - x_2) / std(x_2)`` [%];
* J7 -- ``std(y_3 - x_3) / std(x_3)`` [%];
* J8 -- ``max|y_2 - x_2| / max|x_2|`` [%];
* J9 -- ``max|y_3 - x_3| / max|x_3|`` [%].

``corr`` is Pearson's coefficient; J1 searches lags 0-49 samples (F4's ``jj = 1:50``) and takes
the first maximum.  F4 rounds J1 to 0.1 ms and J2-J9 to 0.01 % (MATLAB ``round``, halves
away from zero).  F4 also stops with an error when the actuator force ``Force_act`` reaches
8.9 kN (:data:`ACTUATOR_CAPACITY`).

These differ from :mod:`rths.metrics` (RMS instead of std, a sub-sample two-sided J1 search, no
rounding, fractions instead of percent); both are reported, under different names.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rths.core.errors import DataError, check_positive

__all__ = [
    "ACTUATOR_CAPACITY",
    "CRITERIA",
    "J1_LAGS",
    "BenchmarkScores",
    "evaluate",
    "j1_correlations",
    "matlab_round",
]

FloatArray = NDArray[np.float64]

#: Actuator force capacity [N] (``F4_evaluation.m``: ``max(abs(Force_act.Data)) >= 8900``).
ACTUATOR_CAPACITY: float = 8900.0
#: Number of lags F4 searches for J1 (``N = 1:50``, lags 0-49 samples).
J1_LAGS: int = 50
#: Criterion names in F4's order.
CRITERIA: tuple[str, ...] = tuple(f"J{i}" for i in range(1, 10))


def matlab_round(x: float) -> float:
    """MATLAB ``round``: nearest integer, halves away from zero.

    Parameters
    ----------
    x : float
        The value to round (any unit; F4 rounds J1 in units of 0.1 ms, J2-J9 of 0.01 %).
    """
    return math.copysign(math.floor(abs(x) + 0.5), x)


@dataclass(frozen=True, slots=True)
class BenchmarkScores:
    """J1 [ms] and J2-J9 [%] of one run (F4's units; rounded as F4 unless made unrounded).

    The symbols are those of the module docstring; F4 rounds J1 to 0.1 ms and J2-J9 to 0.01 %
    (:func:`evaluate` with ``rounded=False`` keeps full precision).

    Attributes
    ----------
    J1 : float
        Tracking delay [ms]: the lag of the best correlation, 0 .. 49 samples, times ``dt``.
    J2 : float
        ``std(x_m - y_1) / std(y_1)`` [%]: tracking error, normalised by the target.
    J3 : float
        ``max|x_m - y_1| / max|y_1|`` [%]: peak tracking error.
    J4 : float
        ``std(x_m - x_1) / std(x_1)`` [%]: measured vs reference floor 1.
    J5 : float
        ``max|x_m - x_1| / max|x_1|`` [%]: peak, measured vs reference floor 1.
    J6 : float
        ``std(y_2 - x_2) / std(x_2)`` [%]: floor 2 vs reference.
    J7 : float
        ``std(y_3 - x_3) / std(x_3)`` [%]: floor 3 vs reference.
    J8 : float
        ``max|y_2 - x_2| / max|x_2|`` [%]: peak, floor 2 vs reference.
    J9 : float
        ``max|y_3 - x_3| / max|x_3|`` [%]: peak, floor 3 vs reference.
    """

    J1: float
    J2: float
    J3: float
    J4: float
    J5: float
    J6: float
    J7: float
    J8: float
    J9: float

    def to_dict(self) -> dict[str, float]:
        """``{"J1": ..., "J9": ...}`` in F4's order."""
        return asdict(self)

    def values(self) -> tuple[float, ...]:
        """The nine values in F4's order."""
        return tuple(getattr(self, name) for name in CRITERIA)


def _column(values: ArrayLike, name: str, n: int | None = None) -> FloatArray:
    x = np.asarray(values, dtype=float)
    if x.ndim != 1 or x.size < J1_LAGS + 2:
        raise DataError(
            f"{name} must be a 1-D record of at least {J1_LAGS + 2} samples; got shape {x.shape}"
        )
    if n is not None and x.size != n:
        raise DataError(f"{name} must have {n} samples like the measurement; got {x.size}")
    if not np.all(np.isfinite(x)):
        raise DataError(f"{name} must be finite; got {int(np.sum(~np.isfinite(x)))} bad samples")
    return x


def _floors(values: ArrayLike, name: str, n: int) -> FloatArray:
    x = np.asarray(values, dtype=float)
    if x.ndim != 2 or x.shape[0] != n or x.shape[1] < 3:
        raise DataError(f"{name} must have shape ({n}, 3) (floors 1-3); got {x.shape}")
    if not np.all(np.isfinite(x[:, :3])):
        raise DataError(f"{name} must be finite")
    return x[:, :3]


def j1_correlations(measured: ArrayLike, target: ArrayLike) -> FloatArray:
    """F4's ``r1``: Pearson correlation of ``x_m`` delayed by 0-49 samples with the target.

    ``r[j] = corr(x_m[j:], y_1[:n-j])`` for ``j = 0 .. 49`` (MATLAB ``jj = j + 1``); a constant
    window gives NaN, which MATLAB's ``max`` skips.

    Parameters
    ----------
    measured : array_like, shape (n,)
        Measured specimen displacement ``x_m`` [m], finite, ``n >= 52`` samples at ``dt``.
    target : array_like, shape (n,)
        Target displacement ``y_1`` [m] at the same instants.
    """
    x_m = _column(measured, "measured")
    y = _column(target, "target", x_m.size)
    n = x_m.size
    r = np.full(J1_LAGS, np.nan)
    for j in range(J1_LAGS):
        a = x_m[j:] - np.mean(x_m[j:])
        b = y[: n - j] - np.mean(y[: n - j])
        den = math.sqrt(float(a @ a) * float(b @ b))
        if den > 0.0:
            r[j] = float(a @ b) / den
    return r


def _std(v: FloatArray) -> float:
    """MATLAB ``std``: sample standard deviation (normalised by ``N - 1``)."""
    return float(np.std(v, ddof=1))


def _peak(v: FloatArray) -> float:
    return float(np.max(np.abs(v)))


def _ratio(num: float, den: float, name: str) -> float:
    if not den > 0.0:
        raise DataError(f"{name}: the normalising record is identically constant or zero")
    return num / den


def evaluate(
    measured: ArrayLike,
    numerical: ArrayLike,
    reference: ArrayLike,
    dt: float,
    *,
    rounded: bool = True,
) -> BenchmarkScores:
    """J1-J9 of one RTHS run, as ``F4_evaluation.m``.

    Parameters
    ----------
    measured
        ``X_m``: measured specimen displacement [m], shape ``(n,)``, from ``t = 0``.
    numerical
        ``Num_resp(:, 1:3)``: the numerical substructure's floor displacements [m], ``(n, 3)``;
        column 0 is the target.
    reference
        ``Ref_Resp(:, 1:3)``: the reference frame's floor displacements [m], ``(n, 3)``.
    dt
        Sampling step [s] (``dt_rths``).
    rounded
        Apply F4's rounding (J1 to 0.1 ms, J2-J9 to 0.01 %); ``False`` keeps full precision.

    Raises
    ------
    DataError
        Records of the wrong shape, non-finite, shorter than 52 samples, a constant
        normaliser, or no finite J1 correlation.
    """
    dt = check_positive(dt, "sampling step dt")
    x_m = _column(measured, "measured")
    n = x_m.size
    y = _floors(numerical, "numerical", n)
    ref = _floors(reference, "reference", n)
    r = j1_correlations(x_m, y[:, 0])
    if not np.any(np.isfinite(r)):
        raise DataError("J1: measured or target is constant over every lag window")
    lag = int(np.nanargmax(r))
    delay = lag * dt
    ratios = [
        _ratio(_std(x_m - y[:, 0]), _std(y[:, 0]), "J2"),
        _ratio(_peak(x_m - y[:, 0]), _peak(y[:, 0]), "J3"),
        _ratio(_std(x_m - ref[:, 0]), _std(ref[:, 0]), "J4"),
        _ratio(_peak(x_m - ref[:, 0]), _peak(ref[:, 0]), "J5"),
        _ratio(_std(y[:, 1] - ref[:, 1]), _std(ref[:, 1]), "J6"),
        _ratio(_std(y[:, 2] - ref[:, 2]), _std(ref[:, 2]), "J7"),
        _ratio(_peak(y[:, 1] - ref[:, 1]), _peak(ref[:, 1]), "J8"),
        _ratio(_peak(y[:, 2] - ref[:, 2]), _peak(ref[:, 2]), "J9"),
    ]
    if rounded:  # F4's expressions: round(10000*del1(I))/10, round(10000*ratio)/100
        raw = [matlab_round(10000.0 * delay) / 10.0]
        raw += [matlab_round(10000.0 * v) / 100.0 for v in ratios]
    else:
        raw = [1000.0 * delay] + [100.0 * v for v in ratios]
    return BenchmarkScores(*raw)
