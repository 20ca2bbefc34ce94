"""Cable–damper complex modes: exact frequency equation vs FE eigenvalues vs seed-paper numbers."""

import math

import numpy as np
import pytest
import scipy.optimize as so

import plants.cable.frequency_equation as cd_module
from plants.cable.frequency_equation import (
    DamperRoot,
    asymptotic_damping,
    device_impedance,
    exact_roots,
    fe_roots,
    frequency_function,
    normalised_impedance,
)
from plants.cable.model import (
    CableProperties,
    InterfaceDevice,
    PointDamper,
    RayleighDamping,
    fe_matrices,
    normalised_stiffness,
    physical_damper,
    physical_stiffness,
)
from rths.core.errors import ParameterError

X_D = 0.02  # seed RTHS damper position (S0 §5.3)
C_VISCOUS = 1.0 / (math.pi**2 * X_D)  # kappa = n pi^2 c_d x_d = 1 for n = 1
SEED = (3, X_D, 0.53, 0.015 / X_D)  # mode 3, m_e = 0.53, c_d x_d = 0.015 (S0 §5.3)
SEED_BETAS = (9.46092 + 0.85996j, 9.70890 + 0.85534j)  # design.md §6
SEED_ZETAS = (0.0905, 0.0878)


def test_viscous_damper_at_kappa_one_exact():
    (root,) = exact_roots(1, X_D, 0.0, C_VISCOUS)
    assert root.zeta / X_D == pytest.approx(0.51057, rel=1e-3)  # brief: 0.1 %
    assert abs(frequency_function(root.beta, X_D, 0.0, C_VISCOUS)) < 1e-12  # it is a root


def test_viscous_damper_at_kappa_one_fe():
    (root,) = fe_roots(1, X_D, 0.0, C_VISCOUS, elements=400)
    assert root.method == "fe"
    assert root.zeta / X_D == pytest.approx(0.51057, rel=1e-2)  # brief: 1 % with >= 400 elements


def test_seed_imd_optimum_has_two_roots_exact():
    roots = exact_roots(*SEED)
    assert len(roots) == 2 and all(r.multiplicity == 1 for r in roots)
    for root, beta, zeta in zip(roots, SEED_BETAS, SEED_ZETAS, strict=True):
        assert root.beta.real == pytest.approx(beta.real, abs=1e-5)  # 6 significant figures quoted
        assert root.beta.imag == pytest.approx(beta.imag, abs=1e-5)
        assert root.zeta == pytest.approx(
            zeta, rel=1e-3
        )  # brief: 0.1 % (values quoted to 3 figures)


def test_seed_imd_optimum_has_two_roots_fe():
    roots = fe_roots(*SEED, elements=400)
    assert len(roots) == 2
    for root, zeta in zip(roots, SEED_ZETAS, strict=True):
        assert root.zeta == pytest.approx(zeta, rel=2e-2)  # brief: 2 %


def test_viscous_damper_at_best_gives_about_one_percent_for_mode_3():
    def minus_zeta(c_d: float) -> float:
        (root,) = exact_roots(3, X_D, 0.0, c_d)
        return -root.zeta

    best = so.minimize_scalar(minus_zeta, bounds=(0.2, 5.0), method="bounded")
    assert -best.fun == pytest.approx(0.0103, rel=5e-3)  # quoted to 3 figures
    assert -best.fun < 0.2 * min(SEED_ZETAS)  # the IMD does almost ten times better
    assert best.x == pytest.approx(1.0 / (3 * math.pi**2 * X_D), rel=0.05)  # near kappa = 1


@pytest.mark.parametrize("x_d", [0.005, 0.01, 0.02])
def test_asymptotic_formula_holds_for_a_small_viscous_damper(x_d):
    c_d = 1.0 / (math.pi**2 * x_d)
    (root,) = exact_roots(1, x_d, 0.0, c_d)
    assert asymptotic_damping(1, x_d, 0.0, c_d) == pytest.approx(0.5 * x_d, rel=1e-12)  # kappa = 1
    assert root.zeta / asymptotic_damping(1, x_d, 0.0, c_d) - 1.0 == pytest.approx(
        0.0, abs=1.2 * x_d
    )  # O(x)


def test_asymptotic_formula_fails_near_the_imd_optimum():
    assert asymptotic_damping(*SEED) < 0.6 * min(SEED_ZETAS)


def test_roots_are_symmetric_in_the_damper_position():
    # sin(b x) sin(b (1 - x)) is symmetric under x -> 1 - x
    a = exact_roots(3, 0.3, 0.1, 0.5)
    b = exact_roots(3, 0.7, 0.1, 0.5)
    assert [r.beta for r in a] == pytest.approx([r.beta for r in b], rel=1e-12)  # Newton tolerance


def test_no_damper_gives_the_string_modes():
    for n in (1, 2, 5):
        (root,) = exact_roots(n, 0.137, 0.0, 0.0)
        assert root.beta == pytest.approx(n * math.pi, abs=1e-12)  # sin(b) = 0
        assert root.frequency_ratio == pytest.approx(1.0, abs=1e-12)


def test_fe_with_intrinsic_rayleigh_damping_only():
    (root,) = fe_roots(
        3, X_D, 0.0, 0.0, elements=100, intrinsic_damping=RayleighDamping(0.001, (1, 3))
    )
    assert root.zeta == pytest.approx(
        0.001, rel=1e-4
    )  # anchored at string mode 3; FE frequency error ~1e-6
    assert root.frequency_ratio == pytest.approx(
        1.0, abs=1e-5
    )  # fourth-order FE frequencies at N = 100


def test_fe_converges_at_second_order_and_the_average_mass_matrix_wins():
    (exact,) = exact_roots(1, X_D, 0.0, C_VISCOUS)
    err = {}
    for kind in ("consistent", "lumped", "average"):
        err[kind] = [abs(_fe_zeta(kind, n) / exact.zeta - 1.0) for n in (50, 100)]
    assert err["average"][1] < 0.05 * min(
        err["consistent"][1], err["lumped"][1]
    )  # evidence for the choice
    assert math.log2(err["average"][0] / err["average"][1]) == pytest.approx(
        2.0, abs=0.1
    )  # O(h^2) kink


def _fe_zeta(kind: str, elements: int) -> float:
    """Damping ratio of the FE model of fe_roots (mode 1, kappa = 1) with another element mass."""
    unit = CableProperties(1.0, 1.0, 1.0)
    fe = fe_matrices(
        unit,
        X_D,
        elements,
        damper=PointDamper(*physical_damper(unit, 0.0, C_VISCOUS)),
        mass_matrix=kind,
    )
    s = cd_module._state_space_eigenvalues(fe.stiffness, fe.mass, fe.damping, 1j * math.pi, 1.0)
    (beta,) = -1j * s[s.imag > 0]
    return beta.imag / abs(beta)


def test_dense_and_sparse_eigen_paths_agree(monkeypatch):
    sparse = fe_roots(*SEED, elements=150)  # 298 states > dense limit: ARPACK shift-invert
    monkeypatch.setattr(cd_module, "_DENSE_LIMIT", 10_000)
    dense = fe_roots(*SEED, elements=150)
    assert [r.beta for r in sparse] == pytest.approx(
        [r.beta for r in dense], rel=1e-10
    )  # ARPACK tol ~ eps


def test_damper_root_properties():
    root = DamperRoot(3.0 + 4.0j, mode=2, method="exact")
    assert root.zeta == pytest.approx(0.8, rel=1e-15)
    assert root.frequency_ratio == pytest.approx(5.0 / (2 * math.pi), rel=1e-15)


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        ((0, 0.02, 0.1, 0.1), {}, "mode number n must be a positive integer; got 0"),
        ((1, 0.0, 0.1, 0.1), {}, r"damper position x_d must lie in \(0, 1\); got 0.0"),
        ((1, 1.5, 0.1, 0.1), {}, r"damper position x_d must lie in \(0, 1\); got 1.5"),
        ((1, 0.02, -0.1, 0.1), {}, "normalised inertance m_e must be non-negative; got -0.1"),
        ((1, 0.02, 0.1, -1.0), {}, "normalised damping c_d must be non-negative; got -1.0"),
        ((1, 0.02, 0.1, 0.1), {"max_imag": 0.0}, "max_imag must be positive; got 0.0"),
        (
            (1, 0.02, 0.1, 0.1),
            {"k_e": 0.0},
            "normalised series stiffness k_e must be positive; got 0.0",
        ),
        (
            (1, 0.02, 0.1, 0.1),
            {"k_e": -3.0},
            "normalised series stiffness k_e must be positive; got -3.0",
        ),
        (
            (1, 0.02, 0.0, 0.0),
            {"k_e": 1.0},
            "a series stiffness needs m_e or c_d > 0 behind it; got k_e=1.0",
        ),
    ],
)
@pytest.mark.parametrize("finder", [exact_roots, fe_roots])
def test_bad_input_is_rejected(finder, args, kwargs, match):
    with pytest.raises(ParameterError, match=match):
        finder(*args, **kwargs)


@pytest.mark.parametrize(
    ("k_e", "m_e", "match"),
    [
        (0.0, 0.1, "normalised series stiffness k_e must be positive; got 0.0"),
        (1.0, 0.0, "a series stiffness needs m_e or c_d > 0 behind it; got k_e=1.0"),
    ],
)
def test_asymptotic_formula_rejects_bad_series_stiffness(k_e, m_e, match):
    with pytest.raises(ParameterError, match=match):
        asymptotic_damping(1, 0.02, m_e, m_e, k_e=k_e)


def test_bad_fe_mesh_and_asymptotic_input_are_rejected():
    with pytest.raises(
        ParameterError, match=r"number of elements must lie in \[2, 100000\]; got 1"
    ):
        fe_roots(1, 0.5, 0.0, 1.0, elements=1)
    with pytest.raises(ParameterError, match="mode 40 needs more FE elements than 40"):
        fe_roots(40, 0.5, 0.0, 1.0, elements=40)
    with pytest.raises(ParameterError, match=r"damper position x_d must lie in \(0, 1\); got -0.2"):
        asymptotic_damping(1, -0.2, 0.0, 1.0)


def test_roots_outside_the_imaginary_window_are_not_reported():
    (root,) = exact_roots(1, X_D, 0.0, C_VISCOUS)
    assert exact_roots(1, X_D, 0.0, C_VISCOUS, max_imag=0.5 * root.beta.imag) == ()
    assert fe_roots(1, X_D, 0.0, C_VISCOUS, elements=100, max_imag=0.5 * root.beta.imag) == ()
    assert np.isfinite(root.zeta)


# ---------------------------------------------------------------------------- series stiffness (S0 Eq.12)
SEED_CABLE = CableProperties(
    length=200.0, tension=5.0e6, mass_per_length=80.0
)  # brief's prototype cable
K_E = normalised_stiffness(SEED_CABLE, 6.4e7)  # Type II k0 at prototype scale: k_e = 259.4
SEED_SERIES = (*SEED, K_E)


def test_general_impedance_reduces_to_the_rigid_imd():
    # Z = K(omega) L/(T beta) with K = -mbar omega^2 + i cbar omega is -m_e beta + i pi c_d (design.md §6)
    beta = np.array([9.46 + 0.86j, 3.0, 0.5 + 2.0j])
    m_bar, c_bar = physical_damper(SEED_CABLE, 0.53, 0.75)
    rigid = device_impedance(beta, SEED_CABLE, InterfaceDevice(m_bar, c_bar))
    np.testing.assert_allclose(rigid, -0.53 * beta + 1j * math.pi * 0.75, rtol=1e-13)  # rounding
    np.testing.assert_allclose(normalised_impedance(beta, 0.53, 0.75), rigid, rtol=1e-13)
    series = InterfaceDevice(series_stiffness=6.4e7, series_inertance=m_bar, series_damping=c_bar)
    np.testing.assert_allclose(
        device_impedance(beta, SEED_CABLE, series),
        normalised_impedance(beta, 0.53, 0.75, k_e=K_E),
        rtol=1e-12,
    )  # Eq.23 scalings round-off


def test_series_roots_solve_the_frequency_equation_with_the_pole_form_impedance():
    x_d = SEED[1]
    for root in exact_roots(*SEED, k_e=K_E):
        z = normalised_impedance(root.beta, 0.53, 0.75, k_e=K_E)
        b = root.beta
        assert (
            abs(np.sin(b) + z * np.sin(b * x_d) * np.sin(b * (1 - x_d))) < 1e-11
        )  # Newton tolerance 1e-13
        assert abs(frequency_function(b, x_d, 0.53, 0.75, k_e=K_E)) < 1e-11


def test_newton_derivative_matches_finite_differences():
    b = np.array([9.4 + 0.8j, 3.1 + 0.2j, 20.0 + 1.0j])
    step = 1e-6
    for k_e in (None, K_E, 2.0):
        numeric = (
            cd_module._function(b + step, 0.02, 0.53, 0.75, k_e)
            - cd_module._function(b - step, 0.02, 0.53, 0.75, k_e)
        ) / (2 * step)
        exact = cd_module._derivative(b, 0.02, 0.53, 0.75, k_e)
        np.testing.assert_allclose(
            exact, numeric, rtol=1e-7
        )  # central difference O(step^2) + round-off/step


def test_seed_point_with_type_ii_stiffness_exact_vs_fe():
    exact = exact_roots(*SEED, k_e=K_E)
    fe = fe_roots(*SEED, k_e=K_E, elements=400)
    assert len(exact) == len(fe) == 2
    for e, f in zip(exact, fe, strict=True):
        assert f.zeta == pytest.approx(
            e.zeta, rel=2e-2
        )  # brief: 2 % at >= 400 elements (measured 3e-4)
        assert abs(f.beta - e.beta) < 1e-3 * abs(e.beta)  # second-order FE error at N = 400
    rigid = exact_roots(*SEED)
    # the internal stiffness detunes the optimum: the pair splits and the worse root loses damping
    assert exact[0].zeta > max(r.zeta for r in rigid) and exact[1].zeta < 0.8 * min(
        r.zeta for r in rigid
    )


def test_series_roots_tend_to_the_rigid_roots_as_the_stiffness_grows():
    rigid = np.array([r.beta for r in exact_roots(*SEED)])
    gaps = [
        np.max(np.abs([r.beta for r in exact_roots(*SEED, k_e=k_e)] - rigid))
        for k_e in (1e4, 1e5, 1e6)
    ]
    assert gaps[2] < 1e-4
    np.testing.assert_allclose(
        np.array(gaps[1:]) / gaps[:-1], 0.1, rtol=0.05
    )  # first order in 1/k_e


def test_soft_series_spring_adds_the_device_root():
    # device's own mode near pi sqrt(k_e/m_e) = 14.1 pi, in the window of mode 12 once damped and coupled
    args = (12, 0.02, 0.01, 0.1)
    assert len(exact_roots(*args)) == 1
    exact = exact_roots(*args, k_e=2.0)
    fe = fe_roots(*args, k_e=2.0, elements=400)
    assert len(exact) == len(fe) == 2
    assert (
        exact[0].zeta > 0.3 > 0.01 > exact[1].zeta
    )  # the strongly damped device root and the string's
    for e, f in zip(exact, fe, strict=True):
        assert f.zeta == pytest.approx(e.zeta, rel=2e-2)  # brief: 2 % at >= 400 elements


def test_stiff_series_spring_adds_no_root_near_the_device_frequency():
    # Type II on the seed cable: pi sqrt(k_e/m_e) = 22.1 pi, yet the windows there hold one root each, as rigid
    assert math.sqrt(K_E / 0.53) == pytest.approx(22.12, abs=0.01)
    for n in (21, 22, 23):
        series, rigid = exact_roots(n, X_D, 0.53, 0.75, k_e=K_E), exact_roots(n, X_D, 0.53, 0.75)
        assert len(series) == len(rigid) == 1
        assert abs(series[0].beta - rigid[0].beta) < 1e-3 * abs(rigid[0].beta)  # only shifted


def test_viscous_damper_with_support_stiffness_exact_fe_and_asymptotic():
    # Maxwell element (m_e = 0): Z = pi^2 k_e i pi c_d/(pi^2 k_e + i pi c_d beta)
    for k_e in (50.0, 3.0):
        (exact,) = exact_roots(1, X_D, 0.0, C_VISCOUS, k_e=k_e)
        (fe,) = fe_roots(1, X_D, 0.0, C_VISCOUS, k_e=k_e, elements=400)
        assert fe.zeta == pytest.approx(
            exact.zeta, rel=1e-4
        )  # measured 2e-6; the kink error is O(1/N^2)
        assert exact.zeta < 0.51057 * X_D  # a support spring only loses damping
    for x_d in (0.005, 0.01):
        c_d, k_e = 1.0 / (math.pi**2 * x_d), 2.0 / (math.pi**2 * x_d)
        (root,) = exact_roots(1, x_d, 0.0, c_d, k_e=k_e)
        assert root.zeta / asymptotic_damping(1, x_d, 0.0, c_d, k_e=k_e) - 1.0 == pytest.approx(
            0.0, abs=1.2 * x_d
        )  # O(x)


def test_asymptotic_formula_with_a_stiff_series_spring_tends_to_the_rigid_one():
    rigid = asymptotic_damping(*SEED)
    assert asymptotic_damping(*SEED, k_e=1e9) == pytest.approx(
        rigid, rel=1e-6
    )  # O(m_e (n pi)^2/(pi^2 k_e))
    assert physical_stiffness(SEED_CABLE, K_E) == pytest.approx(6.4e7, rel=1e-15)
