"""One run of a scenario on the ``fast`` clock, in this process, with no log: the unit of work of
campaigns (Monte Carlo, compensator comparisons, parameter studies).

:func:`run_in_process` builds the scenario's substructure, compensator and emulated lab through
:mod:`rths.config.build` (exactly as ``rths run --clock fast`` does), runs the loop and keeps the
interface signals -- and any substructure outputs asked for -- in preallocated arrays.  Nothing
is written to disk and nothing crosses zenoh, so thousands of these can run side by side in
worker processes.  A run the interlock stops is a result (``stopped`` says why), not an error.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rths.config import build
from rths.config.scenario import Scenario
from rths.core.channels import RowBlock
from rths.runtime.loop import InProcessLink, Loop, LoopResult

__all__ = ["BatchRun", "draw_lab", "run_in_process"]


@dataclass(frozen=True)
class BatchRun:
    """The signals of one in-process run (arrays cut to the steps completed).

    Attributes
    ----------
    result
        The loop's result: steps completed and why it stopped early (None: it ran to the end).
    dt
        Loop step [s].
    target, measured, force
        Interface target and measured displacement [m] and specimen force [N], specimen scale,
        shape ``(steps,)``; sample ``k`` is the end of step ``k``.
    outputs
        The substructure outputs asked for (``outputs`` of :func:`run_in_process`), e.g.
        ``midspan_displacement`` [m, prototype], same shape.
    """

    result: LoopResult
    dt: float
    target: NDArray[np.float64]
    measured: NDArray[np.float64]
    force: NDArray[np.float64]
    outputs: dict[str, NDArray[np.float64]] = field(default_factory=dict)

    @property
    def stopped(self) -> str | None:
        """Why the run stopped early (an interlock), or None."""
        return self.result.stopped


class _Keep:
    """The loop's sink: copies the kept channels of each row block into preallocated arrays."""

    def __init__(self, n: int, outputs: Sequence[str]) -> None:
        self.signals = {name: np.zeros(n) for name in ("target", "measured", "force")}
        self.outputs = {name: np.full(n, np.nan) for name in outputs}

    def __call__(self, block: RowBlock) -> None:
        k0, m = int(block.seq[0]), block.count
        for name, values in self.signals.items():
            values[k0 : k0 + m] = block.column(name)
        for name, values in self.outputs.items():
            if "sub_" + name in block.names:
                values[k0 : k0 + m] = block.column("sub_" + name)


def draw_lab(draw: int, seed: int) -> dict[str, Any]:
    """Keyword arguments of :func:`run_in_process` for a Monte-Carlo draw: the lab's generator
    ``default_rng([seed, draw])`` (perturbed specimen and actuator) and the noise seed
    ``seed + draw``.

    Parameters
    ----------
    draw
        Draw number, >= 0.
    seed
        Monte-Carlo seed.
    """
    return {"seed": seed + draw, "rng": np.random.default_rng([seed, draw])}


def run_in_process(
    scn: Scenario,
    *,
    compensator: str | None = None,
    seed: int | None = None,
    rng: np.random.Generator | None = None,
    outputs: Sequence[str] = (),
) -> BatchRun:
    """Run ``scn`` on the fast clock in this process and return its signals.

    Parameters
    ----------
    scn
        The scenario (its ``[run]`` duration and rate set the steps).
    compensator
        Compensator kind overriding the scenario's (with that kind's default options).
    seed
        Seed of the lab's converter noise (default: the scenario's ``[run] seed``).
    rng
        Generator of a Monte-Carlo draw of the lab (perturbed specimen and actuator,
        :func:`rths.config.build.lab`); None: the nominal lab.
    outputs
        Substructure outputs to keep (names of its ``outputs()``, e.g.
        ``"midspan_displacement"``); an output the substructure does not have is NaN.
    """
    n = scn.run.steps
    keep = _Keep(n, outputs)
    loop = Loop(
        build.substructure(scn),
        build.compensator(scn, compensator),
        InProcessLink(build.lab(scn, seed=seed, rng=rng)),
        scn.scaling,
        n,
        sink=keep,
        command_limit=scn.loop.stroke,
        force_filter=build.correction_filter(scn),
    )
    result = loop.run()
    k = result.steps
    s = keep.signals
    return BatchRun(
        result,
        scn.run.dt,
        s["target"][:k],
        s["measured"][:k],
        s["force"][:k],
        {name: values[:k] for name, values in keep.outputs.items()},
    )
