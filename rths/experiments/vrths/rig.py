"""The vRTHS benchmark assembled from the project's own parts and run through its loop.

One trial = one partitioning case, one ground motion, one plant (nominal or drawn) and one
compensator, run on the ``fast`` clock (in-process lab, :class:`rths.runtime.loop.Loop`):

* numerical substructure: :class:`plants.frame.FrameSubstructure` (with the benchmark's
  *Unit Delay* on the force);
* lab: the drawn specimen (:class:`plants.linear_specimen.LinearSpecimen`) behind
  :class:`plants.actuator.ServoHydraulicActuator` with the drawn ``beta1``, ``beta2``, ``a3`` (CSI
  included), in an :class:`plants.lab.EmulatedLab` whose converters are the benchmark's
  (:func:`benchmark_converters`);
* compensator: ``pi_lead`` (the benchmark's sample controller) or any kind of
  :mod:`controllers.factory`, designed on the *nominal* plant.

The record starts at ``t = 0`` (rest) like the Simulink logs, so :func:`score` applies F4
directly.  :func:`run_trial` also keeps the lab's truth: the noise-free specimen displacement and
the hydraulic force ``F_a`` (``Force_act``), checked against the 8.9 kN capacity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import control
import numpy as np
from numpy.typing import NDArray

from controllers.base import Compensator
from controllers.factory import make_compensator
from plants.actuator import BENCHMARK, ServoHydraulicActuator
from plants.frame.cases import BenchmarkCase
from plants.frame.ground_motion import DEFAULT_INTENSITY, GroundMotion
from plants.frame.substructure import FrameSubstructure, reference_response
from plants.lab import Converter, EmulatedLab, LabConverters
from rths.core.channels import RowBlock
from rths.core.errors import check_positive
from rths.core.scaling import Scaling
from rths.experiments.vrths.draws import NOMINAL, PlantDraw
from rths.experiments.vrths.simulink import DISPLACEMENT_NOISE_POWER, FORCE_NOISE_POWER
from rths.metrics.vrths import BenchmarkScores, evaluate
from rths.runtime.clocks import Pacer
from rths.runtime.loop import InProcessLink, LinkSample, Loop

__all__ = [
    "DT",
    "STROKE",
    "Trial",
    "benchmark_compensator",
    "benchmark_converters",
    "benchmark_lab",
    "nominal_plant",
    "run_trial",
    "score",
]

FloatArray = NDArray[np.float64]

#: The benchmark's loop step [s] (``fs = 4096`` Hz).
DT: float = 1.0 / 4096.0
#: Interlock on the command [m]: the loop stops beyond it (the benchmark names no stroke; this is
#: ten times the largest first-floor displacement of the three records at intensity 0.4).
STROKE: float = 0.05

_FORCE_PER_VOLT = 1000.0  # N/V: force channel scaling, so the 24-bit code is 3.8 mN


def benchmark_converters(dt: float = DT, noise: bool = True) -> LabConverters:
    """The benchmark's converters and sensor noise as :class:`plants.lab.LabConverters`.

    The Simulink model quantises displacements with interval ``2^-18`` m and saturates at
    +/-3.8 m (``quantize_int``, ``sat_limit_*``), and adds band-limited white noise of standard
    deviation ``sqrt(Cov/dt)``: 16 um on the LVDT, 2.18 N on the load cell at 4096 Hz.  Here:
    24-bit converters of +/-32 V at 1 m/V have the same ``2^-18`` m interval (their saturation,
    +/-32 m, is as unreachable as +/-3.8 m); the load cell's channel (1000 N/V, 3.8 mN codes) is
    practically unquantised, as in the benchmark.  The two noises are independent here (the
    benchmark seeds both blocks alike, which only scales one sequence twice).

    Parameters
    ----------
    dt : float
        Loop step [s], > 0 (default :data:`DT` = 1/4096 s, the benchmark's).
    noise : bool
        True (default): the benchmark's sensor noise, ``sqrt(Cov/dt)`` RMS; False: none.
    """
    dt = check_positive(dt, "time step dt")
    sx = math.sqrt(DISPLACEMENT_NOISE_POWER / dt) if noise else 0.0
    sf = math.sqrt(FORCE_NOISE_POWER / dt) / _FORCE_PER_VOLT if noise else 0.0
    return LabConverters(
        command=Converter(1.0, bits=24, full_scale=32.0),
        displacement=Converter(1.0, bits=24, full_scale=32.0, noise_rms=sx),
        force=Converter(_FORCE_PER_VOLT, bits=24, full_scale=32.0, noise_rms=sf),
    )


def benchmark_lab(
    plant: PlantDraw = NOMINAL, dt: float = DT, seed: int | None = 0, noise: bool = True
) -> EmulatedLab:
    """The drawn specimen behind the drawn servo-hydraulic actuator, with the benchmark's
    converters; ``seed`` seeds the sensor noise.

    Parameters
    ----------
    plant : PlantDraw
        The trial's specimen stiffness and servo-valve/hydraulic parameters (default
        :data:`rths.experiments.vrths.draws.NOMINAL`, the nominal plant).
    dt : float
        Loop step [s], > 0 (default :data:`DT` = 1/4096 s, the benchmark's).
    seed : int or None
        Seed of the sensor noise (default 0); None: fresh entropy.
    noise : bool
        True (default): the benchmark's sensor noise; False: none.
    """
    actuator = ServoHydraulicActuator(plant.specimen(), dt, plant.actuator())
    return EmulatedLab(actuator, benchmark_converters(dt, noise), seed=seed)


def nominal_plant(dt: float = DT) -> control.TransferFunction:
    """Command -> displacement model of the nominal plant (``G_plant`` of F1, CSI included).

    Parameters
    ----------
    dt : float
        Loop step [s], > 0 (default :data:`DT` = 1/4096 s, the benchmark's).
    """
    actuator = ServoHydraulicActuator(NOMINAL.specimen(), dt, BENCHMARK)
    return control.minreal(actuator.transfer_function(), verbose=False)


def benchmark_compensator(kind: str, dt: float = DT, **options: Any) -> Compensator:
    """A :mod:`controllers.factory` kind (``pi_lead``, ``ff_lqg``, ...) designed on
    :func:`nominal_plant`.

    Parameters
    ----------
    kind : str
        A registered compensator kind, e.g. ``"pi_lead"``, ``"ff_lqg"``, ``"none"``.
    dt : float
        Loop step [s], > 0 (default :data:`DT` = 1/4096 s, the benchmark's).
    **options
        Fields of the kind's options dataclass (``rths kinds compensator``), e.g.
        ``order=4`` for ``ff_lqg``.
    """
    return make_compensator(kind, dt, nominal_plant(dt), **options)


@dataclass(frozen=True)
class Trial:
    """One RTHS trial on the benchmark, sampled at ``t_k = k dt`` from ``t = 0``.

    Attributes
    ----------
    dt
        Step [s].
    numerical
        Floor displacements of the numerical substructure [m], ``(n, 3)``; column 0 is the target.
    measured
        Measured specimen displacement [m] (noise, converters), ``(n,)``.
    true_displacement
        Noise-free specimen displacement [m] (the emulated lab's truth), ``(n,)``.
    command
        Actuator command [m], ``(n,)`` (row ``k`` is held from ``t_{k-1}``; row 0 is 0).
    actuator_force
        Hydraulic force ``F_a`` [N], ``(n,)``.
    stopped
        Why the loop stopped early (interlock), or ``None``.
    """

    dt: float
    numerical: FloatArray
    measured: FloatArray
    true_displacement: FloatArray
    command: FloatArray
    actuator_force: FloatArray
    stopped: str | None

    @property
    def peak_actuator_force(self) -> float:
        """``max |F_a|`` [N]."""
        return float(np.max(np.abs(self.actuator_force)))


def _no_clock() -> int:
    return 0


class _Recorder(InProcessLink):
    """In-process link (no guard: the loop's stroke interlock stops a trial) that also keeps the
    lab's truth each step, in lists (a list append is cheaper than a NumPy item write)."""

    def __init__(self, lab: EmulatedLab, actuator: ServoHydraulicActuator) -> None:
        super().__init__(lab)
        self._lab, self._actuator = lab, actuator
        self._step = lab.step
        self.true: list[float] = [0.0]
        self.force: list[float] = [0.0]

    def exchange(self, seq: int, t_ns: int, command: float) -> LinkSample:
        displacement, force = self._step(command)
        self.true.append(self._lab.kinematics.displacement)
        self.force.append(self._actuator.hydraulic_force)
        return LinkSample(displacement, force, 0, seq)


def run_trial(
    case: BenchmarkCase,
    ground: GroundMotion,
    compensator: Compensator,
    plant: PlantDraw = NOMINAL,
    *,
    intensity: float = DEFAULT_INTENSITY,
    seed: int | None = 0,
    noise: bool = True,
    stroke: float = STROKE,
) -> Trial:
    """Run one trial through :class:`rths.runtime.loop.Loop` on the ``fast`` clock.

    Parameters
    ----------
    case, ground
        Partitioning case and ground motion (the run lasts ``ground.steps(dt)`` steps).
    compensator
        Designed on the nominal plant; reset before the run.
    plant
        The trial's specimen stiffness and actuator parameters.
    intensity
        ``eq_intensity`` [-].
    seed
        Sensor-noise seed.
    noise
        ``False`` removes the sensor noise.
    stroke
        Command interlock [m].
    """
    dt = compensator.dt
    sub = FrameSubstructure(case, plant.specimen(), ground, dt, intensity=intensity)
    lab = benchmark_lab(plant, dt, seed, noise)
    n = sub.n_steps
    assert isinstance(lab.actuator, ServoHydraulicActuator)
    link = _Recorder(lab, lab.actuator)
    numerical = np.zeros((n + 1, 3))
    measured, command = np.zeros(n + 1), np.zeros(n + 1)

    def sink(block: RowBlock) -> None:
        n_rows = block.count
        if not n_rows:
            return
        k = int(block.seq[0]) + 1
        rows = slice(k, k + n_rows)
        for j, name in enumerate(("sub_x1", "sub_x2", "sub_x3")):
            numerical[rows, j] = block.column(name)
        measured[rows], command[rows] = block.column("measured"), block.column("command")

    compensator.reset()
    # a trial reports no timing: the free-running pacer gets a constant clock (saves four clock
    # reads and two array writes per step)
    untimed = Pacer(dt, n, now_ns=_no_clock)
    loop = Loop(sub, compensator, link, Scaling(), n, pacer=untimed, sink=sink,
                command_limit=stroke)  # fmt: skip
    result = loop.run()
    m = result.steps + 1
    return Trial(
        dt=dt,
        numerical=numerical[:m],
        measured=measured[:m],
        true_displacement=np.array(link.true[:m]),
        command=command[:m],
        actuator_force=np.array(link.force[:m]),
        stopped=result.stopped,
    )


def score(trial: Trial, reference: FloatArray) -> BenchmarkScores:
    """F4's J1-J9 of a trial against the reference response (``(n, 3)`` from ``t = 0``).

    Parameters
    ----------
    trial : Trial
        The trial (:func:`run_trial`).
    reference : numpy.ndarray, shape (>= n, 3)
        Floor displacements [m] of the unpartitioned reference frame from ``t = 0`` at the
        trial's ``dt`` (:func:`reference_for`); the first ``n`` rows are used.
    """
    n = trial.measured.size
    return evaluate(trial.measured, trial.numerical, reference[:n], trial.dt)


def reference_for(
    case: BenchmarkCase, ground: GroundMotion, dt: float = DT, intensity: float = DEFAULT_INTENSITY
) -> FloatArray:
    """:func:`plants.frame.reference_response` over the whole run (``tend``)."""
    return reference_response(case, ground, dt, intensity=intensity)
