"""Three gaps that are no effect: coloured transducer noise (read where the records start at
rest), a held-out record at frequencies the identification records did not cover, and a force
read a fraction of a sample ahead of its displacement."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import interpolate, signal

from rths.diagnose.channels import specimen_channel
from rths.diagnose.channels.rest import COLOUR_Z, leading_rest, rest_spectra
from rths.diagnose.data.nominal import ActuatorNominal, NominalModel, SpecimenNominal
from rths.diagnose.data.records import Record
from rths.diagnose.effects.alignment import ALIGNMENT_SAMPLES
from rths.diagnose.effects.specimen import RigidSpecimen
from rths.diagnose.search.selection import select

FS = 1024.0
DT = 1.0 / FS
UNIT = ActuatorNominal((1.0,), (1.0,), 0.0)


def _coloured(rng: np.random.Generator, n: int, white: float, share: float, fc: float):
    """White noise of RMS ``white`` plus a first-order low-passed part at ``fc`` [Hz] holding
    ``share`` of the total variance."""
    b, a = signal.butter(1, fc, fs=FS)
    low = signal.lfilter(b, a, rng.standard_normal(n + 2048))[2048:]
    low *= white * math.sqrt(share / (1.0 - share)) / np.std(low)
    return white * rng.standard_normal(n) + low


def _record(name: str, x: np.ndarray, force: np.ndarray, rest: int) -> Record:
    """``x`` and ``force`` after ``rest`` samples at rest (command held at 0)."""
    n = rest + x.size
    t = DT * np.arange(n)
    u = np.concatenate([np.zeros(rest), x])
    return Record(name, DT, t, u, u.copy(), np.concatenate([np.zeros(rest), force]))


def test_the_noise_colour_is_read_where_the_record_is_at_rest():
    """White noise plus a first-order part at 25 Hz holding a third of the variance: the
    rest's PSD over the white level is ``1 + r |H(f)|^2``, ``H`` the discrete filter and ``r``
    fixed by the part's variance (half the white one), within the pooled Welch estimate's
    scatter (4 standard deviations); where the part has faded (above 200 Hz) the factor is
    white's.  A command that moves from its first sample holds no rest."""
    rng = np.random.default_rng(4)
    n, rest = 4096, 1024
    records = []
    for i in range(4):
        noise = _coloured(rng, n, 1e-6, 1.0 / 3.0, 25.0)
        force = 0.5 * rng.standard_normal(n)
        x = np.zeros(n)
        x[rest:] = 1e-3 * np.sin(2 * math.pi * 2.0 * DT * np.arange(n - rest))
        r = Record(f"r{i}", DT, DT * np.arange(n), x, x + noise, force)
        assert leading_rest(r) == rest + 1 - round(0.02 * FS)  # sin 0 = 0 at sample `rest`
        records.append(r)
    shapes = rest_spectra(records, {"measured": 1e-6, "force": 0.5})
    assert "force" not in shapes  # white: no colour kept
    shape = shapes["measured"]
    b, a = signal.butter(1, 25.0, fs=FS)
    f = shape.frequency
    h2 = np.abs(signal.freqz(b, a, worN=f, fs=FS)[1]) ** 2
    # the low-passed part's variance sum(|H|^2 df) over the one-sided band is `share` of the
    # total; its PSD ratio to the white level 2 s^2 dt is h2 times that scale
    scale = 0.5 / (np.sum(h2) * (f[1] - f[0]) * 2 * DT)
    expected = 1.0 + scale * h2
    low = f < 20.0
    count = 4 * (2 * (rest - 20) / 256 - 1)
    assert np.all(np.abs(shape.factor[low] / expected[low] - 1.0) < 4.0 / math.sqrt(count))
    assert np.all(shape.factor[f > 200.0] < 1.0 + 2 * COLOUR_Z / math.sqrt(count))
    moving = Record("m", DT, DT * np.arange(n), np.ones(n), np.ones(n), force)
    assert leading_rest(moving) == 0 and rest_spectra([moving], {"measured": 1e-6}) == {}


def _rigid_records(
    rng: np.random.Generator, colour: bool, m: float = 570.0, k: float = 3e5, c: float = 0.0
) -> list[Record]:
    """Four band-limited random records (0.5-12 Hz, 3 mm) of a rigid specimen ``m a + c v +
    k x`` after 0.5 s at rest, 0.5 N of force noise and 1.5 um of white displacement noise
    (and as much again low-passed at 25 Hz when ``colour``)."""
    band = signal.butter(4, [0.5, 12.0], "bandpass", fs=FS, output="sos")
    out = []
    for i in range(4):
        n = int(8 * FS)
        x = signal.sosfiltfilt(band, rng.standard_normal(n))
        s = np.clip(DT * np.arange(n) / 0.5, 0.0, 1.0)  # from rest with no jump in a
        x *= 3e-3 / np.std(x) * s**3 * (10.0 - 15.0 * s + 6.0 * s**2)
        v = np.gradient(x, DT)
        force = m * np.gradient(v, DT) + c * v + k * x + 0.5 * rng.standard_normal(n)
        rest = 512
        rec = _record(f"r{i}", x, force, rest)
        noise = (
            _coloured(rng, rec.n, 1.5e-6, 0.5, 25.0)
            if colour
            else 1.5e-6 * rng.standard_normal(rec.n)
        )
        out.append(Record(rec.name, DT, rec.time, rec.command, rec.measured + noise, rec.force))
    return out


def test_coloured_displacement_noise_through_the_inertance_is_no_gap():
    """A rigid specimen exactly as nominal, half its displacement noise low-passed at 25 Hz:
    through the 570 kg inertance that noise is several times the white floor below 30 Hz.
    With the colour read at the records' rest the channel is at its floor; with the white
    floor alone the same residual is significant (the failure this guards against)."""
    records = _rigid_records(np.random.default_rng(11), colour=True)
    nominal = NominalModel(UNIT, SpecimenNominal(570.0, 0.0, 3e5))
    channel = specimen_channel(records, nominal, 30.0)
    assert "measured" in channel.noise_shape
    assert select(channel, ("coulomb_friction",)).verdict == "none"
    channel.noise_shape.clear()
    assert select(channel, ("coulomb_friction",)).decomposition.significant


def test_a_held_out_band_the_identification_did_not_cover_is_calibration():
    """The identification records are two sines near 1 Hz: only ``k - m w^2`` is determined
    there, so the inertance keeps its nominal value (7 % high) and the stiffness takes the
    difference.  The held-out random record to 12 Hz then shows a significant gap no effect
    closes; calibrated on every record's time blocks the baseline reaches the floor: the
    channel is ``none`` by coverage, not ``unexplained``."""
    rng = np.random.default_rng(3)
    m = 1944.0
    records = []
    for i, f0 in enumerate((1.11, 0.97)):
        n = int(8 * FS)
        t = DT * np.arange(n)
        s = np.clip(t / 1.0, 0.0, 1.0)
        x = 5e-3 * s**3 * (10.0 - 15.0 * s + 6.0 * s**2) * np.sin(2 * math.pi * f0 * t)
        v = np.gradient(x, DT)
        force = m * np.gradient(v, DT) + 2.7e4 * v + 0.5 * rng.standard_normal(n)
        records.append(_record(f"sine{i}", x, force, 256))
    records += _rigid_records(rng, colour=False, m=m, k=0.0, c=2.7e4)[:2]
    nominal = NominalModel(UNIT, SpecimenNominal(1.07 * m, 2.7e4, 0.0))
    channel = specimen_channel(records, nominal, 30.0)
    res = select(channel, ("coulomb_friction", "amplitude_damping"))
    assert res.decomposition.significant  # the record hold-out does show a gap
    assert res.verdict == "none" and res.evidence == "coverage"
    assert res.baseline.baseline["inertance"] == pytest.approx(1.07 * m, rel=1e-6)


def _shifted_records(
    rng: np.random.Generator, lead: float, m: float = 570.0, k: float = 3e5, friction: float = 0.0
):
    """Four band-limited random records (0.5-12 Hz, 3 mm) of a rigid specimen ``m a + k x``
    (and a Coulomb ``friction`` [N], smoothed over 1 mm/s) after 0.5 s at rest whose force is
    read ``lead`` samples ahead of the displacement (a displacement conditioner's group delay
    beyond the load cell's), 0.5 N of force noise and 1.5 um of displacement noise."""
    band = signal.butter(4, [0.5, 12.0], "bandpass", fs=FS, output="sos")
    out = []
    for i in range(4):
        n = int(8 * FS)
        t = DT * np.arange(n)
        x = signal.sosfiltfilt(band, rng.standard_normal(n))
        s = np.clip(t / 0.5, 0.0, 1.0)
        x *= 3e-3 / np.std(x) * s**3 * (10.0 - 15.0 * s + 6.0 * s**2)
        spline = interpolate.CubicSpline(t, x)
        ahead = t + lead * DT
        force = m * spline(ahead, 2) + k * spline(ahead) + 0.5 * rng.standard_normal(n)
        force += friction * np.tanh(spline(ahead, 1) / 1e-3)
        rec = _record(f"r{i}", x, force, 512)
        noise = 1.5e-6 * rng.standard_normal(rec.n)
        out.append(Record(rec.name, DT, rec.time, rec.command, rec.measured + noise, rec.force))
    return out


def test_a_force_read_a_fraction_of_a_sample_ahead_is_calibration(monkeypatch):
    """The force read 0.6 samples ahead of the displacement (conditioners of different group
    delay: the independent generator's LVDT demodulator against its load cell) is the
    baseline's calibration, like the actuator channel's one-sample alignment: the channel is
    at its floor and the alignment is read back to 0.05 samples (its regressor is the
    nominal force's rate; the first-order remainder ``(w s dt)^2 / 2`` is 1e-3 of the force
    at 12 Hz, below the noise).  Without the alignment the same residual is a significant gap
    (the false ``unexplained`` it guards against); a lead of three samples is no calibration:
    the alignment stops at its one-sample bound and the gap stays."""
    nominal = NominalModel(UNIT, SpecimenNominal(570.0, 0.0, 3e5))
    channel = specimen_channel(_shifted_records(np.random.default_rng(5), 0.6), nominal, 30.0)
    res = select(channel, ("coulomb_friction",))
    assert res.verdict == "none" and not res.decomposition.significant
    assert res.baseline.baseline["alignment"] == pytest.approx(0.6 * DT, abs=0.05 * DT)

    far = specimen_channel(_shifted_records(np.random.default_rng(5), 3.0), nominal, 30.0)
    held = select(far, ("coulomb_friction",))
    assert held.decomposition.significant
    assert held.baseline.baseline["alignment"] == pytest.approx(ALIGNMENT_SAMPLES * DT)

    def unaligned(self, channel):
        return np.zeros(self.prior(channel).size)

    monkeypatch.setattr(RigidSpecimen, "limits", unaligned)
    again = specimen_channel(_shifted_records(np.random.default_rng(5), 0.6), nominal, 30.0)
    assert select(again, ("coulomb_friction",)).decomposition.significant


def test_an_alignment_that_does_not_buy_itself_is_off():
    """No lag, an unmodelled friction of 200 N: the alignment (the nominal force's rate, its
    ``k v`` share velocity-like) closes less than one parameter's price of the baseline's
    held-out gap, so the channel's models go without it (the real MTS record: at its bound
    it took the friction fit's held-out NRMSE from 18 to 25 %) and the friction is named."""
    nominal = NominalModel(UNIT, SpecimenNominal(570.0, 0.0, 3e5))
    records = _shifted_records(np.random.default_rng(6), 0.0, friction=200.0)
    channel = specimen_channel(records, nominal, 30.0)
    res = select(channel, ("coulomb_friction",))
    assert not channel.alignment
    assert res.baseline.baseline["alignment"] == 0.0
    assert res.effects == ("coulomb_friction",)
    assert res.final.params["coulomb_friction"]["friction"] == pytest.approx(200.0, rel=0.05)
