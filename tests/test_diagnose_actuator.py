"""The actuator channel of the diagnosis: cross-validation folds, the orifice-law column, the
rate limit's "limit held" check, the flow limit inside the loop (against an independent
integration) and its two structures told apart, the model-form resolution, and one
end-to-end delay case of a servo-valve with the square-root flow law
(``tools/servogen.py``, written without the diagnosis code)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate, signal

from plants.lines import rate_limited
from rths.diagnose import load_nominal, load_record
from rths.diagnose.channels import Channel, Segment, actuator_channel
from rths.diagnose.data.nominal import ActuatorNominal, NominalModel, SpecimenNominal
from rths.diagnose.effects import ActuatorModel
from rths.diagnose.effects.kernels import loop_rate_limited
from rths.diagnose.search.crossval import blocked
from rths.diagnose.search.selection import select

TOOLS = Path(__file__).resolve().parents[1] / "tools"
DT = 1.0 / 1000.0
W = 2 * math.pi * 10.0  # first-order nominal actuator, 10 Hz


def _channel(
    observed: list[np.ndarray],
    command: list[np.ndarray],
    flow=None,
    force: list[np.ndarray] | None = None,
    nominal: NominalModel | None = None,
) -> Channel:
    nominal = nominal or NominalModel(ActuatorNominal((W,), (1.0, W), 0.0), SpecimenNominal(0.0))
    segs = []
    for i, (y, u) in enumerate(zip(observed, command, strict=True)):
        n = y.size
        ident = np.zeros(n, bool)
        ident[50 : n - 50] = True
        signals = {
            "command": u,
            "dforce": np.zeros(n),
            "load_flow": np.zeros(n) if flow is None else flow,
        }
        if force is not None:
            signals["reactive"] = force[i]
        segs.append(Segment(f"r{i}", i, DT, y, signals, ident, np.zeros(n, bool)))
    noise = {"measured": 1e-7, "force": 1.0, "command": 0.0}
    return Channel("measured", "actuator", segs, nominal, noise)


def test_block_folds_partition_every_record_and_exchange_roles():
    n = 1200
    ch = _channel([np.zeros(n), np.zeros(n)], [np.zeros(n), np.zeros(n)])
    a, b = blocked(ch, 0), blocked(ch, 1)
    for s, sa, sb in zip(ch.segments, a.segments, b.segments, strict=True):
        scored = s.ident | s.held
        assert np.array_equal(sa.ident | sa.held, scored)
        assert not np.any(sa.ident & sa.held)
        assert np.array_equal(sa.ident, sb.held) and np.array_equal(sa.held, sb.ident)
        assert np.any(sa.ident) and np.any(sa.held)  # every record in both roles


def test_orifice_column_is_the_loop_sensitivity_over_s():
    # T = w/(s+w): S(s)/s = 1/(s+w); a constant |v| F = q settles at q/w (exact ZOH model)
    n = 2000
    q = 3.0
    ch = _channel([np.zeros(n)], [np.zeros(n)], flow=np.full(n, q))
    col = ActuatorModel()._flow_column(ch, ch.segments[0])[:, 0]
    t = np.arange(n) * DT
    # ZOH-exact first-order step response from rest (the input applied from t_0 first seen
    # at t_1: the DAQ convention)
    expected = q / W * (1.0 - np.exp(-W * t))
    assert col[0] == 0.0
    assert col == pytest.approx(expected, rel=1e-9, abs=1e-12)


def _sine_channel(limit: float | None, sag: float = 1.0) -> tuple[Channel, ActuatorModel]:
    t = np.arange(4000) * DT
    u = 0.02 * np.sin(2 * math.pi * 1.5 * t)
    m = ActuatorModel(("rate_limit",))
    ch = _channel([np.zeros(t.size)], [u])
    y = m._linear(ch, ch.segments[0], {"shift": 0.0})
    ch.segments[0].observed = y if limit is None else rate_limited(y, sag * limit, DT)
    return ch, m


def test_rate_limit_is_held_where_the_motion_is_limited():
    # peak linear speed 0.02 * 2 pi 1.5 / |1 + j 0.15| = 0.187 m/s; limit 0.1 m/s clips
    ch, m = _sine_channel(0.1)
    assert m.physical(ch, {"rate_limit": {"velocity_limit": 0.1}})
    # a plateau sagging 5 % below the fitted limit (a valve's flow at load pressure) holds
    ch, m = _sine_channel(0.1, sag=0.95)
    assert m.physical(ch, {"rate_limit": {"velocity_limit": 0.1}})


def test_rate_limit_that_is_never_reached_is_rejected():
    # a linear attenuation (a limiter fitted to mimic it): the measured speed peaks at
    # 0.45 * 0.187 = 0.084 m/s, below the 0.1 m/s claimed
    ch, m = _sine_channel(None)
    ch.segments[0].observed = 0.45 * ch.segments[0].observed
    assert not m.physical(ch, {"rate_limit": {"velocity_limit": 0.1}})
    # and where the limiter is active the motion sags far below a claimed limit
    ch, m = _sine_channel(0.1, sag=0.7)
    assert not m.physical(ch, {"rate_limit": {"velocity_limit": 0.1}})


def test_a_limit_the_drive_exceeds_by_a_tenth_is_checked_on_the_top_of_its_excess():
    # peak linear speed 0.187 m/s (above); a limit 10 % below it clips only the crests: no
    # sample of the linear motion is 20 % above the limit, so the check reads the samples
    # above half the excess (5 %), where the clipped motion sits on the limit
    v_max = 0.187 / 1.1
    ch, m = _sine_channel(v_max)
    assert m.physical(ch, {"rate_limit": {"velocity_limit": v_max}})
    # the same claim on an attenuated motion (0.45 of the linear one) is still refused: the
    # measured speed never comes near the limit
    ch, m = _sine_channel(None)
    ch.segments[0].observed = 0.45 * ch.segments[0].observed
    assert not m.physical(ch, {"rate_limit": {"velocity_limit": v_max}})
    # and a limit exceeded by 3 % -- within the gain's calibration -- shows nothing of its own
    ch, m = _sine_channel(0.187 / 1.03)
    assert not m.physical(ch, {"rate_limit": {"velocity_limit": 0.187 / 1.03}})


def test_a_limit_exceeded_by_less_than_the_gain_error_is_held_from_a_small_record():
    # the actuator's gain is 1.1 against the nominal's 1: a 0.1 m/s limit clips a sine whose
    # true peak speed is 0.125 m/s, which the nominal's linear motion puts at 0.114 m/s (only
    # 14 % above the limit); a second record at a twelfth of the amplitude (peak 0.010 m/s,
    # a tenth of the limit, 700 times the secant speed's noise) never touches the limit
    # and gives the gain, so the linear motion is read at 0.125 m/s
    t = np.arange(4000) * DT
    m = ActuatorModel(("rate_limit",))
    commands = [a * np.sin(2 * math.pi * 1.5 * t) for a in (0.01215, 0.001)]
    ch = _channel([np.zeros(t.size)] * 2, commands)
    for s in ch.segments:
        s.observed = rate_limited(1.1 * m._linear(ch, s, {"shift": 0.0}), 0.1, DT)
    assert m._free_gain(ch, [m._linear(ch, s, {"shift": 0.0}) for s in ch.segments], 0.1, 5) == (
        pytest.approx(1.1, rel=1e-3)
    )
    assert m.physical(ch, {"rate_limit": {"velocity_limit": 0.1}})
    # the small record's linear speed stays below a fifth of the limit: no sample of it is
    # "near" the limit, and only the noise bounds the speeds that calibrate the gain
    small = m._linear(ch, ch.segments[1], {"shift": 0.0})
    assert np.max(np.abs(np.diff(small))) / DT < 0.2 * 0.1


def test_resolution_is_a_one_sample_shift_of_a_sine():
    # mean square of A sin(w t) - A sin(w (t - dt)) is A^2 (1 - cos(w dt)) over whole periods
    # (1200 samples scored: 3 periods of 2.5 Hz at 1 kHz; the rest is rounding)
    a, f = 0.01, 2.5
    t = np.arange(1300) * DT
    p = a * np.sin(2 * math.pi * f * t)
    ch = _channel([p], [p])
    got = ActuatorModel().resolution(ch, [p])
    assert got == pytest.approx(a * a * (1.0 - math.cos(2 * math.pi * f * DT)), rel=1e-9)


def test_square_root_flow_law_with_extra_delay_names_it(tmp_path):
    sys.path.insert(0, str(TOOLS))
    from servogen import build_case

    # 1000 Hz, 3 s records keep the test short
    label = build_case(np.random.default_rng(4), "actuator_delay", tmp_path, 3.0, 1000.0)
    records = [load_record(f) for f in sorted(tmp_path.glob("rec_*.csv"))]
    nominal = load_nominal(tmp_path / "NOMINAL.toml")
    r = select(actuator_channel(records, nominal, 30.0), ("actuator_delay", "rate_limit"))
    truth = label["effects"][0]["params"]["delay"]
    assert r.verdict == "actuator_delay"
    # a delay trades against the +/-10 % pole calibration, worth 10 % of the nominal's
    # low-frequency group delay a1/a0 - b1/b0 (~1.6 ms for a 10 Hz loop), plus one sample
    # (the nominal delay's own calibration error is up to 0.4 sample)
    num, den = nominal.actuator.num, nominal.actuator.den
    lag = den[-2] / den[-1] - (num[-2] / num[-1] if len(num) > 1 else 0.0)
    found = r.final.params["actuator_delay"]["delay"]
    assert abs(found - truth) <= 0.1 * lag + 1.0 / label["rate"]


def _broadband(n: int, seed: int) -> np.ndarray:
    """Band-limited random command (0-20 Hz at 1 kHz), 10 mm RMS: a delay and a slower pole
    differ in phase across the band (a single sine cannot tell them apart)."""
    from scipy import signal

    rng = np.random.default_rng(seed)
    sos = signal.butter(4, 20.0 * 2 * DT, output="sos")
    u = signal.sosfilt(sos, rng.standard_normal(n))
    return 0.01 * u / np.std(u)


def _response(u: np.ndarray, pole_hz: float, delay_samples: float) -> np.ndarray:
    """``u`` through ``w/(s + w)`` (ZOH, the DAQ convention of the channel) then delayed."""
    from scipy import signal

    from rths.diagnose.channels.signals import discrete_tf, shifted

    w = 2 * math.pi * pole_hz
    b, a = discrete_tf((w,), (1.0, w), DT)
    return shifted(signal.lfilter(b, a, u), delay_samples)


@pytest.mark.parametrize("pole_scale", [1.0, 0.95])
def test_pure_delay_of_known_samples_is_identified(pole_scale):
    # a pure 6-sample (6 ms) delay behind the nominal TF, and behind one whose pole is 5 %
    # slower (calibration within the +/-10 % tolerance); noise-free but for 1 um white noise.
    # Oracle: the delay is the applied one.  Tolerance: 0.2 sample exact TF; with the slower
    # pole, the trade-off the +/-10 % calibration allows is 10 % of the pole's group delay
    # 1/w = 15.9 ms at low frequency, broadband excitation pins it far tighter: 1 sample
    n = 4000
    rng = np.random.default_rng(3)
    cmds = [_broadband(n, 1), _broadband(n, 2)]
    obs = [_response(u, 10.0 * pole_scale, 6.0) + 1e-6 * rng.standard_normal(n) for u in cmds]
    ch = _channel(obs, cmds)
    for s in ch.segments:  # second half of every record held out
        s.held[n // 2 : n - 50] = True
        s.ident[n // 2 :] = False
    r = select(ch, ("actuator_delay",))
    assert r.verdict == "actuator_delay"
    found = r.final.params["actuator_delay"]["delay"]
    tol = 0.2 if pole_scale == 1.0 else 1.0
    assert abs(found / DT - 6.0) <= tol
    assert r.closed >= 0.9


def test_an_advance_is_no_delay():
    # the actuator faster than the nominal (an advance beyond the nominal's delay) is model
    # form of the nominal, never the reference-path effect; a lag of one sample or less is
    # alignment (calibration)
    ch = _channel([np.zeros(100)], [np.zeros(100)])
    m = ActuatorModel(("actuator_delay",))
    assert m.physical(ch, {"actuator_delay": {"delay": 3 * DT}})
    assert not m.physical(ch, {"actuator_delay": {"delay": 0.9 * DT}})
    assert not m.physical(ch, {"actuator_delay": {"delay": -3 * DT}})


def test_miscalibrated_nominal_without_effect_is_none():
    # truth: the nominal's pole 7 % faster, gain 3 % high, no delay; the re-calibration
    # (within its +/-10 % tolerance) reaches the noise floor: none
    n = 4000
    rng = np.random.default_rng(5)
    cmds = [_broadband(n, 4), _broadband(n, 5)]
    obs = [1.03 * _response(u, 10.7, 0.0) + 1e-6 * rng.standard_normal(n) for u in cmds]
    ch = _channel(obs, cmds)
    ch.noise["measured"] = 1e-6
    for s in ch.segments:
        s.held[n // 2 : n - 50] = True
        s.ident[n // 2 :] = False
    r = select(ch, ("actuator_delay", "rate_limit"))
    assert r.verdict == "none"
    assert r.effects == ()


def test_rootwise_calibration_with_equal_factors_is_the_common_one():
    # two implementations, one answer: every root scaled by the same factors is the
    # baseline's common re-calibration (5th-order servo TF: a real pole, two complex pairs,
    # a real zero); unit factors give the nominal back
    from rths.diagnose.effects.actuator import scaled_tf
    from rths.diagnose.effects.calibration import root_modes, rootwise_tf

    num = (1.0e10, 1.2e11)
    den = (1.0, 416.5, 1.39e6, 1.73e8, 1.09e10, 1.26e11)
    nz, npl = len(root_modes(num)), len(root_modes(den))
    assert (nz, npl) == (1, 3)
    for f, d in [(1.0, 1.0), (0.93, 1.07), (1.1, 0.9)]:
        b, a = rootwise_tf(num, den, [f] * nz, [f] * npl, [d] * npl)
        b0, a0 = scaled_tf(num, den, f, d)
        w = 2 * math.pi * np.array([0.5, 5.0, 50.0])
        h = np.polyval(b, 1j * w) / np.polyval(a, 1j * w)
        h0 = np.polyval(b0, 1j * w) / np.polyval(a0, 1j * w)
        assert h == pytest.approx(h0, rel=1e-9)


def test_rootwise_calibration_taking_on_a_sample_of_lag_is_no_model_form():
    # the 10 Hz pole's group delay is 1/W = 15.9 ms: at -10 % it adds 1.77 ms (1.77 samples
    # at 1 kHz), at -3 % 0.49 ms; the alignment adds its own share of a sample
    from rths.diagnose.effects.calibration import RootwiseActuator

    ch = _channel([np.zeros(100)], [np.zeros(100)])
    m = RootwiseActuator()
    m.prepare(ch, {})
    assert [p.name for p in m.space(ch)] == ["pole_0", "shift"]
    assert m.lagging(ch, {"pole_0": 0.9, "shift": 0.0})
    assert m.lagging(ch, {"pole_0": 1.0, "shift": 1.0})
    assert m.lagging(ch, {"pole_0": 0.95, "shift": 0.5})  # 0.84 ms + 0.5 ms
    assert not m.lagging(ch, {"pole_0": 1.1, "shift": -1.0})
    assert not m.lagging(ch, {"pole_0": 0.97, "shift": 0.3})  # 0.49 ms + 0.3 ms
    assert not m.lagging(ch, {"pole_0": 1.1, "shift": 1.0})  # -1.45 ms + 1 ms


def test_rootwise_calibration_slowing_one_root_and_speeding_another_is_model_form():
    # nominal 10 Hz real pole and 40 Hz pair (zeta 0.7): group delays 15.9 ms and
    # 2 zeta/w = 5.6 ms; the pair 10 % slower (+0.62 ms) beside the real pole 4 % faster
    # (-0.61 ms) nets no lag although a pole sits at the tolerance's slow bound
    from rths.diagnose.data.nominal import ActuatorNominal, NominalModel, SpecimenNominal
    from rths.diagnose.effects.calibration import RootwiseActuator, group_delay, rootwise_tf

    wn, z = 2 * math.pi * 40.0, 0.7
    den = tuple(np.polymul([1.0, W], [1.0, 2 * z * wn, wn * wn]))
    nominal = NominalModel(ActuatorNominal((W * wn * wn,), den, 0.0), SpecimenNominal(0.0))
    ch = _channel([np.zeros(100)], [np.zeros(100)])
    ch = Channel("measured", "actuator", ch.segments, nominal, ch.noise)
    m = RootwiseActuator()
    m.prepare(ch, {})
    names = [p.name for p in m.space(ch)]
    assert names == ["pole_0", "damping_0", "pole_1", "shift"]
    theta = {"pole_0": 1.0, "damping_0": 1.0, "pole_1": 1.0, "shift": 0.0}
    pair = next(i for i in (0, 1) if f"damping_{i}" in names)
    real = 1 - pair
    b, a = rootwise_tf((W * wn * wn,), den, [], [1.0, 1.0], [1.0, 1.0])
    assert group_delay(b, a) == pytest.approx(1 / W + 2 * z / wn, rel=1e-9)
    slow = {**theta, f"pole_{pair}": 0.9, f"pole_{real}": 1.04}
    assert not m.lagging(ch, slow)
    assert m.lagging(ch, {**theta, f"pole_{pair}": 0.9, f"pole_{real}": 0.95})  # +1.46 ms


def _two_mode_channel(delay_samples: int, seed: int) -> Channel:
    """A third-order servo loop (a real pole at 8 Hz and a pair at 30 Hz, zeta 0.6) as the
    nominal; the truth has every root off by its own factor within the +/-10 % tolerance
    (real pole 8 % slower, pair 9 % faster and 8 % more damped: no common factor follows),
    discretised by scipy's own ZOH and delayed by whole samples; 1 um white noise."""
    from scipy import signal

    def tf(f_real: float, f_pair: float, zeta: float) -> tuple[np.ndarray, np.ndarray]:
        a, w = 2 * math.pi * f_real, 2 * math.pi * f_pair
        den = np.polymul([1.0, a], [1.0, 2 * zeta * w, w * w])
        return np.array([a * w * w]), den

    num0, den0 = tf(8.0, 30.0, 0.6)
    num, den = tf(8.0 * 0.92, 30.0 * 1.09, 0.6 * 1.08)
    b, a, _ = signal.cont2discrete((num, den), DT, method="zoh")
    n = 4000
    rng = np.random.default_rng(seed)
    cmds = [_broadband(n, seed + 10), _broadband(n, seed + 11)]
    obs = []
    for u in cmds:
        y = signal.lfilter(np.ravel(b), a, u)
        y = np.concatenate([np.zeros(delay_samples), y[: n - delay_samples]])
        obs.append(y + 1e-6 * rng.standard_normal(n))
    ch = _channel(obs, cmds)
    ch.nominal = NominalModel(ActuatorNominal(tuple(num0), tuple(den0), 0.0), SpecimenNominal(0.0))
    ch.noise["measured"] = 1e-6
    for s in ch.segments:  # second half of every record held out
        s.held[n // 2 : n - 50] = True
        s.ident[n // 2 :] = False
    return ch


@pytest.mark.parametrize("delay_samples", [2, 4])
def test_delay_behind_a_nominal_miscalibrated_root_by_root_is_named(delay_samples):
    # truth: a pure delay of 2 or 4 samples beyond the nominal, behind a TF whose roots are
    # each off by their own factor (within the contract's +/-10 %).  The common
    # re-calibration cannot follow the roots, so with it the delay closes only part of the
    # gap; judged against the nominal calibrated root by root it must be named.  Oracle:
    # the applied delay; tolerance one sample (the calibration's +/-10 % trades against
    # a delay's lag; broadband excitation pins it within a sample)
    ch = _two_mode_channel(delay_samples, 21)
    r = select(ch, ("actuator_delay", "rate_limit"))
    assert r.verdict == "actuator_delay"
    assert r.effects == ("actuator_delay",)
    found = r.final.params["actuator_delay"]["delay"]
    assert abs(found / DT - delay_samples) <= 1.0
    assert r.closed >= 0.9


def test_root_by_root_miscalibration_alone_is_no_delay():
    # the same mis-calibrated roots and no delay: the nominal's own parameters explain it
    ch = _two_mode_channel(0, 22)
    r = select(ch, ("actuator_delay", "rate_limit"))
    assert r.verdict == "none"
    assert "actuator_delay" not in r.effects


def test_absorbed_lag_is_the_group_delay_the_calibration_adds():
    # closed form: w/(s + w) has the low-frequency group delay 1/w; its pole 10 % slower has
    # 1/(0.9 w); the alignment adds itself.  A pair w^2/(s^2 + 2 z w s + w^2): 2 z/w, and
    # with the factors f (frequency) and d (damping): 2 d z/(f w)
    from rths.diagnose.effects.calibration import absorbed_lag

    assert absorbed_lag((W,), (1.0, W), {"frequency_scale": 0.9}) == pytest.approx(
        1.0 / (0.9 * W) - 1.0 / W, rel=1e-9
    )
    assert absorbed_lag((W,), (1.0, W), {"alignment": 1e-3}) == pytest.approx(1e-3, rel=1e-9)
    w, z = 2 * math.pi * 30.0, 0.6
    pair = ((w * w,), (1.0, 2 * z * w, w * w))
    lag = absorbed_lag(*pair, {"frequency_scale": 1.05, "damping_scale": 0.95})
    assert lag == pytest.approx(2 * 0.95 * z / (1.05 * w) - 2 * z / w, rel=1e-9)


def test_a_delay_hidden_in_calibration_at_one_frequency_is_reported_as_calibration_lag():
    # records at one frequency (2 Hz sines): a delay and a pole's phase lag are the same thing
    # there, so a 2-sample delay behind an exact nominal is re-calibrated away (slower pole +
    # alignment) and the verdict is none -- but the lag the calibration took on is reported,
    # and the text says that a delay of up to that cannot be told from calibration.
    # Oracle: the lag equals the hidden delay, 2 ms.  Tolerance 0.15 ms: the calibration
    # matches the phase at 2 Hz, the low-frequency group delay reported differs from the phase
    # delay there by ~(w_2Hz / w_pole)^2 = 4 % of the pole's share, plus 1 um noise.
    from rths.diagnose import Options, diagnose
    from rths.diagnose.data.records import Record
    from rths.diagnose.report import table

    n = 4000
    t = np.arange(n) * DT
    rng = np.random.default_rng(7)
    records = []
    for i, (amp, phase) in enumerate([(0.01, 0.0), (0.008, 0.3)]):
        u = amp * np.sin(2 * math.pi * 2.0 * t + phase)
        x = _response(u, 10.0, 2.0) + 1e-6 * rng.standard_normal(n)
        force = 2000.0 * x + 0.5 * rng.standard_normal(n)  # a 2 kN/m spring, 0.5 N noise
        records.append(Record(f"sine{i}", DT, t, u, x, force))
    nominal = NominalModel(ActuatorNominal((W,), (1.0, W), 0.0), SpecimenNominal(0.0, 0.0, 2000.0))
    d = diagnose(records, nominal, Options(effects=("actuator_delay", "rate_limit")))
    measured = d.to_dict()["channels"]["measured"]
    assert d.channels["measured"].verdict == "none"
    assert measured["calibration_lag_s"] == pytest.approx(2.0 * DT, abs=0.15e-3)
    assert d.to_dict()["channels"]["force"]["calibration_lag_s"] is None
    assert "note: the measured channel's re-calibration took on 2" in table(d)


# -- control-structure interaction: a bare or an installed nominal TF ----------------------------
_MASS, _K_LOOP = 200.0, 2.9e7  # kg on the piston, N/m loop stiffness
_WR, _WN, _ZETA = 2 * math.pi * 25.0, 2 * math.pi * 60.0, 0.6  # the bare loop's poles
_B0 = _WR * _WN**2  # its numerator (unit DC gain)
_BARE = tuple(np.polymul((1.0, _WR), (1.0, 2 * _ZETA * _WN, _WN**2)))


def _zoh(num, den, u: np.ndarray) -> np.ndarray:
    """``u`` (held from each sample) through the continuous ``num/den`` (proper), exactly."""
    from scipy import signal

    b, a, _ = signal.cont2discrete((num, den), DT, method="zoh")
    return signal.lfilter(np.ravel(b), a, u)


def _installed_den() -> tuple[float, ...]:
    """The loop's denominator with the mass installed: ``y = G (u - m s^2 y/K)``, ``G =
    b_0/D(s)``, gives ``D(s) + (b_0 m/K) s^2`` (+25 % on the ``s^2`` coefficient: beyond what
    a +/-10 % common calibration of the poles follows)."""
    return tuple(np.asarray(_BARE) + np.array([0.0, _B0 * _MASS / _K_LOOP, 0.0, 0.0]))


def _interacting(u: np.ndarray, delay: int) -> tuple[np.ndarray, np.ndarray]:
    """The mass on the bare loop behind ``delay`` samples: ``y = wn^2/D(s) u(t - delay)`` and
    ``F = m s^2 y`` (:func:`_installed_den`), closed forms sampled at ``t_k``."""
    ud = np.concatenate([np.zeros(delay), u[: u.size - delay]])
    den = _installed_den()
    return _zoh((_B0,), den, ud), _zoh((_MASS * _B0, 0.0, 0.0), den, ud)


@pytest.mark.parametrize("convention", ["bare", "installed"])
def test_a_delay_behind_either_nominal_convention_is_identified(convention):
    # Oracle: closed-form records of a mass on a loop of compliance 1/K, behind a 4-sample
    # delay.  The nominal is the bare loop's TF (the interaction shows as the column of the
    # nominal specimen's reactive force, here the whole force m y'', coefficient 1/K) or the
    # installed one (the interaction is in the TF: the coefficient is 0).  Tolerances: the
    # model is exact but for the force column's first-order hold (the force is smooth, not
    # linear, between samples: an error of order (w dt)^2/12 of a term worth m w^2/K ~ 3 % of
    # the motion at 10 Hz) and 1 um noise: the delay within 0.25 sample, the compliance within
    # 10 % of 1/K (bare) or under 5 % of it (installed).
    n = 4000
    rng = np.random.default_rng(11)
    cmds = [_broadband(n, 6), _broadband(n, 7)]
    pairs = [_interacting(u, 4) for u in cmds]
    obs = [y + 1e-6 * rng.standard_normal(n) for y, _ in pairs]
    den = _BARE if convention == "bare" else _installed_den()
    nominal = NominalModel(ActuatorNominal((_B0,), den, 0.0), SpecimenNominal(_MASS))
    ch = _channel(obs, cmds, force=[f for _, f in pairs], nominal=nominal)
    ch.noise["measured"] = 1e-6
    for s in ch.segments:
        s.held[n // 2 : n - 50] = True
        s.ident[n // 2 :] = False
    r = select(ch, ("actuator_delay", "rate_limit"))
    assert r.effects == ("actuator_delay",)
    assert abs(r.final.params["actuator_delay"]["delay"] / DT - 4.0) <= 0.25
    compliance = r.final.baseline["loop_compliance"]
    if convention == "bare":
        assert abs(compliance * _K_LOOP - 1.0) <= 0.1
    else:
        assert abs(compliance * _K_LOOP) <= 0.05


def test_loop_limit_matches_the_integrated_saturated_loop():
    # x' = clip(p (z - x), +/- v) integrated by solve_ivp (rtol 1e-10) from the loop's input
    # z = A sin(w t); the kernel sees only the linear response y = p/(s + p) z.  A 30 Hz pole,
    # a demand of 0.094 m/s against a 0.05 m/s limit: the kernel's per-sample clip differs
    # from the continuous one by 4.9e-5 A at 2048 Hz and 3.0e-6 A at 8192 Hz (second order
    # in dt); the bound 2e-4 A is four times the coarser.  The linear motion is 62 % off.
    p, v, a, w = 2 * math.pi * 30.0, 0.05, 0.01, 2 * math.pi * 1.5
    dt = 1.0 / 2048.0
    t = np.arange(0.0, 2.0, dt)
    _, y, _ = signal.lsim(([p], [1.0, p]), a * np.sin(w * t), t)
    sol = integrate.solve_ivp(
        lambda tt, x: [np.clip(p * (a * np.sin(w * tt) - x[0]), -v, v)],
        (0.0, 2.0),
        [0.0],
        t_eval=t,
        rtol=1e-10,
        atol=1e-13,
        max_step=dt,
    )
    x = loop_rate_limited(y, p, v, dt)
    assert np.max(np.abs(x - sol.y[0])) < 2e-4 * a
    assert np.max(np.abs(y - sol.y[0])) > 0.5 * a  # the limit acts


def test_loop_limit_idle_is_the_linear_motion_and_an_infinite_pole_the_output_limiter():
    rng = np.random.default_rng(0)
    y = np.cumsum(rng.standard_normal(3000)) * 1e-5
    # idle: the linear motion, to the round-off of a running sum (|y| < 1e-3 m)
    np.testing.assert_allclose(loop_rate_limited(y, 100.0, 1e3, 1e-3), y, rtol=0, atol=1e-15)
    np.testing.assert_allclose(  # both start at rest: identical to round-off
        loop_rate_limited(y, math.inf, 0.005, 1e-3), rate_limited(y, 0.005, 1e-3), atol=1e-15
    )


@pytest.mark.parametrize(
    ("kind", "structure"), [("loop", "limit inside the loop"), ("output", "limit on the output")]
)
def test_selection_tells_a_loop_limit_from_an_output_limiter(kind: str, structure: str) -> None:
    # a 10 Hz first-order loop (its pole W), two sines (peak speeds 0.19 and 0.17 m/s) and a
    # band-limited record against a 0.1 m/s limit, 1 um noise: the limit is named in the
    # structure that made the records, within 1 % (the two differ only in how a held-back
    # piston recovers)
    n = 3000
    t = np.arange(n) * DT
    rng = np.random.default_rng(3)
    cmds = [
        0.02 * np.sin(2 * math.pi * 1.5 * t),
        0.012 * np.sin(2 * math.pi * 2.3 * t),
        0.5 * _broadband(n, 4),
    ]
    m = ActuatorModel(("rate_limit",))
    ch = _channel([np.zeros(n)] * 3, cmds)
    ch.noise["measured"] = 1e-6
    for s in ch.segments:
        y = m._linear(ch, s, {"shift": 0.0})
        limited = loop_rate_limited(y, W, 0.1, DT) if kind == "loop" else rate_limited(y, 0.1, DT)
        s.observed = limited + 1e-6 * rng.standard_normal(n)
        s.held[n // 2 : n - 50] = True
        s.ident[n // 2 :] = False
    r = select(ch, ("actuator_delay", "rate_limit"))
    assert r.effects == ("rate_limit",)
    assert r.final.model.structure == structure
    assert r.final.params["rate_limit"]["velocity_limit"] == pytest.approx(0.1, rel=0.01)


def test_band_lag_is_the_delay_a_calibration_mimics_over_the_drive():
    # a pole 10 % slower under a 0.5-2 Hz drive: its extra phase is omega (1/(0.9 W) - 1/W) to
    # within (omega/W)^2 < 4 % at 10 Hz, so the fitted delay is the group-delay change; a
    # pole-zero pair at 0.06 Hz mis-set apart adds a phase falling as 1/omega, which mimics
    # almost no delay over the same band although its DC group delay moves by 0.43 s
    from rths.diagnose.effects.calibration import band_lag

    f = np.linspace(0.0, 5.0, 51)
    w = ((f >= 0.5) & (f <= 2.0)).astype(float)
    one = (np.array([W]), np.array([1.0, W]))
    slow = (np.array([0.9 * W]), np.array([1.0, 0.9 * W]))
    assert band_lag(one, slow, (f, w)) == pytest.approx(1 / (0.9 * W) - 1 / W, rel=0.04)
    assert band_lag(one, slow, None) == pytest.approx(1 / (0.9 * W) - 1 / W, rel=1e-9)
    pair0 = (np.array([1.0, 0.336]) * 0.4 / 0.336, np.array([1.0, 0.4]))
    pair1 = (np.array([1.0, 0.366]) * 0.373 / 0.366, np.array([1.0, 0.373]))
    assert band_lag(pair0, pair1, None) == pytest.approx(0.4248, rel=1e-3)
    assert abs(band_lag(pair0, pair1, (f, w))) < 1e-3


def test_loop_columns_are_cached_per_calibration_read_only_and_equal_a_fresh_build():
    # the compliance column moves with the calibration (the reactive force through the
    # re-calibrated TF), the CSI and orifice columns do not; a cached block must equal the
    # block built on an empty cache, for every calibration, and refuse in-place writes
    n = 1500
    rng = np.random.default_rng(3)
    force = [rng.standard_normal(n)]
    flow = rng.standard_normal(n)

    def fresh():
        return _channel([np.zeros(n)], [rng.standard_normal(n)], flow=flow, force=force)

    ch = fresh()
    seg, m = ch.segments[0], ActuatorModel()
    slow = {"frequency_scale": 0.9, "damping_scale": 1.0, "shift": 0.0}
    fast = {"frequency_scale": 1.1, "damping_scale": 1.0, "shift": 0.3}
    first = m._loop_columns(ch, seg, slow)
    assert m._loop_columns(ch, seg, {**slow, "shift": 0.7}) is first  # the shift: no rebuild
    other = m._loop_columns(ch, seg, fast)
    assert not np.allclose(first[:, 0], other[:, 0])  # the compliance column moved
    assert np.array_equal(first[:, 1:], other[:, 1:])  # CSI and orifice columns did not
    ch2 = fresh()
    assert np.array_equal(m._loop_columns(ch2, ch2.segments[0], slow), first)
    with pytest.raises(ValueError):
        first[0, 0] = 1.0
