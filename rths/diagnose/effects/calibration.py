"""The actuator's nominal transfer function re-calibrated pole by pole: the model-form check.

The baseline (:class:`rths.diagnose.effects.actuator.ActuatorModel`) scales every pole and zero
frequency of NOMINAL.toml's transfer function by *one* factor and every complex pole's damping
ratio by another.  A nominal mis-calibrated within the contract's +/-10 % may be off by a
different factor at every root (design.md section 7; an identified TF's poles are not off
together), which no common factor follows: the re-calibrated baseline then leaves a
significant gap that no effect closes either.  :class:`RootwiseActuator` gives every real root
and every complex pair its own frequency factor, and every complex pole pair its own damping
factor, all within :data:`rths.diagnose.effects.actuator.CALIBRATION_TOLERANCE`, besides the
gain, the offset and the one-sample alignment of the baseline: still NOMINAL.toml's own
parameters and nothing else.  It is used only to tell model form from an unexplained gap
(:func:`rths.diagnose.search.selection.select`), never to absorb an effect a candidate names:
it is tried when no candidate effect buys its parameters, and it counts only when it does not
take on more than a sample of lag in all (:meth:`RootwiseActuator.lagging`).

Within the tolerance a pole's factor mimics at most a delay of 10 % of its own low-frequency
group delay ``1/|p|`` (``2 zeta/w`` for a pair), so a delay far beyond that sum is still no
calibration.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from rths.diagnose.channels.channel import Channel
from rths.diagnose.effects.actuator import CALIBRATION_TOLERANCE, ActuatorModel, _move, scaled_tf
from rths.diagnose.effects.model import Param, Theta

__all__ = [
    "Band",
    "RootwiseActuator",
    "absorbed_lag",
    "band_lag",
    "drive_band",
    "group_delay",
    "root_modes",
    "rootwise_tf",
]

_LO, _HI = 1.0 - CALIBRATION_TOLERANCE, 1.0 + CALIBRATION_TOLERANCE


def root_modes(coeffs: tuple[float, ...]) -> list[complex]:
    """One root per mode of a polynomial: every real root and the upper member of every
    complex pair (roots at the origin kept: they are not scaled).

    Parameters
    ----------
    coeffs
        Polynomial coefficients, descending powers of ``s``.
    """
    if len(coeffs) <= 1:
        return []
    roots = np.roots(coeffs)
    out = [complex(q) for q in roots if q.imag >= 0.0 or abs(q.imag) <= 1e-9 * abs(q)]
    return [complex(q.real, 0.0) if abs(q.imag) <= 1e-9 * abs(q) else q for q in out]


def rootwise_tf(
    num: tuple[float, ...],
    den: tuple[float, ...],
    zero_freq: list[float],
    pole_freq: list[float],
    pole_damp: list[float],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``num/den`` with every mode's frequency (and every complex pole pair's damping ratio)
    scaled by its own factor; the DC gain kept (as
    :func:`rths.diagnose.effects.actuator.scaled_tf`).

    Parameters
    ----------
    num, den
        Continuous-time transfer function, descending powers of ``s``.
    zero_freq, pole_freq
        Factor [-] per mode of :func:`root_modes` of ``num`` and of ``den``.
    pole_damp
        Factor [-] per mode of ``den`` (ignored for real modes).
    """
    new_z: list[complex] = []
    for q, f in zip(root_modes(num), zero_freq, strict=True):
        new_z += _move(np.array([q]), f, 1.0)
    new_p: list[complex] = []
    for q, f, d in zip(root_modes(den), pole_freq, pole_damp, strict=True):
        new_p += _move(np.array([q]), f, d)
    b = np.real(np.poly(new_z)) if new_z else np.array([1.0])
    a = np.real(np.poly(new_p)) if new_p else np.array([1.0])
    if den[-1] != 0.0 and num[-1] != 0.0 and a[-1] != 0.0 and b[-1] != 0.0:
        k = (num[-1] / den[-1]) / (b[-1] / a[-1])
    else:
        k = num[0] / den[0]
    return k * b, a


def _factors(
    num: tuple[float, ...], den: tuple[float, ...], theta: Theta
) -> tuple[list[float], list[float], list[float]]:
    """``(zero, pole, damping)`` factors of :func:`rootwise_tf` from a fit (1 where absent)."""
    nz, np_ = len(root_modes(num)), len(root_modes(den))
    return (
        [float(theta.get(f"zero_{i}", 1.0)) for i in range(nz)],
        [float(theta.get(f"pole_{i}", 1.0)) for i in range(np_)],
        [float(theta.get(f"damping_{i}", 1.0)) for i in range(np_)],
    )


def group_delay(b: NDArray[np.float64], a: NDArray[np.float64]) -> float:
    """Low-frequency group delay ``a_1/a_0 - b_1/b_0`` [s] of ``b(s)/a(s)`` (coefficients in
    descending powers of ``s``; 0 for a TF with a root at the origin).

    Parameters
    ----------
    b, a
        Numerator and denominator coefficients.
    """
    if a[-1] == 0.0 or b[-1] == 0.0:
        return 0.0
    ga = a[-2] / a[-1] if a.size > 1 else 0.0
    gb = b[-2] / b[-1] if b.size > 1 else 0.0
    return float(ga - gb)


#: Welch segment [samples] of :func:`drive_band`.
_BAND_SEGMENT = 4096
#: A band over which a lag is read: ``(frequency [Hz], weight [-])``.
Band = tuple[NDArray[np.float64], NDArray[np.float64]]


def drive_band(channel: Channel) -> Band | None:
    """The actuator channel's command power per frequency (Welch, pooled over records, DC
    left out): where the records can tell a delay from a pole's lag.  None when the command
    holds no power (cached on the first segment).

    Parameters
    ----------
    channel
        The actuator channel (signal ``command`` in every segment).
    """
    seg = channel.segments[0]
    if "band:f" not in seg.cache:
        grid = np.fft.rfftfreq(_BAND_SEGMENT, channel.dt)
        total = np.zeros_like(grid)
        for s in channel.segments:
            u = s.signals["command"]
            n = min(_BAND_SEGMENT, u.size)
            if n >= 16:
                f, p = signal.welch(u, fs=1.0 / s.dt, nperseg=n, detrend="constant")
                total += np.interp(grid, f, p) * u.size
        seg.cache["band:f"] = np.asarray(grid, dtype=np.float64)
        seg.cache["band:w"] = total
    f, w = seg.cache["band:f"], seg.cache["band:w"].copy()
    w[f <= 0.0] = 0.0
    return (f, w) if np.sum(w) > 0.0 else None


def band_lag(
    nominal: tuple[NDArray[np.float64], NDArray[np.float64]],
    calibrated: tuple[NDArray[np.float64], NDArray[np.float64]],
    band: Band | None,
) -> float:
    """The delay [s] a calibrated TF mimics beside the nominal one where the records hold
    power: the least-squares fit ``tau`` of ``omega tau`` to the extra phase lag
    ``arg(G_0/G)`` with the command's power per frequency as weights, ``sum(w omega phi) /
    sum(w omega^2)`` (exact for a pure delay); without a band, the change of the low-frequency
    group delay (:func:`group_delay`).  Both agree for a drive far below the poles; for a root
    far below the drive (an integral controller's slow pole-zero pair) the group delay at DC
    counts a lag that falls off as 1/omega in phase, which no delay mimics: a pair at 0.06 Hz
    mis-set apart by 7 and 9 % read 0.43 s of lag at DC under a 0-3 Hz drive (and 2.4 ms as
    a power-weighted phase delay, dominated by the lowest bins).

    Parameters
    ----------
    nominal, calibrated
        ``(num, den)`` of the two TFs (descending powers of ``s``).
    band
        :func:`drive_band` (or None).
    """
    if band is None:
        return group_delay(*calibrated) - group_delay(*nominal)
    f, w = band
    omega = 2.0 * np.pi * f[1:]
    g0 = np.polyval(nominal[0], 1j * omega) / np.polyval(nominal[1], 1j * omega)
    g = np.polyval(calibrated[0], 1j * omega) / np.polyval(calibrated[1], 1j * omega)
    phase = np.angle(g0 / g)  # the calibrated TF's extra phase lag [rad]
    return float(np.sum(w[1:] * omega * phase) / np.sum(w[1:] * omega**2))


def absorbed_lag(
    num: tuple[float, ...],
    den: tuple[float, ...],
    baseline: dict[str, float],
    band: Band | None = None,
) -> float:
    """The lag [s] the common re-calibration adds to the nominal TF where the records hold
    power (:func:`band_lag`; at low frequency without a band) under the fitted frequency and
    damping factors, plus the alignment.  A re-calibration that took on more than one sample
    of lag may hide a delay beyond the nominal (a slower pole mimics up to the tolerance's
    share of its own group delay).

    Parameters
    ----------
    num, den
        The nominal actuator TF (descending powers of ``s``).
    baseline
        The common re-calibration (``frequency_scale``, ``damping_scale``, ``alignment`` [s]).
    band
        :func:`drive_band` of the channel, or None.
    """

    f = float(baseline.get("frequency_scale", 1.0))
    z = float(baseline.get("damping_scale", 1.0))
    b, a = scaled_tf(num, den, f, z)
    b0, a0 = np.asarray(num, float), np.asarray(den, float)
    return band_lag((b0, a0), (b, a), band) + float(baseline.get("alignment", 0.0))


class RootwiseActuator(ActuatorModel):
    """The baseline with every root calibrated on its own (module docstring), optionally with
    the actuator's effects (:class:`rths.diagnose.effects.actuator.ActuatorModel`): a delay
    or a rate limit is then judged against the nominal's own parameters calibrated as
    finely as the contract allows, not only against their common factors.

    Parameters
    ----------
    effects
        Actuator effects the model holds besides the root-by-root calibration (default none).
    """

    structure = "rootwise"

    def __init__(self, effects: tuple[str, ...] = ()) -> None:
        super().__init__(effects)
        # alone, three coordinate sweeps before the refinement (the whole range, then finer
        # around the best): the roots' factors are ill-conditioned together (a slow pole-zero
        # pair moves the gain far faster than the other roots; the trust-region step stopped
        # at 900 times the truth's cost).  With an effect the search starts from this fit
        # (:mod:`rths.diagnose.search.calibrated`): sweeping the roots before the delay let
        # them take half a 5-sample delay's lag
        self.sweeps = 0 if effects else 3

    def space(self, channel: Channel) -> list[Param]:
        a = channel.nominal.actuator
        f0 = float(np.clip(self._base.get("frequency_scale", 1.0), _LO, _HI))
        d0 = float(np.clip(self._base.get("damping_scale", 1.0), _LO, _HI))
        out = [
            Param(f"zero_{i}", _LO, _HI, log=False, start=f0) for i in range(len(root_modes(a.num)))
        ]
        for i, q in enumerate(root_modes(a.den)):
            out.append(Param(f"pole_{i}", _LO, _HI, log=False, start=f0))
            if q.imag > 0.0:
                out.append(Param(f"damping_{i}", _LO, _HI, log=False, start=d0))
        if self.delay or self.limit:  # the effects' own parameters (and a delay's shift range)
            scales = ("frequency_scale", "damping_scale")
            return out + [p for p in super().space(channel) if p.name not in scales]
        start = float(np.clip(self._base.get("alignment", 0.0) / channel.dt, -1.0, 1.0))
        out.append(Param("shift", -1.0, 1.0, log=False, start=start))
        return out

    def starts(self, channel: Channel) -> list[Theta]:
        """The nominal TF (unit factors, no shift)."""
        return [{p.name: (0.0 if p.name == "shift" else 1.0) for p in self.space(channel)}]

    def lagging(self, channel: Channel, theta: Theta) -> bool:
        """Whether the fit took on a sample of lag or more: the lag the root-by-root TF adds
        to the nominal where the records hold power (:func:`band_lag`) plus the alignment.
        Each pole mimics up to 10 % of its own group delay, so a calibration that slows the
        poles by more than a sample in all may be hiding a delay and is no evidence of model
        form; one that slows some roots and speeds others by as much (the nominal off by
        different factors at different roots) is.

        Parameters
        ----------
        channel
            The actuator channel.
        theta
            The fitted factors.
        """
        a = channel.nominal.actuator
        zf, pf, pd = _factors(a.num, a.den, theta)
        num, den = rootwise_tf(a.num, a.den, zf, pf, pd)
        nominal = (np.asarray(a.num, float), np.asarray(a.den, float))
        lag = band_lag(nominal, (num, den), drive_band(channel))
        lag += float(theta.get("shift", 0.0)) * channel.dt
        return lag >= (1.0 - 1e-3) * channel.dt  # the alignment's own bound counts

    def _transfer_key(self, channel: Channel, theta: Theta) -> str:
        a = channel.nominal.actuator
        zf, pf, pd = _factors(a.num, a.den, theta)
        return f"root:{zf!r}:{pf!r}:{pd!r}"

    def _transfer(
        self, channel: Channel, theta: Theta
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        a = channel.nominal.actuator
        zf, pf, pd = _factors(a.num, a.den, theta)
        return rootwise_tf(a.num, a.den, zf, pf, pd)
