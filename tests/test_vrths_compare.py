"""The comparison runner and its tables on a short chirp (no benchmark package needed)."""

from __future__ import annotations

import json
import pickle

import numpy as np
import pytest

from rths.campaign import Cluster
from rths.core.errors import ParameterError
from rths.experiments.vrths.compare import run_comparison, run_one, trial_specs
from rths.experiments.vrths.tables import nominal_table, plot_j2, render, worst_j2_table

CHIRP = {"f_start": 0.5, "f_end": 6.0, "duration": 1.0}
THREADS = Cluster(workers=1, processes=False)  # quick to start; processes: test_compare_campaign


@pytest.fixture(scope="module")
def comparison():
    return run_comparison(["pi_lead", "ff_lqg"], [1, 4], ground="chirp", perturbed=1,
                          chirp=CHIRP, cluster=THREADS)  # fmt: skip


def test_every_trial_is_run_and_scored(comparison) -> None:
    assert len(comparison.results) == 2 * 2 * 2 and comparison.kinds == ["pi_lead", "ff_lqg"]
    for r in comparison.results:
        assert r.stopped is None and set(r.scores) == {f"J{i}" for i in range(1, 10)}
        assert 0 < r.peak_force < 8900 and r.noise_floor > 0
    # the same draws and noise for both kinds: pi_lead lags ~4.6 ms, ff_lqg does not
    j1 = {k: comparison.criterion(k, 1, "J1", True)[0] for k in comparison.kinds}
    assert j1["pi_lead"] > 4.0 and j1["ff_lqg"] <= 0.1
    json.dumps(comparison.to_dict())


def test_tables_have_the_benchmark_layout(comparison, tmp_path) -> None:
    table = nominal_table(comparison, "pi_lead").splitlines()
    assert table[1].split() == ["Case", "1", "Case", "4"]
    assert [line.split()[0] for line in table[2:11]] == [f"J{i}" for i in range(1, 10)]
    assert "ff_lqg" in worst_j2_table(comparison) and "wall time" in render(comparison)
    assert plot_j2(comparison, tmp_path / "j2.png").stat().st_size > 1000


def test_worst_is_the_largest_perturbed_value(comparison) -> None:
    values = comparison.criterion("ff_lqg", 4, "J2", False)
    assert values.size == 1 and np.isfinite(values).all()


def test_bad_choices_name_the_value() -> None:
    with pytest.raises(ParameterError, match="unknown compensator"):
        run_comparison(["pid"], [1], ground="chirp", perturbed=0)
    with pytest.raises(ParameterError, match="got 7"):
        run_comparison(["none"], [7], ground="chirp", perturbed=0)


def test_run_one_mapped_over_the_specs_is_the_comparison(comparison) -> None:
    # what a campaign (dask: client.map(run_one, specs)) does: the same trials, the same scores
    specs = trial_specs(["pi_lead", "ff_lqg"], [1, 4], ground="chirp", perturbed=1, chirp=CHIRP)
    assert len(specs) == len(comparison.results)
    pickled = [pickle.loads(pickle.dumps(s)) for s in specs[-2:]]
    mapped = list(map(run_one, pickled))
    for got, want in zip(mapped, comparison.results[-2:], strict=True):
        assert (got.kind, got.case, got.plant) == (want.kind, want.case, want.plant)
        assert got.scores == want.scores and got.peak_force == want.peak_force
