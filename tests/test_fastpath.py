"""The fast clock's compiled path (rths.runtime.fastpath) against the Python path it replaces:
every logged row of the loop and of the lab bit for bit (``np.array_equal``: the kernel is the
same operations in the same order, no fastmath), the components' state after the run, and the
stops (stroke interlock, guard trip) at the same step with the same message.  The oracle is the
Python path of each component (itself checked against closed forms elsewhere); a tolerance would
hide a reordered operation, so there is none."""

from __future__ import annotations

import numpy as np
import pytest
from _scenarios import short

from rths.config import build
from rths.config.scenario import parse_scenario
from rths.core.channels import RowBlock
from rths.log.reader import read_topic
from rths.runtime import fastpath
from rths.runtime.guard import CommandGuard
from rths.runtime.loop import InProcessLink, Loop
from rths.session.runner import RunOptions, run_scenario


class _Rows:
    """Collects the lab's rows as the runner's link does (blocks of 256)."""

    def __init__(self, lab):
        self.channels = lab.channels()
        self.blocks: list[RowBlock] = []
        self.block = RowBlock(self.channels, 256)

    def current(self) -> RowBlock:
        return self.block

    def flush(self) -> None:
        if self.block.count:
            self.blocks.append(self.block)
            self.block = RowBlock(self.channels, 256)


class _Link(InProcessLink):
    """An in-process link that logs the lab's rows on both paths."""

    def __init__(self, lab, guard):
        super().__init__(lab, guard)
        self.rows = _Rows(lab)

    def exchange(self, seq, t_ns, command):
        sample = super().exchange(seq, t_ns, command)
        b = self.rows.block
        i = b.count
        self.lab.write_channels(b.values[i])
        b.seq[i], b.t_ns[i] = seq, t_ns
        b.count = i + 1
        if b.count == 256:
            self.rows.flush()
        return sample

    def fused(self):
        return self.lab, self.guard, self.rows


def _rows(blocks):
    return (
        np.concatenate([b.values[: b.count] for b in blocks]),
        np.concatenate([b.seq[: b.count] for b in blocks]),
        np.concatenate([b.t_ns[: b.count] for b in blocks]),
    )


def _run(text, compiled, compensator=None, guard=True):
    scn = parse_scenario(text)
    lab = build.lab(scn, scn.run.seed)
    link = _Link(lab, CommandGuard(build.guard_limits(scn), scn.run.dt) if guard else None)
    sub, comp = build.substructure(scn), build.compensator(scn, compensator)
    blocks: list[RowBlock] = []
    loop = Loop(
        sub,
        comp,
        link,
        scn.scaling,
        scn.run.steps,
        sink=blocks.append,
        force_filter=build.correction_filter(scn),
        command_limit=scn.loop.stroke,
    )
    loop.compiled = compiled
    result = loop.run()
    link.rows.flush()
    after = {
        "guard": None if link.guard is None else link.guard.summary(),
        "saturations": lab.saturation_counts,
        "truth": lab.truth(),
        "sub": (sub.steps, sub.interface, sub.device_force, sub.displacement.tolist()),
        "comp": (comp.steps, comp.state()),
        "safe_stop": loop.safe_stop_steps,
    }
    return result, loop, _rows(blocks), _rows(link.rows.blocks), after


def _same(text, compensator=None, guard=True):
    """Run both paths; assert every row and the end state agree; return the compiled run."""
    ref = _run(text, False, compensator, guard)
    new = _run(text, True, compensator, guard)
    assert ref[1].compiled_steps == 0
    for a, b in zip(ref[2] + ref[3], new[2] + new[3], strict=True):
        assert a.shape == b.shape and np.array_equal(a, b)
    assert (new[0].steps, new[0].stopped) == (ref[0].steps, ref[0].stopped)
    assert new[4] == ref[4]
    return new


#: 2.5 s at 2048 Hz: 5120 steps, across the lab's second block of noise draws (4096 steps).
SEED = short(2.5)


def test_compiled_path_logs_the_seed_scenario_bit_for_bit():
    """Cable + S0 Eq.22 load + nominal IMD, FF+LQG, guard, TF actuator, Type II IMD with the
    amplitude-dependent damping of S0 Eq.18, 16-bit noisy converters, 60 Hz correction filter."""
    result, loop, *_ = _same(SEED)
    assert result.stopped is None and loop.compiled_steps == result.steps == 5120


@pytest.mark.parametrize(
    ("substitutions", "compensator", "guard"),
    [
        # the rigid IMD of S0 Eq.1 with Coulomb friction (tanh), LQG alone, no guard, no filter
        (
            {
                r'^kind = "imd"(\s+# internal)': r'kind = "imd_simplified"\1',
                r'^preset = "type_ii".*$': 'preset = "type_ii"\nfriction = 20.0',
                r"^correction_filter = 60.0.*$": "correction_filter = 0.0",
            },
            "lqg",
            False,
        ),
        # backlash and fixed damping (S0 Table 6 EIMD), FF+LQG
        ({r'^preset = "type_ii".*$': 'preset = "eimd_small"'}, None, True),
        # the feedforward alone (the MTS model's order 3: one difference of the acceleration)
        ({}, "ff", True),
    ],
    ids=["simplified-friction-lqg", "backlash-ff_lqg", "ff"],
)
def test_compiled_path_matches_other_specimens_and_compensators(substitutions, compensator, guard):
    result, loop, *_ = _same(short(1.0, **substitutions), compensator, guard)
    assert loop.compiled_steps > 0


def test_stroke_interlock_stops_at_the_same_step_with_the_same_message():
    """The segment that reaches the interlock is rolled back and the Python path stops it."""
    result, loop, *_ = _same(short(1.0, **{r"^stroke = 0.05": "stroke = 1e-4"}), guard=False)
    assert result.stopped is not None and result.stopped.startswith("interlock: command")
    assert 0 < loop.compiled_steps < result.steps


def test_a_guard_trip_hands_the_rest_of_the_run_to_the_python_path():
    """The guard trips on a command rate it cannot follow; its ramp-down is the Python path's."""
    text = short(
        1.0, **{r"^stroke = 0.05.*$": "stroke = 0.05\nmax_velocity = 0.002\nramp_velocity = 0.001"}
    )
    result, loop, rows, truth, after = _same(text)
    assert after["guard"]["guard_tripped"].startswith("command rate above")
    assert loop.compiled_steps < result.steps


def test_runner_logs_the_same_mcap_rows_on_both_paths(tmp_path, monkeypatch):
    """End to end through ``rths run --clock fast``: the MCAP topics agree field by field."""
    scn = parse_scenario(SEED)
    run_scenario(scn, RunOptions(clock="fast", out=tmp_path / "compiled.mcap"))
    monkeypatch.setattr(fastpath.FusedPlan, "of", classmethod(lambda cls, loop: None))
    run_scenario(scn, RunOptions(clock="fast", out=tmp_path / "python.mcap"))
    for topic in ("rths/loop", "rths/specimen"):
        a = read_topic(tmp_path / "python.mcap", topic)
        b = read_topic(tmp_path / "compiled.mcap", topic)
        assert a.keys() == b.keys() and len(a["t"]) == scn.run.steps
        for name in a:
            if name != "publish_time_ns":
                assert np.array_equal(a[name], b[name]), (topic, name)


@pytest.mark.parametrize("compiled", [False, True])
def test_a_stop_request_is_honoured_at_the_next_block(compiled):
    """A stop asked for from the sink (as the runner's signal handler does between blocks)
    ends the run after the block on both paths, with the request's reason and a ramp-down."""
    scn = parse_scenario(SEED)
    lab = build.lab(scn, scn.run.seed)
    blocks: list[RowBlock] = []

    def sink(block):
        blocks.append(block)
        if len(blocks) == 3:
            loop.stop("stopped by the test")

    loop = Loop(
        build.substructure(scn),
        build.compensator(scn),
        InProcessLink(lab, CommandGuard(build.guard_limits(scn), scn.run.dt)),
        scn.scaling,
        scn.run.steps,
        sink=sink,
        force_filter=build.correction_filter(scn),
        command_limit=scn.loop.stroke,
    )
    loop.compiled = compiled
    result = loop.run()
    assert (result.steps, result.stopped) == (3 * 256, "stopped by the test")
    assert loop.compiled_steps == (3 * 256 if compiled else 0)
    assert loop.safe_stop_steps > 0 and lab.truth()["command"] == 0.0


@pytest.mark.parametrize("hold", [True, False])
@pytest.mark.parametrize("order", [1, 2, 4, 5])
def test_compiled_feedforward_steps_as_the_python_one_for_every_order(order, hold):
    """The differences of the acceleration history (orders 4 and 5: dt**2 and dt**3) that the
    seed's third-order model does not reach: ``ff_step`` against ``FeedforwardCompensator.step``
    on a noisy target, bit for bit, and the committed state equal to the Python one."""
    from controllers.model_based._lqg_kernel import ff_step
    from controllers.model_based.feedforward import FeedforwardCompensator, LowOrderModel
    from rths.core.kinematics import Kinematics

    den = tuple(np.poly(-np.arange(1.0, order + 1.0) * 30.0))
    model = LowOrderModel(b0=float(den[-1]), den=den)
    ref, new = (FeedforwardCompensator(1 / 2048, model, hold) for _ in range(2))
    step = new.compiled_step()
    (p,), (s, counter) = step.constants, step.state
    rng = np.random.default_rng(order)
    for r, v, a in rng.standard_normal((300, 3)) * (1e-3, 1e-2, 1.0):
        expected = ref.step(Kinematics(r, v, a), 0.0)
        assert ff_step(p, s, r, v, a) == expected
        counter[0] += 1.0
    step.commit()
    assert (new.steps, new.state(), new._prev, list(new._acc)) == (
        ref.steps, ref.state(), ref._prev, list(ref._acc),
    )  # fmt: skip


def test_throttle_holds_a_producer_until_the_writer_has_caught_up(tmp_path):
    """The fast clock's compiled loop outruns the writer thread; ``Recorder.throttle`` returns
    only once no more than the given number of items wait (what a nearly full disk's reserve
    must still take when it stops the run), and the log has every row."""
    from rths.core.channels import Channel
    from rths.log.recorder import Recorder

    channels = (Channel("x", "m", "a value"),)
    with Recorder(tmp_path / "t.mcap", topics={}, writer="thread") as rec:
        for b in range(200):
            block = RowBlock(channels, 256)
            block.values[:, 0] = np.arange(256.0)
            block.seq[:] = np.arange(256) + 256 * b
            block.t_ns[:] = block.seq
            block.count = 256
            rec.put_block("rows", block)
        rec.throttle(4)
        assert rec._queue.qsize() <= 4
    assert read_topic(tmp_path / "t.mcap", "rows")["sequence"].size == 200 * 256
