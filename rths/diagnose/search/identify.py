"""Identify a model on the identification samples and score it on the held-out ones.

Variable projection: for given nonlinear parameters ``theta`` the linear ones ``beta`` (the
re-calibrated baseline and the effects' levels) and one offset per record are the
least-squares solution, so the search runs over ``theta`` only, in three stages:

1. global: every point of the model's grid (:class:`rths.diagnose.effects.model.Param`:
   orders of magnitude on a log scale) and every warm start is scored on short windows of
   the identification records (:data:`SEARCH_SECONDS` each, where the drive moves most; the
   whole records for a model that is not ``windowed``: an amplitude law needs every
   amplitude the records hold);
2. refine (:mod:`rths.diagnose.search.refine`): ``scipy.optimize.least_squares``
   (trust-region reflective, bounded, on the log scale for log parameters) from the
   :data:`REFINE_STARTS` best distinct points, on longer windows (:data:`REFINE_SECONDS`),
   after coordinate sweeps for a model that asks for them (an ill-conditioned surface);
   kinked cost surfaces (dead zones, limiters) are polished by Nelder-Mead;
3. final: ``beta`` on all identification samples, predictions of every record, held-out
   residuals with each held-out record's offset calibrated on that record (its mean residual).

:func:`rths.diagnose.search.crossval.cross_fit` scores a model by two-fold cross-validation
over time blocks of *every* record (identified on the even blocks and held out on the odd ones,
then the other way round): every fold sees every excitation and amplitude.

A window restarts the model at rest on the drive; its first :data:`WARMUP_SECONDS` and the
smoother's edges are not scored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from rths.core.errors import NumericalError
from rths.diagnose.channels.channel import Channel, Segment
from rths.diagnose.effects.model import Model, Theta
from rths.diagnose.effects.zero_terms import zero_term_scale
from rths.diagnose.search.bounded import box_bounds, ridge_box_lstsq
from rths.diagnose.search.refine import Coords, coordinate_sweep, grid_points, refine

__all__ = [
    "REFINE_SECONDS",
    "REFINE_STARTS",
    "RIDGE",
    "SEARCH_SECONDS",
    "WARMUP_SECONDS",
    "Fit",
    "fit_model",
    "nuisance_columns",
    "stride_for",
]

#: Relative weight of the pull towards the nominal linear parameters (see ``_Problem.solve``).
RIDGE: float = 1e-3
#: Length [s] of the global-search window per identification record.
SEARCH_SECONDS: float = 3.0
#: Length [s] of the refinement window per identification record.
REFINE_SECONDS: float = 8.0
#: Unscored start of every window [s] (the model restarts at rest there).
WARMUP_SECONDS: float = 0.5
#: Distinct grid points refined.
REFINE_STARTS: int = 2


@dataclass(frozen=True)
class Fit:
    """A model identified on a channel.

    Attributes
    ----------
    model
        The model.
    theta, beta
        Nonlinear (by name) and linear parameters (without the offsets).
    params
        Effect parameters by effect (SI, named per design.md section 7).
    baseline
        Re-calibrated nominal parameters.
    offsets
        Per record: the offset and any nuisance terms of the model (identified with the
        model or, for held-out records, calibrated on the record), whole-record arrays.
    ident_mse, held_mse
        Mean squared residual on the identification and on the held-out samples.
    prediction
        Model output per record (whole records, offsets included).
    """

    model: Model
    theta: Theta
    beta: NDArray[np.float64]
    params: dict[str, dict[str, float]]
    baseline: dict[str, float]
    offsets: list[NDArray[np.float64]]
    ident_mse: float
    held_mse: float
    prediction: list[NDArray[np.float64]] = field(repr=False)

    @property
    def name(self) -> str:
        """The model's name."""
        return self.model.name

    @property
    def effects(self) -> tuple[str, ...]:
        """The effects the model holds."""
        return self.model.effects

    def residuals(self, channel: Channel) -> list[NDArray[np.float64]]:
        """Observed minus predicted, per record."""
        return [s.observed - p for s, p in zip(channel.segments, self.prediction, strict=True)]


def _window(seg: Segment, seconds: float, edge: int) -> Segment:
    """The ``seconds`` of ``seg``'s identification samples where the drive moves most."""
    idx = np.flatnonzero(seg.ident)
    n = int(round(seconds / seg.dt))
    warm = int(round(WARMUP_SECONDS / seg.dt))
    if idx.size <= n + warm:
        lo, hi = max(0, idx[0] - warm), idx[-1] + 1
    else:
        motion = seg.signals.get("x", seg.signals.get("command", seg.observed))
        energy = np.diff(motion) ** 2
        csum = np.concatenate([[0.0], np.cumsum(energy * seg.ident[1:])])
        starts = idx[idx + n < idx[-1] + 1]
        gains = csum[starts + n] - csum[starts]
        lo = max(0, int(starts[int(np.argmax(gains))]) - warm)
        hi = lo + warm + n
    mask = seg.ident[lo:hi].copy()
    mask[: warm + (edge if lo > 0 else 0)] = False
    if hi < seg.observed.size:
        mask[-edge:] = False
    return Segment(
        seg.name,
        seg.index,
        seg.dt,
        seg.observed[lo:hi],
        {k: (v[lo:hi] if v.size == seg.observed.size else v) for k, v in seg.signals.items()},
        mask,
        np.zeros(hi - lo, dtype=bool),
        seg.sos,
        window=(seg, lo) if seg.window is None else (seg.window[0], seg.window[1] + lo),
    )


def _windows(model: Model, channel: Channel, seconds: float, edge: int) -> list[Segment]:
    """The search windows of every identification record (:func:`_window`), or the whole
    identification records when the model is not :attr:`Model.windowed`."""
    ident = [s for s in channel.segments if np.any(s.ident)]
    return [_window(s, seconds, edge) for s in ident] if model.windowed else ident


def stride_for(channel: Channel) -> int:
    """Row stride of the search stages: ~8 samples per period of the channel's band edge (the
    specimen smoother's cutoff; 256 Hz for the actuator channel).

    Parameters
    ----------
    channel
        The channel searched.
    """
    top = channel.cutoff if channel.cutoff is not None else 256.0
    return max(1, int(1.0 / (8.0 * top * channel.dt)))


class _Problem:
    """Stacked regression of one model over identification samples (every ``stride``-th)."""

    def __init__(
        self, model: Model, channel: Channel, segments: list[Segment], stride: int = 1
    ) -> None:
        self.model, self.channel = model, channel
        self.segments = [s for s in segments if np.any(s.ident)]
        self.rows = []
        for s in self.segments:
            rows = np.flatnonzero(s.ident)[::stride]
            self.rows.append(rows)
        self.y = np.concatenate(
            [s.observed[r] for s, r in zip(self.segments, self.rows, strict=True)]
        )
        self.records = sorted({s.index for s in self.segments})
        self.prior = model.prior(channel)
        self.tolerance = model.tolerance(channel)
        self.limits = model.limits(channel)
        self.nonnegative = model.nonnegative(channel) & (self.prior >= 0.0)
        # an effect's level NOMINAL.toml gives no value is not pulled (towards zero)
        self.ridge = np.where(model.unanchored(channel) & (self.prior == 0.0), 0.0, RIDGE)
        self.zero_scale: NDArray[np.float64] | None = None

    def _zero_scale(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Per column the bound scale of a term NOMINAL.toml sets to zero
        (:func:`rths.diagnose.effects.zero_terms.zero_term_scale`, per record over its rows)."""
        out = np.zeros(x.shape[1])
        cut = np.cumsum([r.size for r in self.rows])[:-1]
        observed = np.split(self.y, cut)
        for j in np.flatnonzero(np.isfinite(self.tolerance) & (self.prior == 0.0)):
            out[j] = zero_term_scale(np.split(x[:, j], cut), observed)
        return out

    def design(self, theta: Theta) -> tuple[NDArray, NDArray, NDArray]:
        xs, fs, nuis = [], [], []
        for s, rows in zip(self.segments, self.rows, strict=True):
            x, f = self.model.columns(self.channel, s, theta)
            xs.append(x[rows])
            fs.append(f[rows])
            nuis.append(nuisance_columns(self.model, self.channel, s, theta)[rows])
        width = sum(n.shape[1] for n in nuis)
        o = np.zeros((sum(r.size for r in self.rows), width))
        i = j = 0
        for n in nuis:  # block-diagonal: every segment its own nuisance terms
            o[i : i + n.shape[0], j : j + n.shape[1]] = n
            i, j = i + n.shape[0], j + n.shape[1]
        return np.concatenate(xs), np.concatenate(fs), o

    def solve(self, theta: Theta) -> tuple[NDArray, NDArray, NDArray]:
        """``(residual, beta, offsets)``; ridge ``RIDGE * ||d_j (beta_j - prior_j)||^2``
        with ``d_j`` the column norms (negligible where the data determine ``beta``; none on
        an effect's level, :meth:`rths.diagnose.effects.model.Model.unanchored`); the
        nominal's own parameters within the model's tolerance (:mod:`.bounded`) and its
        absolute limits (:meth:`rths.diagnose.effects.model.Model.limits`), a passive
        specimen's inertance and damping not below zero, and the model's ordered pairs
        ``beta_i <= beta_j`` (:attr:`rths.diagnose.effects.model.Model.ordered`): a pair the
        solution violates is solved again with ``beta_i = beta_j`` (with one more linear
        constraint on a convex problem, an optimum that violates it lies on its boundary)."""
        x, f, o = self.design(theta)
        target = self.y - f
        if self.zero_scale is None:  # the bands where each column acts: from the first design
            self.zero_scale = self._zero_scale(x)
        lo, hi = box_bounds(self.prior, self.tolerance, x, target, self.zero_scale)
        lim = np.isfinite(self.limits)
        lo[lim] = np.maximum(lo[lim], -self.limits[lim])
        hi[lim] = np.minimum(hi[lim], self.limits[lim])
        lo[self.nonnegative] = np.maximum(lo[self.nonnegative], 0.0)
        beta, off = ridge_box_lstsq(
            x, o, target, (self.prior, self.ridge), (lo, hi), self.model.ordered
        )
        return target - x @ beta - o @ off, beta, off

    def cost(self, theta: Theta) -> float:
        try:
            r = self.solve(theta)[0]
        except (np.linalg.LinAlgError, ValueError):
            return math.inf
        c = float(np.mean(r * r))
        return c if math.isfinite(c) else math.inf


def nuisance_columns(model: Model, channel: Channel, seg: Segment, theta: Theta) -> NDArray:
    """The offset column and the model's nuisance columns of a segment.

    Parameters
    ----------
    model
        The model whose nuisance columns (calibration terms solved by least squares) are asked.
    channel
        The channel it is fitted on.
    seg
        One record's segment.
    theta
        The model's nonlinear parameters.
    """
    extra = model.nuisance(channel, seg, theta)
    ones = np.ones((seg.observed.size, 1))
    return ones if extra is None else np.hstack([ones, extra])


def fit_model(
    model: Model,
    channel: Channel,
    base: dict[str, float] | None = None,
    starts: list[Theta] | None = None,
) -> Fit:
    """Identify ``model`` on ``channel`` and score it on the held-out samples.

    Parameters
    ----------
    model
        Baseline or extended model.
    channel
        The channel with its identification/held-out masks.
    base
        The re-calibrated baseline (starting values and scales of the model).
    starts
        Warm starts (e.g. the parameters of nested fits), added to the global grid.

    Raises
    ------
    NumericalError
        If the identification gives non-finite parameters.
    """
    model.prepare(channel, base or {})
    space = model.space(channel)
    edge = int(round(4.0 / (channel.cutoff or 0.25 / channel.dt) / channel.dt)) + 1
    theta: Theta = {}
    if space:
        coords = Coords(space)
        stride = stride_for(channel)
        windows = _windows(model, channel, SEARCH_SECONDS, edge)
        search = _Problem(model, channel, windows, stride)
        grid = grid_points(space, [*model.starts(channel), *(starts or [])], model.max_grid)
        costs = np.array([search.cost(t) for t in grid])
        order = np.argsort(costs)
        picked: list[NDArray] = []
        for i in order:
            z = coords.to_z(grid[i])
            if all(np.max(np.abs(z - q)) > 0.05 for q in picked) and math.isfinite(costs[i]):
                picked.append(z)
            if len(picked) == REFINE_STARTS:
                break
        windows = _windows(model, channel, REFINE_SECONDS, edge)
        longer = _Problem(model, channel, windows, stride)
        best, best_cost = None, math.inf
        for z0 in picked:
            if model.sweeps:  # on the search windows: a coarse stage
                z0 = coordinate_sweep(search, coords, z0, model.sweeps)
            z, c = refine(longer, coords, z0, model.polish)
            if c < best_cost:
                best, best_cost = z, c
        if best is None:
            raise NumericalError(f"identification of '{model.name}' failed: no finite cost")
        theta = coords.to_theta(best)
    full = _Problem(model, channel, channel.segments)
    _, beta, _ = full.solve(theta)
    if not (np.all(np.isfinite(beta)) and all(math.isfinite(v) for v in theta.values())):
        raise NumericalError(f"identification of '{model.name}' gave non-finite parameters")
    params, baseline = model.describe(channel, theta, beta)
    offsets: list[NDArray[np.float64]] = []
    prediction, ident_sq, held_sq, n_ident, n_held = [], 0.0, 0.0, 0, 0
    for s in channel.segments:
        x, f = model.columns(channel, s, theta)
        p = x @ beta + f
        nuis = nuisance_columns(model, channel, s, theta)
        # offsets and nuisance terms (a record's transducer zeros, a body's initial state) are
        # calibrated on the record's own scored samples, held-out ones included
        mask = s.ident | s.held
        if np.any(mask):
            coef = np.linalg.lstsq(nuis[mask], (s.observed - p)[mask], rcond=None)[0]
        else:
            coef = np.zeros(nuis.shape[1])
        offsets.append(nuis @ coef)
        p = p + offsets[-1]
        prediction.append(p)
        r = s.observed - p
        ident_sq += float(np.sum(r[s.ident] ** 2))
        held_sq += float(np.sum(r[s.held] ** 2))
        n_ident += int(np.sum(s.ident))
        n_held += int(np.sum(s.held))
    return Fit(
        model,
        theta,
        beta,
        params,
        baseline,
        offsets,
        ident_sq / max(n_ident, 1),
        held_sq / n_held if n_held else math.nan,
        prediction,
    )
