"""Oracles for plants.lab: converter quantisation, saturation, noise statistics, reproducibility."""

from __future__ import annotations

import math

import numpy as np
import pytest

from plants.actuator import ServoHydraulicActuator, TransferFunctionActuator
from plants.lab import Converter, EmulatedLab, LabConverters
from plants.linear_specimen import LinearSpecimen, benchmark_specimen
from rths.core.errors import ParameterError

DT = 1.0 / 4096.0
QUIET = LabConverters(
    Converter(0.02), Converter(0.02), Converter(1e5 / 3.8)
)  # benchmark converters without noise


def benchmark_lab(converters: LabConverters | None = None, seed: int | None = 0) -> EmulatedLab:
    return EmulatedLab(ServoHydraulicActuator(benchmark_specimen(), DT), converters, seed=seed)


@pytest.mark.parametrize("bits", [8, 18])
def test_quantisation_error_is_at_most_half_an_lsb(bits: int) -> None:
    c = Converter(0.02, bits=bits)
    values = np.random.default_rng(bits).uniform(-c.span, c.span - c.resolution, 20000)
    converted = np.array([c.convert(v)[0] for v in values])
    error = np.abs(converted - values)
    assert np.max(error) <= c.resolution / 2 * (1 + 1e-9)  # rounding to the nearest code
    assert np.max(error) > 0.49 * c.resolution  # and the bound is attained (uniform values)
    np.testing.assert_array_equal(c.quantise(values), converted)
    assert c.lsb == pytest.approx(7.6 / 2**bits, rel=1e-15)  # +/-3.8 V over 2^bits codes


def test_saturation_clips_to_the_end_codes_and_is_counted() -> None:
    c = Converter(0.02, bits=8)
    assert c.convert(10 * c.span) == (127 * c.resolution, True)
    assert c.convert(-10 * c.span) == (-128 * c.resolution, True)
    assert c.convert(0.5 * c.span) == (0.5 * c.span, False)
    lab = benchmark_lab(QUIET)
    span = QUIET.command.span  # 76 mm
    for command in (0.0, 2 * span, -3 * span, 0.001):
        lab.step(command)
    assert lab.saturation_counts == {"command": 2, "displacement": 0, "force": 0}
    assert lab.truth()["command"] == 0.001
    lab.reset()
    assert lab.saturation_counts == {"command": 0, "displacement": 0, "force": 0}


def test_force_channel_saturation() -> None:
    force_adc = Converter(1.0, bits=12)  # +/-3.8 N
    converters = LabConverters(Converter(0.02), Converter(0.02), force_adc)
    ideal = TransferFunctionActuator([1.0], [1.0], LinearSpecimen(0, 0, 1e6), DT)
    lab = EmulatedLab(ideal, converters)
    _, force = lab.step(0.001)  # 1000 N through a 3.8 N channel
    assert lab.saturation_counts["force"] == 1
    assert force == pytest.approx(2047 * converters.force.resolution, rel=1e-15)


def test_noise_rms_within_statistical_band() -> None:
    lab = benchmark_lab(seed=123)
    n = 20000
    measured = np.array([lab.step(0.0) for _ in range(n)])  # at rest: the truth is exactly 0
    assert lab.kinematics.displacement == 0.0 and lab.force == 0.0
    for column, channel in ((0, lab.converters.displacement), (1, lab.converters.force)):
        # Gaussian noise plus uniform quantisation noise (lsb^2/12, negligible at 18 bit)
        sigma = math.sqrt(channel.noise_rms**2 + channel.lsb**2 / 12) * channel.units_per_volt
        rms = np.sqrt(np.mean(measured[:, column] ** 2))
        # se of the sample RMS of n Gaussian values: sigma / sqrt(2n); 5-sigma band (2.5 %)
        assert rms == pytest.approx(sigma, rel=5 / math.sqrt(2 * n))
        assert abs(measured[:, column].mean()) < 5 * sigma / math.sqrt(n)
    assert np.corrcoef(measured.T)[0, 1] == pytest.approx(0.0, abs=5 / math.sqrt(n))  # independent


def test_noise_is_reproducible_by_seed_and_after_reset() -> None:
    command = 0.002 * np.sin(np.arange(300) * 0.05)
    lab = benchmark_lab(seed=42)
    first = [lab.step(u) for u in command]
    lab.reset()
    assert [lab.step(u) for u in command] == first
    same, other = benchmark_lab(seed=42), benchmark_lab(seed=43)
    assert [same.step(u) for u in command[:5]] == first[:5]
    assert [other.step(u) for u in command[:5]] != first[:5]
    fresh = benchmark_lab(seed=None)  # OS entropy, recorded in .seed
    trace = [fresh.step(u) for u in command[:5]]
    replay = benchmark_lab(seed=fresh.seed)
    assert [replay.step(u) for u in command[:5]] == trace


def test_noise_free_lab_is_the_quantised_actuator() -> None:
    command = 0.003 * np.sin(2 * math.pi * 2 * np.arange(2000) * DT)
    lab = benchmark_lab(QUIET)
    reference = ServoHydraulicActuator(benchmark_specimen(), DT)
    for u in command:
        y, f = lab.step(u)
        kinematics, force = reference.step(QUIET.command.quantise(u))
        assert y == QUIET.displacement.quantise(kinematics.displacement)
        assert f == QUIET.force.quantise(force)
    truth = lab.truth()
    assert truth["displacement"] == kinematics.displacement and truth["force"] == force
    assert truth["t"] == pytest.approx(2000 * DT, rel=1e-15) and lab.dt == DT
    assert truth["measured_force"] == f and truth["command_dac"] == QUIET.command.quantise(u)
    assert "actuator.hydraulic_force" in truth and "actuator.specimen.spring_force" in truth


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"units_per_volt": 0.0}, "units_per_volt must be positive; got 0.0"),
        ({"units_per_volt": 1.0, "bits": 0}, "converter bits must be a positive integer; got 0"),
        ({"units_per_volt": 1.0, "bits": 16.0}, "converter bits must be a positive integer"),
        ({"units_per_volt": 1.0, "bits": 33}, "converter bits must be at most 32; got 33"),
        ({"units_per_volt": 1.0, "full_scale": -3.8}, "full_scale must be positive; got -3.8"),
        ({"units_per_volt": 1.0, "noise_rms": -0.1}, "noise_rms must be non-negative; got -0.1"),
    ],
)
def test_converter_validation(kwargs: dict[str, float], match: str) -> None:
    with pytest.raises(ParameterError, match=match):
        Converter(**kwargs)


def test_lab_validation() -> None:
    with pytest.raises(ParameterError, match="LabConverters.force must be a Converter; got 3"):
        LabConverters(force=3)
    with pytest.raises(ParameterError, match="actuator must be a plants.Actuator; got 'a'"):
        EmulatedLab("a")
    actuator = ServoHydraulicActuator(benchmark_specimen(), DT)
    with pytest.raises(ParameterError, match="converters must be LabConverters; got 1"):
        EmulatedLab(actuator, 1)
    with pytest.raises(ParameterError, match="lab command must be finite; got inf"):
        EmulatedLab(actuator).step(math.inf)


def test_block_noise_equals_per_step_draws():
    """Noise is drawn NOISE_BLOCK steps at a time; a lab drawing one step at a time (block of 1)
    with the same seed gives identical outputs, so a logged seed reproduces a run whatever the
    block size."""

    def lab(block: int) -> EmulatedLab:
        conv = LabConverters(
            command=Converter(0.02, noise_rms=0.01),
            displacement=Converter(0.02, noise_rms=0.01),
            force=Converter(100.0, noise_rms=0.01),
        )
        specimen = LinearSpecimen(1.0, 10.0, 1e4)
        out = EmulatedLab(TransferFunctionActuator([1.0], [1.0, 1.0], specimen, 1e-3), conv, seed=7)
        out.NOISE_BLOCK = block
        out.reset()
        return out

    blocked, single, prepared = lab(EmulatedLab.NOISE_BLOCK), lab(1), lab(EmulatedLab.NOISE_BLOCK)
    n = 2 * EmulatedLab.NOISE_BLOCK + 10
    cmd = 0.001 * np.sin(np.arange(n) * 0.01)

    def step_then_prepare(u: float) -> tuple[float, float]:
        out = prepared.step(u)
        prepared.prepare()  # the next block drawn between steps (the real-time specimen)
        return out

    expected = [single.step(u) for u in cmd]
    assert [blocked.step(u) for u in cmd] == expected
    assert [step_then_prepare(u) for u in cmd] == expected


def test_compiled_converters_are_the_python_path_bit_for_bit() -> None:
    """EmulatedLab(use_jit=True) converts with plants.lab_kernel; the same operations in the
    same order as plants.lab.convert (the reference, use_jit=False): equal bit for bit, noise,
    every channel's saturations and exact halves between codes included."""
    conv = LabConverters(
        command=Converter(0.02, bits=10, full_scale=1.0),  # noise-free: the halves stay halves
        displacement=Converter(0.02, bits=10, full_scale=1.0, noise_rms=0.002),
        force=Converter(100.0, bits=10, full_scale=1.0, noise_rms=0.002),
    )
    n = 3000
    cmd = 0.03 * np.sin(np.arange(n) * 0.01)  # +/-30 mm through a +/-20 mm range
    cmd[::40] = np.round(cmd[::40] / conv.command.resolution) * conv.command.resolution
    cmd[::40] += 0.5 * conv.command.resolution  # exact halves between codes
    runs = []
    for use_jit in (True, False):
        act = TransferFunctionActuator([1.0], [1.0], LinearSpecimen(0.0, 0.0, 6e3), DT)
        lab = EmulatedLab(act, conv, seed=11, use_jit=use_jit)
        runs.append(([lab.step(u) for u in cmd], lab.saturation_counts, lab.truth()))
    assert runs[0] == runs[1]
    assert all(count > 100 for count in runs[0][1].values())
