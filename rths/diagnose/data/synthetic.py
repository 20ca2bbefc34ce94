"""Synthetic lab records with hidden effects, made by the project's own emulated lab.

Used by the blind suite (``tools/blind_suite.py``), the tests and the benchmark.  A record is the
loop ``command -> DAC -> TransferFunctionActuator (+ delay, rate limit) -> IMD specimen -> ADCs``
of :class:`plants.lab.EmulatedLab`; the specimen is :class:`plants.imd.models.SimplifiedIMD`
(S0 Eq.1), or :class:`plants.imd.models.InternalStiffnessIMD` (S0 Eq.12) when a series element is
switched on; an amplitude-dependent damping is the IMD's S0 Eq.18 law.  Records follow the CSV
timing convention (row ``k``: the command applied from ``t_k``, the measurement at ``t_k``).
Nothing here is visible to the diagnosis, which sees only the CSV columns and the nominal file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from plants.actuator import MTS_IDENTIFIED, TransferFunctionActuator
from plants.imd.models import IMDParameters, imd_from_parameters
from plants.imd.parameters import AmplitudeDamping
from plants.lab import Converter, EmulatedLab, LabConverters
from rths.core.errors import ParameterError, check_positive, format_choices
from rths.diagnose.data.nominal import ActuatorNominal, NominalModel, SpecimenNominal
from rths.diagnose.data.records import Record, align_log

__all__ = ["CLASSES", "LabCase", "band_limited_command", "lab_record", "seed_converters"]

#: The labels of the blind suite (design.md section 7 verdicts).
CLASSES: tuple[str, ...] = (
    "internal_stiffness",
    "backlash",
    "coulomb_friction",
    "amplitude_damping",
    "actuator_delay",
    "rate_limit",
    "none",
)


def seed_converters(
    displacement_noise: float = 5e-4, force_noise: float = 1e-3, force_per_volt: float = 1000.0
) -> LabConverters:
    """16-bit +/-10 V converters of the seed RTHS (S0 section 5.2, dSPACE DS1103).

    LVDT 0.0076 m/V (+/-76 mm), load cell ``force_per_volt`` [N/V]; noise in V RMS (defaults:
    3.8 um and 1 N).

    Parameters
    ----------
    displacement_noise
        LVDT noise [V RMS] (x 0.0076 m/V).
    force_noise
        Load-cell noise [V RMS] (x ``force_per_volt``).
    force_per_volt
        Load-cell sensitivity [N/V]; +/-10 V full scale.
    """
    return LabConverters(
        command=Converter(0.0076, bits=16, full_scale=10.0),
        displacement=Converter(0.0076, bits=16, full_scale=10.0, noise_rms=displacement_noise),
        force=Converter(force_per_volt, bits=16, full_scale=10.0, noise_rms=force_noise),
    )


@dataclass(frozen=True)
class LabCase:
    """One emulated specimen + transfer system with at most one hidden effect.

    Attributes
    ----------
    effect
        One of :data:`CLASSES`.
    value
        The hidden parameter in the units of the verdict's ``params`` (design.md section 7):
        series ``stiffness`` [N/m], ``gap`` [m], ``friction`` [N], ``c1`` [N s] of the
        amplitude-dependent damping ``c1/(A + c2)``, ``delay`` [s], ``velocity_limit`` [m/s];
        ignored for ``none``.
    inertance, damping
        True specimen ``m_e`` [kg] and ``c_d`` [N s/m] (on the flywheel with a series element).
    gain
        True actuator gain on top of the TF ``num/den`` [-].
    num, den
        Actuator TF (default :data:`plants.actuator.MTS_IDENTIFIED`).
    contact_frequency
        Backlash contact ``sqrt(k_c/m)/2pi`` [Hz].
    converters
        Lab converters (default :func:`seed_converters`).
    specimen
        The true IMD parameters outright (e.g. ``IMDParameters.preset("type_ii")`` with its
        amplitude law, S0 Eq.18); default: built from the fields above and the effect.
    amplitude_c2
        ``c2`` [m] of an ``amplitude_damping`` case (the damping is then ``c1/(A + c2)`` alone,
        ``A`` the IMD's reversal-based load amplitude, and ``damping`` is not used).
    extra
        Further hidden effects ``((effect, value), ...)`` on top of ``effect`` (combined cases;
        backlash and internal stiffness share the IMD's series element and do not combine).
    """

    effect: str
    value: float = 0.0
    inertance: float = 1589.0
    damping: float = 4000.0
    gain: float = 1.0
    num: tuple[float, ...] = MTS_IDENTIFIED.num
    den: tuple[float, ...] = MTS_IDENTIFIED.den
    contact_frequency: float = 100.0
    converters: LabConverters | None = None
    specimen: IMDParameters | None = None
    amplitude_c2: float = 0.5e-3
    extra: tuple[tuple[str, float], ...] = ()

    def __post_init__(self) -> None:
        for effect, value in ((self.effect, self.value), *self.extra):
            if effect not in CLASSES:
                raise ParameterError(
                    f"effect must be one of {format_choices(CLASSES)}; got {effect!r}"
                )
            if effect != "none":
                check_positive(value, f"{effect} value")
        check_positive(self.gain, "actuator gain")

    @property
    def effects(self) -> dict[str, float]:
        """Every hidden effect with its value (``{}`` for none)."""
        out = {} if self.effect == "none" else {self.effect: self.value}
        out.update(self.extra)
        return out

    def specimen_parameters(self) -> IMDParameters:
        """The true IMD (S0 Eq.1 or Eq.12) with the hidden specimen effects switched on."""
        if self.specimen is not None:
            return self.specimen
        p = IMDParameters(inertance=self.inertance, damping=self.damping)
        order = ("internal_stiffness", "backlash", "coulomb_friction", "amplitude_damping")
        for effect in order:  # the damping law needs the series stiffness, if any, first
            if effect in self.effects:
                p = self._with(p, effect, self.effects[effect])
        return p

    def _with(self, p: IMDParameters, effect: str, value: float) -> IMDParameters:
        if effect == "internal_stiffness":
            return replace(p, stiffness=value)
        if effect == "backlash":
            k_c = self.inertance * (2.0 * math.pi * self.contact_frequency) ** 2
            return replace(p, clearance=value, contact_stiffness=k_c)
        if effect == "coulomb_friction":
            return replace(p, friction=value)
        if effect == "amplitude_damping":
            # c_d = 2 xi sqrt(k0 m) with xi = c1'/(A_mm + c2') (S0 Eq.17-18) is c1/(A + c2) for
            # c1' = c1 / (2e-3 sqrt(k0 m)), c2' = 1e3 c2; k0 only scales c1' (no series spring)
            series = p.stiffness is not None
            k0 = (
                float(p.stiffness)  # type: ignore[arg-type]
                if series
                else self.inertance * (2.0 * math.pi * 10.0) ** 2
            )
            law = AmplitudeDamping(
                c1=value / (2e-3 * math.sqrt(k0 * self.inertance)),
                c2=1e3 * self.amplitude_c2,
                small_amplitude_mm=0.0,
            )
            return replace(p, damping=0.0, damping_law=law, stiffness=k0, internal_stiffness=series)
        return p

    def nominal(self, inertance: float, damping: float, gain: float) -> NominalModel:
        """What a user would believe: the rigid IMD and the TF, with given calibrations."""
        num = tuple(gain * c for c in self.num)
        return NominalModel(
            ActuatorNominal(num, self.den, 0.0), SpecimenNominal(inertance, damping, 0.0, 0.0)
        )


def band_limited_command(
    rng: np.random.Generator,
    duration: float,
    dt: float,
    band: tuple[float, float],
    rms: float,
    ramp: float = 1.0,
) -> NDArray[np.float64]:
    """Gaussian noise band-passed to ``band`` [Hz] (4th-order Butterworth, zero phase), scaled
    to ``rms`` [m] and tapered in and out over ``ramp`` [s] (the test starts and ends at rest).

    Parameters
    ----------
    rng
        The random generator (the record is a function of its state).
    duration
        Length [s].
    dt
        Sample period [s].
    band
        Pass band ``(low, high)`` [Hz], inside ``(0, 1/(2 dt))``.
    rms
        RMS of the command [m] before the taper.
    ramp
        Length [s] of the raised-cosine taper at each end.
    """
    n = int(round(duration / dt))
    sos = signal.butter(4, band, btype="bandpass", fs=1.0 / dt, output="sos")
    x = signal.sosfiltfilt(sos, rng.standard_normal(n + 4096))[2048:-2048]
    x *= rms / np.std(x)
    m = int(round(ramp / dt))
    taper = np.ones(n)
    taper[:m] = 0.5 - 0.5 * np.cos(np.linspace(0.0, math.pi, m))
    taper[n - m :] = taper[:m][::-1]
    return x * taper


def _run(case: LabCase, command: NDArray, dt: float, seed: int, converters: LabConverters):
    specimen = imd_from_parameters(case.specimen_parameters())
    delay = case.effects.get("actuator_delay", 0.0)
    v_max = case.effects.get("rate_limit")
    num = tuple(case.gain * c for c in case.num)
    actuator = TransferFunctionActuator(
        num, case.den, specimen, dt, delay=delay, velocity_limit=v_max
    )
    lab = EmulatedLab(actuator, converters, seed=seed)
    n = command.size
    measured, force, peak = np.empty(n), np.empty(n), 0.0
    for k in range(n):
        measured[k], force[k] = lab.step(float(command[k]))
        peak = max(peak, abs(lab.force))
    return measured, force, peak, lab.saturation_counts


def lab_record(
    case: LabCase, command: NDArray[np.float64], dt: float, seed: int, name: str = "lab"
) -> Record:
    """Run the emulated lab on a command history; return the record the CSV would hold.

    The lab holds ``command[k]`` over step ``k`` and measures at its end; the record is aligned
    to the CSV timing convention (:func:`rths.diagnose.data.records.align_log`).

    The converters are ``case.converters`` (default :func:`seed_converters`) with the load cell
    ranged as a lab engineer would: if the force saturates, the run is repeated with the force
    range set to 1.25 times the peak true force.

    Parameters
    ----------
    case
        The specimen, transfer system and hidden effect.
    command
        Command history [m], one value per step.
    dt
        Sample period [s].
    seed
        Seed of the converters' noise.
    name
        The record's name (as a file name would be).
    """
    converters = case.converters or seed_converters()
    measured, force, peak, saturated = _run(case, command, dt, seed, converters)
    if saturated["force"]:
        converters = replace(
            converters,
            force=replace(
                converters.force, units_per_volt=1.25 * peak / converters.force.full_scale
            ),
        )
        measured, force, _, _ = _run(case, command, dt, seed, converters)
    t = dt * np.arange(1, command.size + 1, dtype=np.float64)
    t, u, x, f = align_log(t, np.asarray(command, float).copy(), measured, force)
    return Record(name, dt, t, u, x, f)
