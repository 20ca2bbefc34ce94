"""Taut-cable FE substructure: closed forms, discrete energy balances, Newmark-AA eigenvalues."""

import math

import numpy as np
import pytest
import scipy.integrate as si
import scipy.linalg as sla

from plants.cable.device import SeriesCondensation, augmented_matrices
from plants.cable.fe import Tridiagonal, mesh_nodes, sine_load_shape
from plants.cable.model import (
    Cable,
    CableProperties,
    DistributedLoad,
    InterfaceDevice,
    PointDamper,
    RayleighDamping,
    elements_for,
    fe_matrices,
    max_element_size,
    normalised_damper,
    normalised_stiffness,
    physical_damper,
    physical_stiffness,
)
from rths.core.errors import ParameterError

PROPS = CableProperties(
    length=100.0, tension=1.0e6, mass_per_length=50.0
)  # c = 141 m/s, f1 = 0.71 Hz


def energy(cable: Cable) -> float:
    return cable.kinetic_energy + cable.strain_energy


# ---------------------------------------------------------------------------- parameters
def test_derived_properties():
    c = math.sqrt(1.0e6 / 50.0)
    assert PROPS.wave_speed == pytest.approx(c, rel=1e-15)  # same arithmetic
    assert PROPS.fundamental_frequency == pytest.approx(c / 200.0, rel=1e-15)
    assert PROPS.omega0 == pytest.approx(2.0 * math.pi * PROPS.fundamental_frequency, rel=1e-15)
    assert PROPS.mass == pytest.approx(5000.0, rel=1e-15)


def test_normalisation_eq23_matches_string_forms():
    # general S0 Eq.23 vs the taut-string forms m_e = mbar/(mL), c_d = cbar/(pi sqrt(T m))
    m_e, c_d = normalised_damper(PROPS, inertance=2650.0, damping=1234.0)
    assert m_e == pytest.approx(2650.0 / PROPS.mass, rel=1e-14)  # rounding only
    assert c_d == pytest.approx(1234.0 / (math.pi * math.sqrt(1.0e6 * 50.0)), rel=1e-14)
    assert physical_damper(PROPS, m_e, c_d) == pytest.approx((2650.0, 1234.0), rel=1e-14)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (
            {"length": 0.0, "tension": 1.0, "mass_per_length": 1.0},
            "cable length L must be positive; got 0.0",
        ),
        (
            {"length": 1.0, "tension": -3.0, "mass_per_length": 1.0},
            "cable tension T must be positive; got -3.0",
        ),
        (
            {"length": 1.0, "tension": 1.0, "mass_per_length": math.nan},
            "mass per length m must be finite",
        ),
    ],
)
def test_properties_reject_bad_values(kwargs, match):
    with pytest.raises(ParameterError, match=match):
        CableProperties(**kwargs)


def test_damper_conversions_reject_negative_values():
    with pytest.raises(ParameterError, match="damper inertance must be non-negative; got -1.0"):
        normalised_damper(PROPS, -1.0, 0.0)
    with pytest.raises(ParameterError, match="damper damping coefficient must be non-negative"):
        normalised_damper(PROPS, 0.0, -2.0)
    with pytest.raises(ParameterError, match="normalised inertance m_e must be non-negative"):
        physical_damper(PROPS, -0.5, 0.0)
    with pytest.raises(ParameterError, match="normalised damping c_d must be non-negative"):
        physical_damper(PROPS, 0.5, -0.1)


def test_configuration_dataclasses_reject_bad_values():
    with pytest.raises(ParameterError, match="load amplitude p0 must be finite"):
        DistributedLoad(amplitude=math.inf)
    with pytest.raises(ParameterError, match="load mode n must be a positive integer; got 0"):
        DistributedLoad(1.0, mode=0)
    with pytest.raises(ParameterError, match="load frequency Omega must be non-negative; got -1.0"):
        DistributedLoad(1.0, frequency=-1.0)
    with pytest.raises(
        ParameterError, match=r"intrinsic damping ratio must lie in \[0, 1\); got 1.5"
    ):
        RayleighDamping(ratio=1.5)
    with pytest.raises(ParameterError, match=r"two distinct modes; got \(2, 2\)"):
        RayleighDamping(modes=(2, 2))
    with pytest.raises(ParameterError, match="two distinct modes; got 3"):
        RayleighDamping(modes=3)
    with pytest.raises(
        ParameterError, match="Rayleigh anchor mode must be a positive integer; got 0"
    ):
        RayleighDamping(modes=(0, 3))
    with pytest.raises(ParameterError, match="damper inertance must be non-negative; got -1.0"):
        PointDamper(inertance=-1.0)
    with pytest.raises(ParameterError, match="damper damping coefficient must be non-negative"):
        PointDamper(damping=-1.0)


def test_cable_rejects_bad_mesh_and_step():
    with pytest.raises(ParameterError, match=r"damper position x_d must lie in \(0, 1\); got 1.0"):
        Cable(PROPS, 1.0, 1e-3)
    with pytest.raises(
        ParameterError, match=r"number of elements must lie in \[2, 100000\]; got 1"
    ):
        Cable(PROPS, 0.5, 1e-3, elements=1)
    with pytest.raises(ParameterError, match="time step dt must be positive; got 0.0"):
        Cable(PROPS, 0.5, 0.0)
    with pytest.raises(ParameterError, match="mass_matrix must be"):
        fe_matrices(PROPS, 0.5, 10, mass_matrix="diagonal")
    cable = Cable(PROPS, 0.5, 1e-3, elements=10)
    with pytest.raises(ParameterError, match="restoring force must be finite; got nan"):
        cable.step(math.nan)
    with pytest.raises(ParameterError, match="restoring force must be finite; got inf"):
        cable.predict(math.inf)
    with pytest.raises(
        ParameterError, match=r"nodal displacement must have shape \(9,\); got shape \(8,\)"
    ):
        cable.set_state(np.zeros(8), np.zeros(9))
    with pytest.raises(ParameterError, match="nodal velocity must be finite; got nan"):
        cable.set_state(np.zeros(9), np.full(9, np.nan))
    with pytest.raises(ParameterError, match=r"position x must lie in \[0.0, 1.0\]; got 1.5"):
        cable.displacement_at(1.5)
    with pytest.raises(ParameterError, match="time t must be finite; got inf"):
        cable.nodal_load(math.inf)
    with pytest.raises(ParameterError, match="count must not exceed the 9 free nodes; got 10"):
        cable.modal_frequencies(10)
    with pytest.raises(ParameterError, match="count must be a positive integer; got 0"):
        cable.modal_frequencies(0)


# ---------------------------------------------------------------------------- mesh and load
@pytest.mark.parametrize(
    ("x_d", "elements", "n_left"), [(0.02, 100, 2), (0.02, 30, 1), (0.37, 41, 15), (0.999, 5, 4)]
)
def test_mesh_has_a_node_at_the_damper_and_uniform_sides(x_d, elements, n_left):
    nodes, index = mesh_nodes(PROPS.length, x_d, elements)
    assert nodes.size == elements + 1 and index == n_left - 1
    assert (
        nodes[index + 1] == x_d * PROPS.length
    )  # exact: the damper node is the linspace end point
    left, right = np.diff(nodes[: n_left + 1]), np.diff(nodes[n_left:])
    np.testing.assert_allclose(left, left[0], rtol=1e-12)  # linspace rounding only
    np.testing.assert_allclose(right, right[0], rtol=1e-12)


def test_consistent_load_is_the_exact_integral_against_hat_functions():
    nodes, _ = mesh_nodes(PROPS.length, 0.37, 13)  # non-uniform on both sides
    k = 3 * math.pi / PROPS.length
    shape = sine_load_shape(nodes, k)
    for j in range(1, nodes.size - 1):
        a, b, c = nodes[j - 1 : j + 2]
        hat = lambda x: (x - a) / (b - a) if x <= b else (c - x) / (c - b)
        ref, _ = si.quad(
            lambda x: hat(x) * math.sin(k * x), a, c, points=[b], epsabs=0, epsrel=1e-13
        )
        assert shape[j - 1] == pytest.approx(ref, rel=1e-11)  # quadrature tolerance


def test_static_point_force_gives_the_string_deflection_with_the_cable_receiving_minus_F():
    # With dt huge, Newmark-AA's effective matrix is K to 1/(omega1 dt)^2 ~ 1e-13: one step is static.
    # Linear string elements are nodally exact for a point load: u(x_d) = -F x_d (1 - x_d) L / T.
    cable = Cable(PROPS, 0.3, dt=1.0e6, elements=10, intrinsic_damping=None)
    force = 2.0e4
    state = cable.step(force)
    assert state.displacement == pytest.approx(
        -force * 0.3 * 0.7 * PROPS.length / PROPS.tension, rel=1e-9
    )
    assert cable.displacement_at(0.0) == 0.0 and cable.displacement_at(1.0) == 0.0


def test_grounded_device_spring_in_a_static_step():
    # one static step (huge dt, as above): the string's point stiffness T/(x(1-x)L) in parallel with k_r
    x_d, k_r, force = 0.3, 4e4, 2e4
    cable = Cable(
        PROPS,
        x_d,
        dt=1.0e6,
        elements=10,
        intrinsic_damping=None,
        damper=InterfaceDevice(stiffness=k_r),
    )
    state = cable.step(force)
    k_string = PROPS.tension / (x_d * (1 - x_d) * PROPS.length)
    assert state.displacement == pytest.approx(
        -force / (k_string + k_r), rel=1e-9
    )  # 1/(omega1 dt)^2
    assert cable.device_force == pytest.approx(k_r * state.displacement, rel=1e-15)  # F = k_r u_d
    assert cable.strain_energy == pytest.approx(
        0.5 * (k_string + k_r) * state.displacement**2, rel=1e-9
    )


# ---------------------------------------------------------------------------- integrator
@pytest.mark.parametrize(
    "damper",
    [
        PointDamper(inertance=2650.0, damping=900.0),
        InterfaceDevice(
            300.0, 500.0, series_stiffness=2e6, series_inertance=2650.0, series_damping=900.0
        ),
    ],
)
def test_compiled_kernel_matches_the_reference_path(damper):
    runs = []
    for use_numba in (True, False):
        cable = Cable(
            PROPS,
            0.02,
            2e-3,
            elements=60,
            load=DistributedLoad(200.0, mode=3),
            damper=damper,
            use_numba=use_numba,
        )
        history = [cable.step(5e3 * math.sin(7.0 * k * 2e-3)) for k in range(400)]
        runs.append(
            (history, cable.displacement, cable.velocity, cable.acceleration, cable.device_force)
        )
    (h1, *s1, f1), (h2, *s2, f2) = runs
    # same arithmetic in another order: u agrees to round-off; v = 2/h du - v and a = 4/h^2 du - ...
    # amplify the round-off of u by 1/(omega h) and 1/(omega h)^2 for the fast FE modes
    for x, y, tol in zip(s1, s2, (1e-12, 1e-11, 1e-9), strict=True):
        np.testing.assert_allclose(x, y, rtol=0, atol=tol * np.max(np.abs(y)))
    assert h1[-1].displacement == pytest.approx(h2[-1].displacement, rel=1e-10)
    assert f1 == pytest.approx(f2, rel=1e-9)  # m_r a carries the 1/(omega h)^2 amplification too


def test_predict_equals_step_and_leaves_the_state_alone():
    cable = Cable(PROPS, 0.02, 1e-3, elements=40, load=DistributedLoad(100.0, mode=3))
    for k in range(50):
        cable.step(100.0 * k)
    before = (cable.time, cable.displacement, cable.interface)
    predicted = cable.predict(321.0)
    assert (cable.time, cable.interface) == (before[0], before[2])
    np.testing.assert_array_equal(cable.displacement, before[1])
    assert cable.step(321.0) == predicted  # identical arithmetic
    assert cable.time == pytest.approx(51e-3, rel=1e-15)
    cable.reset()
    assert cable.time == 0.0 and cable.interface.displacement == 0.0 and energy(cable) == 0.0


def test_undamped_free_vibration_conserves_energy():
    # Newmark-AA conserves E = v'Mv/2 + u'Ku/2 exactly for linear undamped systems.
    cable = Cable(
        PROPS, 0.02, 5e-3, elements=50, intrinsic_damping=None, damper=PointDamper(inertance=1000.0)
    )
    rng = np.random.default_rng(1)
    cable.set_state(rng.normal(size=49) * 1e-2, rng.normal(size=49) * 1e-1)
    e0 = energy(cable)
    for _ in range(1000):
        cable.step(0.0)
    assert energy(cable) == pytest.approx(e0, rel=1e-11)  # round-off accumulated over 1000 steps


def test_discrete_energy_balance_with_viscous_damper_load_and_device_force():
    # E_{k+1} - E_k = du'(f_k + f_{k+1})/2 - h cbar ((v_k + v_{k+1})/2)^2 exactly for Newmark-AA.
    h, cbar = 2e-3, 3.0e4
    cable = Cable(
        PROPS,
        0.02,
        h,
        elements=80,
        intrinsic_damping=None,
        load=DistributedLoad(300.0, mode=3),
        damper=PointDamper(inertance=2000.0, damping=cbar),
    )
    d = cable.damper_index
    f_prev = cable.nodal_load(0.0)
    e_prev, u_prev, v_prev = energy(cable), cable.displacement, cable.velocity
    work = dissipated = trapezoid = 0.0
    for k in range(3000):
        force = 2e3 * math.sin(11.0 * k * h)
        cable.step(force)
        f = cable.nodal_load(cable.time)
        f[d] -= force
        u, v = cable.displacement, cable.velocity
        w_k = (u - u_prev) @ (f + f_prev) / 2.0
        dis_k = h * cbar * ((v[d] + v_prev[d]) / 2.0) ** 2
        e = energy(cable)
        assert e - e_prev == pytest.approx(w_k - dis_k, abs=1e-9 * max(e, 1.0))  # round-off
        work, dissipated = work + w_k, dissipated + dis_k
        trapezoid += h * cbar * (v[d] ** 2 + v_prev[d] ** 2) / 2.0
        e_prev, u_prev, v_prev, f_prev = e, u, v, f
    assert dissipated > 0.1 * work > 0.0
    # the trapezoidal integral of c v^2 differs from the exact midpoint form by O((omega h)^2) ~ 1e-3
    assert trapezoid == pytest.approx(dissipated, rel=1e-2)


def test_newmark_discrete_eigenvalue_of_a_complex_mode():
    # Trapezoidal rule: a mode with continuous eigenvalue lam decays with (2/h) artanh(lam h/2).
    h = 0.03  # omega_3 h ~ 0.4: Newmark's period error (~1 %) is far above the 1e-6 tolerance
    rayleigh = RayleighDamping(ratio=0.02, modes=(1, 3))
    cable = Cable(PROPS, 0.5, h, elements=24, intrinsic_damping=rayleigh)
    fe = fe_matrices(PROPS, 0.5, 24, intrinsic_damping=rayleigh)
    k, m, c = (x.toarray() for x in (fe.stiffness, fe.mass, fe.damping))
    w2, modes = sla.eigh(k, m)
    phi = modes[:, 2] / np.max(np.abs(modes[:, 2]))
    lam = np.roots([1.0, (phi @ c @ phi) / (phi @ m @ phi), w2[2]])
    lam = lam[np.argmax(lam.imag)]
    cable.set_state(phi, lam.real * phi)  # u(t) = phi Re exp(lam t)
    q = [1.0]
    for _ in range(300):
        cable.step(0.0)
        u = cable.displacement
        q.append((phi @ m @ u) / (phi @ m @ phi))
        assert np.max(np.abs(u - q[-1] * phi)) < 1e-12  # classical damping: stays in this mode
    q = np.asarray(q)
    # q_{k+1} = p1 q_k + p0 q_{k-1}; the multiplier z solves z^2 = p1 z + p0
    p1, p0 = np.linalg.lstsq(np.column_stack([q[1:-1], q[:-2]]), q[2:], rcond=None)[0]
    z = np.roots([1.0, -p1, -p0])
    lam_discrete = np.log(z[np.argmax(z.imag)]) / h
    expected = 2.0 / h * np.arctanh(lam * h / 2.0)
    assert abs(lam_discrete - expected) < 1e-6 * abs(expected)  # brief's tolerance
    assert abs(lam_discrete - lam) > 1e-3 * abs(lam)  # and the test can tell it from lam itself


def test_fe_frequencies_converge_to_n_omega0_at_fourth_order():
    # average mass matrix on a uniform mesh: omega_h/omega - 1 = O((k h)^4)
    errors = []
    for n_el in (50, 100):
        cable = Cable(PROPS, 0.02, 1e-3, elements=n_el)
        w = cable.modal_frequencies(3)
        errors.append(np.abs(w / (PROPS.omega0 * np.arange(1, 4)) - 1.0))
    assert np.all(errors[1] < 2e-6)  # (3 pi/100)^4/... ~ 1e-6 at mode 3
    order = np.log2(errors[0] / errors[1])
    np.testing.assert_allclose(order, 4.0, atol=0.05)  # asymptotic regime already at N = 50


def sdof_response_from_rest(t, omega, zeta, forcing, frequency):
    """Closed form of q'' + 2 zeta omega q' + omega^2 q = forcing sin(frequency t), q(0) = q'(0) = 0."""
    amp = forcing / math.hypot(omega**2 - frequency**2, 2.0 * zeta * omega * frequency)
    phase = math.atan2(2.0 * zeta * omega * frequency, omega**2 - frequency**2)
    wd = omega * math.sqrt(1.0 - zeta**2)
    a = amp * math.sin(phase)  # q(0) = 0
    b = (zeta * omega * a - amp * frequency * math.cos(phase)) / wd  # q'(0) = 0
    transient = np.exp(-zeta * omega * t) * (a * np.cos(wd * t) + b * np.sin(wd * t))
    return amp * np.sin(frequency * t - phase) + transient


@pytest.mark.parametrize("ratio", [None, 0.8])
def test_forced_response_matches_the_modal_closed_form(ratio):
    # S0 Eq.22 load on mode n excites only mode n: q'' + 2 zeta w q' + w^2 q = (p0/m) sin(W t)
    n, p0, zeta = 3, 100.0, 0.001
    w = n * PROPS.omega0
    frequency = w if ratio is None else ratio * w  # None: the default, resonance
    h = 2.0 * math.pi / w / 400
    rayleigh = RayleighDamping(zeta, (1, n))  # exactly zeta at the string's mode n
    load = DistributedLoad(p0, mode=n, frequency=None if ratio is None else frequency)
    cable = Cable(PROPS, 0.02, h, elements=100, load=load, intrinsic_damping=rayleigh)
    t = np.arange(1, 20 * 400 + 1) * h
    u = []
    for _ in t:
        cable.step(0.0)
        u.append(cable.displacement)
    q = sdof_response_from_rest(t, w, zeta, p0 / PROPS.mass_per_length, frequency)
    expected = np.outer(q, np.sin(n * math.pi * cable.positions / PROPS.length))
    # Newmark period error (w h)^2/12 = 2e-5 over 20 cycles -> phase 2.5e-3 rad; FE error ~ 1e-6
    assert np.max(np.abs(np.asarray(u) - expected)) < 5e-3 * np.max(np.abs(expected))
    i = cable.damper_index
    assert (
        cable.interface.displacement == u[-1][i] and cable.interface.velocity == cable.velocity[i]
    )
    out = cable.outputs()
    assert out["midspan_displacement"] == cable.displacement_at(0.5) == u[-1][49]  # node 50 at L/2
    assert cable.kinetic_energy + cable.strain_energy == pytest.approx(energy(cable), rel=1e-15)


def test_mock_rths_with_an_internal_imd_follows_its_complex_mode():
    # Non-classical damping (IMD inside the model, seed optimum): u(t) = Re(phi exp(lam t)) from the
    # state-space eigenproblem; Newmark-AA must give Re(phi z^k), z = (1 + lam h/2)/(1 - lam h/2),
    # and lam L/c must be the normalised root of plants.cable.frequency_equation for the same mesh.
    from plants.cable.frequency_equation import fe_roots

    n_el, h = 40, 0.01
    damper = PointDamper(*physical_damper(PROPS, 0.53, 0.75))
    cable = Cable(PROPS, 0.02, h, elements=n_el, intrinsic_damping=None, damper=damper)
    fe = fe_matrices(PROPS, 0.02, n_el, damper=damper)
    k, m, c = (x.toarray() for x in (fe.stiffness, fe.mass, fe.damping))
    size = k.shape[0]
    a = np.block([[np.zeros((size, size)), np.eye(size)], [-k, -c]])
    b = np.block([[np.eye(size), np.zeros((size, size))], [np.zeros((size, size)), m]])
    lam_all, vectors = sla.eig(a, b)
    beta = -1j * lam_all * PROPS.length / PROPS.wave_speed
    j = int(np.argmin(np.abs(beta - 9.46)))  # the lower root of the seed pair
    lam, phi = lam_all[j], vectors[:size, j] / np.max(np.abs(vectors[:size, j]))
    roots = fe_roots(3, 0.02, 0.53, 0.75, elements=n_el)
    assert min(abs(r.beta - beta[j]) for r in roots) < 1e-9 * abs(beta[j])  # same model, units only
    cable.set_state(phi.real, (lam * phi).real)
    z = (1 + lam * h / 2) / (1 - lam * h / 2)
    for step in range(1, 201):
        cable.step(0.0)
        expected = (phi * z**step).real
        np.testing.assert_allclose(cable.displacement, expected, rtol=0, atol=1e-9)  # |phi| <= 1


def test_configuration_values_are_stored_as_floats():
    props = CableProperties(np.float32(100.0), 1_000_000, "50")  # validators coerce like float()
    assert all(type(v) is float for v in (props.length, props.tension, props.mass_per_length))
    assert type(DistributedLoad(1, mode=2, frequency=3).frequency) is float
    assert RayleighDamping(0, [2, 5]).modes == (2, 5)


# ---------------------------------------------------------------------------- nominal interface device
SERIES = InterfaceDevice(
    300.0, 500.0, series_stiffness=2e6, series_inertance=2650.0, series_damping=3e3, stiffness=4e4
)
MAXWELL = InterfaceDevice(
    series_stiffness=5e5, series_damping=4e4
)  # spring + dashpot, no flywheel mass


def augmented_newmark(device: InterfaceDevice, elements: int, h: float):
    """Dense (N-1)+1 DOF matrices with the flywheel appended by hand, and the factor of the effective matrix."""
    rigid = InterfaceDevice(device.inertance, device.damping, stiffness=device.stiffness)
    fe = fe_matrices(PROPS, 0.02, elements, intrinsic_damping=RayleighDamping(), damper=rigid)
    n, j, k_s = fe.stiffness.shape[0], fe.damper_index, device.series_stiffness
    k, m, c = (np.zeros((n + 1, n + 1)) for _ in range(3))
    k[:n, :n], m[:n, :n], c[:n, :n] = (
        fe.stiffness.toarray(),
        fe.mass.toarray(),
        fe.damping.toarray(),
    )
    k[j, j] += k_s
    k[j, n] = k[n, j] = -k_s
    k[n, n] = k_s
    m[n, n], c[n, n] = device.series_inertance, device.series_damping
    return k, m, c, sla.lu_factor(k + 2.0 / h * c + 4.0 / h**2 * m), j


@pytest.mark.parametrize("device", [SERIES, MAXWELL], ids=["flywheel", "maxwell"])
@pytest.mark.parametrize("use_numba", [True, False])
def test_condensed_step_equals_the_augmented_system(device, use_numba):
    h, n_el = 2e-3, 60
    cable = Cable(
        PROPS,
        0.02,
        h,
        elements=n_el,
        load=DistributedLoad(200.0, mode=3),
        damper=device,
        use_numba=use_numba,
    )
    k, m, c, lu, j = augmented_newmark(device, n_el, h)
    n = k.shape[0] - 1
    u, v, a = np.zeros(n + 1), np.zeros(n + 1), np.zeros(n + 1)
    for step in range(1500):
        force = 5e3 * math.sin(7.0 * step * h)
        cable.step(force)
        f = np.zeros(n + 1)
        f[:n] = cable.nodal_load((step + 1) * h)
        f[j] -= force
        u1 = sla.lu_solve(lu, f + m @ (4.0 / h**2 * u + 4.0 / h * v + a) + c @ (2.0 / h * u + v))
        u, v, a = u1, 2.0 / h * (u1 - u) - v, 4.0 / h**2 * (u1 - u) - 4.0 / h * v - a
        fly = cable.flywheel
        got = np.append(cable.displacement, fly.displacement)
        assert np.max(np.abs(got - u)) < 1e-10 * np.max(
            np.abs(u)
        )  # brief: 1e-10 (round-off ~1e-12)
        assert fly.velocity == pytest.approx(
            v[n], rel=1e-9, abs=1e-9 * np.max(np.abs(v))
        )  # 2/h du amplifies
    expected = device.inertance * a[j] + device.damping * v[j] + device.stiffness * u[j]
    expected += device.series_stiffness * (u[j] - u[n])
    assert cable.device_force == pytest.approx(
        expected, rel=1e-8
    )  # m_r a: 4/h^2 du amplifies round-off


def test_very_stiff_series_spring_reproduces_the_rigid_device():
    # K(omega) = k_s Z0/(k_s + Z0) -> Z0 as k_s -> inf: the departure is O(m_s omega^2/k_s)
    h = 2e-3
    rigid = Cable(
        PROPS,
        0.02,
        h,
        elements=60,
        load=DistributedLoad(200.0, mode=3),
        damper=PointDamper(2650.0, 900.0),
    )
    gaps = []
    for k_s in (1e10, 1e11):
        stiff = InterfaceDevice(series_stiffness=k_s, series_inertance=2650.0, series_damping=900.0)
        cable = Cable(
            PROPS, 0.02, h, elements=60, load=DistributedLoad(200.0, mode=3), damper=stiff
        )
        rigid.reset()
        gap = scale = force_gap = force_scale = 0.0
        for step in range(1500):
            force = 5e3 * math.sin(7.0 * step * h)
            a, b = rigid.step(force), cable.step(force)
            gap, scale = (
                max(gap, abs(a.displacement - b.displacement)),
                max(scale, abs(a.displacement)),
            )
            force_gap = max(force_gap, abs(rigid.device_force - cable.device_force))
            force_scale = max(force_scale, abs(rigid.device_force))
        gaps.append(gap / scale)
        # O(m_s w^2/k_s) with w = 30 rad/s above the 7 and 13 rad/s forcing; factor 2 margin
        assert force_gap < 2.0 * 2650.0 * 30.0**2 / k_s * force_scale
    assert gaps[1] < 1e-4  # m_s w^2/k_s ~ 2e-5 at k_s = 1e11
    assert gaps[1] / gaps[0] == pytest.approx(0.1, rel=0.05)  # first order in 1/k_s


def test_discrete_energy_balance_with_the_series_device():
    # E = v'Mv/2 + u'Ku/2 (with k_r u_d^2/2) + m_s x'^2/2 + k_s (u_d - x)^2/2; Newmark-AA on the augmented linear system:
    # E_{k+1} - E_k = du'(f_k + f_{k+1})/2 - h c_r vbar_d^2 - h c_s xbar'^2 exactly.
    h = 2e-3
    device = InterfaceDevice(
        800.0, 2e4, series_stiffness=3e6, series_inertance=2650.0, series_damping=5e3, stiffness=1e5
    )
    cable = Cable(
        PROPS,
        0.02,
        h,
        elements=80,
        intrinsic_damping=None,
        load=DistributedLoad(300.0, mode=3),
        damper=device,
    )
    d = cable.damper_index
    f_prev = cable.nodal_load(0.0)
    e_prev, u_prev, v_prev, xd_prev = energy(cable), cable.displacement, cable.velocity, 0.0
    dissipated = 0.0
    for k in range(3000):
        force = 2e3 * math.sin(11.0 * k * h)
        cable.step(force)
        f = cable.nodal_load(cable.time)
        f[d] -= force
        u, v, xd = cable.displacement, cable.velocity, cable.flywheel.velocity
        work = (u - u_prev) @ (f + f_prev) / 2.0
        loss = h * (
            device.damping * ((v[d] + v_prev[d]) / 2.0) ** 2
            + device.series_damping * ((xd + xd_prev) / 2.0) ** 2
        )
        e = energy(cable)
        assert e - e_prev == pytest.approx(work - loss, abs=1e-9 * max(e, 1.0))  # round-off
        dissipated += loss
        e_prev, u_prev, v_prev, xd_prev, f_prev = e, u, v, xd, f
    assert dissipated > 0.1 * e > 0.0  # the balance is not vacuous
    # the energies are the augmented system's quadratic forms (flywheel DOF appended by fe_matrices)
    fe = fe_matrices(PROPS, 0.02, 80, damper=device)
    q, qd = np.append(u, cable.flywheel.displacement), np.append(v, xd)
    assert cable.kinetic_energy == pytest.approx(
        0.5 * qd @ fe.mass @ qd, rel=1e-12
    )  # summation order
    assert cable.strain_energy == pytest.approx(
        0.5 * q @ fe.stiffness @ q, rel=1e-9
    )  # k_s (u_d - x) cancels


def test_flywheel_rings_at_its_own_frequency_when_the_node_is_held():
    # A string of tension 1e14 N holds the damper node (compliance h/(2T) = 5e-16 m/N against k_s = 1e6 N/m);
    # the flywheel then obeys m_s x'' + c_s x' + k_s x = 0 and Newmark-AA maps each eigenvalue lam to
    # z = (1 + lam h/2)/(1 - lam h/2) exactly: x_k = Re sum(A z^k).
    k_s, m_s, c_s, h = 1e6, 1e3, 2e3, 1e-3
    held = CableProperties(1.0, 1e14, 1.0)
    device = InterfaceDevice(series_stiffness=k_s, series_inertance=m_s, series_damping=c_s)
    cable = Cable(held, 0.5, h, elements=10, intrinsic_damping=None, damper=device)
    x0 = 1e-2
    cable.set_state(np.zeros(9), np.zeros(9), flywheel=(x0, 0.0))
    assert cable.flywheel.acceleration == pytest.approx(-k_s * x0 / m_s, rel=1e-15)  # equilibrium
    lam = np.roots([m_s, c_s, k_s])
    amp = np.linalg.solve(np.array([[1.0, 1.0], lam]), [x0, 0.0])
    z = (1 + lam * h / 2) / (1 - lam * h / 2)
    for step in range(1, 2001):
        cable.step(0.0)
        expected = float(np.real(np.sum(amp * z**step)))
        # the node's compliance perturbs the flywheel by ~k_s h/(2T) ~ 1e-9 relative per cycle
        assert cable.flywheel.displacement == pytest.approx(expected, abs=1e-7 * x0)
    assert cable.device_force == pytest.approx(
        -k_s * cable.flywheel.displacement, rel=1e-6
    )  # F = k_s (u_d - x)
    assert np.abs(z[0]) < 1.0 and np.angle(z[0]) != 0.0  # a damped ringing, not a trivial decay


def test_modal_frequencies_of_a_two_dof_cable_with_the_flywheel():
    # N = 2 elements: one free node (mass 5/12 m h * 2, stiffness 2T/h) and the flywheel: a closed-form 2-DOF system.
    k_s, m_s = 3e5, 400.0
    cable = Cable(
        PROPS,
        0.5,
        1e-3,
        elements=2,
        damper=InterfaceDevice(series_stiffness=k_s, series_inertance=m_s),
    )
    h = PROPS.length / 2
    m_n, k_n = 5.0 / 6.0 * PROPS.mass_per_length * h, 2.0 * PROPS.tension / h
    # det [[k_n + k_s - w2 m_n, -k_s], [-k_s, k_s - w2 m_s]] = 0
    w2 = np.roots([m_n * m_s, -((k_n + k_s) * m_s + k_s * m_n), k_n * k_s])
    np.testing.assert_allclose(
        cable.modal_frequencies(), np.sqrt(np.sort(w2)), rtol=1e-12
    )  # eigh round-off
    with pytest.raises(
        ParameterError,
        match=r"count must not exceed the 2 DOFs \(free nodes and the flywheel\); got 3",
    ):
        cable.modal_frequencies(3)
    # without flywheel inertance the undamped branch carries no force
    maxwell = Cable(PROPS, 0.02, 1e-3, elements=20, damper=MAXWELL)
    plain = Cable(PROPS, 0.02, 1e-3, elements=20)
    np.testing.assert_array_equal(maxwell.modal_frequencies(5), plain.modal_frequencies(5))


def test_device_state_predict_reset_and_outputs():
    cable = Cable(
        PROPS, 0.02, 1e-3, elements=40, load=DistributedLoad(100.0, mode=3), damper=SERIES
    )
    rng = np.random.default_rng(4)
    u, v = rng.normal(size=39) * 1e-3, rng.normal(size=39) * 1e-2
    cable.set_state(u, v)  # default: spring unstretched, flywheel moving with the node
    d = cable.damper_index
    fly = cable.flywheel
    assert (fly.displacement, fly.velocity) == (u[d], v[d])
    assert fly.acceleration == pytest.approx(
        -SERIES.series_damping * v[d] / SERIES.series_inertance, rel=1e-15
    )
    a = cable.acceleration
    expected = SERIES.inertance * a[d] + SERIES.damping * v[d] + SERIES.stiffness * u[d]
    assert cable.device_force == pytest.approx(expected, rel=1e-14)  # summation order
    for k in range(30):
        cable.step(50.0 * k)
    before = (cable.flywheel, cable.device_force)
    predicted = cable.predict(123.0)
    assert (cable.flywheel, cable.device_force) == before
    assert cable.step(123.0) == predicted  # identical arithmetic
    out = cable.outputs()
    assert out["device_force"] == cable.device_force
    assert (out["flywheel_displacement"], out["flywheel_velocity"]) == (
        cable.flywheel.displacement,
        cable.flywheel.velocity,
    )
    cable.reset()
    assert (
        cable.flywheel == cable.interface == type(cable.interface)(0.0, 0.0, 0.0)
        and cable.device_force == 0.0
    )
    # Maxwell element: the flywheel velocity follows from c_s x' = k_s (u_d - x), whatever is given
    maxwell = Cable(PROPS, 0.02, 1e-3, elements=40, damper=MAXWELL)
    maxwell.set_state(u, v, flywheel=(0.0, 99.0))
    assert maxwell.flywheel.velocity == pytest.approx(
        MAXWELL.series_stiffness * u[d] / MAXWELL.series_damping, rel=1e-15
    )
    # no device: no force, no flywheel, no extra outputs
    plain = Cable(PROPS, 0.02, 1e-3, elements=40)
    assert plain.device_force == 0.0 and plain.flywheel is None
    assert set(plain.outputs()) == {"midspan_displacement"}
    rigid = Cable(PROPS, 0.02, 1e-3, elements=40, damper=PointDamper(10.0, 20.0))
    assert set(rigid.outputs()) == {"midspan_displacement", "device_force"}
    # the O(1) logged midspan displacement is the interpolation displacement_at(0.5) gives
    odd = Cable(PROPS, 0.02, 1e-3, elements=41)
    for c in (plain, odd):
        c.set_state(np.sin(np.linspace(0.1, 3.0, c.positions.size)), np.zeros(c.positions.size))
        assert c.outputs()["midspan_displacement"] == pytest.approx(
            c.displacement_at(0.5), rel=1e-14
        )


def test_dynamic_stiffness_closed_forms():
    k_s, m_s, c_s = 4e6, 1000.0, 300.0
    device = InterfaceDevice(
        50.0, 70.0, series_stiffness=k_s, series_inertance=m_s, series_damping=c_s, stiffness=9e3
    )
    w = np.array([0.3, 17.0, 250.0])
    flywheel = -m_s * w**2 + 1j * c_s * w
    expected = 9e3 - 50.0 * w**2 + 70j * w + 1.0 / (1.0 / k_s + 1.0 / flywheel)  # springs in series
    np.testing.assert_allclose(device.dynamic_stiffness(w), expected, rtol=1e-13)  # rounding
    branch = InterfaceDevice(series_stiffness=k_s, series_inertance=m_s)
    assert branch.series_frequency == pytest.approx(math.sqrt(k_s / m_s), rel=1e-15)
    assert abs(branch.dynamic_stiffness(branch.series_frequency * (1 + 1e-9))) > 1e8 * k_s  # pole
    assert branch.dynamic_stiffness(1e6 * branch.series_frequency) == pytest.approx(
        k_s, rel=1e-11
    )  # flywheel still
    assert MAXWELL.series_frequency == math.inf and math.isnan(
        InterfaceDevice(1.0).series_frequency
    )
    assert not InterfaceDevice(1.0).has_series and SERIES.has_series


def test_series_stiffness_normalisation_round_trip():
    k_e = normalised_stiffness(PROPS, 6.4e7)
    assert k_e == pytest.approx(6.4e7 * PROPS.length / (math.pi**2 * PROPS.tension), rel=1e-15)
    assert physical_stiffness(PROPS, k_e) == pytest.approx(6.4e7, rel=1e-15)
    # a device (m_e, k_e) has its own frequency sqrt(k_e/m_e) omega0
    m_e, _ = normalised_damper(PROPS, 2650.0, 0.0)
    assert math.sqrt(k_e / m_e) * PROPS.omega0 == pytest.approx(
        math.sqrt(6.4e7 / 2650.0), rel=1e-14
    )


# ---------------------------------------------------------------------------- mesh rule
SEED_CABLE = CableProperties(
    length=200.0, tension=5.0e6, mass_per_length=80.0
)  # brief's prototype cable
TYPE_II_STIFFNESS = 6.4e7  # S0 Table 4 k0 = 1.2e7 N/m scaled with the inertance 1589 -> 8480 kg


def test_mesh_rule_for_the_seed_type_ii_device():
    assert max_element_size(TYPE_II_STIFFNESS, SEED_CABLE) == pytest.approx(
        0.3125, rel=1e-15
    )  # 4 T/k_s
    n = elements_for(SEED_CABLE, 0.02, TYPE_II_STIFFNESS)
    assert n == 641  # 200 m/0.3125 m = 640 elements is exactly at the limit, which is strict
    for elements, meets in ((n, True), (n - 1, False)):
        nodes, _ = mesh_nodes(SEED_CABLE.length, 0.02, elements)
        h = np.max(np.diff(nodes))
        local = math.sqrt(TYPE_II_STIFFNESS / (SEED_CABLE.mass_per_length * h))
        assert bool(local < 2.0 * SEED_CABLE.wave_speed / h) is meets  # the rule's physical form
    assert (
        elements_for(SEED_CABLE, 0.02, None) == 100
        and elements_for(SEED_CABLE, 0.02, None, minimum=7) == 7
    )
    assert (
        elements_for(SEED_CABLE, 0.02, 1e3, minimum=250) == 250
    )  # soft spring: the minimum decides


def test_device_validation_branches():
    with pytest.raises(ParameterError, match="series stiffness must be positive; got 0.0"):
        InterfaceDevice(series_stiffness=0.0, series_inertance=1.0)
    with pytest.raises(ParameterError, match="series inertance must be non-negative; got -1.0"):
        InterfaceDevice(series_stiffness=1e6, series_inertance=-1.0)
    with pytest.raises(
        ParameterError, match="series damping coefficient must be non-negative; got -2.0"
    ):
        InterfaceDevice(series_stiffness=1e6, series_damping=-2.0)
    with pytest.raises(
        ParameterError,
        match="series inertance/damping need a series stiffness; got series_stiffness=None",
    ):
        InterfaceDevice(series_inertance=5.0)
    with pytest.raises(
        ParameterError,
        match="a series branch needs series_inertance or series_damping > 0; got both 0.0",
    ):
        InterfaceDevice(series_stiffness=1e6)
    with pytest.raises(ParameterError, match="damper stiffness must be non-negative; got -3.0"):
        InterfaceDevice(stiffness=-3.0)
    with pytest.raises(ParameterError, match="series stiffness must be positive; got -1.0"):
        normalised_stiffness(PROPS, -1.0)
    with pytest.raises(
        ParameterError, match="normalised series stiffness k_e must be positive; got 0.0"
    ):
        physical_stiffness(PROPS, 0.0)
    with pytest.raises(ParameterError, match="series stiffness must be positive; got 0"):
        max_element_size(0, PROPS)
    with pytest.raises(ParameterError, match="minimum elements must be a positive integer; got 0"):
        elements_for(PROPS, 0.02, 1e6, minimum=0)
    with pytest.raises(ParameterError, match=r"damper position x_d must lie in \(0, 1\); got 1.5"):
        elements_for(PROPS, 1.5, 1e6)
    rigid = InterfaceDevice(1.0, 2.0)
    with pytest.raises(ParameterError, match="the device has no series branch"):
        SeriesCondensation.of(rigid, 1e-3)
    t = Tridiagonal(np.ones(3), np.zeros(2))
    with pytest.raises(ParameterError, match="the device has no series branch"):
        augmented_matrices(t, t, t, 1, rigid)


def test_set_state_rejects_bad_flywheel_states():
    plain = Cable(PROPS, 0.02, 1e-3, elements=10, damper=InterfaceDevice(1.0))
    with pytest.raises(
        ParameterError,
        match=r"a flywheel state needs a device with a series branch; got flywheel=\(0.0, 0.0\)",
    ):
        plain.set_state(np.zeros(9), np.zeros(9), flywheel=(0.0, 0.0))
    cable = Cable(PROPS, 0.02, 1e-3, elements=10, damper=SERIES)
    with pytest.raises(
        ParameterError, match=r"flywheel must be \(displacement, velocity\); got \(1.0,\)"
    ):
        cable.set_state(np.zeros(9), np.zeros(9), flywheel=(1.0,))
    with pytest.raises(ParameterError, match="flywheel displacement must be finite; got nan"):
        cable.set_state(np.zeros(9), np.zeros(9), flywheel=(math.nan, 0.0))
    with pytest.raises(ParameterError, match="flywheel velocity must be finite; got inf"):
        cable.set_state(np.zeros(9), np.zeros(9), flywheel=(0.0, math.inf))


def test_fe_matrices_append_the_flywheel_dof():
    fe = fe_matrices(PROPS, 0.02, 30, damper=SERIES)
    assert fe.flywheel_index == 29 and fe.stiffness.shape == fe.mass.shape == fe.damping.shape == (
        30,
        30,
    )
    k = fe.stiffness.toarray()
    assert k[fe.damper_index, 29] == k[29, fe.damper_index] == -SERIES.series_stiffness
    assert (fe.mass[29, 29], fe.damping[29, 29]) == (SERIES.series_inertance, SERIES.series_damping)
    assert fe_matrices(PROPS, 0.02, 30, damper=PointDamper(1.0)).flywheel_index is None


def test_compiled_step_outputs_equal_the_python_formulas_bit_for_bit():
    """The kernel's per-step outputs (interface, midspan, device force, flywheel) against
    plants.cable.kernel.outputs_reference on the same state, and the interface/device force
    against the public properties computed from the nodal state."""
    from plants.cable.kernel import outputs_reference

    device = InterfaceDevice(
        300.0, 500.0, series_stiffness=2e6, series_inertance=2650.0, series_damping=900.0
    )
    cable = Cable(
        PROPS, 0.02, 2e-3, elements=61, load=DistributedLoad(200.0, mode=3), damper=device
    )
    expected = np.zeros(7)
    for k in range(200):
        kin = cable.step(5e3 * math.sin(7.0 * k * 2e-3))
        fly = cable.flywheel
        assert fly is not None
        outputs_reference(
            cable.displacement,
            cable.velocity,
            cable.acceleration,
            np.array([fly.displacement, fly.velocity, fly.acceleration]),
            cable._params,
            cable.damper_index,
            expected,
        )
        assert (kin.displacement, kin.velocity, kin.acceleration) == tuple(expected[:3])
        assert cable.outputs() == dict(
            zip(
                (
                    "midspan_displacement",
                    "device_force",
                    "flywheel_displacement",
                    "flywheel_velocity",
                ),
                expected[3:].tolist(),
            )
        )
    # midspan against the interpolation of the public displacement field
    assert cable.outputs()["midspan_displacement"] == pytest.approx(
        cable.displacement_at(0.5), rel=1e-12
    )
