"""The nonlinear search's coordinates and local refinement (:mod:`rths.diagnose.search.identify`
stages 1-2): named parameters mapped to unit coordinates (log or linear), the global grid, and
a budgeted trust-region least-squares refinement polished by Nelder-Mead on kinked surfaces.
"""

from __future__ import annotations

import itertools
import math
from typing import Protocol

import numpy as np
from numpy.typing import NDArray
from scipy import optimize

from rths.diagnose.effects.model import Param, Theta

__all__ = [
    "POLISH_EVALUATIONS",
    "REFINE_EVALUATIONS",
    "SWEEP_POINTS",
    "Coords",
    "Problem",
    "coordinate_sweep",
    "grid_points",
    "refine",
]

#: Evaluations per nonlinear parameter of one least-squares refinement (finite differences
#: included).
REFINE_EVALUATIONS: int = 12
#: Further evaluations per parameter of the Nelder-Mead polish.
POLISH_EVALUATIONS: int = 16


class Problem(Protocol):
    """What the refinement needs of a stacked regression: its observation and residual."""

    y: NDArray

    def solve(self, theta: Theta) -> tuple[NDArray, NDArray, NDArray]:
        """``(residual, beta, offsets)`` at ``theta``.

        Parameters
        ----------
        theta
            Nonlinear parameters by name.
        """
        ...


class Coords:
    """Map between named parameters and the search's unit coordinates (log or scaled).

    Parameters
    ----------
    space
        The model's nonlinear parameters (bounds, log or linear scale).
    """

    def __init__(self, space: list[Param]) -> None:
        self.space = space
        self.lo = np.array([math.log(p.lo) if p.log else p.lo for p in space])
        self.hi = np.array([math.log(p.hi) if p.log else p.hi for p in space])
        self.width = np.maximum(self.hi - self.lo, 1e-12)

    def to_z(self, theta: Theta) -> NDArray:
        """Unit coordinates of ``theta`` (clipped to the box).

        Parameters
        ----------
        theta
            Parameters by name (SI).
        """
        v = np.array(
            [math.log(max(theta[p.name], p.lo)) if p.log else theta[p.name] for p in self.space]
        )
        return np.clip((v - self.lo) / self.width, 0.0, 1.0)

    def to_theta(self, z: NDArray) -> Theta:
        """Named parameters (SI) at unit coordinates ``z``.

        Parameters
        ----------
        z
            Unit coordinates, shape ``(len(space),)``.
        """
        v = self.lo + np.clip(z, 0.0, 1.0) * self.width
        return {
            p.name: float(math.exp(q) if p.log else q) for p, q in zip(self.space, v, strict=True)
        }


def grid_points(space: list[Param], starts: list[Theta], limit: int) -> list[Theta]:
    """The global grid (Cartesian, subsampled with a fixed seed beyond ``limit`` points) and
    the warm starts.

    Parameters
    ----------
    space
        The nonlinear parameters (:meth:`rths.diagnose.effects.model.Param.values`).
    starts
        Warm starts (a parameter a start lacks takes its middle value).
    limit
        Largest number of grid points.
    """
    axes = [p.values() for p in space]
    points = list(itertools.product(*axes))
    if len(points) > limit:
        rng = np.random.default_rng(0)
        keep = rng.choice(len(points), limit, replace=False)
        points = [points[i] for i in sorted(keep)]
    grid = [{p.name: float(v) for p, v in zip(space, q, strict=True)} for q in points]
    for s in starts:
        grid.append({p.name: float(s.get(p.name, p.middle())) for p in space})
    return grid


#: Points per parameter of a coordinate sweep (:func:`coordinate_sweep`).
SWEEP_POINTS: int = 9


def coordinate_sweep(problem: Problem, coords: Coords, z0: NDArray, sweeps: int) -> NDArray:
    """``sweeps`` passes over the parameters, each moved in turn to the best of
    :data:`SWEEP_POINTS` evenly spaced values across its range (pass ``k``: a span of
    ``4^-k`` of it around the best so far), the others held: a start for
    the refinement where the cost surface is too ill-conditioned for a gradient step from
    ``z0`` (a transfer function's roots calibrated one by one: a slow pole-zero pair's factors
    change the low-frequency gain a hundred times faster than the other roots do, and the
    trust-region step from the common calibration stopped within 0.2 % of it, at 900 times the
    cost of the truth's factors).

    Parameters
    ----------
    problem
        The stacked regression.
    coords
        The map to unit coordinates.
    z0
        Starting point (unit coordinates).
    sweeps
        Number of passes.
    """
    track = _Tracker(problem, coords, sweeps * SWEEP_POINTS * z0.size + 1)
    z = np.array(z0, dtype=float)
    best = track.cost(z)
    for k in range(sweeps):
        span = 0.25**k  # the whole range, then a quarter of it around the best, ...
        for i in range(z.size):
            for v in np.clip(z[i] + span * np.linspace(-0.5, 0.5, SWEEP_POINTS), 0.0, 1.0):
                trial = z.copy()
                trial[i] = v
                c = track.cost(trial)
                if c < best:
                    best, z = c, trial
    return z


class _Budget(Exception):
    """Raised inside an optimiser when its evaluation budget is spent."""


class _Tracker:
    """Counts evaluations of a problem's residual, keeps the best point, enforces a budget."""

    def __init__(self, problem: Problem, coords: Coords, budget: int) -> None:
        self.problem, self.coords, self.budget = problem, coords, budget
        self.count = 0
        self.best_z: NDArray | None = None
        self.best = math.inf

    def residual(self, z: NDArray) -> NDArray:
        if self.count >= self.budget:
            raise _Budget
        self.count += 1
        try:
            r = self.problem.solve(self.coords.to_theta(z))[0]
        except (np.linalg.LinAlgError, ValueError):
            return np.full(self.problem.y.size, 1e150)
        if not np.all(np.isfinite(r)):
            return np.full(self.problem.y.size, 1e150)
        c = float(np.mean(r * r))
        if c < self.best:
            self.best, self.best_z = c, np.array(z, dtype=float)
        return r

    def cost(self, z: NDArray) -> float:
        return float(np.mean(self.residual(z) ** 2))


def refine(problem: Problem, coords: Coords, z0: NDArray, polish: bool) -> tuple[NDArray, float]:
    """Trust-region least squares (then Nelder-Mead if ``polish``) from ``z0`` within
    :data:`REFINE_EVALUATIONS` evaluations per parameter; the best point seen and its cost.

    Parameters
    ----------
    problem
        The stacked regression (its residual at a ``theta``).
    coords
        The map to unit coordinates.
    z0
        Starting point (unit coordinates).
    polish
        Polish with Nelder-Mead (kinked cost surfaces).
    """
    track = _Tracker(problem, coords, REFINE_EVALUATIONS * z0.size)
    scale = math.sqrt(max(track.cost(z0), 1e-300))
    try:
        optimize.least_squares(
            lambda z: track.residual(z) / scale,
            z0,
            bounds=(np.zeros(z0.size), np.ones(z0.size)),
            diff_step=1e-3,
            x_scale=np.full(z0.size, 0.05),
        )
    except _Budget:
        pass
    z = track.best_z if track.best_z is not None else z0
    if polish:
        track.budget += POLISH_EVALUATIONS * z0.size
        try:
            optimize.minimize(
                track.cost,
                z,
                method="Nelder-Mead",
                bounds=[(0.0, 1.0)] * z.size,
                options={
                    "xatol": 1e-4,
                    "fatol": 0.0,
                    "initial_simplex": np.vstack(
                        [z] + [np.clip(z + 0.02 * e, 0.0, 1.0) for e in np.eye(z.size)]
                    ),
                },
            )
        except _Budget:
            pass
    assert track.best_z is not None
    return track.best_z, track.best
