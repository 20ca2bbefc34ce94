"""The benchmark frame's compiled step against its NumPy reference, step for step.

:func:`plants.frame.kernel.frame_step` and ``FrameSubstructure._advance`` (``use_jit=False``)
compute the same ``G w`` product; BLAS (``dgemv``) and the kernel sum its 9 terms in different
orders, a few ulp per step.  The discrete frame is exactly stable (``|exp(lambda h)| < 1``) and the
coupled force below is a stiff, damped specimen's, so the differences stay at round-off: over
4096 steps (one second of a 40 Hz chirp) with the specimen's force fed back every state agrees to
1e-12 of its range (measured: ~1e-14).
"""

from __future__ import annotations

import numpy as np
import pytest

from plants.frame import CASES, ChirpMotion, FrameSubstructure
from plants.linear_specimen import LinearSpecimen

DT = 1.0 / 4096.0
SPECIMEN = LinearSpecimen.from_damping_ratio(29.13, 1.19e6, 0.0097)


def coupled(sub: FrameSubstructure) -> np.ndarray:
    """Interface kinematics, logged channels, predictions; a perfect actuator's force fed back."""
    rows = []
    force = 0.0
    out = np.zeros(4)
    for _ in range(sub.n_steps):
        ahead = sub.predict(force)
        kin = sub.step(force)
        assert kin == ahead
        sub.write_channels(out)
        rows.append([*kin, *out, *sub.outputs().values(), *sub.floor_displacements])
        force = (
            SPECIMEN.mass * kin.acceleration
            + SPECIMEN.damping * kin.velocity
            + SPECIMEN.stiffness * kin.displacement
        )
    return np.array(rows)


@pytest.mark.parametrize("force_delay", [0, 1])
@pytest.mark.parametrize("case", [1, 4])
def test_compiled_step_matches_the_numpy_path(case: int, force_delay: int) -> None:
    ground = ChirpMotion(duration=1.0)
    compiled, reference = (
        coupled(
            FrameSubstructure(
                CASES[case], SPECIMEN, ground, DT, force_delay=force_delay, use_jit=use_jit
            )
        )  # fmt: skip
        for use_jit in (True, False)
    )
    assert compiled.shape == (4096, 14)
    scale = np.abs(reference).max(axis=0)
    worst = (np.abs(compiled - reference) / scale).max(axis=0)
    assert np.all(worst <= 1e-12), worst
    np.testing.assert_array_equal(compiled[:, 6], reference[:, 6])  # the ground, sampled


def test_reset_and_the_held_ground_after_the_record() -> None:
    ground = ChirpMotion(duration=0.05)
    runs = []
    for use_jit in (True, False):
        sub = FrameSubstructure(CASES[2], SPECIMEN, ground, DT, use_jit=use_jit)
        for _ in range(sub.n_steps + 5):  # past the record's end: its last value is held
            sub.step(100.0)
        runs.append([*sub.interface, *sub.outputs().values()])
        sub.reset()
        assert sub.time == 0.0 and not np.any(sub.floor_displacements)
        out = np.zeros(4)
        sub.write_channels(out)
        assert out.tolist() == list(sub.outputs().values())
    assert runs[0][-1] == runs[1][-1] == ground.sampled(DT, ground.steps(DT) + 2, 0.4)[-1]
    np.testing.assert_allclose(runs[0], runs[1], rtol=1e-10)  # round-off of small values
