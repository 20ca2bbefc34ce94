"""Complex modes of a taut cable with a grounded point damper (design.md §6, S0 Eq.23).

A damper with normalised inertance ``m_e`` and viscous coefficient ``c_d`` (S0 Eq.23) at the
normalised position ``x`` of a taut string has free vibrations ``exp(i omega t)`` whose complex
wavenumbers ``beta = omega L/c`` solve the exact frequency equation

.. math:: \\sin\\beta + \\hat Z(\\beta)\\,\\sin(\\beta x)\\,\\sin(\\beta(1-x)) = 0,
          \\qquad \\hat Z(\\beta) = -m_e\\beta + i\\pi c_d ,

(continuity of the string and the jump of its slope at the damper, ``T [u'] = F``), with damping
ratio ``zeta = Im beta/|beta|`` and frequency ratio ``|beta|/(n pi)`` for mode ``n``.  An
inertial mass damper (IMD, simplified S0 Eq.1) adds a local mode; near its optimum (S0 §5.3,
``m_e = 0.53``, ``c_d x_d = 0.015``, mode 3) two roots share the neighbourhood of mode ``n``.

Any device enters through its normalised impedance ``Z(beta) = K(omega) L/(T beta)``,
``omega = beta c/L``, with ``K`` its complex dynamic stiffness [N/m]
(:meth:`plants.cable.model.InterfaceDevice.dynamic_stiffness`, :func:`device_impedance`); the rigid
IMD's ``K = -mbar_e omega^2 + i cbar_d omega`` gives the ``Z`` above.  With the internal series
stiffness of S0 Eq.12 (normalised ``k_e = kbar_e L/(pi^2 T)``, the IMD's ``(m_e, c_d)`` behind the
spring) ``Z = pi^2 k_e Z_0/(pi^2 k_e + beta Z_0)``, ``Z_0 = -m_e beta + i pi c_d``, which tends to
``Z_0`` as ``k_e -> inf``.  ``Z`` then has a pole at the device's own resonance, so the frequency
function is multiplied by ``1 + beta Z_0/(pi^2 k_e)``: entire, same roots, and the argument
principle still counts roots only.

The series branch adds one root (one more DOF).  With a soft spring it is the device's own,
strongly damped mode near ``beta ~ pi sqrt(k_e/m_e)`` (its frequency with the node held), e.g.
``m_e = 0.01``, ``c_d = 0.1``, ``k_e = 2``, ``x = 0.02``: ``36.68 + 12.60i`` beside the string root
``37.88 + 0.26i`` in the window of mode 12.  The window of mode ``n`` (below) reports it only
when it falls there.  A stiff spring does not hold still the node it hangs on: for the S0 Type
II IMD on the seed cable (``k_e = 259``, ``pi sqrt(k_e/m_e) = 22.1 pi``) every window up to mode
44 holds as many roots as with the rigid IMD, the flywheel follows the node like a rigid IMD
below its own frequency, and the extra eigenvalue of the FE model is the mode trapped at the
damper node at the top of its spectrum (mesh rule of :func:`plants.cable.model.max_element_size`).
Near mode 3 the IMD pair is detuned: ``zeta = 0.113`` and ``0.068`` instead of ``0.091`` and
``0.088``.

Three independent ways to the same numbers are provided:

* :func:`exact_roots` -- every root of the frequency equation in the window of mode ``n``
  (``(n - 1/2) pi <= Re beta < (n + 1/2) pi``, ``0 <= Im beta <= max_imag``): the argument
  principle counts them, vectorised Newton iterations from a grid of starts find them, and the
  grid is refined until the two agree.
* :func:`fe_roots` -- complex eigenvalues ``s`` of the FE model of :mod:`plants.cable.model` with
the
  damper inside it, from the state-space generalised eigenproblem
  ``[[0, I], [-K, -C]] z = s [[I, 0], [0, M]] z`` (``beta = -i s L/c``,
  ``zeta = -Re s/|s|``).
* :func:`asymptotic_damping` -- the small-damper formula
  ``zeta/x ~ kappa/((1 + alpha)^2 + kappa^2)``, ``kappa = n pi^2 c_d x``,
  ``alpha = -n^2 pi^2 m_e x`` (Krenk 2000 for viscous dampers; Lu et al. 2017 with inertance),
  i.e. ``alpha + i kappa = n pi x Z(n pi)``, which fails near the IMD optimum.

References
----------
S. Krenk, "Vibrations of a taut cable with an external damper", J. Appl. Mech. 67 (2000) 772-776.
L. Lu, Y.-F. Duan, B. F. Spencer Jr., X. Lu, Y. Zhou, "Inertial mass damper for mitigating cable
vibration", Struct. Control Health Monit. 24 (2017) e1986.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.optimize as so
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import ArrayLike, NDArray

from plants.cable.fe import check_mesh
from plants.cable.model import (
    CableProperties,
    InterfaceDevice,
    RayleighDamping,
    fe_matrices,
    physical_damper,
    physical_stiffness,
)
from rths.core.errors import (
    NumericalError,
    ParameterError,
    check_finite,
    check_nonnegative,
    check_positive,
    check_positive_int,
)

__all__ = [
    "DamperRoot",
    "asymptotic_damping",
    "device_impedance",
    "exact_roots",
    "fe_roots",
    "frequency_function",
    "normalised_impedance",
]

_LOWER_IMAG = -0.25  # lower edge of the window in Im beta (passive dampers have Im beta >= 0)
_DENSE_LIMIT = 200  # state-space size up to which the FE eigenproblem is solved densely


@dataclass(frozen=True, slots=True)
class DamperRoot:
    """One complex mode near mode ``mode`` of the cable–damper system.

    Attributes
    ----------
    beta
        Normalised complex wavenumber ``beta = omega L/c`` [-] (``Im beta > 0`` decays).
    mode
        The string mode ``n`` whose neighbourhood the root lies in.
    method
        ``"exact"`` (frequency equation) or ``"fe"`` (FE eigenvalue).
    multiplicity
        How many roots coincide here (1 unless two roots coalesce exactly).
    """

    beta: complex
    mode: int
    method: str
    multiplicity: int = 1

    @property
    def zeta(self) -> float:
        """Damping ratio ``Im beta/|beta|`` [-]."""
        return self.beta.imag / abs(self.beta)

    @property
    def frequency_ratio(self) -> float:
        """``|beta|/(n pi)``: the undamped natural frequency over that of string mode ``n``."""
        return abs(self.beta) / (self.mode * math.pi)


def _check_system(
    mode: int, x_d: float, m_e: float, c_d: float, k_e: float | None
) -> tuple[int, float, float, float, float | None]:
    n = check_positive_int(mode, "mode number n")
    x = check_finite(x_d, "damper position x_d")
    if not 0.0 < x < 1.0:
        raise ParameterError(f"damper position x_d must lie in (0, 1); got {x_d!r}")
    m_e = check_nonnegative(m_e, "normalised inertance m_e")
    c_d = check_nonnegative(c_d, "normalised damping c_d")
    if k_e is not None:
        k_e = check_positive(k_e, "normalised series stiffness k_e")
        if m_e == 0.0 and c_d == 0.0:
            raise ParameterError(
                f"a series stiffness needs m_e or c_d > 0 behind it; got k_e={k_e!r} with both 0"
            )
    return n, x, m_e, c_d, k_e


def normalised_impedance(
    beta: ArrayLike, m_e: float, c_d: float, *, k_e: float | None = None
) -> NDArray[np.complex128]:
    """The IMD's normalised impedance ``Z(beta)`` (module docstring), any shape of ``beta``.

    ``Z_0 = -m_e beta + i pi c_d`` (simplified S0 Eq.1) without ``k_e``; with the normalised
    series stiffness ``k_e`` (S0 Eq.12) ``Z = pi^2 k_e Z_0/(pi^2 k_e + beta Z_0)``.

    Parameters
    ----------
    beta : array_like
        Complex normalised wavenumber(s) ``beta = omega L/c`` [-], any shape.
    m_e : float
        Normalised inertance [-] (S0 Eq.23); not validated here.
    c_d : float
        Normalised viscous coefficient [-] (S0 Eq.23); not validated here.
    k_e : float or None, default None
        Normalised series stiffness ``kbar_e L/(pi^2 T)`` [-] (S0 Eq.12); None for the rigid
        device.

    Returns
    -------
    numpy.ndarray
        ``Z(beta)`` [-], complex, the shape of ``beta``.
    """
    b = np.asarray(beta, dtype=complex)
    z0 = -m_e * b + 1j * math.pi * c_d
    if k_e is None:
        return z0.astype(np.complex128)
    spring = math.pi**2 * k_e
    return spring * z0 / (spring + b * z0)


def device_impedance(
    beta: ArrayLike, properties: CableProperties, device: InterfaceDevice
) -> NDArray[np.complex128]:
    """Normalised impedance ``Z = K(omega) L/(T beta)``, ``omega = beta c/L``, of any physical
    device on a physical cable (``K``: :meth:`plants.cable.InterfaceDevice.dynamic_stiffness`).

    Parameters
    ----------
    beta : array_like
        Complex normalised wavenumber(s) ``beta = omega L/c`` [-], any shape, nonzero.
    properties : CableProperties
        The cable (``L`` [m], ``T`` [N], ``c = sqrt(T/m)`` [m/s]).
    device : InterfaceDevice
        The physical device (SI: kg, N s/m, N/m) at the damper node.

    Returns
    -------
    numpy.ndarray
        ``Z(beta)`` [-], complex, the shape of ``beta``.
    """
    b = np.asarray(beta, dtype=complex)
    p = properties
    return device.dynamic_stiffness(b * p.wave_speed / p.length) * p.length / (p.tension * b)


def _function(
    b: NDArray[np.complex128], x: float, m_e: float, c_d: float, k_e: float | None
) -> NDArray[np.complex128]:
    """The (entire) frequency function; see :func:`frequency_function`."""
    z0 = -m_e * b + 1j * math.pi * c_d
    s12 = np.sin(b * x) * np.sin(b * (1.0 - x))
    if k_e is None:
        return np.sin(b) + z0 * s12
    return (1.0 + b * z0 / (math.pi**2 * k_e)) * np.sin(b) + z0 * s12


def frequency_function(
    beta: ArrayLike, x_d: float, m_e: float, c_d: float, *, k_e: float | None = None
) -> NDArray[np.complex128]:
    """The left side ``sin b + Z(b) sin(b x) sin(b (1-x))``, ``Z = -m_e b + i pi c_d``.

    With the normalised series stiffness ``k_e`` (S0 Eq.12) ``Z`` is that of
    :func:`normalised_impedance` and the whole left side is multiplied by
    ``1 + b Z_0/(pi^2 k_e)`` so that it stays entire (module docstring).

    Parameters
    ----------
    beta
        Complex normalised wavenumber(s) ``omega L/c``, any shape.
    x_d, m_e, c_d
        Normalised damper position, inertance and viscous coefficient (S0 Eq.23).
    k_e
        Normalised series stiffness ``kbar_e L/(pi^2 T)``; ``None`` for a rigid device.
    """
    return _function(np.asarray(beta, dtype=complex), x_d, m_e, c_d, k_e)


def _derivative(
    b: NDArray[np.complex128], x: float, m_e: float, c_d: float, k_e: float | None
) -> NDArray[np.complex128]:
    """d/d(beta) of :func:`frequency_function`."""
    z0 = -m_e * b + 1j * math.pi * c_d
    s1, s2 = np.sin(b * x), np.sin(b * (1.0 - x))
    ds = x * np.cos(b * x) * s2 + (1.0 - x) * s1 * np.cos(b * (1.0 - x))
    if k_e is None:
        return np.cos(b) - m_e * s1 * s2 + z0 * ds
    spring = math.pi**2 * k_e
    p, dp = 1.0 + b * z0 / spring, (z0 - m_e * b) / spring
    return dp * np.sin(b) + p * np.cos(b) - m_e * s1 * s2 + z0 * ds


_System = tuple[float, float, float, float | None]  # x_d, m_e, c_d, k_e


def _winding(corners: list[complex], system: _System) -> int:
    """Zeros of the frequency function inside the closed polygon ``corners`` (argument principle).

    The boundary is sampled until the phase changes by less than pi/4 between samples, which is
    enough to unwrap it unambiguously.
    """
    for per_side in (256, 1024, 4096, 16384, 65536):
        t = np.linspace(0.0, 1.0, per_side, endpoint=False)
        path = np.concatenate(
            [a + (b - a) * t for a, b in zip(corners, corners[1:] + corners[:1], strict=True)]
        )
        f = _function(np.append(path, path[0]), *system)
        if np.min(np.abs(f)) == 0.0:
            break
        jumps = np.angle(f[1:] / f[:-1])
        if np.max(np.abs(jumps)) < math.pi / 4:
            return round(float(np.sum(jumps)) / (2.0 * math.pi))
    raise NumericalError(
        "a root of the frequency equation lies on the search window's boundary; "
        "change max_imag slightly"
    )


def exact_roots(
    mode: int,
    x_d: float,
    m_e: float,
    c_d: float,
    *,
    k_e: float | None = None,
    max_imag: float | None = None,
) -> tuple[DamperRoot, ...]:
    """All roots of the exact frequency equation near string mode ``mode`` (ascending ``Re beta``).

    Parameters
    ----------
    mode
        String mode ``n`` >= 1; the window is ``(n - 1/2) pi <= Re beta < (n + 1/2) pi``.
    x_d
        Normalised damper position in (0, 1).
    m_e, c_d
        Normalised inertance and viscous coefficient (S0 Eq.23), >= 0.
    k_e
        Normalised series stiffness (S0 Eq.12, ``kbar_e L/(pi^2 T)``) with ``(m_e, c_d)`` behind
        it; ``None`` for the rigid device.  A root of the device's own is reported only when it
        falls in the window (module docstring).
    max_imag
        Upper edge of the window in ``Im beta``; default ``(n + 1/2) pi`` (damping ratios up to
        about 0.7).

    Raises
    ------
    NumericalError
        If Newton iterations from ever finer grids of starts cannot find as many roots as the
        argument principle counts (not seen in practice).
    """
    n, x, m_e, c_d, k_e = _check_system(mode, x_d, m_e, c_d, k_e)
    system: _System = (x, m_e, c_d, k_e)
    top = (n + 0.5) * math.pi if max_imag is None else check_positive(max_imag, "max_imag")
    lo, hi = (n - 0.5) * math.pi, (n + 0.5) * math.pi
    bottom = _LOWER_IMAG
    count = _winding(
        [complex(lo, bottom), complex(hi, bottom), complex(hi, top), complex(lo, top)], system
    )
    found: list[complex] = []
    for spacing in (math.pi / 8, math.pi / 32, math.pi / 128):
        re = np.arange(lo + spacing / 2, hi, spacing)
        im = np.arange(0.0, top + spacing / 2, spacing)
        starts = (re[:, None] + 1j * im[None, :]).ravel()
        roots, converged, _ = so.newton(
            _function,
            starts,
            fprime=_derivative,
            args=system,
            tol=1e-13,
            maxiter=100,
            full_output=True,
        )
        inside = (roots.real >= lo) & (roots.real < hi)
        inside &= (roots.imag >= _LOWER_IMAG) & (roots.imag <= top)
        for z in roots[converged & inside]:
            if abs(_function(z, *system)) > 1e-9 * (1.0 + abs(z)):
                continue  # a stalled iteration, not a root
            if all(abs(z - w) > 1e-8 * abs(z) for w in found):
                found.append(complex(z))
        multiplicity = [_local_multiplicity(z, found, system) for z in found]
        if sum(multiplicity) == count:
            order = np.argsort([z.real for z in found])
            return tuple(DamperRoot(found[i], n, "exact", multiplicity[i]) for i in order)
    raise NumericalError(
        f"found {len(found)} of the {count} roots of the frequency equation near mode {n}"
    )


def _local_multiplicity(z: complex, others: list[complex], system: _System) -> int:
    """How many roots lie in a small square around the root ``z`` (argument principle)."""
    gap = min((abs(z - w) for w in others if w != z), default=1.0)
    r = min(1e-3, 0.3 * gap)
    square = [z + r * complex(a, b) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    return _winding(square, system)


def fe_roots(
    mode: int,
    x_d: float,
    m_e: float,
    c_d: float,
    *,
    k_e: float | None = None,
    elements: int = 400,
    intrinsic_damping: RayleighDamping | None = None,
    max_imag: float | None = None,
) -> tuple[DamperRoot, ...]:
    """Complex eigenvalues of the FE cable model with the damper inside it, near mode ``mode``.

    Same window and arguments as :func:`exact_roots`; ``elements`` is the FE mesh size ``N`` and
    ``intrinsic_damping`` optionally adds the cable's Rayleigh damping (none by default, for
    comparison with the frequency equation).  The model is the normalised cable ``L = T = m = 1``
    (so ``c = 1``, ``omega0 = pi``) with the physical damper of S0 Eq.23; with ``k_e`` the
    flywheel is an extra DOF of the eigenproblem (S0 Eq.12) and the mesh rule of
    :func:`plants.cable.model.elements_for` (``N >= 4/(pi^2 k_e)`` here) decides whether the damper
    node radiates at the device's local frequency; roots near mode ``n`` converge either way.

    Parameters
    ----------
    mode : int
        String mode ``n`` >= 1; the window is ``(n - 1/2) pi <= Re beta < (n + 1/2) pi``.
    x_d : float
        Normalised damper position ``x_d = xbar_d/L`` [-] in (0, 1) (S0 Eq.23).
    m_e : float
        Normalised inertance ``m_e = mbar_e L omega0^2/(pi^2 T)`` [-], >= 0 (S0 Eq.23).
    c_d : float
        Normalised viscous coefficient ``c_d = cbar_d L omega0/(pi^2 T)`` [-], >= 0 (S0 Eq.23).
    k_e : float or None, default None
        Normalised series stiffness ``k_e = kbar_e L/(pi^2 T)`` [-], > 0, with ``(m_e, c_d)``
        behind it (S0 Eq.12); None for the rigid device (S0 Eq.1).
    elements : int, default 400
        Number of linear elements ``N`` >= 2 of the FE mesh (average mass matrix).
    intrinsic_damping : RayleighDamping or None, default None
        The cable's Rayleigh damping; None for none (as in the frequency equation).
    max_imag : float or None, default None
        Upper edge of the window in ``Im beta`` [-], > 0; None means ``(n + 1/2) pi``.

    Returns
    -------
    tuple of DamperRoot
        The eigenvalues in the window as roots (``method="fe"``), ascending ``Re beta``.
    """
    n, x, m_e, c_d, k_e = _check_system(mode, x_d, m_e, c_d, k_e)
    _, elements = check_mesh(x, elements)
    if not n < elements:
        raise ParameterError(
            f"mode {n} needs more FE elements than {elements!r}: a mesh of N elements has "
            "N - 1 modes (and resolves those well below N)"
        )
    top = (n + 0.5) * math.pi if max_imag is None else check_positive(max_imag, "max_imag")
    unit = CableProperties(1.0, 1.0, 1.0)
    inertance, damping = physical_damper(unit, m_e, c_d)
    if k_e is None:
        damper = InterfaceDevice(inertance, damping)
    else:
        stiffness = physical_stiffness(unit, k_e)
        damper = InterfaceDevice(
            series_stiffness=stiffness, series_inertance=inertance, series_damping=damping
        )
    fe = fe_matrices(unit, x, elements, intrinsic_damping=intrinsic_damping, damper=damper)
    lo, hi = (n - 0.5) * math.pi, (n + 0.5) * math.pi
    centre = complex(n * math.pi, 0.5 * (top + _LOWER_IMAG))
    radius = abs(complex(0.5 * math.pi, 0.5 * (top - _LOWER_IMAG)))
    beta = -1j * _state_space_eigenvalues(fe.stiffness, fe.mass, fe.damping, 1j * centre, radius)
    keep = (beta.real >= lo) & (beta.real < hi) & (beta.imag >= _LOWER_IMAG) & (beta.imag <= top)
    return tuple(DamperRoot(complex(b), n, "fe") for b in sorted(beta[keep], key=lambda b: b.real))


def _state_space_eigenvalues(
    k: sp.csc_matrix, m: sp.csc_matrix, c: sp.csc_matrix, shift: complex, radius: float
) -> NDArray[np.complex128]:
    """All eigenvalues ``s`` of ``(s^2 M + s C + K) q = 0`` within ``radius`` of ``shift``.

    Dense QZ (:func:`scipy.linalg.eig`) for small models; otherwise ARPACK shift-invert
    (:func:`scipy.sparse.linalg.eigs`), asking for more eigenvalues until the farthest one
    returned lies outside the disc, so that none inside is missed.
    """
    size = k.shape[0]
    eye, zero = sp.identity(size, format="csc"), sp.csc_matrix((size, size))
    a = sp.bmat([[zero, eye], [-k, -c]], format="csc")
    b = sp.bmat([[eye, zero], [zero, m]], format="csc")
    wanted = 8
    while 2 * size > _DENSE_LIMIT and wanted < 2 * size - 2:
        try:
            s = spla.eigs(a.astype(complex), k=wanted, M=b, sigma=shift, return_eigenvectors=False)
        except spla.ArpackNoConvergence:
            break  # fall back to the dense solver
        if np.max(np.abs(s - shift)) > radius:
            return s[np.abs(s - shift) <= radius]
        wanted *= 2
    s = sla.eigvals(a.toarray(), b.toarray())
    return s[np.abs(s - shift) <= radius]


def asymptotic_damping(
    mode: int, x_d: float, m_e: float, c_d: float, *, k_e: float | None = None
) -> float:
    """Small-damper estimate ``zeta = x kappa/((1 + alpha)^2 + kappa^2)`` [-] of mode ``mode``.

    ``kappa = n pi^2 c_d x`` and ``alpha = -n^2 pi^2 m_e x`` (design.md §6); generally
    ``alpha + i kappa = n pi x Z(n pi)`` with the impedance of :func:`normalised_impedance`
    (so ``k_e`` is accounted for at the string's frequency).  Accurate for small ``x`` away
    from the IMD optimum ``alpha -> -1``, where the exact equation has two roots.

    Parameters
    ----------
    mode : int
        String mode ``n`` >= 1.
    x_d : float
        Normalised damper position ``x_d = xbar_d/L`` [-] in (0, 1) (S0 Eq.23).
    m_e : float
        Normalised inertance ``m_e = mbar_e L omega0^2/(pi^2 T)`` [-], >= 0 (S0 Eq.23).
    c_d : float
        Normalised viscous coefficient ``c_d = cbar_d L omega0/(pi^2 T)`` [-], >= 0 (S0 Eq.23).
    k_e : float or None, default None
        Normalised series stiffness ``k_e = kbar_e L/(pi^2 T)`` [-], > 0, with ``(m_e, c_d)``
        behind it (S0 Eq.12); None for the rigid device (S0 Eq.1).
    """
    n, x, m_e, c_d, k_e = _check_system(mode, x_d, m_e, c_d, k_e)
    eta = n * math.pi * x * complex(normalised_impedance(n * math.pi, m_e, c_d, k_e=k_e))
    return x * eta.imag / abs(1.0 + eta) ** 2
