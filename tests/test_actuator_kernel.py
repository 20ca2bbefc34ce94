"""The servo-hydraulic actuator's compiled step against its Python reference, step for step.

:func:`plants.actuator.kernel.servo_hydraulic_step` and
:meth:`plants.actuator.ServoHydraulicActuator._step_impl` (``use_jit=False``) do the same
arithmetic except the 5-term dot products of the stacked update: NumPy hands them to BLAS
(``dgemv``, vectorised partial sums), the kernel sums left to right.  That is a few ulp per
sub-step; the loop is well damped (slowest pole -8 rad/s, ``|z| < 1``) so the differences stay
at round-off instead of growing: over 4000 steps (16000 sub-steps) every logged signal agrees
to 1e-12 of its range (measured: < 2e-13), the limiter's flags and the step counts exactly.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import NDArray

from plants.actuator import HEAVY_INERTIAL_LOAD, ServoHydraulicActuator
from plants.imd.models import IMDParameters, InternalStiffnessIMD
from plants.linear_specimen import LinearSpecimen, benchmark_specimen

FloatArray = NDArray[np.float64]

DT = 1.0 / 4096.0
N = 4000


def chirp_with_noise() -> FloatArray:
    """A 4 mm chirp 1-80 Hz plus 0.1 mm of white noise (fast enough to saturate a limiter)."""
    t = np.arange(N) * DT
    noise = 1e-4 * np.random.default_rng(0).standard_normal(N)
    return 0.004 * np.sin(2.0 * math.pi * (1.0 + 10.0 * t) * t) + noise


def history(act: ServoHydraulicActuator, command: FloatArray) -> FloatArray:
    """Per step: kinematics, force, every ``state()`` value, the specimen's step count."""
    rows = []
    for u in command:
        kin, force = act.step(float(u))
        rows.append([*kin, force, *act.state().values(), act.specimen.steps])
    return np.array(rows)


@pytest.mark.parametrize(
    "options",
    [{}, {"velocity_limit": 0.05}, {"delay": 2.5 * DT}],
    ids=["plain", "rate-limited", "delayed"],
)
def test_compiled_step_matches_the_python_path(options: dict[str, float]) -> None:
    command = chirp_with_noise()
    runs = []
    for use_jit in (True, False):
        act = ServoHydraulicActuator(benchmark_specimen(), DT, use_jit=use_jit, **options)
        assert act.use_jit is use_jit
        runs.append(history(act, command))
    compiled, reference = runs
    names = ["x", "v", "a", "force", *act.state(), "specimen steps"]
    exact = {"rate_limiting", "command_delayed", "specimen steps"}
    if "velocity_limit" in options:  # the limiter is exercised, both ways
        flags = reference[:, names.index("rate_limiting")]
        assert np.count_nonzero(flags > 0) > 100 and np.count_nonzero(flags < 0) > 100
    for j, name in enumerate(names):
        if name in exact:
            np.testing.assert_array_equal(compiled[:, j], reference[:, j], err_msg=name)
        else:
            scale = np.abs(reference[:, j]).max()
            np.testing.assert_allclose(
                compiled[:, j], reference[:, j], rtol=0, atol=1e-12 * scale, err_msg=name
            )
    assert compiled[-1, -1] == N * act.substeps


def test_reset_restarts_the_compiled_state() -> None:
    act = ServoHydraulicActuator(benchmark_specimen(), DT, velocity_limit=0.05)
    command = chirp_with_noise()[:500]
    first = history(act, command)
    act.reset()
    assert act.limiter is not None and act.limiter.output == 0.0 and act.specimen.steps == 0
    np.testing.assert_array_equal(history(act, command), first)


def test_other_specimens_take_the_python_path() -> None:
    imd = InternalStiffnessIMD(IMDParameters.preset("type_ii"))
    assert not ServoHydraulicActuator(imd, DT, HEAVY_INERTIAL_LOAD).use_jit

    class Stiffer(LinearSpecimen):  # a subclass may change the force law: not compiled
        pass

    assert not ServoHydraulicActuator(Stiffer(29.13, 114.0, 1.19e6), DT).use_jit
