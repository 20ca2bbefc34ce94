"""Identify a model on the identification samples and score it on the held-out ones.

Variable projection: for given nonlinear parameters ``theta`` the linear ones ``beta`` (the
re-calibrated baseline) are the least-squares solution (``numpy.linalg.lstsq``), so the search
runs over ``theta`` only -- first the model's grid of starting points (the cost surfaces of
delays, gaps and resonances have many local minima), then ``scipy.optimize.least_squares``
(trust-region reflective, bounded, finite-difference Jacobian) from the best of them.  The
nonlinear search uses every ``stride``-th identification sample (the specimen channel is smoothed
far below the sampling rate); the final ``beta`` uses them all.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy import optimize

from rths.core.errors import NumericalError
from rths.diagnose.channels import Channel, Segment
from rths.diagnose.effects import Model

__all__ = ["RIDGE", "Fit", "fit_model", "noise_floor", "stride_for"]

#: Relative weight of the pull towards the nominal linear parameters (see ``_Problem.solve``):
#: a parameter the data determine moves by ~RIDGE of its mis-calibration (1e-4 for 10 %);
#: one they do not (inertance against stiffness under a single sine) stays nominal.
RIDGE: float = 1e-3


@dataclass(frozen=True)
class Fit:
    """A model identified on a channel.

    Attributes
    ----------
    model
        The model.
    theta, beta
        Nonlinear and linear parameters.
    params
        Effect parameters (SI, named per design.md section 7).
    baseline
        Re-calibrated nominal parameters.
    ident_mse
        Mean squared residual on the identification samples.
    held_mse
        Mean squared residual on the held-out samples.
    prediction
        Model output per record (whole records), for reports.
    """

    model: Model
    theta: NDArray[np.float64]
    beta: NDArray[np.float64]
    params: dict[str, float]
    baseline: dict[str, float]
    ident_mse: float
    held_mse: float
    prediction: list[NDArray[np.float64]] = field(repr=False)

    @property
    def name(self) -> str:
        """The model's name."""
        return self.model.name

    def residuals(self, channel: Channel) -> list[NDArray[np.float64]]:
        """Observed minus predicted, per record."""
        return [s.observed - p for s, p in zip(channel.segments, self.prediction, strict=True)]


def stride_for(channel: Channel) -> int:
    """Row stride of the nonlinear search: ~8 samples per smoother period, else 1."""
    if channel.cutoff is None:
        return 1
    return max(1, int(1.0 / (8.0 * channel.cutoff * channel.dt)))


class _Problem:
    """Stacked regression of one model over the identification samples."""

    def __init__(self, model: Model, channel: Channel, stride: int) -> None:
        self.model, self.channel, self.stride = model, channel, stride
        self.segments = [s for s in channel.segments if np.any(s.ident)]
        self.y = np.concatenate([s.observed[s.ident] for s in self.segments])

    def design(self, theta: NDArray) -> tuple[NDArray, NDArray]:
        xs, fs = [], []
        for s in self.segments:
            x, f = self.model.columns(self.channel, s, theta)
            xs.append(x[s.ident])
            fs.append(f[s.ident])
        return np.concatenate(xs), np.concatenate(fs)

    def solve(self, theta: NDArray, stride: int = 1) -> tuple[NDArray, NDArray]:
        """``(residual, beta)`` on every ``stride``-th identification sample.

        Least squares with a Tikhonov term ``RIDGE * ||d_j (beta_j - prior_j)||^2``
        (``d_j`` the column norms): negligible where the data determine ``beta``, it keeps
        the nominal value along directions they do not (collinear columns).
        """
        x, f = self.design(theta)
        x, f, y = x[::stride], f[::stride], self.y[::stride]
        d = np.sqrt(RIDGE) * np.linalg.norm(x, axis=0)
        prior = self.model.prior(self.channel)
        a = np.vstack([x, np.diag(d)])
        b = np.concatenate([y - f, d * prior])
        beta = np.linalg.lstsq(a, b, rcond=None)[0]
        return y - f - x @ beta, beta


def _polish(problem: _Problem, theta: NDArray, lo: NDArray, hi: NDArray, stride: int) -> NDArray:
    """Nelder-Mead from ``theta`` (for cost surfaces with kinks, e.g. a rate limiter's)."""
    scale = np.maximum(np.abs(theta), (hi - lo) * 1e-3)

    def cost(z: NDArray) -> float:
        r, _ = problem.solve(z * scale, stride)
        return float(np.mean(r * r))

    result = optimize.minimize(
        cost,
        theta / scale,
        method="Nelder-Mead",
        bounds=list(zip(lo / scale, hi / scale, strict=True)),
        options={
            "xatol": 1e-6,
            "fatol": 0.0,
            "maxfev": 150 * theta.size,
            "initial_simplex": np.vstack(
                [theta / scale] + [theta / scale * (1 + 0.02 * e) for e in np.eye(theta.size)]
            ),
        },
    )
    return result.x * scale if result.fun <= cost(theta / scale) else theta


def fit_model(model: Model, channel: Channel, base: dict[str, float] | None = None) -> Fit:
    """Identify ``model`` on ``channel`` and score it on the held-out samples.

    Parameters
    ----------
    model
        Baseline or candidate.
    channel
        The channel with its identification/held-out masks.
    base
        The re-calibrated baseline (for the model's starting points); required for models with
        nonlinear parameters.

    Raises
    ------
    NumericalError
        If the search fails or gives non-finite parameters.
    """
    stride = stride_for(channel)
    model.prepare(channel, base or {})
    problem = _Problem(model, channel, stride)
    starts = model.starts(channel, base or {})
    theta = np.empty(0)
    if starts:
        costs = []
        for t in starts:
            r, _ = problem.solve(t, stride)
            costs.append(float(np.mean(r * r)))
        theta0 = starts[int(np.argmin(costs))]
        lo, hi = model.bounds(channel, base or {})
        theta0 = np.clip(theta0, lo, hi)
        scale = np.sqrt(max(min(costs), 1e-300))
        try:
            result = optimize.least_squares(
                lambda t: problem.solve(t, stride)[0] / scale,
                theta0,
                bounds=(lo, hi),
                x_scale=np.maximum(np.abs(theta0), (hi - lo) * 1e-3),
                diff_step=1e-3,
                max_nfev=60 * theta0.size,
            )
        except (ValueError, np.linalg.LinAlgError) as exc:
            raise NumericalError(f"identification of '{model.name}' failed: {exc}") from None
        theta = result.x if result.cost * 2 <= len(result.fun) * min(costs) / scale**2 else theta0
        if model.polish:
            theta = _polish(problem, theta, lo, hi, stride)
    _, beta = problem.solve(theta)
    if not (np.all(np.isfinite(beta)) and np.all(np.isfinite(theta))):
        raise NumericalError(f"identification of '{model.name}' gave non-finite parameters")
    params, baseline = model.describe(channel, theta, beta)
    prediction, ident_sq, held_sq, n_ident, n_held = [], 0.0, 0.0, 0, 0
    for s in channel.segments:
        x, f = model.columns(channel, s, theta)
        p = x @ beta + f
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
        ident_sq / max(n_ident, 1),
        held_sq / n_held if n_held else math.nan,
        prediction,
    )


def noise_floor(fit: Fit, channel: Channel, seed: int = 0, repeats: int = 2) -> float:
    """Held-out mean squared residual the fitted model would leave if it were exact.

    Actuator channel: the analytic floor (:meth:`Channel.floor_variance`).  Specimen channel:
    the model is driven a second time with a synthetic copy of the estimated displacement noise
    added (white, the estimated RMS, smoothed like the record) and the change of its output is
    the noise it propagates -- for a resonant model (internal stiffness) far more than for a
    rigid one, which is why the floor is per model -- plus the smoothed force noise.  ``repeats``
    independent copies are averaged (seeded: the diagnosis is reproducible).
    """
    if channel.subsystem == "actuator":
        return channel.floor_variance()
    from rths.diagnose._signals import derivatives, impulse_kernel, smooth

    rng = np.random.default_rng(seed)
    sigma_x = channel.noise["drive"]
    acc, count = 0.0, 0
    for _ in range(repeats if sigma_x > 0.0 else 0):
        for s, p in zip(channel.segments, fit.prediction, strict=True):
            if not np.any(s.held):
                continue
            assert s.sos is not None
            x = s.signals["x"] + smooth(sigma_x * rng.standard_normal(s.observed.size), s.sos)
            v, a = derivatives(x, s.dt)
            twin = Segment(
                s.name, s.dt, s.observed, {"x": x, "v": v, "a": a}, s.ident, s.held, s.sos
            )
            cols, fixed = fit.model.columns(channel, twin, fit.theta)
            d = (cols @ fit.beta + fixed - p)[s.held]
            acc += float(np.sum(d * d))
            count += d.size
    sos = channel.segments[0].sos
    assert sos is not None
    force = channel.noise["force"] ** 2 * float(np.sum(impulse_kernel(sos, channel.dt) ** 2))
    return acc / max(count, 1) + force
