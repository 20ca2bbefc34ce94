"""The vRTHS benchmark's plant: nominal values and the random draws of its perturbed runs.

``F1_input_file.m`` draws, for every perturbed trial and in this order, the specimen stiffness
``KE = k_e + 5e4 randn``, then ``beta1 = 425 + 3.3 randn``, ``beta2 = 9.9976e4 + 3.3e3 randn`` and
``a3 = 3.3 + 1.3 randn``; the specimen's dashpot follows the drawn stiffness
(``c_e = 2 zeta_e sqrt(KE m_e)``), and the numerical substructure is rebuilt with the drawn
``KE`` (:mod:`plants.frame.substructure`).  The nominal trial draws nothing.  MATLAB's random
stream cannot be reproduced, so draw ``i`` here comes from ``numpy.random.default_rng([seed, i])``
with the same distributions and order.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from plants.actuator import BENCHMARK, BenchmarkParameters
from plants.linear_specimen import BenchmarkSpecimenParameters, LinearSpecimen
from rths.core.errors import ParameterError, check_finite, check_positive

__all__ = ["NOMINAL", "PlantDraw", "draw_plants"]

_SPECIMEN = BenchmarkSpecimenParameters()


@dataclass(frozen=True, slots=True)
class PlantDraw:
    """One trial's uncertain parameters (defaults: the nominal plant).

    Attributes
    ----------
    specimen_stiffness
        ``KE`` [N/m] (nominal 1.19e6, std 5e4).
    beta1
        Servo-valve ``beta1`` [1/s] (425, std 3.3).
    beta2
        Servo-valve ``beta2`` [1/s^2] (9.9976e4, std 3.3e3).
    a3
        Hydraulic pole ``a3`` [1/s] (3.3, std 1.3; may be drawn negative).
    """

    specimen_stiffness: float = _SPECIMEN.stiffness
    beta1: float = BENCHMARK.beta1
    beta2: float = BENCHMARK.beta2
    a3: float = BENCHMARK.a3

    def __post_init__(self) -> None:
        check_positive(self.specimen_stiffness, "specimen stiffness KE")
        check_positive(self.beta1, "servo-valve beta1")
        check_positive(self.beta2, "servo-valve beta2")
        check_finite(self.a3, "hydraulic pole a3")

    def specimen(self) -> LinearSpecimen:
        """The first-floor specimen ``(m_e, c_e, KE)`` (29.13 kg, zeta_e = 0.0097)."""
        return replace(_SPECIMEN, stiffness=self.specimen_stiffness).specimen()

    def actuator(self) -> BenchmarkParameters:
        """The benchmark actuator's parameters with this draw's ``beta1``, ``beta2``, ``a3``."""
        return replace(BENCHMARK, beta1=self.beta1, beta2=self.beta2, a3=self.a3)


#: The nominal plant (F1's first trial, ``nom = 0``).
NOMINAL = PlantDraw()


def draw_plants(count: int, seed: int = 123) -> list[PlantDraw]:
    """The nominal plant followed by ``count`` perturbed draws (F1's distributions and order).

    Parameters
    ----------
    count
        Number of perturbed plants, >= 0 (the benchmark's studies use 20).
    seed
        Draw ``i`` (1-based) uses ``numpy.random.default_rng([seed, i])``; 123 echoes F1's
        ``rng(123)``.

    Returns
    -------
    list of PlantDraw
        ``count + 1`` plants, the nominal first.
    """
    if isinstance(count, bool) or not isinstance(count, int) or count < 0:
        raise ParameterError(f"number of perturbed plants must be an integer >= 0; got {count!r}")
    plants = [NOMINAL]
    for i in range(1, count + 1):
        z = np.random.default_rng([seed, i]).standard_normal(4)
        plants.append(
            PlantDraw(
                specimen_stiffness=_SPECIMEN.stiffness + _SPECIMEN.stiffness_std * float(z[0]),
                beta1=BENCHMARK.beta1 + BENCHMARK.beta1_std * float(z[1]),
                beta2=BENCHMARK.beta2 + BENCHMARK.beta2_std * float(z[2]),
                a3=BENCHMARK.a3 + BENCHMARK.a3_std * float(z[3]),
            )
        )
    return plants
