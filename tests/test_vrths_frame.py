"""Oracles for the vRTHS benchmark frame (plants.frame): matrices, discretisation, partition."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as sla
from scipy import signal

from plants.frame import (
    CASES,
    PACKAGE_ENV,
    ChirpMotion,
    FrameSubstructure,
    RecordedMotion,
    benchmark_case,
    condensed_stiffness,
    ground_motion,
    load_record,
    modal_damping,
    numerical_matrices,
    package_dir,
    reference_response,
)
from plants.frame._discrete import discretise_structure, state_matrices
from plants.linear_specimen import LinearSpecimen
from rths.core.errors import ConfigError, DataError, ParameterError

DT = 1.0 / 4096.0
SPECIMEN = LinearSpecimen.from_damping_ratio(29.13, 1.19e6, 0.0097)

# Derived numbers copied from the benchmark package's ``Building cases/Case_N.mat`` (variables
# K and C, written by Reference_def.m); the frame module re-derives them from the frame's
# geometry, so these are an independent check of the condensation and of CC_mat.m.
K_CASE_MAT = [
    [26054883.879603837, -23133938.877108198, 5937035.463339146],
    [-23133938.877108198, 32560774.186380334, -14419970.777236981],
    [5937035.463339146, -14419970.777236985, 9267275.506224312],
]
C_CASE_MAT = {
    1: [[14084.275745299876, -7873.031460913151, 440.4514988426247],
        [-7873.031460913151, 14943.622937895665, -6348.672096305331],
        [440.45149884262497, -6348.672096305332, 7223.101316804461]],
    2: [[11817.42262041908, -6606.215423308698, 369.6755622296918],
        [-6606.215423308699, 12538.57756973086, -5327.047373791856],
        [369.6755622296924, -5327.047373791856, 6060.319809850064]],
    3: [[9635.014363361863, -5386.025774196529, 301.43864014406876],
        [-5386.025774196528, 10223.006811768844, -4343.084702116766],
        [301.4386401440686, -4343.084702116764, 4941.298824869293]],
    4: [[8450.565447179924, -4723.818876547891, 264.27089930557526],
        [-4723.818876547892, 8966.173762737399, -3809.203257783199],
        [264.27089930557594, -3809.203257783199, 4333.8607900826755]],
}  # fmt: skip


def test_condensed_stiffness_equals_the_benchmark_matrix() -> None:
    # Same formula evaluated in a different order: round-off only (1e-12 of the largest entry).
    np.testing.assert_allclose(condensed_stiffness(), K_CASE_MAT, rtol=0, atol=1e-12 * 3.3e7)


@pytest.mark.parametrize("number", [1, 2, 3, 4])
def test_case_matrices_equal_the_benchmark_files(number: int) -> None:
    case = benchmark_case(number)
    np.testing.assert_allclose(case.damping, C_CASE_MAT[number], rtol=0, atol=1e-9 * 1.5e4)
    np.testing.assert_array_equal(case.mass, case.floor_mass * np.eye(3))


@pytest.mark.parametrize("number", [1, 2, 3, 4])
def test_modal_frequencies_and_damping_are_the_eigenvalues(number: int) -> None:
    case = CASES[number]
    # generalized symmetric eigenproblem K phi = w^2 M phi, solved independently
    w = np.sqrt(sla.eigh(case.stiffness, case.mass, eigvals_only=True))
    np.testing.assert_allclose(case.frequencies, w / (2 * np.pi), rtol=1e-12)
    # the state matrix's poles carry the case's damping ratio in all three modes; the benchmark
    # rounds omega to 0.01 rad/s before building C, so zeta is off by at most 0.005/omega_1
    a, _, _ = state_matrices(case.mass, case.damping, case.stiffness, case.mass)
    poles = np.linalg.eigvals(a)
    poles = poles[poles.imag > 0]
    zeta = -poles.real / np.abs(poles)
    np.testing.assert_allclose(np.sort(zeta), case.damping_ratio, rtol=0.005 / w[0])


def test_first_mode_frequencies_of_the_cases() -> None:
    # 1000 kg floors: f = 3.61 Hz (Reference_def.m prints fn rounded to 0.01 Hz); heavier floors
    # lower it by sqrt(m1/m).
    f1 = CASES[1].frequencies[0]
    assert f1 == pytest.approx(3.61, abs=0.005)
    assert CASES[3].frequencies[0] == pytest.approx(f1 * math.sqrt(1000 / 1300), rel=1e-12)
    assert CASES[4].frequencies[0] == pytest.approx(f1, rel=1e-12)


def test_modal_damping_without_rounding_is_exact() -> None:
    case = CASES[2]
    c = modal_damping(case.mass, case.stiffness, 0.04, round_frequencies=False)
    a, _, _ = state_matrices(case.mass, c, case.stiffness, case.mass)
    p = np.linalg.eigvals(a)
    np.testing.assert_allclose(-p.real / np.abs(p), 0.04, rtol=1e-10)


def test_discretisation_is_exact_for_a_ramp_and_a_held_force() -> None:
    # SDOF x'' + w^2 x = -a_g(t) + f/m with a_g = r t (linear) and f held: closed form
    # x(t) = -r (t - sin(w t)/w)/w^2 + f (1 - cos w t)/(m w^2) from rest.
    m, w, r, f, h = 2.0, 7.0, 0.3, 5.0, 0.01
    a, b_g, b_f = state_matrices([[m]], [[0.0]], [[m * w * w]], [[m]])
    d = discretise_structure(a, b_g, b_f[:, 0], h)
    z = np.zeros(2)
    for k in range(300):
        z = d.phi @ z + d.g0 * r * k * h + d.g1 * r * (k + 1) * h + d.gf[:, 0] * f
    t = 300 * h
    exact = -r * (t - math.sin(w * t) / w) / w**2 + f * (1 - math.cos(w * t)) / (m * w * w)
    assert z[0] == pytest.approx(exact, rel=1e-11)
    # discrete eigenvalues are exp(lambda h) exactly
    np.testing.assert_allclose(
        np.sort_complex(np.linalg.eigvals(d.phi)), np.sort_complex(np.exp(np.linalg.eigvals(a) * h))
    )


def test_reference_response_equals_lsim_with_linear_interpolation() -> None:
    # scipy's lsim interpolates the input linearly between samples (= MATLAB 'foh').
    case, ground = CASES[1], ChirpMotion(f_start=0.5, f_end=30.0, duration=3.0)
    ref = reference_response(case, ground, DT)
    a, b_g, _ = state_matrices(case.mass, case.damping, case.stiffness, case.mass)
    t = np.arange(ref.shape[0]) * DT
    c = np.hstack([np.eye(3), np.zeros((3, 3))])
    _, y, _ = signal.lsim((a, b_g[:, None], c, np.zeros((3, 1))), ground.acceleration(t), t)
    np.testing.assert_allclose(ref, y, rtol=0, atol=1e-6 * np.max(np.abs(y)))


def _perfect_actuator_error(dt: float, force_delay: int) -> float:
    """NRMS error [-] of floor 1 of the partitioned frame with a perfect actuator (F = m a +
    c v + k x of the target) against the reference frame."""
    case, ground = CASES[1], ChirpMotion(f_start=0.5, f_end=12.0, duration=4.0)
    sub = FrameSubstructure(case, SPECIMEN, ground, dt, force_delay=force_delay)
    x = np.zeros(sub.n_steps + 1)
    force = 0.0
    for k in range(sub.n_steps):
        kin = sub.step(force)
        force = (
            SPECIMEN.mass * kin.acceleration
            + SPECIMEN.damping * kin.velocity
            + (SPECIMEN.stiffness * kin.displacement)
        )
        x[k + 1] = kin.displacement
    ref = reference_response(case, ground, dt)[:, 0]
    return float(np.sqrt(np.mean((x - ref) ** 2) / np.mean(ref**2)))


@pytest.mark.parametrize("force_delay", [0, 1])
def test_partition_with_a_perfect_actuator_converges_to_the_reference(force_delay: int) -> None:
    # The only departure from the monolithic frame is the interface force held over a step
    # (plus the Unit Delay): an O(dt) error, so halving dt halves it (ratio 2 +/- 10 %), and at
    # 4096 Hz it is a few 0.1 % of the response.
    coarse, fine = (
        _perfect_actuator_error(DT, force_delay),
        _perfect_actuator_error(DT / 2, force_delay),
    )
    assert coarse / fine == pytest.approx(2.0, rel=0.1)
    assert coarse < 0.01 * (1 + 2 * force_delay)


def test_interface_acceleration_is_the_derivative_of_the_velocity() -> None:
    sub = FrameSubstructure(CASES[4], SPECIMEN, ChirpMotion(duration=1.0), DT, force_delay=0)
    kin = [sub.step(0.0) for _ in range(sub.n_steps)]
    v = np.array([k.velocity for k in kin])
    acc = np.array([k.acceleration for k in kin])
    central = (v[2:] - v[:-2]) / (2 * DT)
    # central differences err by (w dt)^2/6 of the signal: 6e-4 at the chirp's 40 Hz end
    np.testing.assert_allclose(acc[1:-1], central, atol=1e-3 * np.max(np.abs(acc)))


def test_step_predict_reset_and_outputs() -> None:
    sub = FrameSubstructure(CASES[2], SPECIMEN, ChirpMotion(duration=0.5), DT)
    for _ in range(100):
        sub.step(10.0)
    ahead = sub.predict(250.0)
    time = sub.time
    assert sub.step(250.0) == ahead and sub.time == time + DT
    out = sub.outputs()
    assert set(out) == {"x1", "x2", "x3", "ag"} and out["x1"] == sub.interface.displacement
    sub.reset()
    assert sub.time == 0.0 and not np.any(sub.floor_displacements)


def test_unit_delay_applies_the_force_one_step_later() -> None:
    quiet = ChirpMotion(duration=0.1)
    delayed = FrameSubstructure(CASES[1], SPECIMEN, quiet, DT, intensity=0.0, force_delay=1)
    direct = FrameSubstructure(CASES[1], SPECIMEN, quiet, DT, intensity=0.0, force_delay=0)
    delayed.step(100.0)
    assert delayed.interface.displacement == 0.0  # the force has not acted yet
    assert delayed.step(0.0) == direct.step(100.0)


def test_numerical_matrices_remove_the_specimen_from_floor_one() -> None:
    mn, cn, kn = numerical_matrices(CASES[3], SPECIMEN)
    assert mn[0, 0] == 1300 - 29.13 and kn[0, 0] == CASES[3].stiffness[0, 0] - 1.19e6
    assert cn[0, 0] == CASES[3].damping[0, 0] - SPECIMEN.damping and mn[1, 1] == 1300


def test_bad_inputs_name_the_value() -> None:
    with pytest.raises(ParameterError, match="case must be one of 1, 2, 3, 4; got 5"):
        benchmark_case(5)
    with pytest.raises(ParameterError, match="force_delay must be 0 or 1 steps; got 2"):
        FrameSubstructure(CASES[1], SPECIMEN, ChirpMotion(), DT, force_delay=2)
    with pytest.raises(ParameterError, match="below the first floor"):
        numerical_matrices(CASES[1], LinearSpecimen(2000.0, 0.0, 1.0))
    with pytest.raises(ParameterError, match="intensity must be >= 0; got -1"):
        ChirpMotion().acceleration([0.0], -1)
    with pytest.raises(ParameterError, match="unknown ground motion 'loma'"):
        ground_motion("loma")
    with pytest.raises(DataError, match="time must start at 0"):
        RecordedMotion("x", np.array([1.0, 2.0]), np.zeros(2))


def test_chirp_sweeps_linearly_to_its_target_frequency() -> None:
    g = ChirpMotion(f_start=1.0, f_end=5.0, duration=10.0)
    t = np.arange(0, 10.0, 1e-4)
    a = g.acceleration(t, 1.0)
    up = t[1:][(a[:-1] < 0) & (a[1:] >= 0)]  # upward zero crossings: one per period
    periods = np.diff(up)
    mid = 0.5 * (up[1:] + up[:-1])
    np.testing.assert_allclose(1 / periods, 1.0 + 0.4 * mid, rtol=2e-3)
    assert g.steps(DT) == 40960 and g.name == "chirp"


def test_missing_package_is_a_one_line_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(PACKAGE_ENV, raising=False)
    monkeypatch.delenv("RTHS_DATA", raising=False)
    with pytest.raises(ConfigError) as err:
        load_record("el_centro")
    message = str(err.value)
    assert "\n" not in message and "MECHS-RCN/BENCHMARKS" in message and "chirp" in message
    with pytest.raises(ConfigError, match="is not the vRTHS benchmark package"):
        package_dir("/nonexistent")


def test_package_found_under_rths_data(monkeypatch: pytest.MonkeyPatch, tmp_path) -> None:
    # RTHS_VRTHS_PACKAGE wins; without it, $RTHS_DATA/vrths-benchmark (the project's data folder)
    (tmp_path / "vrths-benchmark").mkdir()
    (tmp_path / "vrths-benchmark" / "ElCentroAccelNoScaling.mat").write_bytes(b"")
    monkeypatch.delenv(PACKAGE_ENV, raising=False)
    monkeypatch.setenv("RTHS_DATA", str(tmp_path))
    assert package_dir() == tmp_path / "vrths-benchmark"
    monkeypatch.setenv(PACKAGE_ENV, "/nonexistent")
    with pytest.raises(ConfigError, match="'/nonexistent' is not the vRTHS benchmark package"):
        package_dir()


def _package_or_skip() -> str:
    try:
        return str(package_dir())
    except ConfigError:
        pytest.skip(f"benchmark package not available (set {PACKAGE_ENV} or RTHS_DATA)")


@pytest.mark.parametrize(
    ("name", "duration", "dt", "peak"),
    [("el_centro", 41.18, 0.02, 3.13), ("kobe", 50.94, 0.01, 6.33), ("morgan", 39.97, 0.005, 2.39)],
)
def test_records_read_from_the_package(name: str, duration: float, dt: float, peak: float) -> None:
    g = load_record(name, _package_or_skip())
    assert g.duration == pytest.approx(duration) and np.diff(g.time)[0] == pytest.approx(dt)
    assert np.max(np.abs(g.samples)) == pytest.approx(peak, abs=0.01)  # m/s^2 (F1: UNITS m/s^2)
    assert g.acceleration(g.duration + 5.0) == pytest.approx(0.4 * g.samples[-1])
