"""The specimen side's command guard: stroke, rate clamp, trip on sustained excess, latched
ramp-down at the ramp velocity (never a jump), and the figures it keeps."""

from __future__ import annotations

import math

import pytest

from rths.core.errors import ParameterError
from rths.runtime.guard import CommandGuard, GuardLimits

DT = 1 / 2048


def test_commands_within_the_limits_pass_unchanged():
    g = CommandGuard(GuardLimits(stroke=0.05, max_velocity=0.5), DT)
    u = [1e-3 * math.sin(2 * math.pi * 2 * k * DT) for k in range(2000)]
    assert [g.apply(x) for x in u] == u
    assert g.limited == 0 and g.tripped is None
    assert g.largest_step == pytest.approx(max(abs(b - a) for a, b in zip([0.0, *u], u)))


def test_a_jump_is_slewed_at_max_velocity_and_counted():
    g = CommandGuard(GuardLimits(stroke=0.05, max_velocity=0.5, trip_after=1.0), DT)
    out = [g.apply(0.02) for _ in range(100)]
    step = 0.5 * DT
    assert out[0] == pytest.approx(step) and out[1] == pytest.approx(2 * step)
    assert max(b - a for a, b in zip([0.0, *out], out)) <= step * (1 + 1e-12)
    assert out[-1] == 0.02  # reached: 0.02 m at 0.5 m/s is 82 steps
    assert g.limited == math.ceil(0.02 / step) - 1 and g.tripped is None


def test_sustained_excess_rate_trips_and_ramps_down():
    lim = GuardLimits(stroke=0.05, max_velocity=0.5, ramp_velocity=0.05, trip_after=0.01)
    g = CommandGuard(lim, DT)
    out = [g.apply(0.04 * (-1) ** k) for k in range(200)]  # a 40 mm chatter
    assert g.tripped is not None and "command rate above 0.5 m/s" in g.tripped
    assert g.largest_step <= 0.5 * DT * (1 + 1e-12)
    assert out[-1] == 0.0 and g.ignored > 0


def test_a_command_outside_the_stroke_trips_and_the_ramp_is_controlled():
    lim = GuardLimits(stroke=0.05, max_velocity=0.5, ramp_velocity=0.05)
    g = CommandGuard(lim, DT)
    for k in range(200):
        g.apply(0.01 * min(1.0, k / 150))
    before = g.last
    assert g.apply(0.2) == pytest.approx(before - 0.05 * DT)  # tripped: ramp, not the 0.2 m
    assert "outside the stroke" in g.tripped
    n = g.ramp_steps()
    assert n == math.ceil(g.last / (0.05 * DT))
    start = g.last
    ramp = [g.apply(0.03) for _ in range(n + 5)]  # commands after the trip are ignored
    assert ramp[-1] == 0.0 and g.at_rest and ramp[n - 1] == 0.0
    assert max(abs(b - a) for a, b in zip([start, *ramp], ramp)) <= 0.05 * DT * (1 + 1e-12)
    assert g.summary()["guard_ignored"] == n + 5


def test_nan_trips():
    g = CommandGuard(GuardLimits(), DT)
    g.apply(math.nan)
    assert g.tripped is not None


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"stroke": 0.0}, "stroke must be positive"),
        ({"max_velocity": -1.0}, "max_velocity must be positive"),
        ({"ramp_velocity": math.nan}, "ramp_velocity must be positive"),
        ({"max_velocity": 0.1, "ramp_velocity": 0.2}, "must not exceed max_velocity"),
    ],
)
def test_limits_are_validated(kw, match):
    with pytest.raises(ParameterError, match=match):
        GuardLimits(**kw)
