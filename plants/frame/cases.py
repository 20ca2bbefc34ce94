"""The vRTHS benchmark's reference structure: a 3-storey, 2-bay steel moment frame, 4 cases.

The benchmark (Silva et al. 2020, companion package ``Reference_def.m``) models a small steel
frame (columns 635 mm, beams 762 mm) and statically condenses it to three lateral DOFs, one per
floor (``KK_mat.m``): the 12-DOF stiffness matrix of the lateral translations and joint rotations
(vertical translations neglected, rigid floor diaphragms) is condensed onto the translations,

.. math:: K = K_{tt} - K_{rt}^T K_{rr}^{-1} K_{rt}.

Floor masses are lumped (``MM_mat.m``) and the damping is classical with the same ratio in the
three modes (``CC_mat.m``):

.. math:: C = \\Phi^{-T} \\operatorname{diag}(2 \\zeta_i \\omega_i M_i) \\Phi^{-1}, \\quad
          M_i = \\phi_i^T M \\phi_i,

where the benchmark rounds ``omega_i`` to 0.01 rad/s first (``modes.m``); this module does the
same so that ``C`` equals the benchmark's ``Building cases/Case_N.mat`` to round-off.

The four partitioning cases differ in floor mass and damping ratio (``Reference_def.m``,
``m_ref``/``z_ref``): 1000 kg / 5 %, 1100 kg / 4 %, 1300 kg / 3 %, 1000 kg / 3 %.

References
----------
.. [1] Silva, C. E., Gomez, D., Maghareh, A., Dyke, S. J., Spencer, B. F. Jr. (2020).
   Benchmark control problem for real-time hybrid simulation. Mech. Syst. Signal Process. 135,
   106381.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from rths.core.errors import ParameterError, check_in_range, check_positive

__all__ = [
    "CASES",
    "BenchmarkCase",
    "FrameGeometry",
    "benchmark_case",
    "condensed_stiffness",
    "modal_damping",
    "natural_frequencies",
]

FloatArray = NDArray[np.float64]

_INCH = 25.4e-3  # m


@dataclass(frozen=True, slots=True)
class FrameGeometry:
    """Section and length data of the benchmark frame (``Reference_def.m``), SI units.

    Attributes
    ----------
    elastic_modulus
        Steel ``E`` [Pa] (200 GPa).
    column_inertia
        Second moment of area of a column ``I_c`` [m^4] (2.520 in^4).
    beam_inertia
        Second moment of area of a beam ``I_b`` [m^4] (255267 mm^4).
    column_length
        Storey height ``L_c`` [m] (0.635).
    beam_length
        Bay width ``L_b`` [m] (0.762).
    """

    elastic_modulus: float = 200.0e9
    column_inertia: float = 2.520 * _INCH**4
    beam_inertia: float = 255267.0e-12
    column_length: float = 0.635
    beam_length: float = 0.762

    def __post_init__(self) -> None:
        check_positive(self.elastic_modulus, "elastic modulus E")
        check_positive(self.column_inertia, "column second moment of area I_c")
        check_positive(self.beam_inertia, "beam second moment of area I_b")
        check_positive(self.column_length, "column length L_c")
        check_positive(self.beam_length, "beam length L_b")


def _twelve_dof_stiffness(g: FrameGeometry) -> FloatArray:
    """The 12-DOF stiffness matrix of ``KK_mat.m`` [N/m, N, N m]: floor translations 1-3, then
    the rotations of the nine joints (three per floor, outer-inner-outer)."""
    ic, ib, h, span = g.column_inertia, g.beam_inertia, g.column_length, g.beam_length
    kk = np.diag([
        45 * ic / h**3, 72 * ic / h**3, 36 * ic / h**3,
        7 * ic / h + 4 * ib / span, 7 * ic / h + 8 * ib / span, 7 * ic / h + 4 * ib / span,
        8 * ic / h + 4 * ib / span, 8 * ic / h + 8 * ib / span, 8 * ic / h + 4 * ib / span,
        4 * ic / h + 4 * ib / span, 4 * ic / h + 8 * ib / span, 4 * ic / h + 4 * ib / span,
    ])  # fmt: skip
    a, b, c = 3 * ic / h**2, 6 * ic / h**2, 36 * ic / h**3
    rows = {
        0: [-c, 0, -a, -a, -a, -b, -b, -b, 0, 0, 0],
        1: [-c, b, b, b, 0, 0, 0, -b, -b, -b],
        2: [0, 0, 0, b, b, b, b, b, b],
        3: [2 * ib / span, 0, 2 * ic / h, 0, 0, 0, 0, 0],
        4: [2 * ib / span, 0, 2 * ic / h, 0, 0, 0, 0],
        5: [0, 0, 2 * ic / h, 0, 0, 0],
        6: [2 * ib / span, 0, 2 * ic / h, 0, 0],
        7: [2 * ib / span, 0, 2 * ic / h, 0],
        8: [0, 0, 2 * ic / h],
        9: [2 * ib / span, 0],
        10: [2 * ib / span],
    }
    for i, row in rows.items():
        kk[i, i + 1 :] = row
        kk[i + 1 :, i] = row
    return g.elastic_modulus * kk


def condensed_stiffness(geometry: FrameGeometry | None = None) -> FloatArray:
    """Lateral stiffness matrix [N/m] of the three floors (static condensation, ``KK_mat.m``).

    Parameters
    ----------
    geometry
        Frame data; the benchmark's by default.

    Returns
    -------
    numpy.ndarray
        Symmetric positive-definite ``K``, shape ``(3, 3)``.
    """
    kk = _twelve_dof_stiffness(FrameGeometry() if geometry is None else geometry)
    kt, kr, krt = kk[:3, :3], kk[3:, 3:], kk[3:, :3]
    k = kt - krt.T @ np.linalg.solve(kr, krt)
    return 0.5 * (k + k.T)


def _sorted_modes(mass: FloatArray, stiffness: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Circular frequencies [rad/s] (ascending) and mode shapes (columns) of ``(M, K)``."""
    w2, phi = np.linalg.eig(np.linalg.solve(mass, stiffness))
    order = np.argsort(w2.real)
    return np.sqrt(w2.real[order]), phi.real[:, order]


def natural_frequencies(mass: FloatArray, stiffness: FloatArray) -> FloatArray:
    """Natural frequencies [Hz] of ``(M, K)`` in ascending order.

    Parameters
    ----------
    mass : numpy.ndarray, shape (n, n)
        Mass matrix ``M`` [kg].
    stiffness : numpy.ndarray, shape (n, n)
        Stiffness matrix ``K`` [N/m].
    """
    return _sorted_modes(np.asarray(mass, float), np.asarray(stiffness, float))[0] / (2 * math.pi)


def modal_damping(
    mass: FloatArray, stiffness: FloatArray, damping_ratio: float, *, round_frequencies: bool = True
) -> FloatArray:
    """Classical damping matrix [N s/m] with ratio ``damping_ratio`` in every mode (``CC_mat.m``).

    Parameters
    ----------
    mass, stiffness
        ``M`` [kg] and ``K`` [N/m], shape ``(n, n)``.
    damping_ratio
        ``zeta`` [-] of every mode, in [0, 1).
    round_frequencies
        Round the circular frequencies to 0.01 rad/s first, as ``modes.m`` does (the benchmark's
        matrices); ``False`` gives the exact ratio.

    Returns
    -------
    numpy.ndarray
        Symmetric ``C``, shape ``(n, n)``.
    """
    zeta = check_in_range(damping_ratio, "modal damping ratio", 0.0, 0.999)
    m = np.asarray(mass, dtype=float)
    omega, phi = _sorted_modes(m, np.asarray(stiffness, dtype=float))
    if round_frequencies:
        omega = np.round(100.0 * omega) / 100.0
    modal_mass = np.einsum("ij,ik,kj->j", phi, m, phi)
    inv = np.linalg.inv(phi)
    c = inv.T @ np.diag(2.0 * zeta * omega * modal_mass) @ inv
    return 0.5 * (c + c.T)


@dataclass(frozen=True)
class BenchmarkCase:
    """One partitioning case of the benchmark's reference frame (``Reference_def.m``).

    Attributes
    ----------
    number
        Case number 1-4 (``Building cases/Case_N.mat``).
    floor_mass
        Lumped mass of each floor [kg].
    damping_ratio
        Damping ratio of every mode [-].
    geometry
        Frame data (the benchmark's by default).
    mass, stiffness, damping
        ``M`` [kg], ``K`` [N/m], ``C`` [N s/m], shape ``(3, 3)`` (derived on construction).
    """

    number: int
    floor_mass: float
    damping_ratio: float
    geometry: FrameGeometry = field(default_factory=FrameGeometry)
    mass: FloatArray = field(init=False, repr=False, compare=False)
    stiffness: FloatArray = field(init=False, repr=False, compare=False)
    damping: FloatArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        m = check_positive(self.floor_mass, "floor mass")
        mass = m * np.eye(3)
        stiffness = condensed_stiffness(self.geometry)
        damping = modal_damping(mass, stiffness, self.damping_ratio)
        for name, value in (("mass", mass), ("stiffness", stiffness), ("damping", damping)):
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    @property
    def frequencies(self) -> FloatArray:
        """Natural frequencies [Hz] of the reference frame, ascending."""
        return natural_frequencies(self.mass, self.stiffness)


#: The benchmark's four partitioning cases (``Reference_def.m``: ``m_ref``, ``z_ref``).
CASES: dict[int, BenchmarkCase] = {
    1: BenchmarkCase(1, 1000.0, 0.05),
    2: BenchmarkCase(2, 1100.0, 0.04),
    3: BenchmarkCase(3, 1300.0, 0.03),
    4: BenchmarkCase(4, 1000.0, 0.03),
}


def benchmark_case(number: int) -> BenchmarkCase:
    """The benchmark case ``number`` (1-4); :class:`ParameterError` for any other value.

    Parameters
    ----------
    number : int
        Case number, 1 .. 4 (:data:`CASES`).
    """
    if isinstance(number, bool) or not isinstance(number, int) or number not in CASES:
        raise ParameterError(f"benchmark case must be one of 1, 2, 3, 4; got {number!r}")
    return CASES[number]
