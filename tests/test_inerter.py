"""Oracles for the ideal and rack-and-pinion inerters (plants.tmdi.inerter, S1 Eq.9-11)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from plants.base import drive
from plants.tmdi.inerter import (
    FLYWHEELS,
    S1_IDEAL_INERTANCE,
    S1_RACK_PINION,
    IdealInerter,
    RackPinionInerter,
    RackPinionParameters,
    ideal_inerter_preset,
    rack_pinion_preset,
)
from rths.core.errors import ParameterError

J_B, R_P = S1_RACK_PINION.flywheel_inertia, S1_RACK_PINION.pinion_radius


def rigid_device(stiffness: float = 1e7, friction: float = 0.0) -> RackPinionParameters:
    """The S1 device with ε = 0, c_B = 0, a stiff series spring and critical series damping."""
    return replace(
        S1_RACK_PINION,
        series_stiffness=stiffness,
        series_damping=2.0 * math.sqrt(stiffness * J_B),
        clearance_forward=0.0,
        clearance_backward=0.0,
        flywheel_damping=0.0,
        friction_force=friction,
    )


def sine_drive(dt: float, duration: float, amplitude: float, freq: float, start_at_rest: bool):
    """Drive samples (t, u, v, a): ``A(1-cos ωt)`` (starts at rest) or ``A sin ωt``."""
    t = np.arange(0.0, duration + 0.5 * dt, dt)
    w = 2.0 * math.pi * freq
    if start_at_rest:
        return (
            t,
            amplitude * (1 - np.cos(w * t)),
            amplitude * w * np.sin(w * t),
            amplitude * w * w * np.cos(w * t),
        )
    return (
        t,
        amplitude * np.sin(w * t),
        amplitude * w * np.cos(w * t),
        -amplitude * w * w * np.sin(w * t),
    )


def test_presets_match_s1_table_1_and_section_4_2() -> None:
    # b = J_B / r_P² = 47.8 kg for the identified IF device (Table 1 nominal: 47.9 kg)
    assert S1_RACK_PINION.nominal_inertance == pytest.approx(47.8395, abs=1e-4)
    # inertance ratios β = b / m_I of Table 1, to the printed three decimals
    for name, beta in {"NF": 0.001, "IF": 0.383, "LF": 0.765}.items():
        assert round(FLYWHEELS[name] / 125.0, 3) == beta
        ratio = FLYWHEELS[name] / FLYWHEELS["IF"]
        # NF/LF scale J_B (and the ideal inertance) by the nominal ratio, IF is the identified one
        assert rack_pinion_preset(name).flywheel_inertia == pytest.approx(J_B * ratio, rel=1e-15)
        assert ideal_inerter_preset(name) == pytest.approx(48.7 * ratio, rel=1e-15)
    assert rack_pinion_preset("IF") == S1_RACK_PINION
    assert S1_IDEAL_INERTANCE == 48.7


def test_ideal_inerter_force_is_b_times_acceleration() -> None:
    spec = IdealInerter(47.9)
    t, u, v, a = sine_drive(1e-3, 1.0, 0.01, 2.0, start_at_rest=False)
    np.testing.assert_array_equal(drive(spec, u, 1e-3, v, a), 47.9 * a)
    assert spec.rigid_inertance == 47.9 and spec.rigid_damping == 0.0
    assert spec.state() == {}


def test_rigid_limit_is_the_ideal_inerter_b_equals_jb_over_rp2() -> None:
    """k_S → ∞, ε → 0, f_y → 0, c_B → 0 ⇒ F_B = (J_B/r_P²) ü_T: proves the sign convention."""
    dt = 1.0 / 1024.0
    t, u, v, a = sine_drive(dt, 2.0, 0.01, 2.0, start_at_rest=True)
    rack = drive(RackPinionInerter(rigid_device()), u, dt, v, a)
    ideal = drive(IdealInerter(J_B / R_P**2), u, dt, v, a)
    late = t > 0.1  # after the start-up transient of the series spring (critically damped, ~0.1 ms)
    scale = np.max(np.abs(ideal))
    # residual = cubic-Hermite drive interpolation O((ω dt)²/12) ≈ 2e-5 plus the series
    # compliance (ω/ω_c)² ≈ 2.5e-7
    assert np.max(np.abs(rack[late] - ideal[late])) < 1e-4 * scale
    # approach to the limit: a softer series spring adds F/b ü - 1 ≈ (ω/ω_c)², ω_c² = k_S/J_B
    soft_k = 1e4
    soft = drive(RackPinionInerter(rigid_device(soft_k)), u, dt, v, a)
    compliance = (2.0 * math.pi * 2.0) ** 2 * J_B / soft_k  # 2.4e-4
    deviation = np.max(np.abs(soft[late] - ideal[late])) / scale
    assert deviation == pytest.approx(compliance, rel=0.1)  # 10 %: drive error ≈ 1e-5 on 2.4e-4


def test_friction_loop_area_is_four_fy_a() -> None:
    """Rigid device + Coulomb friction: the inertial part is conservative, so ∮F du = 4 f_y A."""
    dt, amplitude, freq = 1.0 / 2048.0, 0.01, 2.0
    t, u, v, a = sine_drive(dt, 3.0, amplitude, freq, start_at_rest=False)
    params = rigid_device(friction=7.3)
    force = drive(RackPinionInerter(params), u, dt, v, a)
    cycles = t >= 1.0 - 0.5 * dt  # four whole cycles after the start-up transient
    area = np.trapezoid(force[cycles] * v[cycles], t[cycles]) / 4.0
    r = params.friction_velocity / (amplitude * 2.0 * math.pi * freq)
    expected = 4.0 * 7.3 * amplitude * (1.0 - math.pi**2 / 24.0 * r**2)  # tanh regularisation
    # periodic trapezoidal quadrature of a smooth loop: measured 6e-8 relative
    assert area == pytest.approx(expected, rel=1e-6)
    # the regularisation deficit (π²/24)(v_eps/Aω)² is 2.6e-5
    assert area == pytest.approx(4.0 * 7.3 * amplitude, rel=1e-4)


def test_open_gap_transmits_no_torque_and_the_flywheel_coasts() -> None:
    dt = 1e-3
    t, u, v, a = sine_drive(dt, 3.0, 0.01, 2.0, start_at_rest=True)
    spec = RackPinionInerter(S1_RACK_PINION)
    states, forces = [], []
    for k in range(t.size):
        forces.append(spec.step(u[k], v[k], a[k], dt))
        states.append(spec.state())
    contact = np.array([s["contact"] for s in states])
    torque = np.array([s["torque"] for s in states])
    gap = np.array([s["gap"] for s in states])
    omega = np.array([s["omega_G"] for s in states])
    friction = np.array([s["friction"] for s in states])
    is_open = contact == 0
    assert 0.03 < is_open.mean() < 0.5  # the drive exercises both the open and closed gap
    assert np.all(torque[is_open] == 0.0)
    np.testing.assert_array_equal(np.array(forces)[is_open], friction[is_open])
    np.testing.assert_allclose(friction, 7.3 * np.tanh(v / 1e-3), rtol=1e-14)
    # the gap never leaves [-ε2, ε1] (event tolerance 1e-13 rad)
    assert gap.max() <= S1_RACK_PINION.clearance_forward + 1e-12
    assert gap.min() >= -S1_RACK_PINION.clearance_backward - 1e-12
    # closed gap: torque pushes the flywheel towards the contact face (S1 Eq.11 sign)
    assert np.all(torque[contact == 1] >= 0.0) and np.all(torque[contact == -1] <= 0.0)
    # free coasting while open for a whole step: ω_{k+1}/ω_k = exp(-c_B dt/J_B); trapezoidal
    # rule error (c_B dt/J_B)³/12 ≈ 6e-9
    both = is_open[1:] & is_open[:-1] & (omega[:-1] != 0.0)  # not the initial rest
    assert both.sum() > 10
    ratio = omega[1:][both] / omega[:-1][both]
    np.testing.assert_allclose(ratio, math.exp(-0.03 * dt / J_B), rtol=1e-8)


def test_converges_with_the_call_step_second_order() -> None:
    duration, amplitude, freq = 2.0, 0.01, 2.0
    forces = {}
    for dt in (1.0 / 1024.0, 1.0 / 2048.0, 1.0 / 8192.0):
        t, u, v, a = sine_drive(dt, duration, amplitude, freq, start_at_rest=True)
        forces[dt] = drive(RackPinionInerter(), u, dt, v, a)
    fine = forces[1.0 / 8192.0]

    def error(dt: float) -> float:
        coarse = forces[dt]
        ref = fine[:: round(dt * 8192)][: coarse.size]
        late = np.arange(coarse.size) * dt > 0.5
        return float(np.sqrt(np.mean((coarse - ref)[late] ** 2) / np.mean(ref[late] ** 2)))

    e1, e2 = error(1.0 / 1024.0), error(1.0 / 2048.0)
    assert e1 < 2e-3  # measured 5.3e-4 at 1 kHz against an 8 kHz reference
    assert e2 < 0.35 * e1  # second order: measured ratio 1/4.1


def test_reset_reproduces_the_run_and_substeps_follow_the_time_scales() -> None:
    dt = 1e-3
    t, u, v, a = sine_drive(dt, 0.5, 0.01, 2.0, start_at_rest=True)
    spec = RackPinionInerter(rack_pinion_preset("NF"))
    first = drive(spec, u, dt, v, a)
    np.testing.assert_array_equal(drive(spec, u, dt, v, a), first)
    # NF: J_B/(c_S + c_B) = 37 µs is the shortest scale → quarter of it per sub-step
    assert spec.substeps(dt) == math.ceil(dt / (0.25 * spec.parameters.flywheel_inertia / 0.88))
    assert RackPinionInerter().substeps(dt) == 1
    assert RackPinionInerter().rigid_inertance == 0.0
    assert RackPinionInerter(rigid_device()).state()["contact"] == 1.0  # no play: always closed


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("pinion_radius", 0.0, "pinion radius r_P must be positive; got 0.0"),
        ("flywheel_inertia", -1.0, "flywheel inertia J_B must be positive; got -1.0"),
        ("series_stiffness", 0.0, "series stiffness k_S must be positive; got 0.0"),
        ("series_damping", -0.1, "series damping c_S must be non-negative; got -0.1"),
        ("clearance_forward", -1e-3, "forward clearance eps1 must be non-negative"),
        ("clearance_backward", math.nan, "backward clearance eps2 must be finite"),
        ("flywheel_damping", -0.03, "flywheel damping c_B must be non-negative"),
        ("friction_force", -7.3, "friction force f_y must be non-negative; got -7.3"),
        ("friction_velocity", 0.0, "regularisation velocity v_eps must be positive; got 0.0"),
    ],
)
def test_bad_rack_pinion_parameters_are_rejected(field: str, value: float, match: str) -> None:
    with pytest.raises(ParameterError, match=match):
        replace(S1_RACK_PINION, **{field: value})


def test_bad_specimen_inputs_are_rejected() -> None:
    with pytest.raises(ParameterError, match="inertance b must be positive; got 0.0"):
        IdealInerter(0.0)
    with pytest.raises(ParameterError, match="parameters must be RackPinionParameters; got dict"):
        RackPinionInerter({})  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="flywheel must be one of 'NF', 'IF', 'LF'; got 'XL'"):
        rack_pinion_preset("XL")
    with pytest.raises(ParameterError, match="flywheel must be one of .*; got None"):
        ideal_inerter_preset(None)  # type: ignore[arg-type]
    spec = RackPinionInerter()
    with pytest.raises(ParameterError, match="time step dt must be positive; got 0.0"):
        spec.step(0.0, 0.0, 0.0, 0.0)
    with pytest.raises(ParameterError, match="drive state must be finite; got u=nan"):
        spec.step(math.nan, 0.0, 0.0, 1e-3)
