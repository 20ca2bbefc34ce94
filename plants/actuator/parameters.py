"""Parameters of the vRTHS benchmark servo-hydraulic actuator and its presets.

The model (Silva et al. 2020; design.md section 5) with an optional differential-pressure (Delta-P)
feedback and the actuator's own moving mass/damping::

    servo-valve   q   = a1b0 / (s^2 + b1 s + b2) * e,   e = gain*command - x - K_dp*F_a
    hydraulics    (s + a3) F_a = q - a2 * xdot
    mechanics     (m_p + m_r) xddot + (c_p + c_r) xdot = F_a - F_rest

Units: ``e`` and ``x`` in m, ``F_a`` in N, ``q`` in N/s; hence ``a1b0`` [N/(m s^3)], ``b1``
[1/s], ``b2`` [1/s^2], ``a2`` [N/m], ``a3`` [1/s], ``K_dp`` [m/N].
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from rths.core.errors import check_finite, check_nonnegative, check_positive

__all__ = [
    "BENCHMARK",
    "HEAVY_INERTIAL_LOAD",
    "MTS_IDENTIFIED",
    "BenchmarkParameters",
    "IdentifiedTransferFunction",
]


@dataclass(frozen=True, slots=True)
class BenchmarkParameters:
    """Servo-hydraulic actuator parameters; the defaults are the vRTHS benchmark's code values.

    Attributes
    ----------
    a1_beta0
        Servo-valve gain ``a1*beta0`` [N/(m s^3)], > 0; the servo-controller's proportional gain
        is absorbed in it (benchmark 2.1283e13).
    a2
        Natural velocity feedback of the piston flow ``a2`` [N/m], > 0 (benchmark 4.2297e6).
    a3
        Hydraulic (leakage) pole ``a3`` [1/s] (benchmark 3.3, standard deviation 1.3).  Only
        finiteness is required: the benchmark's normal Monte-Carlo spread can draw small negative
        values; stability is checked on the closed loop.
    beta1
        Servo-valve damping coefficient ``beta1`` [1/s], > 0 (benchmark 425, std 3.3).
    beta2
        Servo-valve stiffness coefficient ``beta2`` [1/s^2], > 0 (benchmark 9.9976e4, std 3.3e3).
    gain
        Calibration gain [-] on the command, > 0 (benchmark 1.0261: it brings the 0.982 DC gain
        of the loop with the benchmark specimen to ~1).
    piston_mass
        The actuator's own moving mass ``m_p`` [kg], >= 0 (benchmark 0: lumped in its specimen).
    piston_damping
        The actuator's own viscous damping ``c_p`` [N s/m], >= 0 (benchmark 0).
    pressure_feedback
        Delta-P stabilisation gain ``K_dp`` [m/N], >= 0: the valve input becomes
        ``gain*command - x - K_dp*F_a`` (benchmark 0: no Delta-P loop).
    a3_std, beta1_std, beta2_std
        Standard deviations of ``a3`` [1/s], ``beta1`` [1/s] and ``beta2`` [1/s^2], >= 0, of the
        Monte-Carlo draws (:meth:`sample`).
    """

    a1_beta0: float = 2.1283e13
    a2: float = 4.2297e6
    a3: float = 3.3
    beta1: float = 425.0
    beta2: float = 9.9976e4
    gain: float = 1.0261
    piston_mass: float = 0.0
    piston_damping: float = 0.0
    pressure_feedback: float = 0.0
    a3_std: float = 1.3
    beta1_std: float = 3.3
    beta2_std: float = 3.3e3

    def __post_init__(self) -> None:
        check_positive(self.a1_beta0, "servo-valve gain a1_beta0")
        check_positive(self.a2, "velocity feedback a2")
        check_finite(self.a3, "hydraulic pole a3")
        check_positive(self.beta1, "servo-valve beta1")
        check_positive(self.beta2, "servo-valve beta2")
        check_positive(self.gain, "calibration gain")
        check_nonnegative(self.piston_mass, "piston_mass")
        check_nonnegative(self.piston_damping, "piston_damping")
        check_nonnegative(self.pressure_feedback, "pressure_feedback")
        check_nonnegative(self.a3_std, "a3_std")
        check_nonnegative(self.beta1_std, "beta1_std")
        check_nonnegative(self.beta2_std, "beta2_std")

    def sample(self, rng: np.random.Generator) -> BenchmarkParameters:
        """One Monte-Carlo draw of the benchmark's uncertain parameters.

        ``a3``, ``beta1`` and ``beta2`` are drawn, in that order, from independent normal
        distributions centred on the current values with the ``*_std`` deviations (the
        benchmark's parametric uncertainty); every other field is kept.  A seeded
        ``numpy.random.Generator`` therefore reproduces the draws.

        Parameters
        ----------
        rng
            The random generator (three normal variates are consumed).

        Returns
        -------
        BenchmarkParameters
            The perturbed parameters.
        """
        a3, beta1, beta2 = rng.normal(
            [self.a3, self.beta1, self.beta2], [self.a3_std, self.beta1_std, self.beta2_std]
        )
        return replace(self, a3=float(a3), beta1=float(beta1), beta2=float(beta2))


#: The vRTHS benchmark actuator (Silva et al. 2020), for light specimens (~30 kg).
BENCHMARK = BenchmarkParameters()

#: Benchmark hydraulics stabilised for a heavy inertial load (e.g. the 1589 kg Type II IMD, S0
#: Table 4, behind a 30 kg piston).  The benchmark loop driving 1.6 t is unstable (poles near
#: +17 +/- 56j rad/s); as real labs do, a Delta-P loop ``K_dp = 5e-7 m/N`` and a piston damping
#: ``c_p = 3e4 N s/m`` damp the oil-column mode and the servo gain is reduced to 0.6x the
#: benchmark's.  The calibration gain is 1: with no specimen stiffness the loop has unit DC gain.
#: With a rigid 1589 kg load the slowest poles have damping ratio ~0.6; the gain is flat within
#: 1 % up to 3 Hz with ~50 ms phase delay (figures in tools/bench_actuator.py).
HEAVY_INERTIAL_LOAD = replace(
    BENCHMARK,
    a1_beta0=0.6 * BENCHMARK.a1_beta0,
    gain=1.0,
    piston_mass=30.0,
    piston_damping=3.0e4,
    pressure_feedback=5.0e-7,
)


@dataclass(frozen=True, slots=True)
class IdentifiedTransferFunction:
    """A command→displacement transfer function identified on a real actuator.

    Attributes
    ----------
    num, den
        Coefficients in descending powers of ``s`` (SI: m/m).
    source
        Where the identification comes from and how it was done.
    """

    num: tuple[float, ...]
    den: tuple[float, ...]
    source: str


def _third_order(gain: float, omega: float, zeta: float, pole: float) -> IdentifiedTransferFunction:
    num = (gain * omega**2 * pole,)
    den = tuple(float(c) for c in np.polymul([1.0, 2.0 * zeta * omega, omega**2], [1.0, pole]))
    return IdentifiedTransferFunction(
        num,
        den,
        "MTS servo-hydraulic actuator driving an MR damper at 0 A: linear sine sweep 0.5-20 Hz, "
        "+/-2 mm, 1 kHz (UTFSM thesis data, DanielMaurelE/vRTHS_AMBC_MRdamper, 0A.txt, MIT). "
        "H1 FRF (Welch, 4096-sample segments) fitted over 0.5-20 Hz by least squares on the "
        "relative complex error with g w^2 p / ((s^2 + 2 z w s + w^2)(s + p)): g = 1.0143, "
        "w = 322.27 rad/s (51.3 Hz), z = 0.673, p = 44.30 rad/s; worst relative FRF error 2.9 %; "
        "phase delay 26.6 ms at 1 Hz, 19.5 ms at 10 Hz.",
    )


#: A real MTS actuator's identified transfer function (3rd order, see ``source``): the transfer
#: system of the emulated cable-IMD RTHS (S0 used an MTS 204.63).  Its phase delay is 26.6 ms at
#: 1 Hz and 19.5 ms at 10 Hz.
MTS_IDENTIFIED = _third_order(1.0143, 322.27, 0.673, 44.30)
