"""Cable–damper complex modes: exact frequency equation vs FE eigenvalues vs seed-paper numbers."""

import math

import numpy as np
import pytest
import scipy.optimize as so

import plants.cable_damper as cd_module
from plants.cable import CableProperties, PointDamper, RayleighDamping, fe_matrices, physical_damper
from plants.cable_damper import (
    DamperRoot,
    asymptotic_damping,
    exact_roots,
    fe_roots,
    frequency_function,
)
from rths.errors import ParameterError

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
        assert root.zeta == pytest.approx(zeta, rel=1e-3)  # brief: 0.1 % (values quoted to 3 figures)


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
    assert root.zeta / asymptotic_damping(1, x_d, 0.0, c_d) - 1.0 == pytest.approx(0.0, abs=1.2 * x_d)  # O(x)


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
    (root,) = fe_roots(3, X_D, 0.0, 0.0, elements=100, intrinsic_damping=RayleighDamping(0.001, (1, 3)))
    assert root.zeta == pytest.approx(0.001, rel=1e-4)  # anchored at string mode 3; FE frequency error ~1e-6
    assert root.frequency_ratio == pytest.approx(1.0, abs=1e-5)  # fourth-order FE frequencies at N = 100


def test_fe_converges_at_second_order_and_the_average_mass_matrix_wins():
    (exact,) = exact_roots(1, X_D, 0.0, C_VISCOUS)
    err = {}
    for kind in ("consistent", "lumped", "average"):
        err[kind] = [abs(_fe_zeta(kind, n) / exact.zeta - 1.0) for n in (50, 100)]
    assert err["average"][1] < 0.05 * min(err["consistent"][1], err["lumped"][1])  # evidence for the choice
    assert math.log2(err["average"][0] / err["average"][1]) == pytest.approx(2.0, abs=0.1)  # O(h^2) kink


def _fe_zeta(kind: str, elements: int) -> float:
    """Damping ratio of the FE model of fe_roots (mode 1, kappa = 1) with another element mass."""
    unit = CableProperties(1.0, 1.0, 1.0)
    fe = fe_matrices(unit, X_D, elements, damper=PointDamper(*physical_damper(unit, 0.0, C_VISCOUS)), mass_matrix=kind)
    s = cd_module._state_space_eigenvalues(fe.stiffness, fe.mass, fe.damping, 1j * math.pi, 1.0)
    (beta,) = -1j * s[s.imag > 0]
    return beta.imag / abs(beta)


def test_dense_and_sparse_eigen_paths_agree(monkeypatch):
    sparse = fe_roots(*SEED, elements=150)  # 298 states > dense limit: ARPACK shift-invert
    monkeypatch.setattr(cd_module, "_DENSE_LIMIT", 10_000)
    dense = fe_roots(*SEED, elements=150)
    assert [r.beta for r in sparse] == pytest.approx([r.beta for r in dense], rel=1e-10)  # ARPACK tol ~ eps


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
    ],
)
@pytest.mark.parametrize("finder", [exact_roots, fe_roots])
def test_bad_input_is_rejected(finder, args, kwargs, match):
    with pytest.raises(ParameterError, match=match):
        finder(*args, **kwargs)


def test_bad_fe_mesh_and_asymptotic_input_are_rejected():
    with pytest.raises(ParameterError, match="number of elements must be at least 2; got 1"):
        fe_roots(1, 0.5, 0.0, 1.0, elements=1)
    with pytest.raises(ParameterError, match=r"damper position x_d must lie in \(0, 1\); got -0.2"):
        asymptotic_damping(1, -0.2, 0.0, 1.0)


def test_roots_outside_the_imaginary_window_are_not_reported():
    (root,) = exact_roots(1, X_D, 0.0, C_VISCOUS)
    assert exact_roots(1, X_D, 0.0, C_VISCOUS, max_imag=0.5 * root.beta.imag) == ()
    assert fe_roots(1, X_D, 0.0, C_VISCOUS, elements=100, max_imag=0.5 * root.beta.imag) == ()
    assert np.isfinite(root.zeta)
