"""The discrete state-space update of the transfer-function actuator, compiled with numba
(private to :mod:`plants.actuator.transfer_function`).

One loop step of a linear model ``z' = A z + B u``, ``y = C z' + D u`` is a handful of products
on a 3x3 system: as NumPy expressions (``A @ z``, ``C @ z``, ``tolist``) it costs several
microseconds of dispatch, as one compiled call about one.  The NumPy expressions stay in
:meth:`plants.actuator.transfer_function.TransferFunctionActuator._step_impl` as the reference
path (``use_jit=False``); ``tests/test_actuator.py`` checks the two agree step for step.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["state_space_step"]


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
