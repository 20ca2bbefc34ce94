"""The realtime clock's warm-up before step 0 (rths.session.warm_up) and the probes it sends
(rths.wire.codec.Command.probe): the schedule and stopping rule on a fake clock, and the real
specimen process's serving loop answering probes without moving its lab.

Every wait over zenoh is a timeout (an upper bound reached only when something is broken), never
a duration that is asserted.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest

from rths.config import build
from rths.config.scenario import load_scenario
from rths.runtime.guard import CommandGuard
from rths.session.specimen import serve
from rths.session.warm_up import warm_up
from rths.session.zenoh_run import RESERVE_NS
from rths.wire.auth import RunSecret
from rths.wire.codec import PROBE_T_NS, Command, Measurement
from rths.wire.sync_link import SyncClient
from rths.wire.transport import Presence, RunKeys, ZenohEndpoints, open_session

PATIENCE = 10.0
SEED = Path(__file__).resolve().parents[1] / "scenarios" / "cable_imd_mode3.toml"


class FakeClock:
    """Monotonic nanoseconds that advance 1 µs per reading and by what a sleep asks."""

    def __init__(self) -> None:
        self.t = 10**9

    def now(self) -> int:
        self.t += 1000
        return self.t

    def sleep(self, seconds: float) -> None:
        self.t += round(seconds * 1e9)


class Prober:
    """Answers probe ``k`` in time when ``answers(k)``; keeps the deadlines it was given."""

    def __init__(self, answers) -> None:
        self.answers = answers
        self.seqs: list[int] = []
        self.deadlines: list[int] = []

    def probe(self, seq: int, deadline_ns: int) -> bool:
        self.seqs.append(seq)
        self.deadlines.append(deadline_ns)
        return bool(self.answers(seq))


DT = 1 / 2048


def test_warm_up_settles_on_a_run_of_answers_and_waits_until_the_next_step() -> None:
    clock = FakeClock()
    prober = Prober(lambda k: k >= 10)  # cold: the first ten answers come too late
    seen = warm_up(
        prober,
        DT,
        on_time_run=8,
        longest=0.05,
        now_ns=clock.now,
        sleep=clock.sleep,
        reserve_ns=RESERVE_NS,
    )
    assert seen.settled and seen.probes == 18 and seen.on_time == 8
    assert prober.seqs == list(range(18))  # numbered like steps, one per step
    dt_ns = round(DT * 1e9)
    steps = [d + RESERVE_NS for d in prober.deadlines]
    # each probe waits until the next step is due (less the reserve), on the step schedule
    assert [b - a for a, b in zip(steps, steps[1:], strict=False)] == [dt_ns] * 17
    assert "settled after 18 probes" in seen.describe()


def test_warm_up_gives_up_after_its_longest_time_and_says_so() -> None:
    clock = FakeClock()
    seen = warm_up(
        Prober(lambda k: k % 2 == 0),
        DT,
        on_time_run=8,
        longest=0.05,
        now_ns=clock.now,
        sleep=clock.sleep,
    )
    n = round(0.05 / DT)  # 102 steps of the schedule
    assert not seen.settled and seen.probes == n and seen.on_time == n // 2
    assert "not settled after 102 probes" in seen.describe()
    never = warm_up(Prober(lambda k: False), DT, 8, 0.05, clock.now, clock.sleep)
    assert never.on_time == 0 and never.round_trip_p50_us == never.round_trip_max_us == 0.0


def test_a_probe_is_a_command_no_step_can_be() -> None:
    probe = Command.probe(7)
    assert probe.is_probe and probe.t_ns == PROBE_T_NS < 0 and probe.command == 0.0
    assert Command.unpack(probe.pack()) == probe
    assert not Command(0, 0, 0.0).is_probe  # step 0 ends at t = dt > 0: never a probe
    assert Measurement(3, PROBE_T_NS, 0.0, 0.0, 1).is_probe


@pytest.mark.skipif(not SEED.exists(), reason="no seed scenario")
def test_the_specimen_answers_probes_without_moving_its_lab() -> None:
    """The real serving loop (``rths specimen``'s): probes are answered, the lab is not
    stepped -- the first real command's measurement is exactly a fresh lab's first step -- and
    answers to probes never pass for measurements of a step."""
    scn = load_scenario(SEED)
    secret, keys, ep = RunSecret.new(), RunKeys("probes"), ZenohEndpoints.loopback()
    served: list[int] = []
    specimen = threading.Thread(
        target=lambda: served.append(
            serve(scn, "probes", ep.peer(), "lockstep", log_state=False, seed=3, secret=secret)
        )
    )
    with open_session(ep) as session, SyncClient(session, keys, secret) as client:
        with Presence(session, keys, "coordinator", ep.describe(), secret) as presence:
            specimen.start()
            presence.wait_for_peer(PATIENCE, [client.publisher])

            def far() -> int:
                return time.monotonic_ns() + round(PATIENCE * 1e9)

            assert all(client.probe(k, far()) for k in range(20))
            lab = build.lab(scn, 3)  # what the specimen's lab must do with the same commands
            guard = CommandGuard(build.guard_limits(scn), scn.run.dt)
            for k in range(5):
                u = 1e-4 * (k + 1)
                t_ns = round((k + 1) * scn.run.dt * 1e9)
                m = client.exchange(Command(k, t_ns, u), far())
                assert m is not None and (m.seq, m.t_ns) == (k, t_ns) and not m.is_probe
                assert (m.displacement, m.force) == lab.step(guard.apply(u))  # bit for bit
            presence.request_stop("test over")
            specimen.join(PATIENCE)
    assert not specimen.is_alive() and served == [5]  # probes are not steps
    assert client.newest is not None and client.newest.seq == 4
