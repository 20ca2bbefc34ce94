"""The ATS compensator's compiled step against its Python reference, step for step.

:func:`controllers.baselines._ats_kernel.ats_step` runs the same filters, window, threshold and clipping
as ``AdaptiveTimeSeries(use_jit=False)`` (bit for bit), but sums the least-squares terms (column
norms and the 3x3 normal matrix over a 4094-sample window) left to right where NumPy/BLAS use
other orders: each update's coefficients differ by round-off of those sums, ~1e-16 of the
normal matrix, amplified by its condition number (~1e3-1e4 for a multi-sine).  Over four
windows (16384 steps, 769 updates) of a plant with gain 0.9 and a 40-sample delay the commands
agree to 1e-12 of their range (measured 2e-14) and the coefficients to 1e-11 of theirs
(measured: a0 3e-14, a1 1e-13, a2 9e-13, the worst-determined); the update count exactly.  The
identification itself is checked against the plant: ``a0 = 1/0.9``, ``a1/a0`` = the delay.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from controllers.baselines.ats import AdaptiveTimeSeries, ATSSettings
from plants.base import Kinematics

DT = 1.0 / 4096.0
LAG = 40  # samples of plant delay (9.77 ms)
GAIN = 0.9


def closed_loop(use_jit: bool, settings: ATSSettings) -> tuple[np.ndarray, np.ndarray, dict]:
    n = 4 * 4096
    t = np.arange(n) * DT
    r = sum(2e-3 * np.sin(2 * math.pi * f * t + 1.3 * i * i)
            for i, f in enumerate((1.0, 2.3, 3.7, 5.1)))  # fmt: skip
    v = np.gradient(r, DT)
    a = np.gradient(v, DT)
    comp = AdaptiveTimeSeries(DT, settings, use_jit=use_jit)
    assert comp.use_jit is use_jit
    commands, coefficients = np.zeros(n), np.zeros((n, 3))
    out = np.zeros(5)
    y = 0.0
    for k in range(n):
        commands[k] = comp.step(Kinematics(r[k], v[k], a[k]), y)
        comp.write_channels(out)
        coefficients[k] = out[:3]
        y = GAIN * commands[k - LAG] if k >= LAG else 0.0
        y += 1e-6 * math.sin(1e3 * k)  # a little measurement noise
    assert out.tolist() == list(comp.state().values())
    return commands, coefficients, comp.state()


@pytest.mark.parametrize("filtered", [True, False], ids=["low-pass", "no-filter"])
def test_compiled_step_matches_the_python_path(filtered: bool) -> None:
    settings = ATSSettings(initial=(1.0, 0.0, 0.0), cutoff_hz=20.0 if filtered else None)
    (u_jit, c_jit, s_jit), (u_py, c_py, s_py) = (closed_loop(j, settings) for j in (True, False))
    assert s_jit["updates"] == s_py["updates"] > 500
    assert np.abs(u_jit - u_py).max() <= 1e-12 * np.abs(u_py).max()
    worst = np.abs(c_jit - c_py).max(axis=0) / np.abs(c_py).max(axis=0)
    assert np.all(worst <= 1e-11), worst
    # and both identify the plant: a0 = 1/gain, a1/a0 = the delay (within 2 %)
    assert s_jit["a0"] == pytest.approx(1.0 / GAIN, rel=0.02)
    assert s_jit["delay"] == pytest.approx(LAG * DT, rel=0.02)


def test_reset_restarts_the_compiled_state() -> None:
    comp = AdaptiveTimeSeries(DT)
    target = [Kinematics(1e-3 * math.sin(0.01 * k), 0.0, 0.0) for k in range(5000)]
    first = [comp.step(x, 0.5 * x.displacement) for x in target]
    comp.reset()
    assert comp.state()["updates"] == 0.0
    assert [comp.step(x, 0.5 * x.displacement) for x in target] == first
