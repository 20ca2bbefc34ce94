"""The emulated lab's converters compiled with numba (private to :mod:`plants.lab`).

:func:`convert_counting` is :func:`plants.lab.convert` on one channel of a constants table, with
the saturation counted in place: three per loop step (the DAC and the two ADCs) cost about
1.5 us as Python calls and a fraction of that compiled.  The arithmetic is the same operations in
the same order (the code is kept as a float; below ``2**53`` that is the Python integer exactly),
so the two agree bit for bit; :func:`plants.lab.convert` stays the reference
(``EmulatedLab(use_jit=False)``) and ``tests/test_lab.py`` compares them.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["convert_counting"]


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
