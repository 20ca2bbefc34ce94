"""Signal helpers of the diagnosis: zero-phase smoothing, derivatives, noise level, TF replay,
fractional shifts and the running load amplitude.

Smoothing and differentiation (the specimen channel).  The drive displacement may be noisy and
its second derivative is needed, so every specimen signal goes through the same zero-phase
low-pass ``h`` (Butterworth, order :data:`SMOOTHING_ORDER`, run forwards and backwards by
``scipy.signal.sosfiltfilt``: magnitude ``1/(1 + (f/f_c)^8)``, no phase): the displacement is
smoothed, ``x_f = h*x``, and differentiated by fourth-order (five-point) central differences
(:func:`derivative`), which commute with ``h``; the measured force is smoothed by the same
``h``, and so is every model's force output.  For a linear model ``L`` the comparison is then
``h*F`` against ``h*L(h*x) = h*h*L(x)``, equal to ``h*L(x)`` to ``1 - |H|``.

Noise level.  White measurement noise is estimated from the record itself as the median of its
Welch PSD over the top of the band (:data:`NOISE_BAND` of the Nyquist frequency), where lab
signals hold nothing but converter noise and quantisation; the median ignores narrow tones.
Impacts (a stiff contact closing) put broadband energy at the top of the band too, but only
for the few milliseconds of each impact: the level is therefore at most the robust
time-domain estimate, the median absolute third difference (white noise of variance
``s^2`` gives third differences of variance ``20 s^2``, and a smooth signal's third
difference is negligible), which ignores the impacts' samples, floored at a quantised
record's ``LSB/sqrt(12)``.

Replay (DAQ timing convention, :mod:`rths.diagnose.data.records`).  The command ``u_k`` is held
from ``t_k`` to ``t_{k+1}`` (zero-order hold) and the displacement is sampled at ``t_k``: with
the ZOH-exact discrete model ``z_{k+1} = A z_k + B u_k``, ``y_k = C z_k + D u_k``.

Running load amplitude (the ``A`` of S0 Eq.17-18).  ``A = sqrt(2 LP[d^2])``, ``d = x -
mean(x)`` the motion about the record's mean position: the square root of twice the running
mean square, ``LP`` a causal critically damped second-order low-pass (two first-order stages
of time constant ``tau``).  For a sine of amplitude ``X`` it settles on ``X`` within a few
``tau``, whatever the frequency; it follows a non-stationary record with a memory of about
``2 tau``.  The other common reading of an
amplitude, the decaying peak hold of :func:`peak_amplitude` (an envelope detector: it takes a
new peak at once and lets it fade with time constant ``tau``), follows a growing motion without
lag; for a non-stationary record the two differ (by up to the peak factor of a random motion),
so the amplitude law is fitted on a blend of both (:mod:`rths.diagnose.effects.specimen`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import linalg, signal

from rths.core.errors import ParameterError

__all__ = [
    "NOISE_BAND",
    "SMOOTHING_ORDER",
    "actuator_replay",
    "derivative",
    "derivatives",
    "discrete_tf",
    "dominant_tone",
    "impulse_kernel",
    "peak_amplitude",
    "running_amplitude",
    "shifted",
    "smooth",
    "smoother",
    "white_noise_rms",
]

#: Order of the Butterworth prototype of the zero-phase smoother (doubled by filtfilt).
SMOOTHING_ORDER: int = 4
#: Fraction of the Nyquist band [lo, hi] whose PSD median gives the white-noise level.
NOISE_BAND: tuple[float, float] = (0.7, 0.95)
#: A motion is one tone when this share of its variance lies within a factor
#: :data:`TONE_BAND` of its spectral peak (a sine with its ramps and the few per cent of
#: harmonics a displacement-controlled actuator adds; a sweep or a random motion spreads far wider).
TONE_SHARE: float = 0.95
#: Half-width (a frequency factor) of the band around the peak that holds a tone.
TONE_BAND: float = 1.25


def smoother(cutoff: float, dt: float) -> NDArray[np.float64]:
    """Second-order sections of the low-pass ``h``.

    Parameters
    ----------
    cutoff
        Corner frequency [Hz]; in ``(0, 0.9 f_Nyquist)``.
    dt
        Sample period [s].

    Returns
    -------
    numpy.ndarray
        Butterworth second-order sections, order :data:`SMOOTHING_ORDER`.

    Raises
    ------
    ParameterError
        When ``cutoff`` lies outside ``(0, 0.9 f_Nyquist)``; the message names it.
    """
    nyquist = 0.5 / dt
    if not 0.0 < cutoff < 0.9 * nyquist:
        raise ParameterError(
            f"smoothing cutoff must lie in (0, {0.9 * nyquist:.6g}) Hz at {1 / dt:.6g} Hz "
            f"sampling; got {cutoff!r}"
        )
    return signal.butter(SMOOTHING_ORDER, cutoff, fs=1.0 / dt, output="sos")


_ZI: dict[bytes, NDArray[np.float64]] = {}


def _zi(sos: NDArray[np.float64]) -> NDArray[np.float64]:
    key = sos.tobytes()
    if key not in _ZI:
        if len(_ZI) > 32:
            _ZI.clear()
        _ZI[key] = signal.sosfilt_zi(sos)
    return _ZI[key]


def smooth(x: NDArray[np.float64], sos: NDArray[np.float64]) -> NDArray[np.float64]:
    """Zero-phase ``h*x``: ``scipy.signal.sosfiltfilt``'s algorithm (odd-extension padding of
    ``min(n - 1, 768)`` samples, steady-state initial conditions) with the initial-condition
    vector cached per filter.

    Parameters
    ----------
    x
        Record, shape ``(n,)``, any unit (the output has the same).
    sos
        Second-order sections of the low-pass (:func:`smoother`).
    """
    n = x.size
    pad = min(n - 1, 3 * 256)
    if pad > 0:
        ext = np.concatenate([2.0 * x[0] - x[pad:0:-1], x, 2.0 * x[-1] - x[-2 : -pad - 2 : -1]])
    else:
        ext = np.asarray(x, dtype=float)
    zi = _zi(sos)
    y, _ = signal.sosfilt(sos, ext, zi=zi * ext[0])
    y, _ = signal.sosfilt(sos, y[::-1], zi=zi * y[-1])
    y = y[::-1]
    return y[pad : pad + n] if pad > 0 else y


def derivative(y: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
    """First derivative of a smooth record: the five-point central difference inside,
    ``numpy.gradient`` at the two samples of each end.

    The five-point stencil ``(y[k-2] - 8 y[k-1] + 8 y[k+1] - y[k+2]) / (12 dt)`` passes a
    tone of ``theta = omega dt`` with the gain ``(8 sin theta - sin 2 theta) / (6 theta) = 1
    - theta^4/30 + ...``; the three-point ``numpy.gradient`` has ``sin theta / theta = 1 -
    theta^2/6``.  Applied twice for an acceleration, the three-point error (-0.5 % at 20 Hz
    on a 1024 Hz record) grows as ``omega^4`` in the force ``m a``: a re-calibration fitted
    it with a spurious stiffness of some kN/m that no low-frequency record has (an
    independent generator's no-effect specimen: 1.7 kN/m against none, its held-out gap 60 %
    above the floor).  Fourth order leaves 1.5e-5 there.

    Parameters
    ----------
    y
        Smooth record, shape ``(n,)``, any unit.
    dt
        Sample period [s].
    """
    if y.size < 5:
        return np.gradient(y, dt)
    out = np.empty(y.size)
    out[:2] = np.gradient(y[:3], dt)[:2]
    out[-2:] = np.gradient(y[-3:], dt)[1:]
    out[2:-2] = (y[:-4] - 8.0 * y[1:-3] + 8.0 * y[3:-1] - y[4:]) / (12.0 * dt)
    return out


def derivatives(x: NDArray[np.float64], dt: float) -> tuple[NDArray, NDArray]:
    """Velocity and acceleration of a smooth record (:func:`derivative` twice).

    Parameters
    ----------
    x
        Smoothed displacement [m], shape ``(n,)``.
    dt
        Sample period [s].

    Returns
    -------
    tuple of numpy.ndarray
        Velocity [m/s] and acceleration [m/s^2].
    """
    v = derivative(x, dt)
    return v, derivative(v, dt)


def white_noise_rms(x: NDArray[np.float64], dt: float) -> float:
    """RMS of the white noise on a record, from the median PSD over :data:`NOISE_BAND`.

    Parameters
    ----------
    x
        Record, shape ``(n,)``, any unit.
    dt
        Sample period [s].

    Returns
    -------
    float
        Standard deviation of the white noise in the record's units; 0 for a constant record.
    """
    n = min(512, x.size)
    f, p = signal.welch(x - np.mean(x), fs=1.0 / dt, nperseg=n, detrend="linear")
    nyquist = 0.5 / dt
    band = (f >= NOISE_BAND[0] * nyquist) & (f <= NOISE_BAND[1] * nyquist)
    level = float(np.median(p[band])) if np.any(band) else 0.0
    spectral = float(np.sqrt(max(level, 0.0) * nyquist))
    if x.size < 64:
        return spectral
    d3 = np.diff(x, 3)
    robust = 1.4826 * float(np.median(np.abs(d3 - np.median(d3)))) / math.sqrt(20.0)
    steps = np.diff(np.unique(x))
    lsb = float(np.min(steps)) if steps.size else 0.0
    return min(spectral, max(robust, lsb / math.sqrt(12.0)))


def impulse_kernel(
    sos: NDArray[np.float64],
    dt: float,
    linear: tuple[float, float, float] | None = None,
    drive_sos: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """Impulse response of ``h`` (``linear`` None) or of ``h * L * g``, ``L = m D2 + c D1 + k``.

    Used to predict the residual noise floor of the specimen channel: white noise of variance
    ``s^2`` through a kernel ``k`` has variance ``s^2 sum(k^2)``.  ``g`` is the low-pass the
    drive goes through before it is differentiated (``drive_sos``; default ``h`` itself).

    Parameters
    ----------
    sos
        Second-order sections of ``h`` (:func:`smoother`).
    dt
        Sample period [s].
    linear
        ``(m, c, k)`` of ``L``: inertance [kg], damping [N s/m], stiffness [N/m]; None for
        the kernel of ``h`` alone.
    drive_sos
        Sections of the drive's low-pass ``g``; None uses ``sos``.

    Returns
    -------
    numpy.ndarray
        The kernel, 8192 samples centred on the impulse.
    """
    n = 8192
    delta = np.zeros(n)
    delta[n // 2] = 1.0
    k = smooth(delta, sos if drive_sos is None or linear is None else drive_sos)
    if linear is None:
        return k
    m, c, stiffness = linear
    v, a = derivatives(k, dt)
    return smooth(m * a + c * v + stiffness * k, sos)


def sampled_tf(
    num: tuple[float, ...] | NDArray, den: tuple[float, ...] | NDArray, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(b, a)`` of the first-order-hold discrete model of ``num/den``: a *sampled* continuous
    signal (a force on the measured motion, not a command held from ``t_k``) through it, exact
    for a signal linear between samples (a hold would lag it by half a sample).

    Parameters
    ----------
    num, den
        Continuous-time transfer function, descending powers of ``s`` (proper).
    dt
        Sample period [s].
    """
    if len(den) <= 1:
        return np.array([float(num[-1]) / float(den[0])]), np.array([1.0])
    b, a, _ = signal.cont2discrete(
        (np.asarray(num, float), np.asarray(den, float)), dt, method="foh"
    )
    return np.ravel(b).astype(float), np.asarray(a, float)


def discrete_tf(
    num: tuple[float, ...] | NDArray, den: tuple[float, ...] | NDArray, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(b, a)`` of the ZOH-exact discrete model of ``num/den`` in the DAQ convention.

    ``y_k = C z_k + D u_k`` with ``z_{k+1} = A z_k + B u_k``: a strictly proper ``num/den``
    gives ``b[0] = 0`` (the sample at ``t_k`` does not see the command applied from ``t_k``).

    Parameters
    ----------
    num, den
        Continuous-time transfer function, descending powers of ``s``.
    dt
        Sample period [s].

    Returns
    -------
    tuple of numpy.ndarray
        Numerator ``b`` and denominator ``a`` in powers of ``z^-1`` (``scipy.signal.lfilter``).
    """
    if len(den) <= 1:
        return np.array([float(num[-1]) / float(den[0])]), np.array([1.0])
    A, B, C, D = signal.tf2ss(np.asarray(num, float), np.asarray(den, float))
    n = A.shape[0]
    block = np.zeros((n + 1, n + 1))
    block[:n, :n], block[:n, n:] = A * dt, B * dt
    phi = linalg.expm(block)
    b, a = signal.ss2tf(phi[:n, :n], phi[:n, n:], C, D)
    return np.asarray(b[0], dtype=float), np.asarray(a, dtype=float)


def actuator_replay(
    num: tuple[float, ...], den: tuple[float, ...], dt: float, command: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Response of ``num/den`` from rest to a command in the DAQ convention (module docstring).

    Run by ``scipy.signal.lfilter`` on :func:`discrete_tf`.

    Parameters
    ----------
    num, den
        Continuous-time transfer function measured/command, descending powers of ``s``.
    dt
        Sample period [s].
    command
        Command [m], shape ``(n,)``; row ``k`` applied from ``t_k``.

    Returns
    -------
    numpy.ndarray
        The replayed displacement [m] sampled at ``t_k``.
    """
    b, a = discrete_tf(num, den, dt)
    return signal.lfilter(b, a, command)


def shifted(x: NDArray[np.float64], samples: float) -> NDArray[np.float64]:
    """``x`` delayed by ``samples`` (any real number; negative = advanced), linear interpolation.

    Outside the record the first (last) sample is held.

    Parameters
    ----------
    x
        Record, shape ``(n,)``.
    samples
        Delay in samples (fractional allowed).
    """
    if samples == 0.0:
        return x
    whole = math.floor(samples)
    frac = samples - whole
    n = x.size
    idx = np.arange(n) - whole
    lo = x[np.clip(idx, 0, n - 1)]
    hi = x[np.clip(idx - 1, 0, n - 1)]
    return (1.0 - frac) * lo + frac * hi


def running_amplitude(x: NDArray[np.float64], dt: float, tau: float) -> NDArray[np.float64]:
    """Running load amplitude ``sqrt(2 LP[d^2])`` [m] of the motion about the record's mean
    position, ``d = x - mean(x)`` (module docstring): exactly the amplitude of a steady sine
    of any period (the ripple of ``LP[d^2]`` at twice its frequency aside).  A running mean
    of the same memory, subtracted instead, followed the oscillation itself once ``tau`` was
    not long beside the period and read 0.92 of a 2 Hz sine's amplitude at ``tau`` = 0.1 s.

    Parameters
    ----------
    x
        Drive displacement [m], shape ``(n,)``; the low-passes start at rest.
    dt
        Sample period [s].
    tau
        Time constant [s] of each of the two first-order stages of ``LP``.
    """
    pole = math.exp(-dt / tau)
    b, a = np.array([1.0 - pole]), np.array([1.0, -pole])
    d = x - np.mean(x)
    return np.sqrt(2.0 * np.clip(signal.lfilter(b, a, signal.lfilter(b, a, d * d)), 0.0, None))


def peak_amplitude(x: NDArray[np.float64], dt: float, tau: float) -> NDArray[np.float64]:
    """Decaying peak hold ``A_k = max(|d_k|, A_{k-1} exp(-dt/tau))`` [m] of the motion about
    the record's mean position, ``d = x - mean(x)`` (as in :func:`running_amplitude`).

    Computed without a loop in the log domain, ``log A_k = -k dt/tau + cummax_j (log|d_j| +
    j dt/tau)``.

    Parameters
    ----------
    x
        Drive displacement [m], shape ``(n,)``; starts at rest.
    dt
        Sample period [s].
    tau
        Time constant [s] of the fading.
    """
    d = np.abs(x - np.mean(x))
    ramp = np.arange(d.size) * (dt / tau)
    with np.errstate(divide="ignore"):
        held = np.maximum.accumulate(np.log(d) + ramp)
    return np.exp(held - ramp)


def dominant_tone(x: NDArray[np.float64], dt: float) -> float | None:
    """Frequency [Hz] of the one spectral line holding :data:`TONE_SHARE` of ``x``'s variance
    within a factor :data:`TONE_BAND` of the peak, or the window's main lobe (two bins) if
    wider (Hann-windowed periodogram of ``x`` minus its mean); None when the motion spreads
    further (several tones, a sweep, random motion).

    Parameters
    ----------
    x
        A motion (any unit), shape ``(n,)``.
    dt
        Sample period [s].
    """
    d = np.asarray(x, dtype=float) - float(np.mean(x))
    if d.size < 8 or not np.any(d):
        return None
    power = np.abs(np.fft.rfft(d * np.hanning(d.size))) ** 2
    power[0] = 0.0
    freq = np.fft.rfftfreq(d.size, dt)
    peak = float(freq[int(np.argmax(power))])
    lobe = 2.0 / (d.size * dt)  # the Hann window's main lobe: +/-2 bins
    near = (freq >= min(peak / TONE_BAND, peak - lobe)) & (
        freq <= max(peak * TONE_BAND, peak + lobe)
    )
    return peak if float(np.sum(power[near])) >= TONE_SHARE * float(np.sum(power)) else None
