"""The ``fast`` clock's steps fused into one numba kernel (private to :mod:`rths.runtime.fastpath`).

:func:`run_steps` runs ``count`` loop steps of :meth:`rths.runtime.loop.Loop.run` back to back
for the component families it knows -- a cable substructure (:mod:`plants.cable.kernel`), an
LQG, FF+LQG or FF compensator (:mod:`controllers.model_based._lqg_kernel`), the specimen side's
:class:`rths.runtime.guard.CommandGuard` and an emulated lab with a transfer-function actuator
driving an IMD model (:func:`plants.lab_kernel.lab_step`) -- with the optional low-pass on the
force correction (:class:`rths.core.filters.LowPass`), and writes every logged row straight into
the loop's preallocated block (:data:`rths.runtime.loop.LOOP_CHANNELS`, ``ctrl_*``, ``sub_*``)
and the lab's rows into the specimen topic's block.

The kernel releases the interpreter lock (``nogil``): it touches only the arrays it is given, and
the recorder's writer thread (JSON encoding, MCAP) runs on the other core meanwhile instead of
taking turns with the loop.

Every step is the Python path's operations in the same order (no fastmath), so the rows agree bit
for bit.  Whatever would make the Python path stop or raise -- a non-finite value anywhere, the
command outside the stroke, the guard tripping -- makes :func:`run_steps` return the number of
steps it completed before that one; the caller rolls the state back to the start of the call
and lets the Python path run from there, so stops, messages and exceptions are the Python
path's own.

Layouts
-------
``loop_c``  :data:`LOOP_CONSTANTS`;  ``loop_s``  :data:`LOOP_STATE`.
``guard_c`` :data:`GUARD_CONSTANTS`; ``guard_s`` :data:`GUARD_STATE`.
``filt_c``  the filter's second-order sections ``(n, 6)``; ``filt_z`` their state ``(n, 2)``.
The components' arrays are those of their :class:`rths.core.compiled.CompiledStep`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from controllers.model_based._lqg_kernel import ff_step, lqg_step
from plants.cable.kernel import cable_loop_step
from plants.imd.step_kernel import imd_channels
from plants.lab_kernel import lab_step

__all__ = ["GUARD_CONSTANTS", "GUARD_STATE", "LOOP_CONSTANTS", "LOOP_STATE", "run_steps"]

#: ``loop_c``: displacement and force scale factors, ``dt`` [s], the stroke interlock [m], 1.0
#: with a force filter, 1.0 with a guard, the number of ``sub_*`` columns, 1.0 for the ``ff``
#: compensator (else ``lqg``), the number of ``ctrl_*`` columns (the tail of its state).
LOOP_CONSTANTS = (
    "lam_u", "lam_f", "dt", "command_limit", "filter", "guard", "sub_columns", "ff",
    "ctrl_columns",
)  # fmt: skip
#: ``loop_s``: the measurement the next step uses [m], its force [N], the correction fed [N].
LOOP_STATE = ("measured", "force", "fed")
#: ``guard_c``: stroke [m], largest change per step [m], steps of clamping that trip, ramp step.
GUARD_CONSTANTS = ("stroke", "max_step", "trip_steps", "ramp_step")
#: ``guard_s``: the last command executed [m], the largest step [m], commands clamped, the
#: current run of clamped commands, commands ignored.
GUARD_STATE = ("last", "largest_step", "limited", "run", "ignored")

_N_OWN = 11  # len(LOOP_CHANNELS)
_N_LAB = 12  # the lab's 9 channels and the actuator's 3


@njit(cache=True)
def _guard(c: NDArray[np.float64], s: NDArray[np.float64], command: float) -> float:
    """``CommandGuard.apply`` while it has not tripped; NaN where it would trip."""
    if not abs(command) <= c[0]:
        return math.nan
    change = command - s[0]
    if abs(change) > c[1]:
        s[2] += 1.0
        s[3] += 1.0
        if s[3] >= c[2]:
            return math.nan
        command = s[0] + math.copysign(c[1], change)
    else:
        s[3] = 0.0
    step = abs(command - s[0])
    if step > s[1]:
        s[1] = step
    s[0] = command
    return command


@njit(cache=True)
def _low_pass(c: NDArray[np.float64], z: NDArray[np.float64], x: float) -> float:
    """``LowPass.__call__``: transposed direct form II, section by section."""
    for i in range(c.shape[0]):
        y = c[i, 0] * x + z[i, 0]
        z[i, 0] = c[i, 1] * x - c[i, 4] * y + z[i, 1]
        z[i, 1] = c[i, 2] * x - c[i, 5] * y
        x = y
    return x


@njit(cache=True, nogil=True)
def run_steps(
    k0: int,
    count: int,
    row0: int,
    values: NDArray[np.float64],
    seq: NDArray[np.int64],
    t_ns: NDArray[np.int64],
    truth_row0: int,
    truth: NDArray[np.float64],
    truth_seq: NDArray[np.int64],
    truth_t_ns: NDArray[np.int64],
    loop_c: NDArray[np.float64],
    loop_s: NDArray[np.float64],
    cab_ops: NDArray[np.float64],
    cab_params: NDArray[np.float64],
    cab_cfg: NDArray[np.float64],
    cab_state: NDArray[np.float64],
    cab_out: NDArray[np.float64],
    cab_counters: NDArray[np.float64],
    lqg_p: NDArray[np.float64],
    lqg_s: NDArray[np.float64],
    lqg_counter: NDArray[np.float64],
    guard_c: NDArray[np.float64],
    guard_s: NDArray[np.float64],
    filt_c: NDArray[np.float64],
    filt_z: NDArray[np.float64],
    table: NDArray[np.float64],
    noise: NDArray[np.float64],
    saturations: NDArray[np.int64],
    lab: NDArray[np.float64],
    act_a: NDArray[np.float64],
    act_b: NDArray[np.float64],
    act_c: NDArray[np.float64],
    act_d: NDArray[np.float64],
    act_cfg: NDArray[np.float64],
    act_z: NDArray[np.float64],
    act_y: NDArray[np.float64],
    act_s: NDArray[np.float64],
    spec_c: NDArray[np.float64],
    spec_s: NDArray[np.float64],
) -> int:  # pragma: no cover - compiled; covered through the cross-check with the Python path
    """Run loop steps ``k0 .. k0 + count - 1``; return how many completed (``count`` unless a
    step would stop the run or raise: see the module docstring).

    Parameters
    ----------
    k0, count
        First step and number of steps.
    row0, values, seq, t_ns
        First row and the arrays of the loop's :class:`rths.core.channels.RowBlock`.
    truth_row0, truth, truth_seq, truth_t_ns
        The same for the lab's rows (``truth`` with no columns: none are logged).
    loop_c, loop_s, guard_c, guard_s, filt_c, filt_z
        See the module docstring.
    cab_ops, cab_params, cab_cfg, cab_state, cab_out, cab_counters
        The cable's (:func:`plants.cable.kernel.cable_loop_step`).
    lqg_p, lqg_s, lqg_counter
        The compensator's (:func:`controllers.model_based._lqg_kernel.lqg_step`, or ``ff_step``)
        and its count.
    table, noise, saturations, lab, act_a, act_b, act_c, act_d, act_cfg, act_z, act_y, act_s
        The lab's and its actuator's (:func:`plants.lab_kernel.lab_step`).
    spec_c, spec_s
        The specimen's (:mod:`plants.imd.step_kernel`).
    """
    lam_u, lam_f, dt, limit = loop_c[0], loop_c[1], loop_c[2], loop_c[3]
    has_filter, has_guard, n_sub = loop_c[4] != 0.0, loop_c[5] != 0.0, int(loop_c[6])
    is_ff, n_ctrl = loop_c[7] != 0.0, int(loop_c[8])
    log0 = lqg_s.size - n_ctrl
    logged = truth.shape[1] > 0
    measured, force, fed = loop_s[0], loop_s[1], loop_s[2]
    for j in range(count):
        k = k0 + j
        # substructure.step(fed), then the target at specimen scale
        if not math.isfinite(fed):
            return j
        cable_loop_step(cab_ops, cab_params, cab_cfg, cab_state, cab_out, cab_counters, fed)
        if not math.isfinite(cab_out[0] + cab_out[1] + cab_out[2]):
            return j
        r, v, acc = cab_out[0] * lam_u, cab_out[1] * lam_u, cab_out[2] * lam_u
        # compensator.step(target, measured)
        if not math.isfinite(measured + r + v + acc):
            return j
        if is_ff:
            command = ff_step(lqg_p, lqg_s, r, v, acc)
        else:
            command = lqg_step(lqg_p, lqg_s, r, v, acc, measured)
        lqg_counter[0] += 1.0
        if not abs(command) <= limit:  # also NaN: the Python path stops or raises
            return j
        t = np.int64(np.rint((k + 1) * dt * 1e9))
        # link.exchange: the guard, then the lab
        sent = command
        if has_guard:
            sent = _guard(guard_c, guard_s, command)
            if math.isnan(sent):
                return j
        if not lab_step(
            table, noise, saturations, lab, act_a, act_b, act_c, act_d, act_cfg, act_z,
            act_y, act_s, spec_c, spec_s, sent,
        ):  # fmt: skip
            return j
        measured, force = lab[8], lab[9]
        if not (math.isfinite(measured) and math.isfinite(force)):
            return j
        fed = lam_f * force - cab_out[4]
        if has_filter:
            fed = _low_pass(filt_c, filt_z, fed)
        i = row0 + j
        values[i, 0] = t * 1e-9
        values[i, 1], values[i, 2], values[i, 3] = r, v, acc
        values[i, 4], values[i, 5], values[i, 6], values[i, 7] = command, measured, force, fed
        values[i, 8] = values[i, 9] = values[i, 10] = 0.0  # age, lag, lateness: none here
        for m in range(n_ctrl):
            values[i, _N_OWN + m] = lqg_s[log0 + m]
        for m in range(n_sub):
            values[i, _N_OWN + n_ctrl + m] = cab_out[3 + m]
        seq[i], t_ns[i] = k, t
        if logged:
            q = truth_row0 + j
            truth[q, 0] = lab[1] * act_cfg[0]
            for m in range(1, 9):
                truth[q, m] = lab[m + 1]
            truth[q, 9], truth[q, 10], truth[q, 11] = act_s[0], 0.0, act_s[1]
            imd_channels(spec_c, spec_s, truth[q, _N_LAB:])
            truth_seq[q], truth_t_ns[q] = k, t
        loop_s[0], loop_s[1], loop_s[2] = measured, force, fed
    return count
