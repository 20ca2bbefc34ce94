"""J1-J9 as F4_evaluation.m computes them, on hand-made records with known answers."""

from __future__ import annotations

import numpy as np
import pytest

from rths.core.errors import DataError, ParameterError
from rths.metrics.vrths import (
    ACTUATOR_CAPACITY,
    CRITERIA,
    evaluate,
    j1_correlations,
    matlab_round,
)

DT = 1.0 / 4096.0
N = 8192
T = np.arange(N) * DT


def _target() -> np.ndarray:
    """A zero-mean-ish multi-sine [m] (1.3, 2.9, 4.4 Hz)."""
    return 1e-3 * (np.sin(2 * np.pi * 1.3 * T) + 0.5 * np.sin(2 * np.pi * 2.9 * T + 1.0)
                   + 0.2 * np.sin(2 * np.pi * 4.4 * T + 2.0))  # fmt: skip


def _floors(first: np.ndarray) -> np.ndarray:
    return np.column_stack([first, 2 * first + 1e-4 * np.cos(7 * T), 3 * first])


def test_matlab_round_is_half_away_from_zero() -> None:
    assert [matlab_round(v) for v in (0.5, 1.5, 2.5, -0.5, -2.5, 2.4999)] == [1, 2, 3, -1, -3, 2]


@pytest.mark.parametrize("lag", [0, 1, 7, 19, 49])
def test_j1_finds_an_integer_delay_and_rounds_it_as_f4(lag: int) -> None:
    y = _target()
    x_m = np.concatenate([np.zeros(lag), y[: N - lag]])  # x_m[k] = y[k - lag]
    s = evaluate(x_m, _floors(y), _floors(y), DT)
    assert s.J1 == matlab_round(10000 * lag * DT) / 10  # e.g. 19 samples -> 4.6 ms
    r = j1_correlations(x_m, y)
    assert int(np.nanargmax(r)) == lag and r[lag] == pytest.approx(1.0, abs=1e-12)


def test_j1_searches_only_lags_0_to_49() -> None:
    y = _target()
    lead = np.concatenate([y[5:], np.zeros(5)])  # the measurement leads: F4 cannot see it
    assert evaluate(lead, _floors(y), _floors(y), DT).J1 == 0.0
    late = np.concatenate([np.zeros(80), y[: N - 80]])  # beyond the search: F4 saturates
    assert evaluate(late, _floors(y), _floors(y), DT).J1 == 12.0  # 49 samples = 11.96 ms


def test_j1_correlation_against_numpy_corrcoef() -> None:
    rng = np.random.default_rng(3)
    y = _target()
    x_m = np.roll(y, 4) + 1e-5 * rng.standard_normal(N)
    r = j1_correlations(x_m, y)
    for j in (0, 4, 31, 49):
        assert r[j] == pytest.approx(np.corrcoef(x_m[j:], y[: N - j])[0, 1], abs=1e-13)


def test_j2_uses_std_not_rms() -> None:
    y = _target()
    offset = y + 2e-4  # a constant error: std of it is 0, its peak is 2e-4
    s = evaluate(offset, _floors(y), _floors(y), DT, rounded=False)
    assert s.J2 == pytest.approx(0.0, abs=1e-9)
    assert s.J3 == pytest.approx(100 * 2e-4 / np.max(np.abs(y)))


def test_amplitude_error_gives_known_j2_to_j5() -> None:
    y = _target()
    s = evaluate(1.03 * y, _floors(y), _floors(y), DT)
    assert (s.J2, s.J3, s.J4, s.J5) == (3.0, 3.0, 3.0, 3.0)
    assert (s.J6, s.J7, s.J8, s.J9) == (0.0, 0.0, 0.0, 0.0)


def test_j4_to_j9_in_f4_order() -> None:
    y = _target()
    ref = _floors(y)
    num = ref.copy()
    num[:, 1] = 1.01 * ref[:, 1] + 1e-4 * np.sign(T - 1.0)  # floor 2: NRMS and peak differ
    num[:, 2] = 1.07 * ref[:, 2]  # floor 3: 7 % in both
    s = evaluate(y, num, ref, DT, rounded=False)
    e2 = num[:, 1] - ref[:, 1]
    assert s.J6 == pytest.approx(100 * np.std(e2, ddof=1) / np.std(ref[:, 1], ddof=1))
    assert s.J8 == pytest.approx(100 * np.max(np.abs(e2)) / np.max(np.abs(ref[:, 1])))
    assert s.J7 == pytest.approx(7.0) and s.J9 == pytest.approx(7.0)
    assert s.J6 != pytest.approx(s.J8, rel=0.05)  # the two floor-2 indices are distinct
    assert s.J4 == 0.0 and s.J5 == 0.0  # x_m equals the reference's first floor


def test_rounding_to_f4_precision() -> None:
    y = _target()
    s = evaluate(1.0123456 * y, _floors(y), _floors(y), DT)
    assert s.J2 == 1.23
    assert tuple(s.to_dict()) == CRITERIA and len(s.values()) == 9
    assert ACTUATOR_CAPACITY == 8900.0


def test_bad_records_are_data_errors() -> None:
    y = _target()
    with pytest.raises(DataError, match="at least 52 samples"):
        evaluate(y[:10], _floors(y)[:10], _floors(y)[:10], DT)
    with pytest.raises(DataError, match=r"numerical must have shape \(8192, 3\)"):
        evaluate(y, y, _floors(y), DT)
    with pytest.raises(DataError, match="identically constant or zero"):
        evaluate(y, _floors(y), np.zeros((N, 3)), DT)
    with pytest.raises(DataError, match="constant over every lag"):
        evaluate(np.ones(N), _floors(y), _floors(y), DT)
    with pytest.raises(ParameterError, match="dt must be positive; got 0"):
        evaluate(y, _floors(y), _floors(y), 0)
