"""The actuators' steps compiled with numba (private to :mod:`plants.actuator.transfer_function`
and :mod:`plants.actuator.servo_hydraulic`).

One loop step of a linear model ``z' = A z + B u``, ``y = C z' + D u`` is a handful of products
on a 3x3 system: as NumPy expressions (``A @ z``, ``C @ z``, ``tolist``) it costs several
microseconds of dispatch, as one compiled call about one.  The NumPy expressions stay in
:meth:`plants.actuator.transfer_function.TransferFunctionActuator._step_impl` as the reference
path (``use_jit=False``); ``tests/test_actuator.py`` checks the two agree step for step.

:func:`servo_hydraulic_step` is the whole loop step of
:class:`plants.actuator.servo_hydraulic.ServoHydraulicActuator` driving a
:class:`plants.linear_specimen.LinearSpecimen`: every sub-step's stacked state/output update, the
rate limiter (Simulink *Rate Limiter*, :class:`plants.lines.RateLimiter`) and the specimen's force
``m a + c v + k x`` with the remainder fed back one sub-step late.  Its reference is the actuator's
Python ``_step_impl`` (``use_jit=False``); ``tests/test_actuator_kernel.py`` compares the two.

Layouts of :func:`servo_hydraulic_step`
---------------------------------------
``gain``   shape ``(n + 4, n + 2)``: ``[A | B_command | B_remainder]`` over
           ``[C A | C B_command + D_command | C B_remainder + D_remainder]`` (the actuator's
           stacked update, ``n`` linear states, outputs ``x, xdot, xddot, F_a``).
``state``  shape ``(n + 3,)``: the linear state ``z``, the remainder force [N], the limiter's
           output [m] and its ``limiting`` flag (+1/-1/0).
``params`` :data:`SERVO_PARAMS` in order.
``out``    :data:`SERVO_OUTPUTS` in order.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["SERVO_OUTPUTS", "SERVO_PARAMS", "servo_hydraulic_step", "state_space_step"]

#: Constants of :func:`servo_hydraulic_step` (``params``), in order: sub-steps per loop step,
#: the rigid part integrated with the piston ``m_r`` [kg], ``c_r`` [N s/m], the linear specimen's
#: ``m`` [kg], ``c`` [N s/m], ``k`` [N/m], 1.0 with a rate limiter (else 0.0), its largest change
#: per sub-step [m] and its velocity limit [m/s].
SERVO_PARAMS = ("substeps", "m_r", "c_r", "m", "c", "k", "limited", "max_change", "v_max")

#: What :func:`servo_hydraulic_step` writes into ``out``, in order: the specimen end's
#: displacement [m], velocity [m/s], acceleration [m/s^2] (after the limiter), the specimen force
#: [N], then the linear loop's outputs of the last sub-step: displacement before the limiter [m],
#: velocity [m/s], acceleration [m/s^2], hydraulic force ``F_a`` [N].
SERVO_OUTPUTS = ("x", "v", "a", "force", "x_linear", "v_linear", "a_linear", "hydraulic_force")


@njit(cache=True)
def state_space_step(
    a: NDArray[np.float64],
    b: NDArray[np.float64],
    c: NDArray[np.float64],
    d: NDArray[np.float64],
    z: NDArray[np.float64],
    u: float,
    y: NDArray[np.float64],
) -> None:  # pragma: no cover - compiled; covered through the cross-check with the NumPy path
    """Advance the state ``z`` in place to ``A z + B u`` and write ``C z + D u`` into ``y``.

    Parameters
    ----------
    a, b, c, d
        The discrete model: ``A`` (n, n), ``B`` (n,), ``C`` (p, n), ``D`` (p,).
    z
        The state (n,), updated in place.
    u
        The input held over the step.
    y
        Receives the outputs (p,) at the end of the step.
    """
    n = z.size
    new = np.empty(n)
    for i in range(n):
        s = b[i] * u
        for j in range(n):
            s += a[i, j] * z[j]
        new[i] = s
    for i in range(n):
        z[i] = new[i]
    for i in range(y.size):
        s = d[i] * u
        for j in range(n):
            s += c[i, j] * z[j]
        y[i] = s


@njit(cache=True)
def servo_hydraulic_step(
    gain: NDArray[np.float64],
    state: NDArray[np.float64],
    params: NDArray[np.float64],
    out: NDArray[np.float64],
    command: float,
) -> None:  # pragma: no cover - compiled; covered through the cross-check with the Python path
    """One loop step of the servo-hydraulic actuator with a linear specimen (module docstring).

    Parameters
    ----------
    gain
        The stacked update ``(n + 4, n + 2)``.
    state
        ``[z, remainder, limiter output, limiting]``, updated in place.
    params
        :data:`SERVO_PARAMS`.
    out
        Receives :data:`SERVO_OUTPUTS`.
    command
        The (delayed) command [m] held over the step.
    """
    n = gain.shape[1] - 2
    substeps = int(params[0])
    m_r, c_r, m, c, k = params[1], params[2], params[3], params[4], params[5]
    limited = params[6] != 0.0
    max_change, v_max = params[7], params[8]
    z = np.empty(n)
    stacked = np.empty(n + 4)
    remainder = state[n]
    x = v = a = force = 0.0
    for _ in range(substeps):
        for i in range(n):
            z[i] = state[i]
        for i in range(n + 4):
            s = 0.0
            for j in range(n):
                s += gain[i, j] * z[j]
            stacked[i] = s + gain[i, n] * command + gain[i, n + 1] * remainder
        for i in range(n):
            state[i] = stacked[i]
        x, v, a = stacked[n], stacked[n + 1], stacked[n + 2]
        if limited:  # plants.lines.RateLimiter.step, then .clip
            previous = state[n + 1]
            change = x - previous
            if change > max_change:
                x, flag = previous + max_change, 1.0
            elif change < -max_change:
                x, flag = previous - max_change, -1.0
            else:
                flag = 0.0
            state[n + 1], state[n + 2] = x, flag
            if flag != 0.0:
                v, a = flag * v_max, 0.0
            elif v > v_max:
                v, a = v_max, 0.0
            elif v < -v_max:
                v, a = -v_max, 0.0
        force = m * a + c * v + k * x
        remainder = force - m_r * a - c_r * v
    state[n] = remainder
    out[0], out[1], out[2], out[3] = x, v, a, force
    for i in range(4):
        out[4 + i] = stacked[n + i]


#: State of :func:`transfer_function_step` (``s``): the delayed command [m], the displacement
#: before the limiter [m], the drive sent to the specimen ``x`` [m], ``v`` [m/s], ``a`` [m/s^2],
#: the specimen force [N] and the step count.  Constants ``cfg``: ``dt`` [s], relative degree.
TF_STATE = ("command", "linear", "x", "v", "a", "force", "steps")


@njit(cache=True)
def transfer_function_drive(
    a: NDArray[np.float64],
    b: NDArray[np.float64],
    c: NDArray[np.float64],
    d: NDArray[np.float64],
    cfg: NDArray[np.float64],
    z: NDArray[np.float64],
    y: NDArray[np.float64],
    s: NDArray[np.float64],
    command: float,
) -> None:  # pragma: no cover - compiled; covered through the loop's compiled-path cross-check
    """:class:`plants.actuator.transfer_function.TransferFunctionActuator` up to its specimen
    (no delay line, no rate limiter): advance the model with ``command`` [m] and leave the
    drive ``(x, v, a)`` in ``s[2:5]`` (the previous drive is read from there first).

    Parameters
    ----------
    a, b, c, d
        The discrete model (:func:`state_space_step`).
    cfg
        ``dt`` [s] and the relative degree.
    z, y
        The model's state (updated) and output scratch (3,).
    s
        :data:`TF_STATE`.
    command
        The command [m] held over the step.
    """
    dt, degree = cfg[0], cfg[1]
    s[0] = command
    state_space_step(a, b, c, d, z, command, y)
    x, v, acc = y[0], y[1], y[2]
    s[1] = x
    x_old, v_old = s[2], s[3]
    if degree <= 1.0:
        v = (x - x_old) / dt
    if degree <= 2.0:
        acc = (v - v_old) / dt
    s[2], s[3], s[4] = x, v, acc
