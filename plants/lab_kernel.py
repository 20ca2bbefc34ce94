"""The emulated lab's converters compiled with numba (private to :mod:`plants.lab`).

:func:`convert_counting` is :func:`plants.lab.convert` on one channel of a constants table, with
the saturation counted in place: three per loop step (the DAC and the two ADCs) cost about
1.5 us as Python calls and a fraction of that compiled.  The arithmetic is the same operations in
the same order (the code is kept as a float; below ``2**53`` that is the Python integer exactly),
so the two agree bit for bit; :func:`plants.lab.convert` stays the reference
(``EmulatedLab(use_jit=False)``) and ``tests/test_lab.py`` compares them.

:func:`lab_step` is the whole :meth:`plants.lab.EmulatedLab.step` for a transfer-function
actuator driving an IMD model, for the loop's fused kernel (:mod:`rths.core.compiled`); its
oracle is the lab's Python step (``tests/test_fastpath.py``, row by row).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from plants.actuator.kernel import transfer_function_drive
from plants.imd.step_kernel import imd_step

__all__ = ["LAB_STATE", "convert_counting", "lab_step"]

#: State of :func:`lab_step` (``lab``): the next row of the noise block, the step count, the
#: command received and after the DAC [m], the true ``x`` [m], ``v`` [m/s], ``a`` [m/s^2] and
#: force [N], the measured displacement [m] and force [N].
LAB_STATE = ("noise_next", "steps", "command", "command_dac", "x", "v", "a", "force",
             "measured_x", "measured_force")  # fmt: skip


@njit(cache=True)
def convert_counting(
    value: float,
    noise: float,
    constants: NDArray[np.float64],
    channel: int,
    saturations: NDArray[np.int64],
) -> float:  # pragma: no cover - compiled; covered through the cross-check with plants.lab.convert
    """Quantise ``value`` [engineering units] with ``noise`` [V] on ``channel``.

    Parameters
    ----------
    value
        The value [engineering units].
    noise
        Noise [V] added before quantisation.
    constants
        One row per channel: :attr:`plants.lab.Converter.constants` as floats.
    channel
        The row.
    saturations
        Saturation counts per channel; the channel's is incremented when the code is clipped.

    Returns
    -------
    float
        The converted value [engineering units].
    """
    units_per_volt, lsb = constants[channel, 0], constants[channel, 1]
    top, resolution = constants[channel, 2], constants[channel, 3]
    code = np.floor((value / units_per_volt + noise) / lsb + 0.5)  # a float: no int64 overflow
    if code >= top:
        saturations[channel] += 1
        return (top - 1.0) * resolution
    if code < -top:
        saturations[channel] += 1
        return -top * resolution
    return code * resolution


@njit(cache=True)
def lab_step(
    table: NDArray[np.float64],
    noise: NDArray[np.float64],
    saturations: NDArray[np.int64],
    lab: NDArray[np.float64],
    a: NDArray[np.float64],
    b: NDArray[np.float64],
    c: NDArray[np.float64],
    d: NDArray[np.float64],
    cfg: NDArray[np.float64],
    z: NDArray[np.float64],
    y: NDArray[np.float64],
    act: NDArray[np.float64],
    spec_c: NDArray[np.float64],
    spec_s: NDArray[np.float64],
    command: float,
) -> bool:  # pragma: no cover - compiled; covered through the loop's compiled-path cross-check
    """:meth:`plants.lab.EmulatedLab.step` for a transfer-function actuator driving an IMD
    model (:func:`plants.actuator.kernel.transfer_function_drive`,
    :func:`plants.imd.step_kernel.imd_step`); False where the Python path would raise (a
    non-finite result): the caller then rolls back and leaves the step to it.

    Parameters
    ----------
    table, saturations
        As for :func:`convert_counting`.
    noise
        The lab's current block of noise draws [V], shape ``(rows, 3)``; row ``lab[0]`` is next
        (the caller refills the block where the lab would).
    lab
        :data:`LAB_STATE`.
    a, b, c, d, cfg, z, y, act
        The actuator's (:func:`plants.actuator.kernel.transfer_function_drive`).
    spec_c, spec_s
        The specimen's (:mod:`plants.imd.step_kernel`).
    command
        The command received [m] (finite).
    """
    row = int(lab[0])
    lab[0] = row + 1.0
    dac = convert_counting(command, noise[row, 0], table, 0, saturations)
    transfer_function_drive(a, b, c, d, cfg, z, y, act, dac)
    x, v, acc = act[2], act[3], act[4]
    if not imd_step(spec_c, spec_s, x, v, acc, cfg[0]):
        return False
    force = spec_s[6]
    act[5] = force
    act[6] += 1.0
    if not math.isfinite(x + v + acc + force):
        return False
    lab[1] += 1.0
    lab[2], lab[3] = command, dac
    lab[4], lab[5], lab[6], lab[7] = x, v, acc, force
    lab[8] = convert_counting(x, noise[row, 1], table, 1, saturations)
    lab[9] = convert_counting(force, noise[row, 2], table, 2, saturations)
    return True
