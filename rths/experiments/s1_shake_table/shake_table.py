"""Shaking-table models for the stepped-sine emulation (private; used by
:mod:`rths.experiments.s1_shake_table.sweep`).

S1 §2.3 runs the table in displacement control.  For a target peak ground acceleration ``PGA``
at frequency ``ω`` the displacement command is a sine of amplitude ``A = PGA / ω²``; the table's
*measured* motion is what the specimen feels as ``ü_G`` and what S1 Eq.7 normalises by.

:class:`TransferFunctionTable`
    The table's displacement follows the command through a command→displacement transfer function
    ``G(s)`` identified with the specimen on the table (the form of
    :class:`plants.actuator.TransferFunctionActuator`; no control-structure interaction), the
    command being held over each sample (zero-order hold).  ``ü_G`` is the model's acceleration
    *output* ``C A² z`` of a realisation with outputs ``[C; CA; CA²]``: for a relative degree >= 3
    (e.g. :data:`plants.actuator.MTS_IDENTIFIED`) the displacement and its first two
    derivatives are continuous state outputs, so no numerical differentiation of the displacement is
    needed. The ZOH-discretised outputs are evaluated with :func:`scipy.signal.lfilter`.  With
    ``amplitude_correction`` the command amplitude of each step is divided by the discrete model's
    steady-state acceleration gain ``|H_a(e^{iωΔt})| / ω²`` -- what a table controller's
    amplitude/drive iteration (S1: Moog Replication Software) achieves -- so the table's steady
    acceleration amplitude is the target PGA.
:class:`IdealTable`
    Perfect tracking: ``ü_G`` is the analytic acceleration of the command.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import control
import numpy as np
import scipy.signal
from numpy.typing import ArrayLike, NDArray

from plants.excitation.stepped_sine import SteppedSine
from rths.core.errors import ParameterError, check_positive

__all__ = ["IdealTable", "ShakeTable", "TableMotion", "TransferFunctionTable"]


@dataclass(frozen=True)
class TableMotion:
    """Sampled table motion at ``t_n = n dt``, arrays of shape ``(N,)`` [s, m, m, m/s, m/s²].

    Attributes
    ----------
    time : numpy.ndarray
        Sample times ``t_n`` [s].
    command : numpy.ndarray
        Displacement command [m] (held over ``[t_n, t_{n+1})``).
    displacement : numpy.ndarray
        Table displacement ``u_G`` [m].
    velocity : numpy.ndarray
        Table velocity ``u̇_G`` [m/s].
    acceleration : numpy.ndarray
        Table acceleration ``ü_G`` [m/s²]: what the specimen feels and what S1 Eq.7 normalises
        by.
    """

    time: NDArray[np.float64]
    command: NDArray[np.float64]
    displacement: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]


class ShakeTable(Protocol):
    """What :mod:`rths.experiments.s1_shake_table.sweep` needs from a table model.

    Parameters
    ----------
    *args, **kwargs
        None: a protocol is not instantiated (``ShakeTable()`` raises ``TypeError``); these are
        the placeholders :class:`typing.Protocol` gives every protocol's constructor.  See
        :class:`IdealTable` and :class:`TransferFunctionTable` for the implementations.
    """

    def acceleration_gain(self, frequency: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Steady table acceleration amplitude per unit command amplitude [1/s²]."""
        ...

    def run(self, sine: SteppedSine, amplitudes: ArrayLike, dt: float) -> TableMotion:
        """Table motion for the displacement command ``-amplitudes[k] sin(...)`` [m]."""
        ...


class IdealTable:
    """A table whose motion is its command exactly (analytic derivatives)."""

    def acceleration_gain(self, frequency: ArrayLike, dt: float) -> NDArray[np.float64]:
        """``ω²`` [1/s²] at ``frequency`` [Hz] (``dt`` [s] is unused)."""
        return (2.0 * np.pi * np.asarray(frequency, dtype=float)) ** 2

    def run(self, sine: SteppedSine, amplitudes: ArrayLike, dt: float) -> TableMotion:
        """Command and motion ``d = -A_k sin(ω_k τ)``, ``ḋ = -A_k ω_k cos(ω_k τ)``,
        ``d̈ = A_k ω_k² sin(ω_k τ)`` with ``τ = t - t_k``.

        Parameters
        ----------
        sine
            The stepped sine.
        amplitudes
            Command amplitude ``A_k`` [m] per step (or a scalar).
        dt
            Sampling step [s].
        """
        t = sine.sample_times(dt)
        amp = np.broadcast_to(np.asarray(amplitudes, dtype=float), sine.frequencies.shape)
        w = 2.0 * np.pi * sine.frequencies
        d = sine.signal(t, -amp)
        # cos(x) = sin(x + π/2) is not a SteppedSine signal: evaluate the step phase directly
        bounds = sine.boundaries
        k = np.clip(np.searchsorted(bounds, t, side="right") - 1, 0, w.size - 1)
        inside = t < bounds[-1]
        v = np.where(inside, -amp[k] * w[k] * np.cos(w[k] * (t - bounds[k])), 0.0)
        a = sine.signal(t, amp * w**2)
        return TableMotion(t, d, d, v, a)


class TransferFunctionTable:
    """A table following its displacement command through ``num(s)/den(s)`` (see the module).

    Parameters
    ----------
    num, den
        Command→displacement coefficients in descending powers of ``s``; stable, relative
        degree >= 3 (so that the acceleration is a continuous state output).
    dt
        Sampling step [s] of the command (zero-order hold) and of the motion.
    """

    def __init__(self, num: ArrayLike, den: ArrayLike, dt: float) -> None:
        self.dt = check_positive(dt, "time step dt")
        n = np.trim_zeros(np.atleast_1d(np.asarray(num, dtype=float)), "f")
        d = np.trim_zeros(np.atleast_1d(np.asarray(den, dtype=float)), "f")
        if n.size == 0 or d.size == 0 or not (np.all(np.isfinite(n)) and np.all(np.isfinite(d))):
            raise ParameterError(
                f"table transfer function needs finite, non-zero num and den; got {num!r}, {den!r}"
            )
        if d.size - n.size < 3:
            raise ParameterError(
                "table transfer function must have relative degree >= 3 (acceleration as a "
                f"state output); got {d.size - n.size}"
            )
        tf = control.tf(n, d)
        poles = tf.poles()
        if np.any(poles.real >= 0.0):
            raise ParameterError(f"table transfer function is unstable: poles {poles!r} rad/s")
        ss = control.tf2ss(tf)
        a, b, c = (np.asarray(m, dtype=float) for m in (ss.A, ss.B, ss.C))
        outputs = control.ss(a, b, np.vstack([c, c @ a, c @ a @ a]), np.zeros((3, 1)))
        discrete = control.c2d(outputs, self.dt, method="zoh")
        self.num, self.den = tuple(n.tolist()), tuple(d.tolist())
        self._filters = [
            scipy.signal.ss2tf(discrete.A, discrete.B, discrete.C[i : i + 1], discrete.D[i : i + 1])
            for i in range(3)
        ]

    def acceleration_gain(
        self, frequency: ArrayLike, dt: float | None = None
    ) -> NDArray[np.float64]:
        """``|H_a(e^{iωΔt})|`` [1/s²]: steady acceleration amplitude of the sampled table per unit
        amplitude of a sampled sine command (ZOH included).

        Parameters
        ----------
        frequency
            Frequencies [Hz].
        dt
            Sampling step [s]; if given it must be the table's.
        """
        if dt is not None and not np.isclose(dt, self.dt, rtol=1e-12, atol=0.0):
            raise ParameterError(f"dt must be the table's {self.dt!r} s; got {dt!r}")
        b, a = self._filters[2]
        w = 2.0 * np.pi * np.atleast_1d(np.asarray(frequency, dtype=float)) * self.dt
        _, h = scipy.signal.freqz(b[0], a, worN=w)
        return np.abs(h)

    def run(self, sine: SteppedSine, amplitudes: ArrayLike, dt: float | None = None) -> TableMotion:
        """Sample the command ``-A_k sin(ω_k τ)`` at ``t_n`` (held to ``t_{n+1}``) and filter it;
        the motion at ``t_n`` results from the commands up to ``t_{n-1}``.

        Parameters
        ----------
        sine
            The stepped sine.
        amplitudes
            Command amplitude ``A_k`` [m] per step (or a scalar).
        dt
            Sampling step [s]; if given it must be the table's.
        """
        if dt is not None and not np.isclose(dt, self.dt, rtol=1e-12, atol=0.0):
            raise ParameterError(f"dt must be the table's {self.dt!r} s; got {dt!r}")
        t = sine.sample_times(self.dt)
        amp = np.broadcast_to(np.asarray(amplitudes, dtype=float), sine.frequencies.shape)
        command = sine.signal(t, -amp)
        d, v, a = (scipy.signal.lfilter(b[0], den, command) for b, den in self._filters)
        return TableMotion(t, command, d, v, a)
