"""Layout of the arrays the S1 kernel (:mod:`plants.tmdi.integration.kernel`) works on: parameter,
state, input and output vectors, contact modes, and :func:`pack_parameters` that fills the
parameter vector from validated parameter objects."""

from __future__ import annotations

import numpy as np

from plants.tmdi.hdrb import HDRB
from plants.tmdi.parameters import RackPinionParameters, TMDIParameters

__all__ = [
    "BACKWARD",
    "FORWARD",
    "I_AG0",
    "I_AG1",
    "I_DRIVEN",
    "I_FEXT",
    "I_U0",
    "I_U1",
    "I_V0",
    "I_V1",
    "LAW_AHI",
    "LAW_ALO",
    "LAW_C0",
    "LAW_N",
    "LAW_TOL",
    "N_INPUT",
    "N_OUTPUT",
    "N_PARAM",
    "N_STATE",
    "OPEN",
    "OUTPUT_FIELDS",
    "O_A_I_TOT",
    "O_A_T",
    "O_A_T_TOT",
    "O_C_I",
    "O_C_T",
    "O_F_B",
    "O_F_I",
    "O_F_T",
    "O_MODE",
    "O_OM_G",
    "O_TH_G",
    "O_TH_S",
    "O_TORQUE",
    "O_U_I",
    "O_U_T",
    "O_U_TI",
    "O_V_I",
    "O_V_T",
    "P_B",
    "P_CB",
    "P_CS",
    "P_C_G",
    "P_C_I",
    "P_C_T",
    "P_EPS1",
    "P_EPS2",
    "P_FY",
    "P_J",
    "P_K1_I",
    "P_K1_T",
    "P_K2_I",
    "P_K2_T",
    "P_K3_I",
    "P_K3_T",
    "P_KS",
    "P_LAW_I",
    "P_LAW_T",
    "P_M_I",
    "P_M_T",
    "P_R",
    "P_RACK",
    "P_VEPS",
    "S_AMP_I",
    "S_AMP_T",
    "S_MODE",
    "S_OM_G",
    "S_TH_G",
    "S_TH_S",
    "S_U_I",
    "S_U_T",
    "S_V_I",
    "S_V_T",
    "TRK_DC",
    "TRK_DIR",
    "TRK_EXT",
    "TRK_SEEN",
    "TRK_TURN",
    "pack_parameters",
]

# ---- parameter vector layout ---------------------------------------------------------------------
P_M_I, P_K1_I, P_K2_I, P_K3_I, P_C_I = 0, 1, 2, 3, 4
P_M_T, P_K1_T, P_K2_T, P_K3_T, P_C_T = 5, 6, 7, 8, 9
P_B = 10  # rigid inertance between u_T and the ground (ideal inerter) [kg]
P_RACK = 11  # 1.0 when the rack-and-pinion inerter is present
P_R, P_J, P_KS, P_CS, P_CB = 12, 13, 14, 15, 16
P_EPS1, P_EPS2, P_FY, P_VEPS = 17, 18, 19, 20
P_C_G = 21  # viscous coefficient between u_T and the ground (nominal device) [N s/m]
# amplitude-dependent dashpot of each HDRB (plants.tmdi.hdrb.AmplitudeDamping); block offsets +
# 0..5: active flag, exponent n, A_lo [m], A_hi [m], reversal tolerance [m], dashpot at rest c(A_lo)
# [N s/m] (without a law: the block is zero except c(A_lo) = c)
P_LAW_I, P_LAW_T = 22, 28
LAW_N, LAW_ALO, LAW_AHI, LAW_TOL, LAW_C0 = 1, 2, 3, 4, 5
N_PARAM = 34

# ---- state vector layout -------------------------------------------------------------------------
S_U_I, S_V_I, S_U_T, S_V_T, S_TH_S, S_TH_G, S_OM_G, S_MODE = 0, 1, 2, 3, 4, 5, 6, 7
# online amplitude estimate of each HDRB deformation (u_I, u_TI); block offsets + 0..5:
# amplitude [m], direction (+1, -1, 0 = not moved yet), running extremum [m],
# deformation at the last reversal [m], reversals seen (0, 1; capped at 1),
# c(A)/c(A_lo) - 1 [-] (0 at rest, so a zero state is the rest state)
S_AMP_I, S_AMP_T = 8, 14
TRK_DIR, TRK_EXT, TRK_TURN, TRK_SEEN, TRK_DC = 1, 2, 3, 4, 5
N_STATE = 20

# ---- per-step inputs -----------------------------------------------------------------------------
I_AG0, I_AG1, I_FEXT, I_DRIVEN, I_U0, I_V0, I_U1, I_V1 = 0, 1, 2, 3, 4, 5, 6, 7
N_INPUT = 8

# ---- output row layout ---------------------------------------------------------------------------
O_U_I, O_A_I_TOT, O_F_I, O_U_TI, O_A_T_TOT, O_F_T, O_U_T, O_A_T, O_F_B = 0, 1, 2, 3, 4, 5, 6, 7, 8
O_V_I, O_V_T, O_TH_S, O_TH_G, O_OM_G, O_TORQUE, O_MODE = 9, 10, 11, 12, 13, 14, 15
O_C_I, O_C_T = 16, 17
N_OUTPUT = 18
#: Output column of each named response quantity (S1 Eq.7 names and internal states).
OUTPUT_FIELDS: dict[str, int] = {
    "u_I": O_U_I,
    "a_I_tot": O_A_I_TOT,
    "F_I": O_F_I,
    "u_TI": O_U_TI,
    "a_T_tot": O_A_T_TOT,
    "F_T": O_F_T,
    "u_T": O_U_T,
    "a_T": O_A_T,
    "F_B": O_F_B,
    "v_I": O_V_I,
    "v_T": O_V_T,
    "theta_S": O_TH_S,
    "theta_G": O_TH_G,
    "omega_G": O_OM_G,
    "torque": O_TORQUE,
    "contact": O_MODE,
    "c_I": O_C_I,
    "c_T": O_C_T,
}

OPEN, FORWARD, BACKWARD = 0, 1, -1


def pack_parameters(
    structure: TMDIParameters | None = None,
    inertance: float = 0.0,
    device: RackPinionParameters | None = None,
    grounded_damping: float = 0.0,
) -> np.ndarray:
    """The kernel's parameter vector from validated parameter objects.

    Parameters
    ----------
    structure : TMDIParameters or None, default None
        The S1 Eq.12 structure (masses ``m_I``, ``m_T`` [kg] and the S1 Eq.8 isolators
        ``k1`` [N/m], ``k2`` [N/m^2], ``k3`` [N/m^3], ``c`` [N s/m] with their damping laws);
        None for the inerter alone, which gets a placeholder primary mass of 1 kg.
    inertance : float, default 0.0
        Rigid inertance ``b`` [kg] between ``u_T`` and the ground: the ideal inerter, or the
        nominal device of :class:`plants.tmdi.structure.TMDISubstructure`.  Not validated here.
    device : RackPinionParameters or None, default None
        The rack-and-pinion inerter of S1 Eq.9-11 (``r_P`` [m], ``J_B`` [kg m^2], ``k_S``
        [N m/rad], ``c_S``, ``c_B`` [N m s/rad], ``ε1``, ``ε2`` [rad], ``f_y`` [N], ``v_eps``
        [m/s]); None for none.
    grounded_damping : float, default 0.0
        Viscous coefficient ``c_G`` [N s/m] between ``u_T`` and the ground (the nominal
        interface device of :class:`plants.tmdi.structure.TMDISubstructure`).

    Returns
    -------
    numpy.ndarray
        The parameter vector, shape ``(N_PARAM,)``, laid out as the ``P_*`` indices say.
    """
    p = np.zeros(N_PARAM)
    p[P_M_I] = 1.0
    if structure is not None:
        iso = structure.primary_isolator
        p[P_M_I : P_C_I + 1] = (structure.primary_mass, iso.k1, iso.k2, iso.k3, iso.c)
        _pack_law(p, P_LAW_I, iso)
        if structure.has_tmd and structure.secondary_isolator is not None:
            iso = structure.secondary_isolator
            p[P_M_T : P_C_T + 1] = (structure.secondary_mass, iso.k1, iso.k2, iso.k3, iso.c)
            _pack_law(p, P_LAW_T, iso)
    p[P_B] = inertance
    p[P_C_G] = grounded_damping
    if device is not None:
        p[P_RACK] = 1.0
        p[P_R : P_VEPS + 1] = (
            device.pinion_radius,
            device.flywheel_inertia,
            device.series_stiffness,
            device.series_damping,
            device.flywheel_damping,
            device.clearance_forward,
            device.clearance_backward,
            device.friction_force,
            device.friction_velocity,
        )
    return p


def _pack_law(p: np.ndarray, block: int, isolator: HDRB) -> None:
    """Write an HDRB's dashpot at rest and its damping law (if any) into the block."""
    law = isolator.damping_law
    p[block + LAW_C0] = isolator.c
    if law is None:
        return
    lo, hi = law.amplitude_range
    p[block : block + LAW_TOL + 1] = (1.0, law.exponent, lo, hi, law.reversal_tolerance)
    p[block + LAW_C0] = float(isolator.damping_coefficient(0.0))
