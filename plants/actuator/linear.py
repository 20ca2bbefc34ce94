"""Linear (python-control) models behind the actuators: build, close, check, discretise.

Private helpers of :mod:`plants.actuator`; everything here runs once at construction, never
in the stepping loop.
"""

from __future__ import annotations

from dataclasses import dataclass

import control
import numpy as np
from numpy.typing import ArrayLike, NDArray

from plants.actuator.parameters import BenchmarkParameters
from rths.core.errors import ParameterError

__all__ = [
    "MAX_POLE",
    "DiscreteModel",
    "check_stable",
    "check_transfer_function",
    "close_remainder",
    "derivative_model",
    "discretise",
    "servo_hydraulic_model",
    "siso_transfer_function",
]

#: Largest pole magnitude [rad/s] of an actuator model: a million times any servo-valve's
#: bandwidth; beyond it the coefficients overflow in the compensator's design.
MAX_POLE = 1e8

#: Names of the open model's signals (inputs, then outputs).
INPUTS = ["command", "remainder_force"]
OUTPUTS = ["displacement", "velocity", "acceleration", "hydraulic_force"]


def servo_hydraulic_model(
    p: BenchmarkParameters, moving_mass: float, moving_damping: float
) -> control.StateSpace:
    """The benchmark actuator loop as a state-space model with the remainder force as an input.

    Parameters
    ----------
    p
        Actuator parameters (servo-valve, hydraulics, Delta-P gain, calibration gain).
    moving_mass
        Total mass ``m_p + m_r`` [kg] moving with the piston (piston + specimen rigid part), > 0.
    moving_damping
        Total viscous coefficient ``c_p + c_r`` [N s/m].

    Returns
    -------
    control.StateSpace
        Continuous-time, 5 states; inputs ``[command, remainder_force]`` [m, N]; outputs
        ``[displacement, velocity, acceleration, hydraulic_force]`` [m, m/s, m/s^2, N].
    """
    m, c = moving_mass, moving_damping
    valve = control.tf([p.a1_beta0], [1.0, p.beta1, p.beta2], inputs="e", outputs="q", name="valve")
    hydraulics = control.tf([1.0], [1.0, p.a3], inputs="h", outputs="F_a", name="hydraulics")
    mechanics = control.ss(
        [[0.0, 1.0], [0.0, -c / m]],
        [[0.0, 0.0], [1.0 / m, -1.0 / m]],
        [[1.0, 0.0], [0.0, 1.0], [0.0, -c / m]],
        [[0.0, 0.0], [0.0, 0.0], [1.0 / m, -1.0 / m]],
        inputs=["F_a", "remainder_force"],
        outputs=["displacement", "velocity", "acceleration"],
        name="mechanics",
    )
    calibration = control.tf([p.gain], [1.0], inputs="command", outputs="r", name="calibration")
    delta_p = control.tf([p.pressure_feedback], [1.0], inputs="F_a", outputs="dp", name="delta_p")
    flow = control.tf([p.a2], [1.0], inputs="velocity", outputs="a2v", name="flow")
    error = control.summing_junction(inputs=["r", "-displacement", "-dp"], output="e")
    continuity = control.summing_junction(inputs=["q", "-a2v"], output="h")
    model = control.interconnect(
        [valve, hydraulics, mechanics, calibration, delta_p, flow, error, continuity],
        inplist=INPUTS,
        outlist=["displacement", "velocity", "acceleration", "F_a"],
        inputs=INPUTS,
        outputs=OUTPUTS,
        name="servo_hydraulic",
    )
    return control.ss(model)


def close_remainder(
    model: control.StateSpace, remainder: float | control.LTI
) -> control.StateSpace:
    """Close the remainder-force input with a linear specimen remainder ``x -> F_rest``.

    Parameters
    ----------
    model
        The open model of :func:`servo_hydraulic_model`.
    remainder
        A stiffness [N/m] (``F_rest = k x``) or a python-control LTI model of the remainder's
        dynamic stiffness ``F_rest(s)/x(s)`` [N/m] (e.g. an inerter behind a series spring).

    Returns
    -------
    control.StateSpace
        Input ``command`` [m]; outputs as the open model.
    """
    if isinstance(remainder, control.LTI):
        rest = control.ss(remainder)
    else:
        rest = control.ss([], [], [], [[float(remainder)]])
    rest = control.ss(
        rest.A,
        rest.B,
        rest.C,
        rest.D,
        inputs="displacement",
        outputs="remainder_force",
        name="remainder",
    )
    closed = control.interconnect(
        [model, rest], inplist=["command"], outlist=OUTPUTS, inputs="command", outputs=OUTPUTS
    )
    return control.ss(closed)


def check_stable(poles: ArrayLike, what: str) -> None:
    """Raise :class:`ParameterError` naming the poles [rad/s] of ``what`` with Re >= 0.

    Parameters
    ----------
    poles
        Poles [rad/s] of a continuous-time model (real or complex; a scalar counts as one).
    what
        How the model is named in the error message.

    Raises
    ------
    ParameterError
        If a pole has a non-negative real part (marginal stability counts as unstable).
    """
    p = np.atleast_1d(np.asarray(poles, dtype=complex))
    bad = p[p.real >= 0.0]
    if bad.size:
        listed = ", ".join(f"{z.real:.4g}{z.imag:+.4g}j" for z in bad)
        raise ParameterError(f"{what} is unstable: poles with Re >= 0 at [{listed}] rad/s")


def siso_transfer_function(model: control.StateSpace) -> control.TransferFunction:
    """Transfer function of a SISO state-space model from its poles, zeros and gain.

    ``control.ss2tf`` leaves round-off coefficients (~1e-13) in the numerator's high powers,
    i.e. spurious far-away zeros that would become poles of an inverse-model compensator.
    Building the polynomials from the eigenvalues and the (generalised-eigenvalue) transmission
    zeros avoids that; the gain is matched at ``s = 1j`` rad/s.

    Parameters
    ----------
    model
        A continuous-time, single-input single-output model, e.g. :func:`close_remainder`'s
        with only its ``displacement`` output kept [m/m].

    Returns
    -------
    control.TransferFunction
        The same dynamics, input ``command`` [m], output ``displacement`` [m].
    """
    poles, zeros = model.poles(), model.zeros()
    s0 = 1.0j
    gain = complex(model(s0)) * np.prod(s0 - poles) / np.prod(s0 - zeros)
    tf = control.zpk(zeros, poles, gain.real)
    return control.tf(
        np.real(tf.num[0][0]), np.real(tf.den[0][0]), inputs="command", outputs="displacement"
    )


@dataclass(frozen=True, slots=True)
class DiscreteModel:
    """Zero-order-hold discretisation ``z+ = A z + B w``, ``y = C z + D w`` over ``step`` [s].

    Attributes
    ----------
    A, B, C, D
        Discrete state, input, output and feed-through matrices; ``z`` and ``w`` keep the units
        of the continuous model's states and inputs, ``y`` those of its outputs.
    step
        Sampling step [s] over which the input ``w`` is held.
    """

    A: NDArray[np.float64]
    B: NDArray[np.float64]
    C: NDArray[np.float64]
    D: NDArray[np.float64]
    step: float


def discretise(model: control.StateSpace, step: float) -> DiscreteModel:
    """ZOH discretisation with :func:`control.c2d` (exact for inputs held over ``step`` [s]).

    Parameters
    ----------
    model
        Continuous-time state-space model (e.g. :func:`servo_hydraulic_model`).
    step
        Sampling step [s], > 0: the loop step, or a sub-step of it.

    Returns
    -------
    DiscreteModel
        The float64 matrices of the discretised model.
    """
    d = control.c2d(model, step, method="zoh")
    return DiscreteModel(
        np.asarray(d.A, dtype=float),
        np.asarray(d.B, dtype=float),
        np.asarray(d.C, dtype=float),
        np.asarray(d.D, dtype=float),
        step,
    )


def _trim(coefficients: ArrayLike, name: str) -> NDArray[np.float64]:
    c = np.atleast_1d(np.asarray(coefficients, dtype=float))
    if c.ndim != 1 or c.size == 0 or not np.all(np.isfinite(c)):
        raise ParameterError(f"{name} must be a non-empty 1-D array of finite numbers; got {c!r}")
    nonzero = np.flatnonzero(c)
    if nonzero.size == 0:
        raise ParameterError(f"{name} must have a non-zero coefficient; got {c.tolist()!r}")
    return c[nonzero[0] :]


def check_transfer_function(
    num: ArrayLike, den: ArrayLike, what: str = "actuator transfer function"
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Validated ``(num, den)`` of a command→displacement model, leading zeros trimmed.

    Parameters
    ----------
    num, den
        Coefficients in descending powers of ``s``.
    what
        How the model is named in error messages.

    Raises
    ------
    ParameterError
        Naming ``what`` when a coefficient list is empty, all zero or not finite, the model is
        improper (``deg num > deg den``), unstable, or has a pole beyond :data:`MAX_POLE`.
    """
    n = _trim(num, f"{what}: numerator num")
    d = _trim(den, f"{what}: denominator den")
    if n.size > d.size:
        raise ParameterError(
            f"{what} must be proper (deg num <= deg den); got num of degree {n.size - 1} and den "
            f"of degree {d.size - 1}"
        )
    with np.errstate(all="ignore"):
        poles = np.roots(d / d[0]) if d.size > 1 else np.zeros(0)
    if not np.all(np.isfinite(poles)) or np.any(np.abs(poles) > MAX_POLE):
        raise ParameterError(
            f"{what} has a pole beyond {MAX_POLE:g} rad/s (or coefficients out of range): den "
            f"{d.tolist()!r}"
        )
    check_stable(poles, what)
    return n, d


def derivative_model(
    num: ArrayLike, den: ArrayLike
) -> tuple[control.StateSpace, control.TransferFunction, int]:
    """A realisation of ``num/den`` whose outputs are the displacement and two derivatives.

    Parameters
    ----------
    num, den
        Coefficients in descending powers of ``s``; proper (``deg num <= deg den``) and stable.

    Returns
    -------
    model
        Continuous state space, input ``command``, outputs ``[y, y', y'']`` as
        ``[C; CA; CA^2] z + [D; CB; CAB] u`` -- the exact derivatives inside an interval over
        which ``u`` is held (they jump where ``u`` jumps once the order reaches the relative
        degree).
    tf
        The transfer function ``num/den``.
    relative_degree
        ``deg den - deg num``.
    """
    n, d = check_transfer_function(num, den)
    tf = control.tf(n, d, inputs="command", outputs="displacement")
    ss = control.tf2ss(tf)
    A, B, C, D = (np.asarray(m, dtype=float) for m in (ss.A, ss.B, ss.C, ss.D))
    if A.size:
        C3 = np.vstack([C, C @ A, C @ A @ A])
        D3 = np.vstack([D, C @ B, C @ A @ B])
    else:  # static gain: no states, derivatives zero inside an interval
        C3 = np.zeros((3, 0))
        D3 = np.vstack([D, [[0.0]], [[0.0]]])
    model = control.ss(
        A, B, C3, D3, inputs="command", outputs=["displacement", "velocity", "acceleration"]
    )
    return model, tf, d.size - n.size
