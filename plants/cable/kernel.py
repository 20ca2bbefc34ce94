"""The cable's whole step as one compiled call (private to plants.cable.model).

:class:`plants.cable.model.Cable` keeps its operator, state and outputs in three flat arrays so
that a loop step is one dispatch: :func:`cable_step` advances the Newmark state
(:func:`plants.cable.newmark.step_kernel`) and evaluates what the loop and the log read every
step -- the interface kinematics, the nominal device's force and the midspan displacement --
into a small output array.  The same outputs come from :func:`outputs_reference` in plain
Python (the oracle; ``tests/test_cable.py`` checks the two agree bit for bit).

Layouts
-------
``ops``    shape ``(7, n)``: ``M`` diagonal, ``M`` off-diagonal (padded), ``C`` diagonal, ``C``
           off-diagonal (padded), the diagonal of the effective matrix's Cholesky factor, its
           sub-diagonal (padded), the load shape [N].
``state``  shape ``(2, 4, n)``: two buffers (current and next, by ``parity``) of ``u`` [m],
           ``v`` [m/s], ``a`` [m/s^2] and the flywheel ``(x, x', x'')`` in the first three
           entries of the fourth row.
``params`` :data:`PARAMS` in order.
``out``    :data:`OUTPUTS` in order.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from plants.cable.newmark import step_kernel

__all__ = ["OUTPUTS", "PARAMS", "cable_loop_step", "cable_step", "outputs_reference"]

#: The constants of one cable (``params``), in order: step [s], series branch ``k_s`` [N/m],
#: ``m_s`` [kg], ``c_s`` [N s/m], ``D`` [N/m] (:class:`plants.cable.device.SeriesCondensation`),
#: rigid device ``m_r`` [kg], ``c_r`` [N s/m], ``k_r`` [N/m], 1.0 with a device (else 0.0), the
#: free-node index left of midspan in mesh numbering and the interpolation weight to the next.
PARAMS = ("h", "k_s", "m_s", "c_s", "D", "m_r", "c_r", "k_r", "device", "mid_node", "mid_weight")

#: What :func:`cable_step` writes into ``out``, in order.
OUTPUTS = (
    "interface_displacement",
    "interface_velocity",
    "interface_acceleration",
    "midspan_displacement",
    "device_force",
    "flywheel_displacement",
    "flywheel_velocity",
)


@njit(cache=True)
def _outputs(
    u: NDArray[np.float64],
    v: NDArray[np.float64],
    a: NDArray[np.float64],
    fly: NDArray[np.float64],
    params: NDArray[np.float64],
    index: int,
    out: NDArray[np.float64],
) -> None:  # pragma: no cover - compiled; covered through outputs_reference
    n = u.size
    out[0] = u[index]
    out[1] = v[index]
    out[2] = a[index]
    node, weight = int(params[9]), params[10]
    left = 0.0 if node == 0 or node == n + 1 else u[node - 1]
    right = 0.0 if node + 1 == 0 or node + 1 == n + 1 else u[node]
    out[3] = (1.0 - weight) * left + weight * right
    force = 0.0
    if params[8] > 0.0:
        force = params[5] * a[index] + params[6] * v[index]
        force += params[7] * u[index]
        if params[1] > 0.0:
            force += params[1] * (u[index] - fly[0])
    out[4] = force
    out[5] = fly[0]
    out[6] = fly[1]


@njit(cache=True)
def cable_step(
    ops: NDArray[np.float64],
    state: NDArray[np.float64],
    parity: int,
    params: NDArray[np.float64],
    index: int,
    load_scale: float,
    point_force: float,
    out: NDArray[np.float64],
) -> None:  # pragma: no cover - compiled; covered through the cross-check with the Python path
    """Advance ``state[parity]`` to ``state[1 - parity]`` and write :data:`OUTPUTS` of it.

    Parameters
    ----------
    ops, state, params, out
        The arrays of the module docstring.
    parity
        Which buffer of ``state`` holds the current state (0 or 1).
    index
        The damper (interface) node among the free nodes.
    load_scale
        ``sin(omega t_{k+1})``: the distributed load is ``load_scale * ops[6]`` [N].
    point_force
        Force [N] on the interface node at ``t_{k+1}`` (minus the device's restoring force).
    """
    now, nxt = state[parity], state[1 - parity]
    step_kernel(
        ops[0],
        ops[1],
        ops[2],
        ops[3],
        ops[4],
        ops[5],
        params[0],
        now[0],
        now[1],
        now[2],
        ops[6],
        load_scale,
        index,
        point_force,
        params[1:5],
        now[3],
        nxt[0],
        nxt[1],
        nxt[2],
        nxt[3],
    )
    _outputs(nxt[0], nxt[1], nxt[2], nxt[3], params, index, out)


def outputs_reference(
    u: NDArray[np.float64],
    v: NDArray[np.float64],
    a: NDArray[np.float64],
    fly: NDArray[np.float64],
    params: NDArray[np.float64],
    index: int,
    out: NDArray[np.float64],
) -> None:
    """:data:`OUTPUTS` of the state ``(u, v, a, fly)`` in plain Python (the kernel's oracle).

    Parameters
    ----------
    u, v, a
        Nodal displacement [m], velocity [m/s], acceleration [m/s^2] of the free nodes.
    fly
        The flywheel's ``(x, x', x'')``.
    params
        :data:`PARAMS`.
    index
        The interface node among the free nodes.
    out
        Receives :data:`OUTPUTS`.
    """
    n = u.size
    node, weight = int(params[9]), float(params[10])

    def full(j: int) -> float:  # a mesh node's displacement, fixed ends included
        return 0.0 if j in (0, n + 1) else float(u[j - 1])

    force = 0.0
    if params[8] > 0.0:
        force = params[5] * a[index] + params[6] * v[index]
        force += params[7] * u[index]
        if params[1] > 0.0:
            force += params[1] * (u[index] - fly[0])
    out[:] = (
        u[index],
        v[index],
        a[index],
        (1.0 - weight) * full(node) + weight * full(node + 1),
        force,
        fly[0],
        fly[1],
    )


@njit(cache=True)
def cable_loop_step(
    ops: NDArray[np.float64],
    params: NDArray[np.float64],
    cfg: NDArray[np.float64],
    state: NDArray[np.float64],
    out: NDArray[np.float64],
    counters: NDArray[np.float64],
    force: float,
) -> None:  # pragma: no cover - compiled; covered through the loop's compiled-path cross-check
    """``Cable.step(force)`` for the loop's fused kernel: the load factor of S0 Eq.22 at
    ``t_{k+1}``, :func:`cable_step`, the buffer swap and the step count.

    Parameters
    ----------
    ops, params, state, out
        The arrays of the module docstring.
    cfg
        The interface node's index, the load's angular frequency [rad/s], when the load stops
        [s] (inf: never) and the step ``dt`` [s].
    counters
        The step count and the parity of the current buffer (updated).
    force
        The correction force [N] on the interface (the cable receives minus it).
    """
    steps, parity, dt = counters[0], int(counters[1]), cfg[3]
    load_scale = math.sin(cfg[1] * (steps + 1.0) * dt)
    if (steps + 1.0) * dt > cfg[2]:
        load_scale = 0.0
    cable_step(ops, state, parity, params, int(cfg[0]), load_scale, -force, out)
    counters[0] = steps + 1.0
    counters[1] = 1.0 - counters[1]
