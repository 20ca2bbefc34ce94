"""The base classes own the shared work (scipy's OdeSolver.step template): step counting, time,
finiteness checks, reset; the actuator base owns the delay line, the rate limiter and the
specimen."""

from __future__ import annotations

import math

import pytest

from controllers.base import Compensator
from plants.actuator import TransferFunctionActuator
from plants.base import Specimen, Substructure
from plants.linear_specimen import LinearSpecimen
from rths.core.errors import NumericalError, ParameterError
from rths.core.kinematics import Kinematics

DT = 1e-3


class Free(Substructure):
    """A unit mass on a unit spring stepped by the exact exponential (an oracle)."""

    def __init__(self, blow_up_at: int = -1) -> None:
        super().__init__(DT)
        self.blow_up_at = blow_up_at
        self.resets = 0
        self.reset()

    def _reset_impl(self) -> None:
        self.x, self.v = 1.0, 0.0
        self.resets += 1

    @property
    def interface(self) -> Kinematics:
        return Kinematics(self.x, self.v, -self.x)

    def _step_impl(self, restoring_force: float) -> Kinematics:
        c, s = math.cos(DT), math.sin(DT)
        self.x, self.v = c * self.x + s * self.v, -s * self.x + c * self.v
        if self.steps == self.blow_up_at:
            self.x = math.nan
        return self.interface

    def predict(self, restoring_force: float) -> Kinematics:
        return self.interface


def test_substructure_base_counts_owns_time_and_checks():
    sub = Free()
    for _ in range(1000):
        kin = sub.step(0.0)
    assert sub.steps == 1000 and sub.time == pytest.approx(1.0, abs=1e-15)
    assert kin.displacement == pytest.approx(math.cos(1.0), abs=1e-12)  # exact rotation
    sub.reset()
    assert sub.steps == 0 and sub.time == 0.0 and sub.resets == 2 and sub.x == 1.0
    with pytest.raises(ParameterError, match="restoring force must be finite; got nan"):
        sub.step(math.nan)
    with pytest.raises(NumericalError, match=r"Free produced a non-finite result at t = 0\.003"):
        bad = Free(blow_up_at=2)
        for _ in range(3):
            bad.step(0.0)


class Bad(Specimen):
    def _reset_impl(self) -> None:
        pass

    def _step_impl(self, u: float, v: float, a: float, dt: float) -> float:
        return math.inf if u > 1.0 else u


def test_specimen_base_checks_drive_and_force():
    spec = Bad()
    assert spec.step(0.5, 0.0, 0.0, DT) == 0.5 and spec.steps == 1
    with pytest.raises(ParameterError, match=r"Bad drive state must be finite; got u=nan"):
        spec.step(math.nan, 0.0, 0.0, DT)
    with pytest.raises(ParameterError, match=r"Bad drive state must be finite; .*a=inf"):
        spec.step(0.0, 0.0, math.inf, DT)
    with pytest.raises(ParameterError, match="time step dt must be positive; got 0.0"):
        spec.step(0.0, 0.0, 0.0, 0.0)
    with pytest.raises(NumericalError, match="Bad produced a non-finite force inf"):
        spec.step(2.0, 0.0, 0.0, DT)
    spec.reset()
    assert spec.steps == 0


def test_actuator_base_owns_delay_line_rate_limiter_and_specimen():
    """Static unit gain with a 3-sample delay: the specimen sees the command 3 steps late, the
    rate limiter clips the velocity, reset empties the delay line and resets the specimen."""
    spec = LinearSpecimen(0.0, 0.0, 1000.0)
    act = TransferFunctionActuator([1.0], [1.0], spec, DT, delay=3 * DT, velocity_limit=5.0)
    commands = [0.0, 1e-3, 2e-3, 3e-3, 4e-3, 4e-3, 4e-3, 4e-3]
    seen = [act.step(c)[0].displacement for c in commands]
    assert seen == pytest.approx([0.0, 0.0, 0.0, 0.0, 1e-3, 2e-3, 3e-3, 4e-3], abs=1e-15)
    assert act.state()["command_delayed"] == 4e-3 and act.steps == len(commands)
    assert spec.steps == len(commands) and act.state()["rate_limiting"] == 0.0
    act.reset()
    assert act.steps == spec.steps == 0 and act.step(1.0)[0].displacement == 0.0  # delay refilled
    for _ in range(3):
        kin, force = act.step(1.0)
    assert kin.displacement == pytest.approx(5.0 * DT)  # 1 m step limited to 5 m/s
    assert act.state()["rate_limiting"] == 1.0 and force == pytest.approx(1000.0 * 5.0 * DT)
    with pytest.raises(ParameterError, match="actuator command must be finite; got nan"):
        act.step(math.nan)
    with pytest.raises(ParameterError, match="specimen must be a plants.base.Specimen"):
        TransferFunctionActuator([1.0], [1.0], object(), DT)  # type: ignore[arg-type]


class Echo(Compensator):
    def _reset_impl(self) -> None:
        pass

    def _step_impl(self, target: Kinematics, measured: float) -> float:
        return target.displacement / measured if measured else target.displacement


def test_compensator_base_checks_and_counts():
    comp = Echo(DT)
    assert comp.step(Kinematics(2.0, 0.0, 0.0), 0.0) == 2.0 and comp.steps == 1
    with pytest.raises(ParameterError, match="target and measured displacement must be finite"):
        comp.step(Kinematics(math.nan, 0.0, 0.0), 0.0)
    with pytest.raises(ParameterError, match="target and measured displacement must be finite"):
        comp.step(Kinematics(0.0, 0.0, 0.0), math.inf)
    with pytest.raises(NumericalError, match="Echo produced a non-finite command inf"):
        comp.step(Kinematics(1.0, 0.0, 0.0), 1e-320)
    comp.reset()
    assert comp.steps == 0
