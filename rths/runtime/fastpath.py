"""The ``fast`` clock's compiled path: blocks of loop steps in one numba call.

:meth:`rths.runtime.loop.Loop.run` asks :meth:`FusedPlan.of` for a plan before it starts.  There
is one when the run is not paced, the link is in process and offers its parts
(:meth:`rths.runtime.loop.InProcessLink.fused`) and every component offers a compiled step
(:mod:`rths.core.compiled`) of a family the fused kernel knows (:mod:`rths.runtime.fused_kernel`:
cable, LQG/FF+LQG/FF, command guard, lab with a transfer-function actuator and an IMD model,
low-pass force filter).  Otherwise -- any other component, a paced clock, a link over zenoh --
the loop runs its Python path, unchanged.

The plan runs the loop in *segments*: up to the end of the loop's row block (and of the
specimen topic's block, and of the lab's block of noise draws, which it refills where the lab
would), one kernel call each.  Between segments it hands full blocks to the sinks, reports
progress and honours a stop request.  A segment that would stop the run or raise (a non-finite
value, the stroke interlock, the guard tripping) is rolled back -- each call starts from a copy
of every state array -- and the Python path runs from the segment's first step: same stop, same
message, same exception, at the same step.  After the compiled steps every component gets its
state back (``commit``), so the ramp-down and everything after the run see the Python path's
state exactly.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

import numpy as np

from rths.core.channels import RowBlock
from rths.core.compiled import CompiledStep
from rths.runtime.fused_kernel import run_steps

__all__ = ["FusedPlan", "RowSink"]

#: Steps between progress reports (as the Python path).
PROGRESS_EVERY = 256

#: The compensator families and their ``ctrl_*`` columns.
_COMPENSATORS = {"lqg": 6, "ff": 1}
_LAB_COLUMNS = {"imd_internal": 12 + 9, "imd_simplified": 12 + 2}


class RowSink(Protocol):
    """Where an in-process link records the lab's rows (the specimen topic)."""

    def current(self) -> RowBlock:
        """The block being filled (its ``count`` rows are taken)."""
        ...

    def flush(self) -> None:
        """Hand the filled rows on and start a new block."""
        ...


def _offer(part: object) -> CompiledStep | None:
    offer = getattr(part, "compiled_step", None)
    return offer() if offer is not None else None


class FusedPlan:
    """The compiled steps of one run's components (build with :meth:`of`).

    Parameters
    ----------
    steps
        The compiled steps: substructure, compensator, lab, guard (or None), force filter (or
        None).
    lab
        The emulated lab (its noise is drawn through :meth:`plants.lab.EmulatedLab.draw_noise`).
    rows
        Where the lab's rows go, or None.
    constants
        The loop's :data:`rths.runtime.fused_kernel.LOOP_CONSTANTS`.
    """

    def __init__(
        self,
        steps: tuple[CompiledStep | None, ...],
        lab: Any,
        rows: RowSink | None,
        constants: np.ndarray,
    ) -> None:
        self.steps = tuple(s for s in steps if s is not None)
        sub, comp, lab_step, guard, filt = steps
        assert sub is not None and comp is not None and lab_step is not None
        self.lab, self.rows = lab, rows
        self.loop_s = np.zeros(3)
        none = np.zeros((1, 6)), np.zeros((1, 2))
        guard_arrays = (guard.constants[0], guard.state[0]) if guard else (np.zeros(4),) * 2
        filt_arrays = (filt.constants[0], filt.state[0]) if filt else none
        table, a, b, c, d, cfg, spec_c = lab_step.constants
        noise, saturations, lab_s, z, y, act_s, spec_s = lab_step.state
        self._noise, self._lab_s = noise, lab_s
        self._args = (
            constants, self.loop_s, *sub.constants, *sub.state, *comp.constants, *comp.state,
            *guard_arrays, *filt_arrays, table, noise, saturations, lab_s, a, b, c, d, cfg,
            z, y, act_s, spec_c, spec_s,
        )  # fmt: skip
        # what a rolled-back segment restores (the noise block is only read)
        self._state = [x for s in self.steps for x in s.state if x is not noise]
        self._state.append(self.loop_s)

    @classmethod
    def of(cls, loop: Any) -> FusedPlan | None:
        """The plan for ``loop`` (a :class:`rths.runtime.loop.Loop`), or None when any part has
        no compiled step the fused kernel knows (the Python path runs then).

        Parameters
        ----------
        loop
            The loop, before it runs.
        """
        fused = getattr(loop.link, "fused", None)
        parts = fused() if fused is not None and not loop.pacer.paced else None
        if parts is None:
            return None
        lab, guard, rows = parts
        filt = loop.force_filter
        steps = (
            _offer(loop.substructure),
            _offer(loop.compensator),
            _offer(lab),
            None if guard is None else _offer(guard),
            None if filt is None else _offer(filt),
        )
        sub, comp, lab_step = (s.family if s is not None else "" for s in steps[:3])
        if (
            (sub, lab_step) != ("cable", "lab_tf_imd")
            or comp not in _COMPENSATORS
            or (guard is not None and steps[3] is None)
            or (filt is not None and steps[4] is None)
        ):
            return None
        c0, c1 = loop._comp_cols
        s0, s1 = loop._sub_cols
        series = steps[2].constants[-1][0] != 0.0  # type: ignore[union-attr]
        width = _LAB_COLUMNS["imd_internal" if series else "imd_simplified"]
        if c1 - c0 != _COMPENSATORS[comp] or s1 - s0 > 4:
            return None
        if rows is not None and rows.current().values.shape[1] != width:
            return None
        constants = np.array(
            [
                loop.scaling.displacement,
                loop.scaling.force,
                loop.dt,
                loop.command_limit,
                float(filt is not None),
                float(guard is not None),
                float(s1 - s0),
                float(comp == "ff"),
                float(c1 - c0),
            ]
        )
        return cls(steps, lab, rows, constants)

    def commit(self) -> None:
        """Write the compiled state back into every component."""
        for step in self.steps:
            step.commit()

    def run(
        self,
        loop: Any,
        block: RowBlock,
        progress: Callable[[int], None] | None,
        timing: Callable[[int, int, int], None],
    ) -> tuple[int, RowBlock, int, tuple[float, float, float], str | None]:
        """Run the loop's steps from 0 until the end, a stop request or a step the Python path
        must take.

        Parameters
        ----------
        loop
            The loop (its ``n_steps``, ``block_rows``, ``sink``, ``channels`` and stop event).
        block
            The loop's first, empty row block.
        progress
            ``progress(k)`` every :data:`PROGRESS_EVERY` steps, or None.
        timing
            ``timing(k, count, start_ns)`` after each segment (the pacer's accounting).

        Returns
        -------
        tuple
            The next step, the row block being filled and its next row, the measurement,
            force and correction the next step uses, and the stop reason (None: none).
        """
        n, rows, now = loop.n_steps, loop.block_rows, loop.pacer.now_ns
        noise_rows, lab_s = self._noise.shape[0], self._lab_s
        empty = RowBlock((), 0)
        k = i = 0
        stopped: str | None = None
        try:
            while k < n:
                if loop._stop.is_set():
                    stopped = loop._stop_reason
                    break
                if lab_s[0] == noise_rows:  # the lab draws its next block of noise here
                    self.lab.draw_noise()
                    lab_s[0] = 0.0
                truth = empty if self.rows is None else self.rows.current()
                count = min(rows - i, n - k, noise_rows - int(lab_s[0]))
                count = min(count, PROGRESS_EVERY - k % PROGRESS_EVERY)
                if self.rows is not None:
                    count = min(count, truth.seq.size - truth.count)
                saved = [x.copy() for x in self._state]
                start = now()
                done = run_steps(
                    k, count, i, block.values, block.seq, block.t_ns,
                    truth.count, truth.values, truth.seq, truth.t_ns, *self._args,
                )  # fmt: skip
                if done < count:  # the Python path takes it from the segment's first step
                    for x, copy in zip(self._state, saved, strict=True):
                        x[...] = copy
                    break
                timing(k, count, start)
                k += count
                i += count
                if self.rows is not None:
                    truth.count += count
                    if truth.count == truth.seq.size:
                        self.rows.flush()
                if i == rows:
                    block.count = i
                    loop.sink(block)
                    block = RowBlock(loop.channels, rows)
                    i = 0
                if progress is not None and k % PROGRESS_EVERY == 0:
                    progress(k)
        finally:  # the components get their state back however the segments end
            self.commit()
        measured, force, fed = self.loop_s.tolist()
        return k, block, i, (measured, force, fed), stopped
