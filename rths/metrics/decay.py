"""Modal damping from a free decay: the damped modes in a record, by the matrix pencil method.

A structure vibrating freely is a sum of damped modes,

.. math:: y(t) = \\sum_k a_k e^{s_k t} + \\bar a_k e^{\\bar s_k t}, \\qquad
          s_k = -\\zeta_k |s_k| + i\\,\\omega_{d,k},

with ``zeta_k = -Re s_k/|s_k|`` (the definition of the exact cable-damper frequency equation's
damping ratio, :mod:`plants.cable.frequency_equation`).  Near an inertial damper's optimum
two roots nearly coalesce (S0 §5.3) and the free decay is close to
``(a + b t) e^{-sigma t}``: one fitted exponential then reads a damping below both roots,
while the pencil separates them.

:func:`free_decay` forms the Hankel matrix of the record whose columns are the record delayed
by multiples of a lag (about 16 samples per period of the band's upper edge: every sample is
used, no filter touches the record, and the pencil spans half of it), keeps its ``2 modes``
dominant singular vectors and takes the eigenvalues of the shifted pencil ``V_1^+ V_2`` as
``exp(s lag dt)`` (Hua & Sarkar 1990); the amplitudes come from least squares on the record.
Pure NumPy: no project imports beyond the errors.

References
----------
Y. Hua, T. K. Sarkar, "Matrix pencil method for estimating parameters of exponentially
damped/undamped sinusoids in noise", IEEE Trans. Acoust. Speech Signal Process. 38 (1990)
814-824.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from rths.core.errors import DataError, check_positive, check_positive_int

__all__ = ["MAX_COLUMNS", "DecayMode", "free_decay"]

#: Most delayed copies of the record in the pencil (bounds the SVD's cost for long records).
MAX_COLUMNS = 400


@dataclass(frozen=True, slots=True)
class DecayMode:
    """One damped mode found in a free decay.

    Attributes
    ----------
    frequency
        Damped natural frequency ``omega_d/(2 pi)`` [Hz].
    damping_ratio
        ``zeta = -Re s/|s|`` [-].
    amplitude
        Amplitude ``2 |a|`` at the start of the record (units of the record).
    """

    frequency: float
    damping_ratio: float
    amplitude: float


def free_decay(
    record: ArrayLike,
    dt: float,
    *,
    modes: int = 2,
    band: tuple[float, float] | None = None,
    min_amplitude: float = 0.05,
) -> tuple[DecayMode, ...]:
    """The damped modes of a free-decay record (see the module docstring).

    Parameters
    ----------
    record
        The freely decaying signal, shape ``(n,)``, uniformly sampled.
    dt
        Sampling step [s].
    modes
        Number of modes (pole pairs) the pencil keeps, >= 1.
    band
        ``(low, high)`` [Hz]: report only modes in this band; ``high`` also sets the pencil's
        lag (default: a lag of one sample, every mode below the Nyquist frequency).
    min_amplitude
        Report only modes at least this fraction of the largest one's amplitude.

    Returns
    -------
    tuple of DecayMode
        The modes found, ascending in frequency (empty if none passes ``band`` and
        ``min_amplitude``).

    Raises
    ------
    DataError
        Too short for the pencil, not finite, or flat.
    """
    dt = check_positive(dt, "sampling step dt")
    modes = check_positive_int(modes, "number of modes")
    y = np.asarray(record, dtype=np.float64).ravel()
    if not np.all(np.isfinite(y)):
        raise DataError("the free-decay record holds non-finite values")
    if not np.any(y != y[0] if y.size else False):
        raise DataError("the free-decay record is flat: nothing vibrates")
    # lag between pencil columns: about 16 samples per period of the band's upper edge
    lag = 1 if band is None else max(1, int(1.0 / (16.0 * band[1] * dt)))
    order = 2 * modes
    n = y.size
    columns = min((n - 1) // (2 * lag), MAX_COLUMNS)  # the pencil spans up to half the record
    if columns < 2 * order or n < 16:
        raise DataError(
            f"a free decay with {modes} mode(s) needs at least {max(16, 4 * order * lag + 1)} "
            f"samples here; got {n}"
        )
    span = columns * lag
    hankel = np.stack([y[k * lag : n - span + k * lag] for k in range(columns + 1)], axis=1)
    _, _, vh = np.linalg.svd(hankel, full_matrices=False)
    v = vh[:order].T
    z = np.linalg.eigvals(np.linalg.pinv(v[:-1]) @ v[1:])
    poles = np.log(z.astype(complex)) / (lag * dt)
    basis = np.exp(np.outer(dt * np.arange(n), poles))
    amplitudes = np.linalg.lstsq(basis, y.astype(complex), rcond=None)[0]
    found = [
        DecayMode(float(s.imag) / (2 * math.pi), float(-s.real / abs(s)), 2.0 * float(abs(a)))
        for s, a in zip(poles, amplitudes, strict=True)
        if s.imag > 0
    ]
    if band is not None:
        found = [m for m in found if band[0] <= m.frequency <= band[1]]
    if not found:
        return ()
    largest = max(m.amplitude for m in found)
    return tuple(
        sorted(
            (m for m in found if m.amplitude >= min_amplitude * largest), key=lambda m: m.frequency
        )
    )
