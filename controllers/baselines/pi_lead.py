"""The vRTHS benchmark's sample controller: PI tracking control with a phase-lead pre-compensator.

Wired as the benchmark's ``controller_model.slx`` (Silva et al. 2020, companion package)::

    y_n --A/D--> G_T(z) --D/A--> y_p ;   e = y_p - x_m --A/D--> G_C(z) --D/A--> u

* ``G_T(s) = 50.8316 (s + 168.603) / (s + 8570.40)`` -- the phase lead on the reference (the
  package stores ``[50.83163360273612, 8570.397339444286] / [1, 8570.397339444286]``, so
  ``G_T(0) = 1``; the benchmark paper rounds it to ``50.8 (s + 168.6)/(s + 8570)``);
* ``G_C(s) = 2 + 95/s`` -- the PI controller on the tracking error (``pid_1``);
* both discretised with Tustin's rule at the loop rate (``F2_controller.m``:
  ``c2dm(..., dt_rths, 'tustin')``), each as ``y_k = b0 x_k + b1 x_{k-1} - a1 y_{k-1}``;
* every A/D and D/A converter saturates at +/-3.8 and quantises with interval ``2^-18``
  (``F1_input_file.m``: ``sat_limit_upper``, ``quantize_int``; the signals are in metres, so
  these act on metres), Simulink's *Quantizer* rounding half away from zero.

Timing.  The benchmark's controller acts on the numerical substructure's output *at the sample
where the command is computed*: ``u_k`` uses ``y_n(t_k)``.  The loop of this project hands a
compensator the target for the *end* of the step, ``r_{k+1}`` (:mod:`controllers.base`); so by
default this compensator keeps the previous target and feeds ``r_k`` to ``G_T``, which
reproduces the benchmark's wiring.  ``lookahead=True`` feeds ``r_{k+1}`` instead (one sample
less lag, no longer the benchmark's controller).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import control
import numpy as np
from numpy.typing import ArrayLike, NDArray

from controllers.base import Compensator
from controllers.baselines._pi_lead_kernel import PARAMS, STATE, pi_lead_step
from rths.core.channels import Channel
from rths.core.errors import ParameterError, check_nonnegative, check_positive
from rths.core.kinematics import Kinematics
from rths.core.registry import COMPENSATORS

__all__ = [
    "CHANNELS",
    "LEAD_DEN",
    "LEAD_NUM",
    "QUANTIZATION",
    "SATURATION",
    "FirstOrderSection",
    "PILeadCompensator",
    "PILeadOptions",
    "round_half_away",
    "tustin_section",
]

#: Numerator of the phase lead ``G_T(s)`` as the benchmark package stores it.
LEAD_NUM: tuple[float, float] = (50.83163360273612, 8570.397339444286)
#: Denominator of ``G_T(s)``.
LEAD_DEN: tuple[float, float] = (1.0, 8570.397339444286)
#: Quantisation interval of the benchmark's converters (``quantize_int = 1/2^18``), in metres.
QUANTIZATION: float = 2.0**-18
#: Saturation of the benchmark's converters (``sat_limit_upper = 3.8``), in metres.
SATURATION: float = 3.8

#: Declared channels of :meth:`PILeadCompensator.state` / ``write_channels``.
CHANNELS: tuple[Channel, ...] = (
    Channel("reference", "m", "phase-lead output y_p after the D/A"),
    Channel("error", "m", "tracking error y_p - x_m after the A/D"),
    Channel("command", "m", "PI output after the D/A"),
)


def round_half_away(x: float) -> float:
    """Round to the nearest integer, halves away from zero (MATLAB ``round``, Simulink
    *Quantizer*).

    Parameters
    ----------
    x
        The value to round, in any unit (e.g. a converter's input in quantisation steps [-]).

    Returns
    -------
    float
        The nearest integer, as a float with the sign of ``x`` (``-0.0`` for ``-0.4``).
    """
    return math.copysign(math.floor(abs(x) + 0.5), x)


@dataclass(frozen=True, slots=True)
class FirstOrderSection:
    """A discrete first-order section ``y_k = b0 x_k + b1 x_{k-1} - a1 y_{k-1}``.

    Attributes
    ----------
    b0, b1, a1
        Coefficients of ``(b0 + b1 z^-1) / (1 + a1 z^-1)``.
    """

    b0: float
    b1: float
    a1: float

    def dc_gain(self) -> float:
        """``(b0 + b1) / (1 + a1)`` (infinite for an integrator)."""
        den = 1.0 + self.a1
        return math.inf if den == 0.0 else (self.b0 + self.b1) / den


def tustin_section(num: ArrayLike, den: ArrayLike, dt: float) -> FirstOrderSection:
    """Tustin (bilinear) discretisation of a proper first-order ``num(s)/den(s)``.

    Computed with ``control.c2d(..., method="tustin")`` (``F2_controller.m`` uses MATLAB's
    ``c2dm(..., 'tustin')``, the same map ``s = (2/dt)(z - 1)/(z + 1)`` without prewarping).

    Parameters
    ----------
    num, den
        Coefficients in descending powers of ``s``; ``den`` of degree 1, ``num`` of degree <= 1.
    dt
        Sample period [s].
    """
    dt = check_positive(dt, "time step dt")
    n = np.atleast_1d(np.asarray(num, dtype=float))
    d = np.atleast_1d(np.asarray(den, dtype=float))
    if (
        d.size != 2
        or d[0] == 0.0
        or n.size > 2
        or not (np.all(np.isfinite(n)) and np.all(np.isfinite(d)))
    ):
        raise ParameterError(
            f"a first-order section needs den of degree 1 and num of degree <= 1; got "
            f"num={n.tolist()!r}, den={d.tolist()!r}"
        )
    tf = control.c2d(control.tf(n, d), dt, method="tustin")
    bz = np.atleast_1d(np.asarray(tf.num[0][0], dtype=float))
    az = np.atleast_1d(np.asarray(tf.den[0][0], dtype=float))
    bz = np.concatenate([np.zeros(2 - bz.size), bz]) / az[0]
    az = az / az[0]
    return FirstOrderSection(float(bz[0]), float(bz[1]), float(az[1]))


@dataclass(frozen=True)
class PILeadOptions:
    """Options of the ``pi_lead`` compensator kind (defaults: the benchmark's controller).

    Parameters
    ----------
    proportional
        PI proportional gain ``k_p`` [-] (2).
    integral
        PI integral gain ``k_i`` [1/s] (95).
    quantization
        Converter interval [m] (``2^-18``); 0 disables quantisation.
    saturation
        Converter limit [m] (3.8).
    lookahead
        Feed the phase lead the target for the end of the step (not the benchmark's wiring).
    """

    proportional: float = 2.0
    integral: float = 95.0
    quantization: float = QUANTIZATION
    saturation: float = SATURATION
    lookahead: bool = False

    def __post_init__(self) -> None:
        check_nonnegative(self.proportional, "PI proportional gain")
        check_nonnegative(self.integral, "PI integral gain")
        check_nonnegative(self.quantization, "converter quantization")
        check_positive(self.saturation, "converter saturation")


@COMPENSATORS.register("pi_lead", PILeadOptions)
class PILeadCompensator(Compensator):
    """The vRTHS benchmark's sample controller: PI on the tracking error, phase lead on the target.

    Wired as the benchmark's (module docstring), converters on every signal.

    Parameters
    ----------
    dt
        Loop step [s] (benchmark 1/4096).
    proportional, integral
        PI gains ``k_p`` [-] and ``k_i`` [1/s] of ``G_C(s) = k_p + k_i/s`` (benchmark 2, 95).
    lead_num, lead_den
        ``G_T(s)`` coefficients (benchmark :data:`LEAD_NUM`, :data:`LEAD_DEN`).
    quantization
        Converter interval [m] (benchmark ``2^-18``); 0 disables quantisation.
    saturation
        Converter limit [m] (benchmark 3.8); ``inf`` disables it.
    lookahead
        Feed ``G_T`` the target for the end of the step instead of the benchmark's current one.
    use_jit
        Step with the compiled kernel (:func:`controllers.baselines._pi_lead_kernel.pi_lead_step`,
        default; bit for bit the Python path) or in Python (the reference path).
    """

    def __init__(
        self,
        dt: float,
        *,
        proportional: float = 2.0,
        integral: float = 95.0,
        lead_num: ArrayLike = LEAD_NUM,
        lead_den: ArrayLike = LEAD_DEN,
        quantization: float = QUANTIZATION,
        saturation: float = SATURATION,
        lookahead: bool = False,
        use_jit: bool = True,
    ) -> None:
        super().__init__(dt)
        kp = check_nonnegative(proportional, "PI proportional gain")
        ki = check_nonnegative(integral, "PI integral gain")
        if kp == 0.0 and ki == 0.0:
            raise ParameterError(
                "PI controller needs a non-zero gain; got proportional=0, integral=0"
            )
        self.quantization: float = check_nonnegative(quantization, "converter quantization")
        sat = float(saturation)
        if not sat > 0.0:  # also rejects NaN; inf allowed
            raise ParameterError(f"converter saturation must be positive; got {saturation!r}")
        self.saturation: float = sat
        if not isinstance(lookahead, bool):
            raise ParameterError(f"lookahead must be true or false; got {lookahead!r}")
        self.lookahead: bool = lookahead
        self.lead: FirstOrderSection = tustin_section(lead_num, lead_den, self.dt)
        self.tracking: FirstOrderSection = tustin_section([kp, ki], [1.0, 0.0], self.dt)
        self.use_jit: bool = bool(use_jit)
        lead, pi = self.lead, self.tracking
        self._params = np.array(
            [lead.b0, lead.b1, lead.a1, pi.b0, pi.b1, pi.a1, self.quantization, self.saturation,
             1.0 if lookahead else 0.0]
        )  # fmt: skip
        assert self._params.size == len(PARAMS)
        self._state = np.zeros(len(STATE))
        self.reset()

    @classmethod
    def from_options(cls, options: PILeadOptions, *, dt: float, **_: Any) -> PILeadCompensator:
        """The ``pi_lead`` kind (it needs no nominal model)."""
        return cls(dt, proportional=options.proportional, integral=options.integral,
                   quantization=options.quantization, saturation=options.saturation,
                   lookahead=options.lookahead)  # fmt: skip

    def _reset_impl(self) -> None:
        """Back to rest: both sections' memories and the previous target are zero."""
        self._lead_in = self._lead_out = 0.0
        self._pi_in = self._pi_out = 0.0
        self._previous_target = 0.0
        self._reference = self._error = self._command = 0.0
        self._state[:] = 0.0

    def _adc(self, value: float) -> float:
        """Saturate, then quantise (the benchmark's *A/D Converter* subsystem)."""
        s = min(max(value, -self.saturation), self.saturation)
        q = self.quantization
        return q * round_half_away(s / q) if q > 0.0 else s

    def _dac(self, value: float) -> float:
        """Quantise, then saturate (the benchmark's *D/A Converter* subsystem)."""
        q = self.quantization
        v = q * round_half_away(value / q) if q > 0.0 else value
        return min(max(v, -self.saturation), self.saturation)

    def _step_impl(self, target: Kinematics, measured: float) -> float:
        if self.use_jit:
            return pi_lead_step(self._params, self._state, target.displacement, measured)
        r = target.displacement if self.lookahead else self._previous_target
        self._previous_target = target.displacement
        lead, pi = self.lead, self.tracking
        x = self._adc(r)
        y = lead.b0 * x + lead.b1 * self._lead_in - lead.a1 * self._lead_out
        self._lead_in, self._lead_out = x, y
        reference = self._dac(y)
        e = self._adc(reference - measured)
        u = pi.b0 * e + pi.b1 * self._pi_in - pi.a1 * self._pi_out
        self._pi_in, self._pi_out = e, u
        command = self._dac(u)
        self._reference, self._error, self._command = reference, e, command
        return command

    def state(self) -> dict[str, float]:
        """``reference`` (phase-lead output ``y_p``), ``error`` (``y_p - x_m`` after the A/D) and
        ``command`` [m]."""
        if self.use_jit:
            reference, error, command = self._state[5:].tolist()
            return {"reference": reference, "error": error, "command": command}
        return {"reference": self._reference, "error": self._error, "command": self._command}

    def channels(self) -> tuple[Channel, ...]:
        """:data:`CHANNELS` (the keys of :meth:`state`, with units)."""
        return CHANNELS

    def write_channels(self, out: NDArray[np.float64]) -> None:
        """Write :meth:`state`'s values into ``out`` (no dict)."""
        if self.use_jit:
            out[:] = self._state[5:]
            return
        out[0], out[1], out[2] = self._reference, self._error, self._command
