"""Signal helpers of the diagnosis: zero-phase smoothing, derivatives, noise level, TF replay.

Smoothing and differentiation (the specimen channel).  The measured displacement is noisy and its
second derivative is needed, so every specimen signal goes through the same zero-phase low-pass
``h`` (Butterworth, order :data:`SMOOTHING_ORDER`, run forwards and backwards by
``scipy.signal.sosfiltfilt``: magnitude ``1/(1 + (f/f_c)^8)``, no phase): the displacement is
smoothed, ``x_f = h*x``, and differentiated by second-order central differences
(``numpy.gradient``, error ``(w dt)^2/6`` of the derivative: 3e-4 at 14 Hz and 2 kHz), which
commute with ``h``; the measured force is smoothed by the same ``h``, and so is every model's
force output.  For a linear model ``L`` the comparison is then ``h*F`` against ``h*L(h*x) =
h*h*L(x)``, equal to ``h*L(x)`` to ``1 - |H|`` (< 0.4 % of the content below ``f_c/2``).

Noise level.  White measurement noise is estimated from the record itself as the median of its
Welch PSD over the top of the band (:data:`NOISE_BAND` of the Nyquist frequency), where lab
signals hold nothing but converter noise and quantisation; the median ignores narrow tones.
"""

from __future__ import annotations

import control
import numpy as np
from numpy.typing import NDArray
from scipy import signal

from rths.core.errors import ParameterError

__all__ = [
    "NOISE_BAND",
    "SMOOTHING_ORDER",
    "actuator_replay",
    "derivatives",
    "impulse_kernel",
    "smoother",
    "white_noise_rms",
]

#: Order of the Butterworth prototype of the zero-phase smoother (doubled by filtfilt).
SMOOTHING_ORDER: int = 4
#: Fraction of the Nyquist band [lo, hi] whose PSD median gives the white-noise level.
NOISE_BAND: tuple[float, float] = (0.7, 0.95)


def smoother(cutoff: float, dt: float) -> NDArray[np.float64]:
    """Second-order sections of the low-pass ``h`` (cutoff [Hz] at sampling step ``dt`` [s])."""
    nyquist = 0.5 / dt
    if not 0.0 < cutoff < 0.9 * nyquist:
        raise ParameterError(
            f"smoothing cutoff must lie in (0, {0.9 * nyquist:.6g}) Hz at {1 / dt:.6g} Hz "
            f"sampling; got {cutoff!r}"
        )
    return signal.butter(SMOOTHING_ORDER, cutoff, fs=1.0 / dt, output="sos")


def smooth(x: NDArray[np.float64], sos: NDArray[np.float64]) -> NDArray[np.float64]:
    """Zero-phase ``h*x`` (``sosfiltfilt`` with odd-extension padding)."""
    return signal.sosfiltfilt(sos, x, padtype="odd", padlen=min(x.size - 1, 3 * 256))


def derivatives(x: NDArray[np.float64], dt: float) -> tuple[NDArray, NDArray]:
    """Velocity and acceleration of a smooth record by central differences."""
    v = np.gradient(x, dt)
    return v, np.gradient(v, dt)


def white_noise_rms(x: NDArray[np.float64], dt: float) -> float:
    """RMS of the white noise on a record, from the median PSD over :data:`NOISE_BAND`.

    Returns the standard deviation in the record's units; 0 for a constant record.
    """
    n = min(512, x.size)
    f, p = signal.welch(x - np.mean(x), fs=1.0 / dt, nperseg=n, detrend="linear")
    nyquist = 0.5 / dt
    band = (f >= NOISE_BAND[0] * nyquist) & (f <= NOISE_BAND[1] * nyquist)
    level = float(np.median(p[band])) if np.any(band) else 0.0
    return float(np.sqrt(max(level, 0.0) * nyquist))


def impulse_kernel(
    sos: NDArray[np.float64], dt: float, linear: tuple[float, float, float] | None = None
) -> NDArray[np.float64]:
    """Impulse response of ``h`` (``linear`` None) or of ``h * L * h``, ``L = m D2 + c D1 + k``.

    Used to predict the residual noise floor of the specimen channel: white noise of variance
    ``s^2`` through a kernel ``k`` has variance ``s^2 sum(k^2)``.
    """
    n = 8192
    delta = np.zeros(n)
    delta[n // 2] = 1.0
    k = smooth(delta, sos)
    if linear is None:
        return k
    m, c, stiffness = linear
    v, a = derivatives(k, dt)
    return smooth(m * a + c * v + stiffness * k, sos)


def actuator_replay(
    num: tuple[float, ...], den: tuple[float, ...], dt: float, command: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Response of ``num/den`` to a command held over each interval (ZOH), at interval ends.

    Row ``k`` of a record holds the command ``u_k`` held over ``[t_k - dt, t_k]`` and the
    displacement at ``t_k`` (:mod:`rths.diagnose.data`), exactly as
    :class:`plants.actuator.TransferFunctionActuator` steps: ``z+ = A z + B u``,
    ``y = C z+ + D u``.  The discrete model ``(A, B, C A, C B + D)`` is run by
    ``scipy.signal.lfilter`` from rest.
    """
    tf = control.tf(list(num), list(den))
    ss = control.tf2ss(tf)
    if ss.A.size == 0:
        return float(np.asarray(ss.D).ravel()[0]) * command
    d = control.c2d(ss, dt, method="zoh")
    A, B, C, D = (np.asarray(m, dtype=float) for m in (d.A, d.B, d.C, d.D))
    b, a = signal.ss2tf(A, B, C @ A, C @ B + D)
    return signal.lfilter(b[0], a, command)
