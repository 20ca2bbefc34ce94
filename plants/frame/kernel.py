"""The benchmark frame's step as one compiled call (private to :mod:`plants.frame.substructure`).

:class:`plants.frame.substructure.FrameSubstructure` advances its six states by one product
``[z_{k+1}; a_1] = G [z_k; a_g,k; a_g,k+1; F_held]`` (exact FOH/ZOH stepping,
:mod:`plants.frame._discrete`).  As NumPy expressions (assemble the input, ``G @ w``, slice, box
the floats) that is several microseconds of dispatch per loop step; :func:`frame_step` does the
same arithmetic in one compiled call and also writes what the loop and the log read (the
interface kinematics, the floor displacements and the ground acceleration at the new time).
The NumPy path stays in ``FrameSubstructure._advance`` as the reference (``use_jit=False``);
``tests/test_vrths_frame_kernel.py`` compares the two step for step (they differ only in the
summation order of the 9-term products, BLAS against left to right).

Layouts
-------
``g``      shape ``(7, 9)``: rows 0-5 the state update, row 6 floor 1's acceleration.
``ag``     the sampled ground acceleration [m/s^2] (the last value is held beyond its end).
``state``  shape ``(8,)``: ``z`` (floor displacements and velocities), the force held over the
           current step [N] and the force pending for the next (the *Unit Delay*) [N].
``out``    :data:`OUTPUTS` in order.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["OUTPUTS", "frame_step"]

#: What :func:`frame_step` writes into ``out``, in order: floor 1's displacement [m], velocity
#: [m/s] and acceleration [m/s^2] relative to the ground at ``t_{k+1}`` (the interface), the
#: displacements of floors 1-3 [m] and the ground acceleration [m/s^2] at ``t_{k+1}`` (the
#: logged channels :data:`plants.frame.substructure.FRAME_CHANNELS`).
OUTPUTS = ("x1", "v1", "a1", "floor_1", "floor_2", "floor_3", "ag")


@njit(cache=True)
def frame_step(
    g: NDArray[np.float64],
    ag: NDArray[np.float64],
    state: NDArray[np.float64],
    force: float,
    k: int,
    force_delay: int,
    out: NDArray[np.float64],
) -> None:  # pragma: no cover - compiled; covered through the cross-check with the NumPy path
    """Advance from ``t_k`` to ``t_{k+1}`` with the measured restoring force ``force`` [N].

    Parameters
    ----------
    g
        The step matrix ``(7, 9)``.
    ag
        Sampled ground acceleration [m/s^2].
    state
        ``[z, held, pending]``, updated in place.
    force
        Restoring force [N] measured at ``t_k``; it acts over this step (``force_delay`` 0) or
        the next (1).
    k
        Step index (the substructure's step count before this step).
    force_delay
        0 or 1 (the benchmark's *Unit Delay*).
    out
        Receives :data:`OUTPUTS`.
    """
    last = ag.size - 1
    held = state[7] if force_delay else force
    w = np.empty(9)
    for i in range(6):
        w[i] = state[i]
    w[6] = ag[min(k, last)]
    w[7] = ag[min(k + 1, last)]
    w[8] = held
    for i in range(7):
        s = 0.0
        for j in range(9):
            s += g[i, j] * w[j]
        if i < 6:
            state[i] = s
        else:
            out[2] = s
    state[6], state[7] = held, force
    out[0], out[1] = state[0], state[3]
    out[3], out[4], out[5] = state[0], state[1], state[2]
    out[6] = ag[min(k + 1, last)]
