"""The paired held-out test that names an effect hidden within the floor's margin.

Oracles: :func:`rths.diagnose.search.selection.nested_z` on residuals of known structure --
identical residuals carry no evidence (z = 0); halving a residual well above the modelling
tolerance is overwhelming evidence; two independent residuals of equal variance (the null
hypothesis) exceed ``NESTED_Z`` = 3 with probability ~1e-3 per draw (one-sided normal tail of a
mean over ~20 blocks), so at most a few of 200 draws may.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from rths.diagnose.channels.channel import actuator_channel
from rths.diagnose.data.synthetic import LabCase, band_limited_command, lab_record
from rths.diagnose.effects import baseline_for
from rths.diagnose.search.identify import fit_model
from rths.diagnose.search.selection import NESTED_Z, nested_z

DT = 1.0 / 1024.0
M, C = 1589.0, 2 * 0.15 * 1589.0 * 2 * math.pi * 20.0


def _channel_and_fit():
    case = LabCase("none", 0.0, M, C)
    rng = np.random.default_rng(3)
    records = [
        lab_record(
            case,
            band_limited_command(rng, 6.0, DT, (0.3, 6.0), 3e-3),
            DT,
            seed=k,
            name=f"run_{k}.csv",
        )
        for k in range(2)
    ]
    channel = actuator_channel(records, case.nominal(M, C, 1.0), 40.0, None)
    return channel, fit_model(baseline_for(channel.name), channel)


def _with_residuals(channel, fit, residuals):
    prediction = [s.observed - r for s, r in zip(channel.segments, residuals, strict=True)]
    return dataclasses.replace(fit, prediction=prediction)


def test_nested_z_on_residuals_of_known_structure():
    channel, fit = _channel_and_fit()
    rms = [float(np.sqrt(np.mean(s.observed**2))) for s in channel.segments]
    rng = np.random.default_rng(11)

    def noise(level: float):
        return [
            level * r * rng.standard_normal(s.observed.size)
            for r, s in zip(rms, channel.segments, strict=True)
        ]

    simple = _with_residuals(channel, fit, noise(0.05))  # 5 %: far above the 0.2 % tolerance
    assert nested_z(channel, simple, simple) == 0.0
    halved = _with_residuals(channel, fit, [0.5 * r for r in simple.residuals(channel)])
    assert nested_z(channel, simple, halved) > 10 * NESTED_Z
    alarms = 0
    for _ in range(200):
        a = _with_residuals(channel, fit, noise(0.05))
        b = _with_residuals(channel, fit, noise(0.05))
        alarms += nested_z(channel, a, b) >= NESTED_Z
    assert alarms <= 4  # expected 0.3 of 200; 4 has probability < 1e-3 under the null
    tiny = _with_residuals(channel, fit, noise(0.001))  # below the modelling tolerance
    assert nested_z(channel, tiny, _with_residuals(channel, fit, noise(0.0))) == 0.0
