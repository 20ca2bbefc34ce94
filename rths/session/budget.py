"""What a run will cost, checked before it starts: memory, disk and wall time.

A scenario that asks for more than the machine can give -- ``duration = 1e9`` s, a week of fast
simulation, a Monte Carlo of a billion draws -- is refused with one line before anything is
allocated, opened or started, naming the ``[run]`` keys and the figure that does not fit:

* **memory**: the run keeps :data:`MEMORY_PER_STEP` bytes per step for its summary; at most
  :data:`MEMORY_FRACTION` of the memory available now;
* **disk**: the log takes about :data:`LOG_PER_STEP` bytes per step (zstd-compressed JSON of
  ``rths/loop`` and ``rths/specimen``; the seed scenario writes 420) plus the recorder's reserve
  (:data:`rths.log.recorder.RESERVE`); at most the free space of the log's folder;
* **wall time**: steps times the cost of one step, *measured on this machine* by stepping the
  built substructure, compensator and lab a few times (then resetting them), plus the clock's
  overhead per step (:data:`OVERHEAD`); at most :data:`MAX_WALL` seconds.
"""

from __future__ import annotations

import os
import shutil
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rths.config.scenario import Scenario
from rths.core.errors import ConfigError
from rths.log.recorder import RESERVE

__all__ = [
    "LOG_PER_STEP",
    "MAX_WALL",
    "MEMORY_FRACTION",
    "MEMORY_PER_STEP",
    "OVERHEAD",
    "Budget",
    "check_budget",
    "step_cost",
]

#: Bytes held in memory per loop step (target, measured, force, age for the summary).
MEMORY_PER_STEP = 32
#: Largest share of the available memory a run may plan to use.
MEMORY_FRACTION = 0.5
#: Log bytes per loop step [B] (an upper estimate; the seed scenario writes ~420).
LOG_PER_STEP = 600
#: Longest wall time [s] a run may be expected to take: a day.
MAX_WALL = 86400.0
#: Per-step cost [s] of each clock beyond the plants' own: the loop, the record, and in
#: lockstep the zenoh round trip (README: 0.53 ms at 2048 Hz on the 2-core reference machine).
OVERHEAD = {"fast": 50e-6, "lockstep": 600e-6, "realtime": 0.0}
_STEPS_TIMED = 32


@dataclass(frozen=True)
class Budget:
    """What a run is expected to cost.

    Attributes
    ----------
    steps
        Loop steps in all (runs x steps per run).
    memory
        Bytes held in memory by one run [B].
    log
        Bytes of the log [B] (0: no log).
    wall
        Expected wall time [s].
    """

    steps: int
    memory: float
    log: float
    wall: float


def step_cost(*parts: Any) -> float:
    """Seconds per loop step of ``parts``, measured by stepping each :data:`_STEPS_TIMED` times
    after one warm-up step, then resetting it.

    Parameters
    ----------
    *parts
        A :class:`plants.base.Substructure` (stepped with no force), a
        :class:`controllers.base.Compensator` (a target at rest) or an emulated lab (a zero
        command); None is skipped.
    """
    total = 0.0
    for part in parts:
        if part is None:
            continue
        step = _stepper(part)
        step()  # compiled kernels are built on the first step
        start = time.perf_counter()
        for _ in range(_STEPS_TIMED):
            step()
        total += (time.perf_counter() - start) / _STEPS_TIMED
        part.reset()
    return total


def _stepper(part: Any) -> Any:
    from controllers.base import Compensator
    from plants.base import Substructure
    from rths.core.kinematics import Kinematics

    if isinstance(part, Substructure):
        return lambda: part.step(0.0)
    if isinstance(part, Compensator):
        rest = Kinematics(0.0, 0.0, 0.0)
        return lambda: part.step(rest, 0.0)
    return lambda: part.step(0.0)  # an emulated lab: command in


def _available_memory() -> float:
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    try:
        return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return float("inf")


def _size(n: float) -> str:
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n / 1e3:.3g} kB"


def check_budget(
    scn: Scenario,
    clock: str,
    cost: float,
    *,
    log_dir: Path | None = None,
    runs: int = 1,
) -> Budget:
    """The run's :class:`Budget`; :class:`ConfigError` when it does not fit (module docstring).

    Parameters
    ----------
    scn
        The scenario (its ``[run]`` duration and rate give the steps).
    clock
        ``fast``, ``lockstep`` or ``realtime``.
    cost
        Measured seconds per step of the plants (:func:`step_cost`).
    log_dir
        Folder of the log (None: no log is written).
    runs
        Runs of the scenario (Monte Carlo draws x compensators).
    """
    steps = scn.run.steps
    where = f"{scn.source}: [run] duration {scn.run.duration:g} s at rate {scn.run.rate:g} Hz"
    memory = steps * MEMORY_PER_STEP
    available = _available_memory()
    if memory > MEMORY_FRACTION * available:
        raise ConfigError(
            f"{where} = {steps} steps would hold {_size(memory)} in memory; this machine has "
            f"{_size(available)} available: shorten the run or lower the rate"
        )
    log = 0.0
    if log_dir is not None:
        log = steps * LOG_PER_STEP + RESERVE
        free = shutil.disk_usage(log_dir).free
        if log > free:
            raise ConfigError(
                f"{where} = {steps} steps would write a log of about {_size(log)} into "
                f"'{log_dir}', which has {_size(free)} free: shorten the run or log elsewhere "
                "(--out)"
            )
    per_step = cost + OVERHEAD.get(clock, 0.0)
    wall = scn.run.duration * runs if clock == "realtime" else steps * runs * per_step
    if wall > MAX_WALL:
        what = f" x {runs} runs" if runs > 1 else ""
        raise ConfigError(
            f"{where}{what} would take about {wall / 3600:.3g} h on the {clock} clock "
            f"({1e6 * per_step:.0f} µs per step measured here); at most {MAX_WALL / 3600:g} h: "
            "shorten the run, lower the rate or use fewer draws"
        )
    return Budget(steps * runs, memory, log, wall)
