"""The emulated laboratory: DAC → actuator (+ specimen, CSI) → ADC, with the converters' flaws.

This is what the specimen process runs.  Each loop step::

    command [m] --DAC--> quantised command --actuator.step--> true (x, F) at t_{k+1}
                                                  --ADC(noise, quantisation)--> measured (x, F)

Converters (benchmark, design.md section 5: 18-bit, +/-3.8 V, 0.002 V RMS noise) are
:class:`Converter` records: resolution ``bits``, input range ``+/- full_scale`` [V], transducer
calibration ``units_per_volt`` and Gaussian noise ``noise_rms`` [V] added before quantisation.
A value outside the range is clipped to the nearest code and counted in
:attr:`EmulatedLab.saturation_counts`.  Noise comes from one seeded ``numpy`` generator that
:meth:`EmulatedLab.reset` re-seeds, so a run is reproducible from :attr:`EmulatedLab.seed`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from plants.actuator.base import Actuator
from plants.base import Kinematics
from plants.lab_kernel import LAB_STATE, convert_counting
from rths.core.channels import Channel
from rths.core.compiled import CompiledStep
from rths.core.errors import (
    ParameterError,
    check_finite,
    check_nonnegative,
    check_positive,
    check_positive_int,
)

__all__ = ["LAB_CHANNELS", "Converter", "EmulatedLab", "LabConverters", "convert"]

_CHANNELS = ("command", "displacement", "force")

#: The lab's own logged channels (the actuator's follow as ``actuator.<name>``).
LAB_CHANNELS: tuple[Channel, ...] = (
    Channel("t", "s", "simulated time at the end of the step"),
    Channel("command", "m", "command received (after the specimen side's guard)"),
    Channel("command_dac", "m", "command after the DAC"),
    Channel("displacement", "m", "true displacement of the specimen end"),
    Channel("velocity", "m/s", "true velocity of the specimen end"),
    Channel("acceleration", "m/s^2", "true acceleration of the specimen end"),
    Channel("force", "N", "true restoring force of the specimen"),
    Channel("measured_displacement", "m", "displacement after the ADC (noise, quantisation)"),
    Channel("measured_force", "N", "force after the ADC (noise, quantisation)"),
)


@dataclass(frozen=True, slots=True)
class Converter:
    """One converter channel (DAC or ADC) with its transducer calibration.

    A value ``y`` [engineering units] becomes ``V = y / units_per_volt + noise`` [V], is rounded
    to the nearest of the ``2**bits`` two's-complement codes ``-2**(bits-1) .. 2**(bits-1)-1``
    of width ``lsb = 2 full_scale / 2**bits`` [V] (a code outside that range is clipped: a
    *saturation*) and is converted back to engineering units.  Inside the range the
    quantisation error is at most ``lsb/2``.

    Attributes
    ----------
    units_per_volt
        Calibration [engineering unit / V], e.g. m/V for displacement, N/V for force; > 0.
    bits
        Resolution [bits], 1..32 (benchmark: 18).
    full_scale
        Input range ``+/- full_scale`` [V], > 0 (benchmark: 3.8).
    noise_rms
        RMS [V] of the Gaussian noise added before quantisation, >= 0 (benchmark ADC: 0.002).
    """

    units_per_volt: float
    bits: int = 18
    full_scale: float = 3.8
    noise_rms: float = 0.0

    def __post_init__(self) -> None:
        check_positive(self.units_per_volt, "converter units_per_volt")
        check_positive_int(self.bits, "converter bits")
        if self.bits > 32:
            raise ParameterError(f"converter bits must be at most 32; got {self.bits!r}")
        check_positive(self.full_scale, "converter full_scale")
        check_nonnegative(self.noise_rms, "converter noise_rms")

    @property
    def lsb(self) -> float:
        """Code width [V]."""
        return 2.0 * self.full_scale / 2**self.bits

    @property
    def resolution(self) -> float:
        """Code width in engineering units (``lsb * units_per_volt``)."""
        return self.lsb * self.units_per_volt

    @property
    def span(self) -> float:
        """Largest magnitude in engineering units (``full_scale * units_per_volt``)."""
        return self.full_scale * self.units_per_volt

    def convert(self, value: float, noise: float = 0.0) -> tuple[float, bool]:
        """Quantise one value [engineering units] with ``noise`` [V] added.

        Returns
        -------
        tuple
            The converted value [engineering units] and whether it saturated.
        """
        return convert(value, noise, *self.constants)

    @property
    def constants(self) -> tuple[float, float, int, float]:
        """``(units_per_volt, lsb, 2**(bits-1), resolution)``: what :func:`convert` needs."""
        return self.units_per_volt, self.lsb, 2 ** (self.bits - 1), self.resolution

    def quantise(self, values: ArrayLike) -> NDArray[np.float64]:
        """Noise-free conversion of an array (same rounding and clipping as :meth:`convert`)."""
        v = np.asarray(values, dtype=float)
        top = 2 ** (self.bits - 1)
        codes = np.clip(np.floor(v / self.units_per_volt / self.lsb + 0.5), -top, top - 1)
        return codes * self.resolution


def convert(
    value: float, noise: float, units_per_volt: float, lsb: float, top: int, resolution: float
) -> tuple[float, bool]:
    """:meth:`Converter.convert` on the converter's :attr:`Converter.constants` (the lab's
    per-step path: no property look-ups).

    Parameters
    ----------
    value
        The value [engineering units].
    noise
        Noise [V] added before quantisation.
    units_per_volt, lsb, top, resolution
        :attr:`Converter.constants`: calibration, code width [V], ``2**(bits-1)``, code width in
        engineering units.

    Returns
    -------
    tuple
        The converted value [engineering units] and whether it saturated.
    """
    code = math.floor((value / units_per_volt + noise) / lsb + 0.5)
    if code >= top:
        return (top - 1) * resolution, True
    if code < -top:
        return -top * resolution, True
    return code * resolution, False


#: Default displacement calibration [m/V]: +/-3.8 V spans +/-76 mm, the +/-75.2 mm stroke of the
#: MTS 204.63 actuator of S0 section 3.
DISPLACEMENT_M_PER_V = 0.02
#: Default force calibration [N/V]: +/-3.8 V spans the 100 kN capacity of the same actuator.
FORCE_N_PER_V = 1.0e5 / 3.8


@dataclass(frozen=True, slots=True)
class LabConverters:
    """The three converter channels of the emulated lab (benchmark defaults: 18 bit, +/-3.8 V).

    Attributes
    ----------
    command
        DAC of the actuator command (m/V as the displacement transducer: the servo-controller
        compares them); noise-free by default.
    displacement
        ADC of the displacement transducer (LVDT), 0.002 V RMS noise (40 um with 0.02 m/V).
    force
        ADC of the load cell, 0.002 V RMS noise (53 N with 1e5/3.8 N/V).
    """

    command: Converter = Converter(DISPLACEMENT_M_PER_V)
    displacement: Converter = Converter(DISPLACEMENT_M_PER_V, noise_rms=0.002)
    force: Converter = Converter(FORCE_N_PER_V, noise_rms=0.002)

    def __post_init__(self) -> None:
        for name in _CHANNELS:
            if not isinstance(getattr(self, name), Converter):
                raise ParameterError(
                    f"LabConverters.{name} must be a Converter; got {getattr(self, name)!r}"
                )


class EmulatedLab:
    """An actuator with its specimen behind a DAC and two ADCs, stepped once per loop step.

    Parameters
    ----------
    actuator
        The actuator (it owns the specimen); its ``dt`` is the lab's loop step.
    converters
        DAC/ADC channels and calibrations.
    seed
        Seed of the noise generator (``None``: fresh OS entropy, recorded in :attr:`seed`).
    use_jit
        Convert with the compiled kernel (:func:`plants.lab_kernel.convert_counting`, default;
        bit for bit :func:`convert`) or with :func:`convert` (the reference path).
    """

    def __init__(
        self,
        actuator: Actuator,
        converters: LabConverters | None = None,
        *,
        seed: int | None = None,
        use_jit: bool = True,
    ) -> None:
        if not isinstance(actuator, Actuator):
            raise ParameterError(f"actuator must be a plants.Actuator; got {actuator!r}")
        self.actuator: Actuator = actuator
        self.converters: LabConverters = LabConverters() if converters is None else converters
        if not isinstance(self.converters, LabConverters):
            raise ParameterError(f"converters must be LabConverters; got {converters!r}")
        self._seed_sequence = np.random.SeedSequence(seed)
        #: The noise seed actually used (reproduces the run when passed back as ``seed``).
        self.seed: int = int(self._seed_sequence.entropy)  # type: ignore[arg-type]
        c = self.converters
        self._noise_rms = np.array(
            [c.command.noise_rms, c.displacement.noise_rms, c.force.noise_rms]
        )
        self._constants = (c.command.constants, c.displacement.constants, c.force.constants)
        self.use_jit: bool = bool(use_jit)
        self._constant_table = np.array(self._constants, dtype=float)  # compiled path
        self.reset()

    #: Steps of noise drawn at once; the sequence equals per-step draws (tested), only faster.
    #: Small on purpose: a draw happens inside one step, and 4096 steps' worth (12 288 normals
    #: and their Python list) took 0.6 ms median, 5.8 ms worst -- a real-time specimen missed
    #: its deadlines every 4096 steps, and its first step took 1.7 ms.  256 steps: 27 µs median.
    NOISE_BLOCK = 256

    @property
    def dt(self) -> float:
        """Loop step [s] (the actuator's)."""
        return self.actuator.dt

    @property
    def time(self) -> float:
        """Simulated time [s] at the end of the last step."""
        return self._steps * self.actuator.dt

    @property
    def kinematics(self) -> Kinematics:
        """True kinematics of the specimen end after the last step."""
        return self._kinematics

    @property
    def force(self) -> float:
        """True specimen restoring force [N] after the last step."""
        return self._force

    @property
    def saturation_counts(self) -> dict[str, int]:
        """Number of saturated conversions per channel since :meth:`reset`."""
        return dict(zip(_CHANNELS, (int(n) for n in self._saturations)))

    def reset(self) -> None:
        """Back to rest at ``t = 0``; the noise generator restarts from :attr:`seed`."""
        self.actuator.reset()
        self._rng = np.random.default_rng(self._seed_sequence)
        self._noise_block: list[list[float]] = []
        self._noise_array = np.zeros((self.NOISE_BLOCK, 3))  # the same draws (compiled step)
        self._noise_next = 0
        self._saturations = np.zeros(3, dtype=np.int64)  # per channel of _CHANNELS
        self._steps = 0
        self._kinematics = Kinematics(0.0, 0.0, 0.0)
        self._force = 0.0
        self._command = 0.0
        self._command_dac = 0.0
        self._measured = (0.0, 0.0)
        self.draw_noise()  # the first block now, not inside step 0 (the same draws)

    def draw_noise(self) -> None:
        """Draw the next :attr:`NOISE_BLOCK` steps of converter noise [V] (the step does when
        the block is used up; so does the loop's compiled path, at the same step)."""
        draws = self._rng.standard_normal((self.NOISE_BLOCK, 3)) * self._noise_rms
        self._noise_array[:] = draws
        self._noise_block, self._noise_next = draws.tolist(), 0

    def prepare(self) -> None:
        """Do now what the next step would otherwise start with: draw the next block of
        converter noise when this one is used up (the same draws, at the same place in the
        sequence).  The real-time specimen calls it after answering a step, in the time before
        the next command: inside the step, the draw made the step after every 256th late (79 of
        80 such steps missed their deadline at load 5)."""
        if self._noise_next == len(self._noise_block):
            self.draw_noise()

    def compiled_step(self) -> CompiledStep | None:
        """The lab's step for the loop's fused kernel (:mod:`rths.core.compiled`; family
        ``"lab_tf_imd"``, :func:`plants.lab_kernel.lab_step`), or None unless the actuator and
        its specimen offer theirs (a transfer-function actuator driving an IMD model) and the
        compiled converters are on."""
        offer = getattr(self.actuator, "compiled_step", None)
        act = offer() if offer is not None and self.use_jit else None
        if act is None or act.family != "transfer_function_imd":
            return None
        lab = np.zeros(len(LAB_STATE))
        lab[0] = self._noise_next if self._noise_block else self.NOISE_BLOCK  # (used up)
        lab[1], lab[2], lab[3] = self._steps, self._command, self._command_dac
        lab[4:7] = self._kinematics
        lab[7], lab[8:10] = self._force, self._measured

        def commit() -> None:
            act.commit()
            self._noise_next = int(lab[0]) if self._noise_block else 0
            self._steps = int(lab[1])
            self._command, self._command_dac = float(lab[2]), float(lab[3])
            self._kinematics = Kinematics(*lab[4:7].tolist())
            self._force = float(lab[7])
            self._measured = (float(lab[8]), float(lab[9]))

        constants = (self._constant_table, *act.constants)
        state = (self._noise_array, self._saturations, lab, *act.state)
        return CompiledStep("lab_tf_imd", constants, state, commit)

    def step(self, command: float) -> tuple[float, float]:
        """Send ``command`` [m] through the DAC, advance one step and read both ADCs.

        Returns
        -------
        tuple
            Measured displacement [m] and measured force [N] at the end of the step.
        """
        command = check_finite(command, "lab command")
        dac, adc_x, adc_f = self._constants
        if self._noise_next == len(self._noise_block):
            self.draw_noise()
        noise = self._noise_block[self._noise_next]
        self._noise_next += 1
        if self.use_jit:
            table, saturations = self._constant_table, self._saturations
            command_dac = convert_counting(command, noise[0], table, 0, saturations)
            kinematics, force = self.actuator.step(command_dac)
            measured = (
                convert_counting(kinematics.displacement, noise[1], table, 1, saturations),
                convert_counting(force, noise[2], table, 2, saturations),
            )
            self._steps += 1
            self._kinematics, self._force = kinematics, force
            self._command, self._command_dac = command, command_dac
            self._measured = measured
            return measured
        command_dac, sat_u = convert(command, noise[0], *dac)
        kinematics, force = self.actuator.step(command_dac)
        displacement, sat_x = convert(kinematics.displacement, noise[1], *adc_x)
        measured_force, sat_f = convert(force, noise[2], *adc_f)
        if sat_u or sat_x or sat_f:
            saturations = self._saturations
            saturations[0] += sat_u
            saturations[1] += sat_x
            saturations[2] += sat_f
        self._steps += 1
        self._kinematics, self._force = kinematics, force
        self._command, self._command_dac = command, command_dac
        self._measured = (displacement, measured_force)
        return self._measured

    def truth(self) -> dict[str, float]:
        """True and measured signals after the last step, for logging (SI).

        Keys: ``t`` [s], ``command`` and ``command_dac`` [m], ``displacement`` [m], ``velocity``
        [m/s], ``acceleration`` [m/s^2], ``force`` [N], ``measured_displacement`` [m],
        ``measured_force`` [N], then the actuator's ``state()`` (if it has one) under
        ``actuator.<name>``.
        """
        k = self._kinematics
        out = {
            "t": self.time,
            "command": self._command,
            "command_dac": self._command_dac,
            "displacement": k.displacement,
            "velocity": k.velocity,
            "acceleration": k.acceleration,
            "force": self._force,
            "measured_displacement": self._measured[0],
            "measured_force": self._measured[1],
        }
        state = getattr(self.actuator, "state", None)
        if state is not None:
            out.update({f"actuator.{name}": value for name, value in state().items()})
        return out

    def channels(self) -> tuple[Channel, ...]:
        """Declared channels of :meth:`write_channels`: :data:`LAB_CHANNELS`, then the actuator's as
        ``actuator.<name>`` (the keys of :meth:`truth`, in the same order)."""
        act = tuple(
            Channel("actuator." + c.name, c.unit, c.description) for c in self.actuator.channels()
        )
        return LAB_CHANNELS + act

    def write_channels(self, out: NDArray[np.float64]) -> None:
        """Write this step's values of :meth:`channels` into ``out`` (a preallocated row)."""
        k = self._kinematics
        n = len(LAB_CHANNELS)
        out[:n] = (
            self.time,
            self._command,
            self._command_dac,
            k.displacement,
            k.velocity,
            k.acceleration,
            self._force,
            self._measured[0],
            self._measured[1],
        )
        if out.size > n:
            self.actuator.write_channels(out[n:])
