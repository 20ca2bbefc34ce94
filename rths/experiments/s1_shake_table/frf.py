"""Frequency response functions from stepped-sine records, normalised as S1 Eq.7.

S1 §3: at each step of a stepped sine the response settles (20 cycles per step) and the FRF
ordinate is "the maximum stationary value of the response magnitude" at that frequency, normalised
by the same measure of the table acceleration (S1 Eq.7)::

    Ĥ_p(f) = H_p(f) / H_üG(f),   p = u_I, ü_I^(tot), F_I, u_TI, ü_T^(tot), F_T, u_T, ü_T, F_B

so ``Ĥ`` of a displacement is in s², of an acceleration dimensionless, of a force in kg.  Two
amplitude measures over the last ``steady_cycles`` cycles of each step are offered:

``"peak"``      ``max |x|`` (S1 §3.1), sensitive to impacts (backlash) and offsets;
``"harmonic"``  the first-harmonic amplitude, a least-squares fit of ``a sin ωt + b cos ωt + c``
                (exact for a sinusoid over any window length; equals the linear FRF's modulus).

Resonance frequencies are read off the normalised FRFs (:func:`resonance`,
:func:`second_resonance`) and two FRFs on the same grid are compared by the normalised RMS error of
their moduli (:func:`frf_nrmse`, the J2 definition of :mod:`rths.metrics`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import scipy.signal
from numpy.typing import ArrayLike, NDArray

from rths.core.errors import ParameterError, check_positive, format_choices

__all__ = [
    "AMPLITUDE_METHODS",
    "FRF",
    "Resonance",
    "estimate_frf",
    "frf_nrmse",
    "resonance",
    "second_resonance",
    "steady_state_amplitude",
    "steady_state_windows",
]

AMPLITUDE_METHODS = ("peak", "harmonic")


@dataclass(frozen=True)
class FRF:
    """Steady-state amplitudes of one stepped-sine run on ascending frequencies.

    Attributes
    ----------
    frequency
        Step frequencies [Hz], ascending, shape ``(n,)``.
    excitation
        ``H_üG``: table acceleration amplitude per step [m/s²], shape ``(n,)``.
    response
        ``H_p``: amplitude per step of each response quantity (SI), each of shape ``(n,)``.
    """

    frequency: NDArray[np.float64]
    excitation: NDArray[np.float64]
    response: Mapping[str, NDArray[np.float64]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        f = np.asarray(self.frequency, dtype=float)
        if f.ndim != 1 or f.size == 0 or np.any(np.diff(f) <= 0.0):
            raise ParameterError(f"FRF frequencies must be ascending and 1-D; got {f!r}")
        exc = np.asarray(self.excitation, dtype=float)
        if exc.shape != f.shape or np.any(exc <= 0.0):
            raise ParameterError(
                f"FRF excitation must be positive with shape {f.shape}; got {exc!r}"
            )
        for name, values in self.response.items():
            if np.shape(values) != f.shape:
                raise ParameterError(
                    f"FRF response {name!r} must have shape {f.shape}; got {np.shape(values)}"
                )

    @property
    def channels(self) -> tuple[str, ...]:
        """Names of the response quantities."""
        return tuple(self.response)

    def normalised(self, name: str) -> NDArray[np.float64]:
        """``Ĥ_p = H_p / H_üG`` (S1 Eq.7) of the quantity ``name``."""
        if name not in self.response:
            raise ParameterError(
                f"FRF channel must be one of {format_choices(self.channels)}; got {name!r}"
            )
        return np.asarray(self.response[name]) / np.asarray(self.excitation)


@dataclass(frozen=True, slots=True)
class Resonance:
    """A peak of a normalised FRF: frequency [Hz] and ordinate (units of the channel).

    Attributes
    ----------
    frequency : float
        Step frequency [Hz] of the peak.
    value : float
        The normalised FRF ``Ĥ_p = H_p / H_üG`` (S1 Eq.7) there, in the unit of the channel
        (``s²`` for displacements, ``-`` for accelerations, ``kg`` for forces).
    """

    frequency: float
    value: float


def steady_state_windows(
    boundaries: ArrayLike, frequencies: ArrayLike, dt: float, n_samples: int, cycles: float
) -> list[slice]:
    """Sample ranges of the last ``cycles`` cycles of each step.

    The window of step ``k`` holds the samples with
    ``boundaries[k+1] - cycles / f_k <= t_n < boundaries[k+1]``.

    Parameters
    ----------
    boundaries
        Step boundaries [s], shape ``(n + 1,)``: step ``k`` spans
        ``[boundaries[k], boundaries[k+1])``.
    frequencies
        Step frequencies [Hz], shape ``(n,)``.
    dt
        Sampling step [s]; samples are at ``t_n = n dt``.
    n_samples
        Record length; windows are clipped to it.
    cycles
        Cycles per window, ``0 < cycles <=`` the cycles of every step.

    Returns
    -------
    list of slice
        One sample range per step, in playing order.
    """
    dt = check_positive(dt, "time step dt")
    cycles = check_positive(cycles, "steady cycles")
    b = np.asarray(boundaries, dtype=float)
    f = np.asarray(frequencies, dtype=float)
    if b.shape != (f.size + 1,):
        raise ParameterError(f"boundaries must have shape ({f.size + 1},); got {b.shape}")
    if np.any(cycles / f > np.diff(b) * (1.0 + 1e-9)):
        raise ParameterError(f"steady cycles {cycles!r} exceed the cycles of a step")
    windows = []
    for k in range(f.size):
        hi = min(math.ceil(b[k + 1] / dt - 1e-9), n_samples)
        lo = math.ceil((b[k + 1] - cycles / f[k]) / dt - 1e-9)
        if hi - lo < 3:
            raise ParameterError(
                f"the steady window of step {k} ({f[k]:g} Hz) has {hi - lo} samples; "
                "use a smaller dt or more steady cycles"
            )
        windows.append(slice(lo, hi))
    return windows


def steady_state_amplitude(
    x: ArrayLike, window: slice, frequency: float, dt: float, method: str = "peak"
) -> float:
    """Amplitude of a record over a window of samples.

    Parameters
    ----------
    x
        Record sampled at ``t_n = n dt`` (any unit), shape ``(N,)``.
    window
        Sample range (from :func:`steady_state_windows`).
    frequency
        Excitation frequency [Hz] (used by ``"harmonic"``).
    dt
        Sampling step [s].
    method
        ``"peak"``: ``max |x|`` (S1 §3.1); ``"harmonic"``: first-harmonic amplitude of a
        least-squares fit ``a sin ωt + b cos ωt + c``.
    """
    if method not in AMPLITUDE_METHODS:
        raise ParameterError(
            f"amplitude method must be one of {format_choices(AMPLITUDE_METHODS)}; got {method!r}"
        )
    seg = np.asarray(x, dtype=float)[window]
    if method == "peak":
        return float(np.max(np.abs(seg)))
    t = np.arange(window.start, window.start + seg.size) * dt
    w = 2.0 * np.pi * frequency
    basis = np.column_stack([np.sin(w * t), np.cos(w * t), np.ones_like(t)])
    coef, *_ = np.linalg.lstsq(basis, seg, rcond=None)
    return float(math.hypot(coef[0], coef[1]))


def estimate_frf(
    signals: Mapping[str, ArrayLike],
    excitation: ArrayLike,
    frequencies: ArrayLike,
    boundaries: ArrayLike,
    dt: float,
    steady_cycles: float = 5.0,
    method: str = "peak",
) -> FRF:
    """FRF of a stepped-sine record (S1 Eq.7 amplitudes; the steps may be in any order).

    Parameters
    ----------
    signals
        Response histories sampled at ``t_n = n dt`` (SI), each of shape ``(N,)``.
    excitation
        Measured table acceleration ``ü_G`` [m/s²], shape ``(N,)``.
    frequencies, boundaries
        Step frequencies [Hz] in playing order, shape ``(n,)``, and step boundaries [s],
        shape ``(n + 1,)``.
    dt
        Sampling step [s].
    steady_cycles
        Number of final cycles of each step over which the amplitude is taken.
    method
        ``"peak"`` or ``"harmonic"`` (module docstring).
    """
    ag = np.asarray(excitation, dtype=float)
    f = np.asarray(frequencies, dtype=float)
    windows = steady_state_windows(boundaries, f, dt, ag.size, steady_cycles)
    order = np.argsort(f)
    if np.any(np.diff(f[order]) <= 0.0):
        raise ParameterError("step frequencies must be distinct to form an FRF")

    def amplitudes(x: NDArray[np.float64]) -> NDArray[np.float64]:
        values = [steady_state_amplitude(x, w, fk, dt, method) for w, fk in zip(windows, f)]
        return np.asarray(values)[order]

    response = {}
    for name, x in signals.items():
        arr = np.asarray(x, dtype=float)
        if arr.shape != ag.shape:
            raise ParameterError(f"signal {name!r} must have shape {ag.shape}; got {arr.shape}")
        response[name] = amplitudes(arr)
    return FRF(f[order], amplitudes(ag), response)


def _band_mask(frequency: NDArray[np.float64], band: tuple[float, float] | None) -> NDArray:
    if band is None:
        return np.ones(frequency.shape, dtype=bool)
    lo, hi = band
    mask = (frequency >= lo) & (frequency <= hi)
    if not np.any(mask):
        raise ParameterError(f"no FRF frequency inside the band {band!r} Hz")
    return mask


def resonance(frf: FRF, channel: str = "u_I", band: tuple[float, float] | None = None) -> Resonance:
    """The highest ordinate of a normalised FRF.

    Parameters
    ----------
    frf
        The FRF.
    channel
        Quantity whose ``Ĥ`` (S1 Eq.7) is searched; ``"u_I"`` gives ``f0``/``f1`` (S1 §3.1).
    band
        ``(lo, hi)`` [Hz] to search in; the whole grid by default.
    """
    h = frf.normalised(channel)
    mask = _band_mask(frf.frequency, band)
    i = np.flatnonzero(mask)[np.argmax(h[mask])]
    return Resonance(float(frf.frequency[i]), float(h[i]))


def second_resonance(frf: FRF, above: float, channel: str = "a_I_tot") -> Resonance | None:
    """The most prominent local maximum of ``Ĥ_channel`` above ``above`` [Hz] (None if none).

    With a TMDI the second resonance ``f2`` "is mostly evident in the acceleration response of
    the primary and secondary mass" (S1 §3.2); ``above`` is typically ``f1``.  Peaks are
    :func:`scipy.signal.find_peaks` maxima (end points excluded) ranked by prominence.

    Parameters
    ----------
    frf
        The FRF.
    above
        Only peaks above this frequency [Hz] count.
    channel
        Quantity whose ``Ĥ`` (S1 Eq.7) is searched.
    """
    h = frf.normalised(channel)
    peaks, props = scipy.signal.find_peaks(h, prominence=0.0)
    keep = frf.frequency[peaks] > above
    if not np.any(keep):
        return None
    i = peaks[keep][np.argmax(props["prominences"][keep])]
    return Resonance(float(frf.frequency[i]), float(h[i]))


def frf_nrmse(
    reference: FRF, other: FRF, channel: str, band: tuple[float, float] | None = None
) -> float:
    """``RMS(|Ĥ_other| - |Ĥ_ref|) / RMS(|Ĥ_ref|)`` over the common grid (inside ``band`` [Hz]).

    The definition is J2 of :mod:`rths.metrics` with the FRF moduli in place of displacement
    histories (computed here: a band may hold fewer points than the metrics' minimum record
    length).

    Parameters
    ----------
    reference
        The experiment-like FRF (here the rack-and-pinion model).
    other
        The FRF compared with it, on the same grid.
    channel
        Quantity compared (S1 Eq.7 name).
    band
        ``(lo, hi)`` [Hz]; the whole grid by default.
    """
    if reference.frequency.shape != other.frequency.shape or not np.allclose(
        reference.frequency, other.frequency, rtol=0.0, atol=1e-9
    ):
        raise ParameterError("FRFs compared by NRMSE must share the same frequency grid")
    mask = _band_mask(reference.frequency, band)
    ref = reference.normalised(channel)[mask]
    diff = other.normalised(channel)[mask] - ref
    return float(np.sqrt(np.mean(diff * diff) / np.mean(ref * ref)))
