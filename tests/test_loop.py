"""The RTHS loop: partitioned = monolithic when the specimen is the nominal device; interlocks;
stop requests; input checks."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest
from _scenarios import PERFECT_ACTUATOR, QUIET, SAME_AS_MODEL, short

from controllers.factory import make_compensator
from rths.config import build
from rths.config.scenario import parse_scenario
from rths.core.errors import ParameterError, RTHSError
from rths.core.scaling import Scaling
from rths.runtime.loop import InProcessLink, LinkSample, Loop
from rths.session.mock import numerical_run


def _run(scn, link=None, n=None, **kw):
    n = n or scn.run.steps
    rec: list[dict] = []
    loop = Loop(
        build.substructure(scn),
        build.compensator(scn),
        link or InProcessLink(build.lab(scn)),
        scn.scaling,
        n,
        sink=lambda block: rec.extend(block.records()),
        force_filter=build.correction_filter(scn),
        command_limit=scn.loop.stroke,
        **kw,
    )
    return loop.run(), rec


def test_partitioned_rths_equals_the_monolithic_mock_when_the_specimen_is_the_nominal_device():
    """Perfect actuator, noise-free converters and a specimen identical to the [model] device:
    the force correction is the specimen's force minus the device's, which differ only through
    the one-step lag (the specimen moves to the target of t_{k+1}, the device is integrated at
    t_{k+1} too) and 30-bit quantisation.  The cable response then equals the fully numerical
    mock run.  Tolerance 1e-4 of the peak: 30-bit force LSB (2e-8 of full scale) and the
    correction's O(dt) lag acting on a ~1e-6 relative correction."""
    scn = parse_scenario(short(2.0, **SAME_AS_MODEL, **PERFECT_ACTUATOR, **QUIET))
    result, rec = _run(scn)
    assert result.stopped is None and result.steps == scn.run.steps
    mock = numerical_run(scn, "model")
    rths_mid = np.array([r["sub_midspan_displacement"] for r in rec])
    peak = np.max(np.abs(mock["midspan_displacement"]))
    assert np.max(np.abs(rths_mid - mock["midspan_displacement"])) < 1e-4 * peak
    # the measured force is the device's force: the correction is tiny
    corr = np.array([r["correction"] for r in rec])
    force = scn.scaling.force * np.array([r["force"] for r in rec])
    assert np.max(np.abs(corr)) < 1e-3 * np.max(np.abs(force))


def test_interlock_stops_the_run_when_the_command_leaves_the_stroke():
    scn = parse_scenario(short(1.0, **{r"^stroke = 0.05": "stroke = 1e-5"}))
    result, rec = _run(scn)
    assert result.stopped is not None and "outside the stroke" in result.stopped
    assert result.steps == len(rec) < scn.run.steps


class _NaNLink:
    def __init__(self, after: int) -> None:
        self.after = after

    def exchange(self, seq: int, t_ns: int, command: float) -> LinkSample:
        return LinkSample(math.nan if seq >= self.after else 0.0, 0.0, 0, seq)


def test_non_finite_measurement_trips_the_interlock():
    scn = parse_scenario(short(0.1))
    result, rec = _run(scn, link=_NaNLink(after=10))
    assert result.steps == 10 and "non-finite measurement" in result.stopped
    assert len(rec) == 10


class _SlowLink:
    """Answers zeros; at step 50 tells the test and holds the loop there until the test has
    asked it to stop (an event, not a race between the loop and the asking thread)."""

    def __init__(self) -> None:
        self.reached = threading.Event()
        self.asked = threading.Event()

    def exchange(self, seq: int, t_ns: int, command: float) -> LinkSample:
        if seq == 50:
            self.reached.set()
            assert self.asked.wait(60.0), "the stop request never came"
        return LinkSample(0.0, 0.0, 0, seq)


def test_stop_from_another_thread_reports_the_reason():
    scn = parse_scenario(short(5.0))
    link = _SlowLink()
    loop = Loop(build.substructure(scn), build.compensator(scn), link, scn.scaling, scn.run.steps)

    def ask() -> None:
        link.reached.wait()
        loop.stop("specimen went away")
        link.asked.set()

    threading.Thread(target=ask).start()
    result = loop.run()
    assert result.stopped == "specimen went away" and result.steps == 51 < scn.run.steps


def test_time_steps_must_agree():
    scn = parse_scenario(short(0.1))
    comp = make_compensator("none", 2 * scn.run.dt)
    with pytest.raises(RTHSError, match="time steps differ"):
        Loop(build.substructure(scn), comp, _NaNLink(0), scn.scaling, 10)


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"displacement": 0.0}, "displacement scale factor"),
        ({"force": -1.0}, "force scale factor"),
    ],
)
def test_scale_factors_must_be_positive(kw, match):
    with pytest.raises(ParameterError, match=match):
        Scaling(**kw)


def test_impedance_factor():
    assert Scaling(0.1, 53.3).impedance == pytest.approx(5.33)


def test_command_limit_must_be_positive():
    scn = parse_scenario(short(0.1))
    with pytest.raises(ParameterError, match="command limit must be positive"):
        Loop(
            build.substructure(scn),
            build.compensator(scn),
            _NaNLink(0),
            scn.scaling,
            10,
            command_limit=0.0,
        )
