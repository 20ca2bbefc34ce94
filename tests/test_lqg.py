"""LQG feedback: gains cross-checked between libraries, disturbance rejection, validation."""

from __future__ import annotations

import control
import numpy as np
import pytest
import scipy.linalg as sla
from _vrths import benchmark_plant, closed_loop, discretize, j2, multisine
from filterpy.kalman import KalmanFilter

from controllers.model_based.feedforward import FeedforwardCompensator, LowOrderModel
from controllers.model_based.ff_lqg import FFLQGCompensator
from controllers.model_based.lqg import (
    LQGCompensator,
    LQGDesign,
    LQGWeights,
    design_lqg,
    discrete_nominal,
)
from rths.core.errors import ParameterError
from rths.core.kinematics import Kinematics

DT = 1.0 / 4096.0


@pytest.fixture(scope="module")
def design() -> LQGDesign:
    return design_lqg(benchmark_plant(), DT)


def test_kalman_gain_agrees_across_three_libraries(design):
    a, b, c = design.a, design.b, design.c
    w = design.weights
    q = w.process_noise_rms**2 * np.outer(b, b)
    r = w.noise_rms**2
    # scipy: a-priori covariance of the filter DARE (dual of the control DARE)
    p = sla.solve_discrete_are(a.T, c[:, None], q, np.array([[r]]))
    m_scipy = p @ c / (c @ p @ c + r)
    # filterpy: iterate the time-varying filter to steady state
    kf = KalmanFilter(dim_x=a.shape[0], dim_z=1, dim_u=1)
    kf.F, kf.B, kf.H = a, b[:, None], c[None, :]  # B as a column: filterpy broadcasts 1-D B
    kf.Q, kf.R, kf.P = q, np.array([[r]]), np.eye(a.shape[0]) * 1e-6
    for _ in range(20000):
        kf.predict(u=np.zeros((1, 1)))
        kf.update(np.zeros((1, 1)))
    # solutions of the same DARE by different algorithms (Schur / Hamiltonian, and 20000 filter
    # iterations) agree to ~cond * eps; the DARE's condition number here is ~1e8 (estimator
    # poles near z=1 next to sensor noise 4e-10 m^2), so compare to 1e-6 of the gain's norm
    tol = 1e-6 * np.linalg.norm(m_scipy)
    np.testing.assert_allclose(design.filter_gain, m_scipy, rtol=0, atol=tol)
    np.testing.assert_allclose(design.filter_gain, kf.K[:, 0], rtol=0, atol=tol)
    np.testing.assert_allclose(design.covariance, p, rtol=0, atol=1e-6 * np.linalg.norm(p))
    # control.dlqe returns the predictor gain L = A M
    np.testing.assert_allclose(design.predictor_gain, a @ design.filter_gain, rtol=1e-9, atol=1e-14)


def test_lqr_gain_agrees_with_scipy_riccati(design):
    a, b, c, n = design.a, design.b, design.c, design.order
    a_aug = np.block([[a, np.zeros((n, 1))], [-DT * (c @ a)[None, :], np.ones((1, 1))]])
    b_aug = np.r_[b, -DT * (c @ b)][:, None]
    q_aug = sla.block_diag(
        design.weights.error_weight * np.outer(c, c), design.weights.integral_weight
    )
    x = sla.solve_discrete_are(a_aug, b_aug, q_aug, np.eye(1))
    k = np.linalg.solve(np.eye(1) + b_aug.T @ x @ b_aug, b_aug.T @ x @ a_aug)[0]
    np.testing.assert_allclose(np.r_[design.gain_state, design.gain_integral], k, rtol=1e-7)
    # separation principle: regulator and estimator poles inside the unit circle
    assert np.max(np.abs(np.linalg.eigvals(a_aug - b_aug @ k[None, :]))) < 1.0
    assert np.max(np.abs(np.linalg.eigvals(a - np.outer(design.predictor_gain, c)))) < 1.0


def test_discrete_model_keeps_dc_gain_and_models_delay_by_pade():
    g = benchmark_plant()
    a, b, c = discrete_nominal(g, DT)
    dc = c @ np.linalg.solve(np.eye(a.shape[0]) - a, b)
    # ZOH preserves the static gain exactly; balancing is a similarity transform
    assert dc == pytest.approx(float(np.real(g(0))), rel=1e-9)
    a2, b2, c2 = discrete_nominal(g, DT, delay=0.01, pade_order=3)
    assert a2.shape == (8, 8)
    w = 2 * np.pi * 1.0
    z = np.exp(1j * w * DT)
    h0 = c @ np.linalg.solve(z * np.eye(5) - a, b)
    h1 = c2 @ np.linalg.solve(z * np.eye(8) - a2, b2)
    # 3rd-order Pade of 10 ms is exact in phase to (w tau)^7 at 1 Hz
    assert np.angle(h1 / h0) == pytest.approx(-w * 0.01, abs=1e-9)


def test_lqg_alone_rejects_a_constant_output_disturbance(design):
    plant = discretize(benchmark_plant(), DT)
    n = int(4.0 / DT)
    zero = multisine(DT, 4.0, (1.0,), amplitude=0.0)
    d = 1.0e-3
    comp = LQGCompensator(DT, design)
    y, u = closed_loop(comp, plant, zero, output_disturbance=d, disturbance_from=0.5)
    # integral action: the offset decays with the slowest closed-loop pole (~0.2 s); after
    # 3.5 s it is below 1e-6 of d
    assert abs(y[-1]) < 1e-6 * d
    # and the command settles to the static inverse of the disturbance, -d/G(0)
    assert u[n - 1] == pytest.approx(-d / design.static_gain, rel=1e-5)
    assert comp.state()["integral_error"] != 0.0
    # without feedback the offset stays: the feedforward alone cannot see it
    y_ff, _ = closed_loop(
        FeedforwardCompensator(DT, LowOrderModel(1.0, (1.0, 1.0))),
        plant,
        zero,
        output_disturbance=d,
        disturbance_from=0.5,
    )
    assert y_ff[-1] == pytest.approx(d)


def test_ff_lqg_on_exact_model_leaves_feedforward_untouched():
    model = LowOrderModel(2.7e6, (1.0, 274.0, 6.8e4, 2.7e6))
    nominal = control.tf([model.b0], list(model.den))
    plant = discretize(nominal, DT)
    target = multisine(DT, 2.0)
    skip = int(1.0 / DT)
    y_ff, u_ff = closed_loop(FeedforwardCompensator(DT, model), plant, target)
    comp = FFLQGCompensator(DT, design_lqg(nominal, DT), FeedforwardCompensator(DT, model))
    y, u = closed_loop(comp, plant, target)
    # the reference model reproduces the plant: the feedback only sees the feedforward's
    # 5e-6 J2 residual and the commands differ by less than 1e-4 of the command RMS
    assert np.sqrt(np.mean((u - u_ff) ** 2)) < 1e-4 * np.sqrt(np.mean(u_ff**2))
    assert j2(y, target.r, skip) < 2.0 * j2(y_ff, target.r, skip)


def test_state_reports_feedforward_and_feedback_parts(design):
    comp = LQGCompensator(DT, design)
    u = comp.step(Kinematics(1e-3, 0.0, 0.0), 2e-4)
    s = comp.state()
    assert set(s) == {
        "feedforward",
        "feedback",
        "tracking_error",
        "predicted_error",
        "integral_error",
        "innovation",
    }
    assert s["feedforward"] + s["feedback"] == pytest.approx(u, rel=1e-12)
    assert s["feedforward"] == pytest.approx(1e-3 / design.static_gain)
    # first step: y_0 - r_0 = 2e-4 - 0 and the error estimate starts at zero
    assert s["tracking_error"] == s["innovation"] == 2e-4
    assert s["integral_error"] == pytest.approx(-DT * 2e-4)
    comp.reset()
    assert comp.state()["integral_error"] == 0.0


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("error_weight", 0.0, "LQG error_weight must be positive; got 0.0"),
        ("integral_weight", -1.0, "LQG integral_weight must be non-negative; got -1.0"),
        ("noise_rms", 0.0, "LQG noise_rms must be positive; got 0.0"),
        ("process_noise_rms", float("inf"), "LQG process_noise_rms must be finite; got inf"),
        ("pade_order", 0, "LQG pade_order must be a positive integer; got 0"),
    ],
)
def test_weights_validation(field, value, match):
    with pytest.raises(ParameterError, match=match):
        LQGWeights(**{field: value})


def test_design_and_compensator_validation(design):
    with pytest.raises(ParameterError, match="weights must be an LQGWeights; got 3"):
        design_lqg(benchmark_plant(), DT, 3)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="nominal delay must be non-negative; got -0.1"):
        design_lqg(benchmark_plant(), DT, delay=-0.1)
    with pytest.raises(ParameterError, match="nominal model must be strictly proper"):
        design_lqg(control.tf([1.0, 1.0], [1.0, 2.0]), DT)
    with pytest.raises(ParameterError, match="design must be an LQGDesign; got None"):
        LQGCompensator(DT, None)  # type: ignore[arg-type]
    with pytest.raises(
        ParameterError, match=r"LQG design time step must equal dt=0.001; got 0.000244"
    ):
        LQGCompensator(0.001, design)
    with pytest.raises(ParameterError, match="feedforward must be a FeedforwardCompensator; got 1"):
        LQGCompensator(DT, design, 1)  # type: ignore[arg-type]
    ff = FeedforwardCompensator(0.001, LowOrderModel(1.0, (1.0, 1.0)))
    with pytest.raises(ParameterError, match=r"feedforward time step must equal dt=0.000244"):
        LQGCompensator(DT, design, ff)
    with pytest.raises(ParameterError, match="FF\\+LQG needs a feedforward compensator; got None"):
        FFLQGCompensator(DT, design, None)  # type: ignore[arg-type]


@pytest.mark.parametrize("kind", ["ff_lqg", "lqg"])
def test_compiled_step_equals_the_python_reference_step_for_step(kind):
    """The numba kernel (controllers.model_based._lqg_kernel) and the readable Python path give the same
    command and logged state every step, to round-off (dot products summed in another order:
    relative 1e-10 is a few hundred ulps over 3000 steps of a stable filter)."""
    from pathlib import Path

    from rths.config import build
    from rths.config.scenario import parse_scenario
    from rths.core.channels import RowBlock

    seed = Path(__file__).resolve().parent.parent / "scenarios" / "cable_imd_mode3.toml"
    scn = parse_scenario(seed.read_text())
    fast, ref = build.compensator(scn, kind), build.compensator(scn, kind)
    ref.use_jit = False
    ref.reset()
    rng = np.random.default_rng(7)
    row_f = RowBlock(fast.channels(), 1).values[0]
    row_r = RowBlock(ref.channels(), 1).values[0]
    for _ in range(3000):
        target = Kinematics(*(1e-3 * rng.normal(size=3)))
        y = 1e-3 * rng.normal()
        u_f, u_r = fast.step(target, y), ref.step(target, y)
        assert u_f == pytest.approx(u_r, rel=1e-10, abs=1e-16)
        fast.write_channels(row_f)
        ref.write_channels(row_r)
        np.testing.assert_allclose(row_f, row_r, rtol=1e-10, atol=1e-16)
    assert [c.name for c in fast.channels()] == list(ref.state())
