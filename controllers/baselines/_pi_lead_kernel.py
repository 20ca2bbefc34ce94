"""The benchmark's sample controller as one compiled call (private to
:mod:`controllers.baselines.pi_lead`).

:class:`controllers.baselines.pi_lead.PILeadCompensator` runs two first-order sections and four
converters per loop step: a few dozen float operations that cost about 2 us as Python calls.
:func:`pi_lead_step` does the same operations in the same order (scalar arithmetic only, so the
results are bit for bit those of the Python path, the reference kept in
``PILeadCompensator._step_impl`` with ``use_jit=False``; ``tests/test_vrths_pi_lead.py``
compares the two step for step).

Layouts
-------
``params`` :data:`PARAMS` in order.
``state``  :data:`STATE` in order.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["PARAMS", "STATE", "pi_lead_step"]

#: Constants (``params``), in order: the phase lead's ``b0, b1, a1``, the PI's ``b0, b1, a1``,
#: the converters' interval [m] (0: none) and limit [m], 1.0 for ``lookahead`` (else 0.0).
PARAMS = ("lead_b0", "lead_b1", "lead_a1", "pi_b0", "pi_b1", "pi_a1", "q", "sat", "lookahead")

#: State (``state``), in order: the sections' previous input and output (lead, PI), the
#: previous target [m], then the logged ``reference``, ``error`` and ``command`` [m].
STATE = (
    "lead_in", "lead_out", "pi_in", "pi_out", "previous_target", "reference", "error", "command"
)  # fmt: skip


@njit(cache=True)
def _round_half_away(x: float) -> float:  # pragma: no cover - compiled
    return math.copysign(math.floor(abs(x) + 0.5), x)


@njit(cache=True)
def _adc(value: float, q: float, sat: float) -> float:  # pragma: no cover - compiled
    s = min(max(value, -sat), sat)
    return q * _round_half_away(s / q) if q > 0.0 else s


@njit(cache=True)
def _dac(value: float, q: float, sat: float) -> float:  # pragma: no cover - compiled
    v = q * _round_half_away(value / q) if q > 0.0 else value
    return min(max(v, -sat), sat)


@njit(cache=True)
def pi_lead_step(
    params: NDArray[np.float64], state: NDArray[np.float64], target: float, measured: float
) -> float:  # pragma: no cover - compiled; covered through the cross-check with the Python path
    """One step of ``PILeadCompensator``; returns the command [m] and updates ``state``.

    Parameters
    ----------
    params
        :data:`PARAMS`.
    state
        :data:`STATE`, updated in place.
    target
        Target displacement for the end of the step [m].
    measured
        Latest measured displacement [m].
    """
    q, sat = params[6], params[7]
    r = target if params[8] != 0.0 else state[4]
    state[4] = target
    x = _adc(r, q, sat)
    y = params[0] * x + params[1] * state[0] - params[2] * state[1]
    state[0], state[1] = x, y
    reference = _dac(y, q, sat)
    e = _adc(reference - measured, q, sat)
    u = params[3] * e + params[4] * state[2] - params[5] * state[3]
    state[2], state[3] = e, u
    command = _dac(u, q, sat)
    state[5], state[6], state[7] = reference, e, command
    return command
