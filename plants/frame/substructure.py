"""The vRTHS benchmark frame partitioned for RTHS: the numerical substructure and its reference.

Partitioning (``F1_input_file.m``): the physical specimen is the first floor's spring-mass-
dashpot ``(m_e, c_e, k_e)`` (29.13 kg, ``c_e = 2 zeta_e sqrt(k_e m_e)``, 1.19e6 N/m); the numerical
substructure is the rest of the reference frame,

.. math::

    M_N = M - m_e e_1 e_1^T, \\quad C_N = C - c_e e_1 e_1^T, \\quad K_N = K - k_e e_1 e_1^T,

    M_N \\ddot x + C_N \\dot x + K_N x = -M \\iota \\ddot x_g - e_1 F,

with ``x`` the floor displacements relative to the ground and ``F`` the specimen's restoring
force (``F = m_e \\ddot x_1 + c_e \\dot x_1 + k_e x_1`` for a perfect actuator).  The ground
term keeps the *whole* mass ``M`` because the specimen's force is measured in the moving frame
(``B_ns = -(MN\\M) iota``).  In the benchmark's perturbed runs ``k_e`` is drawn and the
numerical substructure is rebuilt with the drawn value, so ``K_N + k_e`` is always the
reference ``K``; pass the drawn specimen here to do the same.

The force reaches the numerical substructure through the benchmark's *Unit Delay*
(``NUMERICAL SUBSTRUCTURE/Unit Delay1``): by default the force measured at ``t_k`` acts over
``[t_{k+1}, t_{k+2}]`` (``force_delay = 1``; 0 applies it over ``[t_k, t_{k+1}]``).  Each step
is exact for that held force and a ground acceleration linear over the step
(:mod:`plants.frame._discrete`).

:func:`reference_response` is the unpartitioned frame under the same ground motion (F3's
``Ref_Resp = lsim(sys_r, EQ_input, t)``), the reference of criteria J4-J9.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from plants.base import Substructure
from plants.frame._discrete import discretise_structure, state_matrices
from plants.frame.cases import CASES, BenchmarkCase
from plants.frame.ground_motion import DEFAULT_INTENSITY, GroundMotion, ground_motion
from plants.frame.kernel import OUTPUTS, frame_step
from plants.linear_specimen import LinearSpecimen
from rths.core.channels import Channel
from rths.core.errors import ParameterError, check_nonnegative, check_positive
from rths.core.kinematics import Kinematics
from rths.core.registry import SUBSTRUCTURES

__all__ = [
    "FRAME_CHANNELS",
    "FrameOptions",
    "FrameSubstructure",
    "numerical_matrices",
    "reference_response",
]

FloatArray = NDArray[np.float64]

#: Declared channels of :meth:`FrameSubstructure.outputs` / ``write_channels`` (the loop logs
#: them as ``sub_x1`` ... ``sub_ag``; the runner scores J4-J9 from ``sub_x1..3``).
FRAME_CHANNELS: tuple[Channel, ...] = (
    Channel("x1", "m", "floor-1 displacement relative to the ground"),
    Channel("x2", "m", "floor-2 displacement relative to the ground"),
    Channel("x3", "m", "floor-3 displacement relative to the ground"),
    Channel("ag", "m/s^2", "ground acceleration (times eq_intensity)"),
)


def numerical_matrices(
    case: BenchmarkCase, specimen: LinearSpecimen
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(M_N, C_N, K_N)`` of the numerical substructure: the case minus the specimen at floor 1.

    ``M_N = M - m_e e_1 e_1^T``, ``C_N = C - c_e e_1 e_1^T``, ``K_N = K - k_e e_1 e_1^T`` (the
    module's partitioning, ``F1_input_file.m``).

    Parameters
    ----------
    case
        The reference frame: its ``mass`` ``M`` [kg], ``damping`` ``C`` [N s/m] and
        ``stiffness`` ``K`` [N/m], shape ``(3, 3)``.
    specimen
        The physical specimen at the first floor: ``mass`` ``m_e`` [kg], ``damping`` ``c_e``
        [N s/m], ``stiffness`` ``k_e`` [N/m] (a perturbed run's drawn ``k_e`` included).

    Returns
    -------
    M_N, C_N, K_N
        Mass [kg], damping [N s/m] and stiffness [N/m] matrices, shape ``(3, 3)``; new arrays.

    Raises
    ------
    ParameterError
        If the specimen is not a :class:`~plants.linear_specimen.LinearSpecimen` or takes all of
        the first floor's mass (``M_N`` must stay positive definite).
    """
    if not isinstance(case, BenchmarkCase):
        raise ParameterError(f"case must be a BenchmarkCase; got {case!r}")
    if not isinstance(specimen, LinearSpecimen):
        raise ParameterError(f"specimen must be a LinearSpecimen; got {specimen!r}")
    mn, cn, kn = case.mass.copy(), case.damping.copy(), case.stiffness.copy()
    mn[0, 0] -= specimen.mass
    cn[0, 0] -= specimen.damping
    kn[0, 0] -= specimen.stiffness
    if mn[0, 0] <= 0.0:
        raise ParameterError(
            f"specimen mass {specimen.mass!r} kg must be below the first floor's "
            f"{case.mass[0, 0]!r} kg"
        )
    return mn, cn, kn


@dataclass(frozen=True)
class FrameOptions:
    """Options of the ``vrths_frame`` substructure kind (the vRTHS benchmark's frame).

    Parameters
    ----------
    case
        Partitioning case 1-4 (``Building cases/Case_N.mat``).
    ground_motion
        ``"el_centro"``, ``"kobe"``, ``"morgan"`` (records read from the benchmark package) or
        ``"chirp"`` (runs without it).  Set ``[run] duration`` to the record's ``tend``: 41.18,
        50.94, 39.97 s, 90 s for the chirp; the last value is held after the end.
    intensity
        ``eq_intensity`` gain on the ground acceleration [-], >= 0 (F1: 0.4).
    force_delay
        Whole steps between the force measurement and the step it acts on: 1 is the
        benchmark's *Unit Delay*, 0 applies it over the next step.
    package
        Folder of the benchmark's companion package (default: ``$RTHS_VRTHS_PACKAGE``).
    chirp_start
        Chirp frequency at t = 0 [Hz] (F1: 0.1).
    chirp_end
        Chirp frequency at ``chirp_duration`` [Hz] (F1: 40).
    chirp_duration
        Chirp target time [s] (F1: 90).
    specimen_mass
        Mass [kg] of the first-floor specimen removed from the frame (29.13).
    specimen_stiffness
        Its stiffness [N/m] (1.19e6).
    specimen_damping_ratio
        Its damping ratio [-] (0.0097): ``c = 2 zeta sqrt(k m)``.
    """

    case: Literal[1, 2, 3, 4] = 1
    ground_motion: Literal["el_centro", "kobe", "morgan", "chirp"] = "el_centro"
    intensity: float = DEFAULT_INTENSITY
    force_delay: Literal[0, 1] = 1
    package: str | None = None
    chirp_start: float = 0.1
    chirp_end: float = 40.0
    chirp_duration: float = 90.0
    specimen_mass: float = 29.13
    specimen_stiffness: float = 1.19e6
    specimen_damping_ratio: float = 0.0097

    def __post_init__(self) -> None:
        check_nonnegative(self.intensity, "ground motion intensity")
        check_positive(self.chirp_duration, "chirp_duration")
        check_nonnegative(self.chirp_start, "chirp_start")
        check_nonnegative(self.chirp_end, "chirp_end")
        check_positive(self.specimen_mass, "specimen_mass")
        check_positive(self.specimen_stiffness, "specimen_stiffness")
        check_nonnegative(self.specimen_damping_ratio, "specimen_damping_ratio")

    def ground(self) -> GroundMotion:
        """The ground motion these options name (reads the record from the package)."""
        if self.ground_motion == "chirp":
            return ground_motion("chirp", f_start=self.chirp_start, f_end=self.chirp_end,
                                 duration=self.chirp_duration)  # fmt: skip
        return ground_motion(self.ground_motion, self.package)

    def specimen(self) -> LinearSpecimen:
        """The specimen the frame is partitioned with."""
        return LinearSpecimen.from_damping_ratio(
            self.specimen_mass, self.specimen_stiffness, self.specimen_damping_ratio
        )


@SUBSTRUCTURES.register("vrths_frame", FrameOptions)
class FrameSubstructure(Substructure):
    """The vRTHS benchmark frame minus its first-floor specimen, under base acceleration.

    The numerical substructure of the benchmark (module docstring).

    The interface is floor 1; the target is its displacement, velocity and acceleration relative
    to the ground.  Each step costs one 6x6 matrix-vector product.

    Parameters
    ----------
    case
        The reference frame (:data:`plants.frame.cases.CASES`).
    specimen
        The physical substructure removed from floor 1 (nominal or a drawn one).
    ground
        The ground motion; its run length is ``ground.steps(dt)``.
    dt
        Loop step [s] (benchmark 1/4096).
    intensity
        ``eq_intensity`` [-] (F1: 0.4).
    force_delay
        Whole steps between the force measurement and the step it acts on (0 or 1; the
        benchmark's *Unit Delay* is 1).
    use_jit
        Step with the compiled kernel (:func:`plants.frame.kernel.frame_step`, default) or with
        the NumPy expressions (the reference path; equal to round-off).

    Notes
    -----
    :meth:`outputs` gives the floor displacements ``x1``, ``x2``, ``x3`` [m] at the end of the step
    and the ground acceleration ``ag`` [m/s^2] (what J4-J9 compare with the reference), and
    :meth:`reference_response` the unpartitioned frame's floors: the runner scores a run with
    the benchmark's J1-J9 when its substructure has one.

    The frame carries no nominal device (``[model]`` only serves the compensators' nominal
    plant): like the benchmark, the loop feeds back the whole measured force.  A scenario's
    Monte Carlo draws the lab's specimen but keeps the partition of the options; F1 rebuilds
    the numerical substructure with each drawn stiffness (``rths compare`` does).
    """

    def __init__(
        self,
        case: BenchmarkCase,
        specimen: LinearSpecimen,
        ground: GroundMotion,
        dt: float,
        *,
        intensity: float = DEFAULT_INTENSITY,
        force_delay: int = 1,
        use_jit: bool = True,
    ) -> None:
        super().__init__(dt)
        if not isinstance(ground, GroundMotion):
            raise ParameterError(f"ground must be a GroundMotion; got {ground!r}")
        if force_delay not in (0, 1) or isinstance(force_delay, bool):
            raise ParameterError(f"force_delay must be 0 or 1 steps; got {force_delay!r}")
        self.case, self.specimen, self.ground = case, specimen, ground
        self.intensity: float = check_nonnegative(intensity, "ground motion intensity")
        self.force_delay: int = force_delay
        self.n_steps: int = ground.steps(self.dt)
        mn, cn, kn = numerical_matrices(case, specimen)
        a, b_g, b_f = state_matrices(mn, cn, kn, case.mass)
        d = discretise_structure(a, b_g, b_f[:, 0], self.dt)
        # One product per step: [z_{k+1}; a_1] = G [z_k; a_g,k; a_g,k+1; F_held], the structure
        # receiving -F at floor 1 (plants.base sign convention); a_1 is row 0 of
        # M_N^-1 (-K_N x - C_N v - M iota a_g - e_1 F) at t_{k+1}.
        acc = np.concatenate([a[3], [b_g[3], -b_f[3, 0]]])  # floor-1 row of z' (z, a_g, F)
        g = np.zeros((7, 9))
        g[:6, :6], g[:6, 6], g[:6, 7], g[:6, 8] = d.phi, d.g0, d.g1, -d.gf[:, 0]
        g[6, :6] = acc[:6] @ g[:6, :6]
        g[6, 6] = acc[:6] @ g[:6, 6]
        g[6, 7] = acc[:6] @ g[:6, 7] + acc[6]
        g[6, 8] = acc[:6] @ g[:6, 8] + acc[7]
        self._step_matrix = g
        self._ag = ground.sampled(self.dt, self.n_steps + 2, self.intensity)
        self._input = np.zeros(9)
        self.use_jit: bool = bool(use_jit)
        self._state = np.zeros(8)  # compiled path: z, held, pending (plants.frame.kernel)
        self._out = np.zeros(len(OUTPUTS))
        self.reset()

    @classmethod
    def from_options(cls, options: FrameOptions, *, dt: float, **_: Any) -> FrameSubstructure:
        """The ``vrths_frame`` kind."""
        return cls(CASES[options.case], options.specimen(), options.ground(), dt,
                   intensity=options.intensity, force_delay=options.force_delay)  # fmt: skip

    @staticmethod
    def nominal_device(model: object) -> None:
        """None: the frame carries no device, whatever ``[model]`` says (class docstring)."""
        return None

    def _reset_impl(self) -> None:
        """Back to rest with no force pending."""
        self._z = np.zeros(6)
        self._held = 0.0  # force acting over the current step
        self._pending = 0.0  # force measured last, acting from the next step (delay 1)
        self._interface = Kinematics(0.0, 0.0, 0.0)
        self._state[:] = 0.0
        self._out[:] = 0.0
        self._out[6] = self._ground(0)

    @property
    def interface(self) -> Kinematics:
        """Floor-1 kinematics relative to the ground at the current time."""
        return self._interface

    @property
    def floor_displacements(self) -> FloatArray:
        """Displacements [m] of floors 1-3 relative to the ground, shape ``(3,)`` (a copy)."""
        return (self._state if self.use_jit else self._z)[:3].copy()

    def _ground(self, k: int) -> float:
        ag = self._ag
        return float(ag[k]) if k < ag.size else float(ag[-1])

    def _advance(self, force: float) -> tuple[FloatArray, float, Kinematics]:
        held = self._pending if self.force_delay else force
        k = self.steps
        w = self._input
        w[:6] = self._z
        w[6], w[7], w[8] = self._ground(k), self._ground(k + 1), held
        out = self._step_matrix @ w
        z = out[:6]
        return z, held, Kinematics(float(z[0]), float(z[3]), float(out[6]))

    def _step_impl(self, restoring_force: float) -> Kinematics:
        if self.use_jit:
            out = self._out
            frame_step(self._step_matrix, self._ag, self._state, restoring_force,
                       self._steps, self.force_delay, out)  # fmt: skip
            x, v, a = out[:3].tolist()
            self._interface = kin = Kinematics(x, v, a)
            return kin
        z, held, kin = self._advance(restoring_force)
        self._z, self._held, self._pending = z, held, restoring_force
        self._interface = kin
        return kin

    def predict(self, restoring_force: float) -> Kinematics:
        """The floor-1 kinematics one step ahead, without committing the step."""
        if self.use_jit:
            out = np.zeros(len(OUTPUTS))
            frame_step(self._step_matrix, self._ag, self._state.copy(), float(restoring_force),
                       self._steps, self.force_delay, out)  # fmt: skip
            x, v, a = out[:3].tolist()
            return Kinematics(x, v, a)
        return self._advance(float(restoring_force))[2]

    def outputs(self) -> dict[str, float]:
        """Floor displacements ``x1``-``x3`` [m] and ground acceleration ``ag`` [m/s^2]."""
        z = self._state if self.use_jit else self._z
        ag = self._ground(self.steps)
        return {"x1": float(z[0]), "x2": float(z[1]), "x3": float(z[2]), "ag": ag}

    def channels(self) -> tuple[Channel, ...]:
        """:data:`FRAME_CHANNELS` (the keys of :meth:`outputs`, with units)."""
        return FRAME_CHANNELS

    def write_channels(self, out: FloatArray) -> None:
        """Write :meth:`outputs`' values into ``out`` (no dict)."""
        if self.use_jit:
            out[:] = self._out[3:]
            return
        out[:3] = self._z[:3]
        out[3] = self._ground(self.steps)

    def reference_response(self, n: int) -> FloatArray:
        """Floor displacements [m] of the unpartitioned frame at ``t_k = k dt``, ``k < n``
        (:func:`reference_response`), shape ``(n, 3)``."""
        return reference_response(self.case, self.ground, self.dt, n, self.intensity)


def reference_response(
    case: BenchmarkCase,
    ground: GroundMotion,
    dt: float,
    n: int | None = None,
    intensity: float = DEFAULT_INTENSITY,
) -> FloatArray:
    """Floor displacements [m] of the whole reference frame at ``t_k = k dt``, ``k = 0 .. n-1``.

    F3's ``Ref_Resp = lsim(sys_r, EQ_input, t)``: the unpartitioned frame from rest, the ground
    acceleration sampled at ``t_k`` and linear in between (first-order hold), integrated exactly.

    Parameters
    ----------
    case
        The reference frame.
    ground
        The ground motion.
    dt
        Sampling step [s].
    n
        Number of samples; default ``ground.steps(dt) + 1`` (``t = 0 .. tend``).
    intensity
        ``eq_intensity`` [-].

    Returns
    -------
    numpy.ndarray
        Shape ``(n, 3)``; row 0 is the initial rest.
    """
    dt = check_positive(dt, "time step dt")
    n = ground.steps(dt) + 1 if n is None else int(n)
    if n < 1:
        raise ParameterError(f"number of samples must be >= 1; got {n!r}")
    a, b_g, b_f = state_matrices(case.mass, case.damping, case.stiffness, case.mass)
    d = discretise_structure(a, b_g, b_f[:, 0], dt)
    ag = ground.sampled(dt, n, intensity)
    drive = np.outer(ag[:-1], d.g0) + np.outer(ag[1:], d.g1)
    z = np.zeros((n, 6))
    phi = d.phi
    state = np.zeros(6)
    for k in range(n - 1):
        state = phi @ state + drive[k]
        z[k + 1] = state
    return z[:, :3]
