"""The compiled-step protocol: how a component hands its step to the loop's fused kernel.

The ``fast`` clock can run a whole block of loop steps inside one numba kernel
(:mod:`rths.runtime.fastpath`) when every component offers a *compiled step*: a method
``compiled_step()`` returning a :class:`CompiledStep` (or ``None`` when this instance cannot --
e.g. its reference path was asked for, or an effect the kernel does not model is switched on).

A :class:`CompiledStep` names its ``family`` (which step function of the fused kernel advances
it; the layouts of its arrays are documented beside that function, in the component's own
``kernel`` module) and holds two tuples of float64 arrays:

``constants``  never written by the kernel;
``state``      everything the step changes, scalars included (step counters, the last drive
               state, ...).  The loop copies these to roll a block back.

The arrays are the component's own wherever it keeps its state in arrays (so a compiled block
advances the object itself); scalars the object keeps as Python attributes are *exported* into
``state`` by ``compiled_step()`` and written back by ``commit()``, which the loop calls after the
compiled steps (and before it hands a step back to the Python path).  A component is then in
exactly the state the Python path would have left it in, bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

__all__ = ["CompiledStep"]


class CompiledStep(NamedTuple):
    """One component's step for the fused kernel (see the module docstring).

    Attributes
    ----------
    family : str
        Which step function runs it (e.g. ``"cable"``, ``"lqg"``, ``"imd_internal"``).
    constants : tuple of numpy.ndarray
        Read-only arrays (float64), layout by family.
    state : tuple of numpy.ndarray
        Arrays the step updates in place (float64), layout by family.
    commit : callable
        ``commit()`` writes ``state``'s scalars back into the component's attributes.
    """

    family: str
    constants: tuple[NDArray[np.float64], ...]
    state: tuple[NDArray[np.float64], ...]
    commit: Callable[[], None]
