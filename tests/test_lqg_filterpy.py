"""The LQG estimator is filterpy's KalmanFilter: the constant-gain hot path step for step against
``filterpy.kalman.KalmanFilter`` (update, then predict) started at the DARE's steady state."""

from __future__ import annotations

import numpy as np
import pytest
from _vrths import benchmark_plant, closed_loop, discretize, multisine, perturbed_plants

from controllers.factory import make_compensator
from controllers.model_based.lqg import design_lqg
from rths.core.errors import ParameterError

DT = 1.0 / 4096.0


def test_steady_filter_gain_is_dlqe_and_stays_steady() -> None:
    design = design_lqg(benchmark_plant(), DT)
    kf = design.kalman_filter()
    rng = np.random.default_rng(0)
    for _ in range(200):
        kf.update(np.array([[rng.normal(0.0, 1e-4)]]))
        # the update's gain is the current-estimator gain M; dlqe's predictor gain is A M (to the
        # round-off of filterpy's Joseph-form covariance update, ~1e-8)
        m = np.max(np.abs(design.filter_gain))
        np.testing.assert_allclose(kf.K[:, 0], design.filter_gain, rtol=0, atol=1e-7 * m)
        l_max = np.max(np.abs(design.predictor_gain))
        np.testing.assert_allclose(design.a @ kf.K[:, 0], design.predictor_gain, atol=1e-7 * l_max)
        kf.predict(u=np.array([[rng.normal(0.0, 1e-4)]]))
    # P is the DARE fixed point: 200 steps leave it where it started (round-off only)
    scale = np.max(np.abs(design.covariance))
    np.testing.assert_allclose(kf.P, design.covariance, rtol=0, atol=1e-7 * scale)
    assert kf.B.shape == (design.order, 1) and kf.H.shape == (1, design.order)


@pytest.mark.parametrize("kind", ["lqg", "ff_lqg"])
def test_hot_path_equals_filterpy_step_for_step(kind: str) -> None:
    # A perturbed plant, sensor noise and a multi-sine: every innovation is non-zero.  filterpy
    # recomputes K from P every step, and the Joseph-form update of P moves K by ~1e-8 of
    # itself (round-off): the commands agree to 1e-7 of their peak (a fraction of a nanometre).
    nominal = benchmark_plant()
    plant = discretize(perturbed_plants(1, seed=5)[0], DT)
    target = multisine(DT, 0.6)
    hot = make_compensator(kind, DT, nominal)  # the compiled kernel (one numba call per step)
    assert hot.use_jit
    slow = make_compensator(kind, DT, nominal)
    slow.estimator = "filterpy"  # switched before the run: reset() builds the filterpy filter
    slow.use_jit = False  # filterpy runs on the Python path
    y_hot, u_hot = closed_loop(hot, plant, target, noise_rms=2e-5)
    y_slow, u_slow = closed_loop(slow, plant, target, noise_rms=2e-5)
    np.testing.assert_allclose(u_slow, u_hot, rtol=0, atol=1e-7 * np.max(np.abs(u_hot)))
    assert hot.state()["innovation"] == pytest.approx(slow.state()["innovation"], rel=1e-6)


def test_unknown_estimator_is_rejected() -> None:
    from controllers.model_based.lqg import LQGCompensator

    with pytest.raises(ParameterError, match="estimator must be 'steady' or 'filterpy'; got 'x'"):
        LQGCompensator(DT, design_lqg(benchmark_plant(), DT), estimator="x")
