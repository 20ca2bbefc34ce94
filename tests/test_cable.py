"""Taut-cable FE substructure: closed forms, discrete energy balances, Newmark-AA eigenvalues."""

import math

import numpy as np
import pytest
import scipy.integrate as si
import scipy.linalg as sla

from plants._cable_fe import mesh_nodes, sine_load_shape
from plants.cable import (
    Cable,
    CableProperties,
    DistributedLoad,
    PointDamper,
    RayleighDamping,
    fe_matrices,
    normalised_damper,
    physical_damper,
)
from rths.errors import ParameterError

PROPS = CableProperties(length=100.0, tension=1.0e6, mass_per_length=50.0)  # c = 141 m/s, f1 = 0.71 Hz


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
        ({"length": 0.0, "tension": 1.0, "mass_per_length": 1.0}, "cable length L must be positive; got 0.0"),
        ({"length": 1.0, "tension": -3.0, "mass_per_length": 1.0}, "cable tension T must be positive; got -3.0"),
        ({"length": 1.0, "tension": 1.0, "mass_per_length": math.nan}, "mass per length m must be finite"),
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
    with pytest.raises(ParameterError, match=r"intrinsic damping ratio must lie in \[0, 1\); got 1.5"):
        RayleighDamping(ratio=1.5)
    with pytest.raises(ParameterError, match=r"two distinct modes; got \(2, 2\)"):
        RayleighDamping(modes=(2, 2))
    with pytest.raises(ParameterError, match="two distinct modes; got 3"):
        RayleighDamping(modes=3)
    with pytest.raises(ParameterError, match="Rayleigh anchor mode must be a positive integer; got 0"):
        RayleighDamping(modes=(0, 3))
    with pytest.raises(ParameterError, match="damper inertance must be non-negative; got -1.0"):
        PointDamper(inertance=-1.0)
    with pytest.raises(ParameterError, match="damper damping coefficient must be non-negative"):
        PointDamper(damping=-1.0)


def test_cable_rejects_bad_mesh_and_step():
    with pytest.raises(ParameterError, match=r"damper position x_d must lie in \(0, 1\); got 1.0"):
        Cable(PROPS, 1.0, 1e-3)
    with pytest.raises(ParameterError, match="number of elements must be at least 2; got 1"):
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
    with pytest.raises(ParameterError, match=r"nodal displacement must have shape \(9,\); got shape \(8,\)"):
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
@pytest.mark.parametrize(("x_d", "elements", "n_left"), [(0.02, 100, 2), (0.02, 30, 1), (0.37, 41, 15), (0.999, 5, 4)])
def test_mesh_has_a_node_at_the_damper_and_uniform_sides(x_d, elements, n_left):
    nodes, index = mesh_nodes(PROPS.length, x_d, elements)
    assert nodes.size == elements + 1 and index == n_left - 1
    assert nodes[index + 1] == x_d * PROPS.length  # exact: the damper node is the linspace end point
    left, right = np.diff(nodes[: n_left + 1]), np.diff(nodes[n_left:])
    np.testing.assert_allclose(left, left[0], rtol=1e-12)  # linspace rounding only
    np.testing.assert_allclose(right, right[0], rtol=1e-12)


def test_consistent_load_is_the_exact_integral_against_hat_functions():
    nodes, _ = mesh_nodes(PROPS.length, 0.37, 13)  # non-uniform on both sides
    k = 3 * math.pi / PROPS.length
    shape = sine_load_shape(nodes, k)
    for j in range(1, nodes.size - 1):
        a, b, c = nodes[j - 1 : j + 2]
        hat = lambda x: (x - a) / (b - a) if x <= b else (c - x) / (c - b)  # noqa: E731
        ref, _ = si.quad(lambda x: hat(x) * math.sin(k * x), a, c, points=[b], epsabs=0, epsrel=1e-13)
        assert shape[j - 1] == pytest.approx(ref, rel=1e-11)  # quadrature tolerance


def test_static_point_force_gives_the_string_deflection_with_the_cable_receiving_minus_F():
    # With dt huge, Newmark-AA's effective matrix is K to 1/(omega1 dt)^2 ~ 1e-13: one step is static.
    # Linear string elements are nodally exact for a point load: u(x_d) = -F x_d (1 - x_d) L / T.
    cable = Cable(PROPS, 0.3, dt=1.0e6, elements=10, intrinsic_damping=None)
    force = 2.0e4
    state = cable.step(force)
    assert state.displacement == pytest.approx(-force * 0.3 * 0.7 * PROPS.length / PROPS.tension, rel=1e-9)
    assert cable.displacement_at(0.0) == 0.0 and cable.displacement_at(1.0) == 0.0


# ---------------------------------------------------------------------------- integrator
def test_compiled_kernel_matches_the_reference_path():
    runs = []
    for use_numba in (True, False):
        cable = Cable(
            PROPS, 0.02, 2e-3, elements=60, load=DistributedLoad(200.0, mode=3),
            damper=PointDamper(inertance=2650.0, damping=900.0), use_numba=use_numba,
        )  # fmt: skip
        history = [cable.step(5e3 * math.sin(7.0 * k * 2e-3)) for k in range(400)]
        runs.append((history, cable.displacement, cable.velocity, cable.acceleration))
    (h1, *s1), (h2, *s2) = runs
    # same arithmetic in another order: u agrees to round-off; v = 2/h du - v and a = 4/h^2 du - ...
    # amplify the round-off of u by 1/(omega h) and 1/(omega h)^2 for the fast FE modes
    for x, y, tol in zip(s1, s2, (1e-12, 1e-11, 1e-9), strict=True):
        np.testing.assert_allclose(x, y, rtol=0, atol=tol * np.max(np.abs(y)))
    assert h1[-1].displacement == pytest.approx(h2[-1].displacement, rel=1e-10)


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
    cable = Cable(PROPS, 0.02, 5e-3, elements=50, intrinsic_damping=None, damper=PointDamper(inertance=1000.0))
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
        PROPS, 0.02, h, elements=80, intrinsic_damping=None,
        load=DistributedLoad(300.0, mode=3), damper=PointDamper(inertance=2000.0, damping=cbar),
    )  # fmt: skip
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
    assert cable.interface.displacement == u[-1][i] and cable.interface.velocity == cable.velocity[i]
    out = cable.outputs()
    assert out["midspan_displacement"] == cable.displacement_at(0.5) == u[-1][49]  # node 50 at L/2
    assert out["kinetic_energy"] + out["strain_energy"] == pytest.approx(energy(cable), rel=1e-15)


def test_mock_rths_with_an_internal_imd_follows_its_complex_mode():
    # Non-classical damping (IMD inside the model, seed optimum): u(t) = Re(phi exp(lam t)) from the
    # state-space eigenproblem; Newmark-AA must give Re(phi z^k), z = (1 + lam h/2)/(1 - lam h/2),
    # and lam L/c must be the normalised root of plants.cable_damper for the same mesh.
    from plants.cable_damper import fe_roots

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
