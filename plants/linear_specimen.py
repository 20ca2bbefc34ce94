"""A linear mass-spring-dashpot specimen: the physical specimen of the vRTHS benchmark.

.. math::

    F = m \\, a + c \\, v + k \\, u

with ``u, v, a`` the displacement [m], velocity [m/s] and acceleration [m/s^2] of the driven end.
The mass and dashpot act rigidly at the driven end (``rigid_inertance = m``, ``rigid_damping = c``),
so an actuator model integrates them implicitly with its own moving mass and feeds back only the
spring force ``k u`` (see :class:`plants.base.Specimen`).

The benchmark values (Silva et al. 2020, design.md section 5) are in
:class:`BenchmarkSpecimenParameters`: ``m = 29.13 kg``, ``k = 1.19e6 N/m`` (standard deviation
``5e4 N/m`` in the benchmark's Monte-Carlo study) and damping ratio ``zeta = 0.0097``, i.e.
``c = 2 zeta sqrt(k m)``.

References
----------
.. [1] Silva, C. E., Gomez, D., Maghareh, A., Dyke, S. J., Spencer, B. F. Jr. (2020).
   Benchmark control problem for real-time hybrid simulation. Mechanical Systems and Signal
   Processing 135, 106381.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from plants.base import Specimen
from rths.core.errors import check_nonnegative, check_positive
from rths.core.registry import SPECIMENS

__all__ = [
    "BenchmarkSpecimenParameters",
    "LinearParameters",
    "LinearSpecimen",
    "benchmark",
    "benchmark_specimen",
]


@dataclass(frozen=True)
class LinearParameters:
    """Options of the ``linear`` specimen kind.

    Parameters
    ----------
    mass
        Mass ``m`` [kg] moving with the driven end, >= 0.
    damping
        Viscous coefficient ``c`` [N s/m], >= 0.
    stiffness
        Stiffness ``k`` [N/m], >= 0.
    """

    mass: float = 0.0
    damping: float = 0.0
    stiffness: float = 0.0

    def __post_init__(self) -> None:
        check_nonnegative(self.mass, "specimen mass")
        check_nonnegative(self.damping, "specimen damping")
        check_nonnegative(self.stiffness, "specimen stiffness")


@SPECIMENS.register("linear", LinearParameters)
class LinearSpecimen(Specimen):
    """Mass ``m`` [kg], viscous damping ``c`` [N s/m] and stiffness ``k`` [N/m] at the driven end.

    The force is the exact algebraic sum ``F = m a + c v + k u`` of the drive state, so the model
    has no internal state and any ``dt`` is exact.

    Parameters
    ----------
    mass
        Mass ``m`` [kg] moving with the driven end, >= 0 (rigid inertance).
    damping
        Viscous coefficient ``c`` [N s/m], >= 0 (rigid damping).
    stiffness
        Stiffness ``k`` [N/m], >= 0; the only part an actuator feeds back explicitly.
    """

    def __init__(self, mass: float, damping: float, stiffness: float) -> None:
        super().__init__()
        self.mass: float = check_nonnegative(mass, "specimen mass")
        self.damping: float = check_nonnegative(damping, "specimen damping")
        self.stiffness: float = check_nonnegative(stiffness, "specimen stiffness")
        self._displacement = 0.0

    @classmethod
    def from_options(cls, options: LinearParameters, **_: object) -> LinearSpecimen:
        """The ``linear`` kind."""
        return cls(options.mass, options.damping, options.stiffness)

    @classmethod
    def from_damping_ratio(
        cls, mass: float, stiffness: float, damping_ratio: float
    ) -> LinearSpecimen:
        """Specimen with ``c = 2 zeta sqrt(k m)`` from the damping ratio ``zeta`` [-].

        Parameters
        ----------
        mass
            Mass [kg], > 0.
        stiffness
            Stiffness [N/m], > 0.
        damping_ratio
            Critical damping ratio ``zeta`` [-], >= 0.
        """
        m = check_positive(mass, "specimen mass")
        k = check_positive(stiffness, "specimen stiffness")
        zeta = check_nonnegative(damping_ratio, "specimen damping ratio")
        return cls(m, 2.0 * zeta * math.sqrt(k * m), k)

    @property
    def rigid_inertance(self) -> float:
        """The mass ``m`` [kg]: all of it acts rigidly at the driven end."""
        return self.mass

    @property
    def rigid_damping(self) -> float:
        """The dashpot ``c`` [N s/m]: all of it acts rigidly at the driven end."""
        return self.damping

    def _reset_impl(self) -> None:
        """Return to rest (the model has no state besides the last displacement for logging)."""
        self._displacement = 0.0

    def _step_impl(self, u: float, v: float, a: float, dt: float) -> float:
        self._displacement = u
        return self.mass * a + self.damping * v + self.stiffness * u

    def stepped_by_kernel(self, displacement: float, steps: int) -> None:
        """Record ``steps`` steps that a compiled actuator kernel took with this specimen's force
        law inline (:func:`plants.actuator.kernel.servo_hydraulic_step`), the last to
        ``displacement`` [m]: :attr:`steps` and :meth:`state` stay as if :meth:`step` had run.

        Parameters
        ----------
        displacement
            Drive displacement [m] of the last of those steps.
        steps
            Number of steps taken.
        """
        self._displacement = displacement
        self._steps += steps

    def state(self) -> dict[str, float]:
        """The spring force ``k u`` [N] (the part an actuator feeds back explicitly)."""
        return {"spring_force": self.stiffness * self._displacement}

    def __repr__(self) -> str:
        return (
            f"LinearSpecimen(mass={self.mass!r}, damping={self.damping!r}, "
            f"stiffness={self.stiffness!r})"
        )


@dataclass(frozen=True, slots=True)
class BenchmarkSpecimenParameters:
    """The vRTHS benchmark's physical specimen and its Monte-Carlo spread (Silva et al. 2020).

    Attributes
    ----------
    mass
        Specimen mass [kg] (benchmark: 29.13).
    stiffness
        Specimen stiffness [N/m] (benchmark: 1.19e6).
    damping_ratio
        Damping ratio [-] (benchmark: 0.0097); the dashpot is ``c = 2 zeta sqrt(k m)``.
    stiffness_std
        Standard deviation [N/m] of the stiffness in Monte-Carlo draws (benchmark: 5e4).
    """

    mass: float = 29.13
    stiffness: float = 1.19e6
    damping_ratio: float = 0.0097
    stiffness_std: float = 5.0e4

    def __post_init__(self) -> None:
        check_positive(self.mass, "specimen mass")
        check_positive(self.stiffness, "specimen stiffness")
        check_nonnegative(self.damping_ratio, "specimen damping ratio")
        check_nonnegative(self.stiffness_std, "specimen stiffness_std")

    @property
    def damping(self) -> float:
        """Viscous coefficient ``c = 2 zeta sqrt(k m)`` [N s/m]."""
        return 2.0 * self.damping_ratio * math.sqrt(self.stiffness * self.mass)

    def specimen(self) -> LinearSpecimen:
        """The :class:`LinearSpecimen` with these values."""
        return LinearSpecimen(self.mass, self.damping, self.stiffness)

    def sample(self, rng: np.random.Generator) -> BenchmarkSpecimenParameters:
        """One Monte-Carlo draw: the stiffness ~ Normal(stiffness, stiffness_std).

        The damping ratio is kept, so the dashpot follows the drawn stiffness.  One normal
        variate is consumed from ``rng`` per call, so a seeded generator reproduces the draws.
        """
        return replace(self, stiffness=float(rng.normal(self.stiffness, self.stiffness_std)))


def benchmark_specimen(rng: np.random.Generator | None = None) -> LinearSpecimen:
    """The vRTHS benchmark specimen, nominal or (with ``rng``) one Monte-Carlo draw of it.

    Parameters
    ----------
    rng
        Random generator for a perturbed stiffness (see
        :meth:`BenchmarkSpecimenParameters.sample`); ``None`` gives the nominal specimen.
    """
    nominal = BenchmarkSpecimenParameters()
    return (nominal if rng is None else nominal.sample(rng)).specimen()


@SPECIMENS.register("benchmark", BenchmarkSpecimenParameters)
def benchmark(
    options: BenchmarkSpecimenParameters, *, rng: np.random.Generator | None = None, **_: object
) -> LinearSpecimen:
    """The vRTHS benchmark's linear specimen (Silva et al. 2020), perturbed by ``rng`` in a
    Monte-Carlo draw (:meth:`BenchmarkSpecimenParameters.sample`).

    Parameters
    ----------
    options : BenchmarkSpecimenParameters
        Nominal mass [kg], stiffness [N/m], damping ratio [-] and stiffness spread [N/m] (the
        ``[specimen]`` table of a ``kind = "benchmark"`` scenario).
    rng : numpy.random.Generator or None, default None
        Generator for one Monte-Carlo draw of the stiffness; None gives the nominal specimen.
        Any other registry context (see :mod:`rths.core.registry`) is accepted and ignored.
    """
    return (options if rng is None else options.sample(rng)).specimen()
