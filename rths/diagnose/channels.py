"""The two replay channels of a diagnosis and the split into identification and held-out data.

``measured`` (subsystem ``actuator``)
    The nominal actuator TF (+ its delay) driven by the recorded command, against the measured
    displacement (raw: the command is noise-free, so the residual noise is the displacement
    transducer's own).
``force`` (subsystem ``specimen``)
    The nominal specimen driven by the measured displacement, against the measured force, both
    through the same zero-phase low-pass (see :mod:`rths.diagnose._signals`).

Split (design.md section 7): with several records the first ``ceil(k/2)`` identify and the rest
are held out; a single record is cut into :data:`TIME_BLOCKS` equal blocks in time, the even ones
identify and the odd ones are held out -- alternating blocks rather than one cut, so that the
held-out part of a sine sweep spans the same frequencies as the identification part instead of
asking for an extrapolation.  The replay always runs over the whole record from its start; only
the fitting and scoring are split.  :data:`EDGE_SECONDS` (at least ``4/f_c``) at both ends of
every record are left out of
fitting and scoring (filter edge transients).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from rths.core.errors import DataError
from rths.diagnose._signals import (
    actuator_replay,
    derivatives,
    impulse_kernel,
    smooth,
    smoother,
    white_noise_rms,
)
from rths.diagnose.data import Record
from rths.diagnose.nominal import NominalModel

__all__ = [
    "DEFAULT_CUTOFF",
    "EDGE_SECONDS",
    "TIME_BLOCKS",
    "Channel",
    "Segment",
    "actuator_channel",
    "specimen_channel",
    "split_roles",
]

#: Default cutoff [Hz] of the specimen channel's zero-phase low-pass: twice the 10-14 Hz ripple
#: band of S0 section 3 (Type I/II self-vibration 12.3/13.8 Hz), low enough that displacement
#: noise differentiated twice stays near the force noise for a 1.6 t inerter.
DEFAULT_CUTOFF: float = 30.0
#: Number of alternating identification/held-out blocks of a single record.
TIME_BLOCKS: int = 6
#: Samples within this time [s] (or ``4/f_c`` if longer) of a record's ends are not scored.
EDGE_SECONDS: float = 0.1

#: Length of the impulse responses behind the noise-floor PSD (4 s at 2 kHz).
_KERNEL_LENGTH = 8192

ChannelName = Literal["measured", "force"]


@dataclass
class Segment:
    """One record as seen by one channel.

    Attributes
    ----------
    name
        Record name.
    dt
        Sample period [s].
    observed
        What the models must reproduce: measured displacement [m] or smoothed force [N].
    signals
        Drive signals: ``command``, ``replay`` (nominal TF without its delay) for the actuator
        channel; ``x``, ``v``, ``a`` (smoothed measured displacement and its derivatives) for
        the specimen channel.
    ident, held
        Boolean masks of the samples used for identification and for held-out scoring.
    sos
        The smoother ``h`` applied to model outputs (specimen channel), else None.
    cache
        Per-model precomputed columns (filled lazily by the models).
    """

    name: str
    dt: float
    observed: NDArray[np.float64]
    signals: dict[str, NDArray[np.float64]]
    ident: NDArray[np.bool_]
    held: NDArray[np.bool_]
    sos: NDArray[np.float64] | None = None
    cache: dict[str, NDArray[np.float64]] = field(default_factory=dict)

    def h(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """A model output through the channel's smoother (identity without one)."""
        return x if self.sos is None else smooth(x, self.sos)


@dataclass
class Channel:
    """A replay channel over all records, with its white-noise levels.

    Attributes
    ----------
    name, subsystem
        ``measured``/``actuator`` or ``force``/``specimen``.
    segments
        One per record.
    nominal
        The nominal model.
    noise
        White-noise RMS estimated from the records: ``measured`` [m], ``force`` [N],
        ``command`` [m]; and ``drive`` [m], the noise on the specimen channel's drive (the
        measured displacement's, or 0 for a replayed drive).
    cutoff
        Smoother cutoff [Hz] (specimen channel), else None.
    friction_scale
        Velocity scale [m/s] of the regularised sign ``tanh(v/eps)`` (specimen channel).
    """

    name: ChannelName
    subsystem: Literal["actuator", "specimen"]
    segments: list[Segment]
    nominal: NominalModel
    noise: dict[str, float]
    cutoff: float | None = None
    friction_scale: float = 1e-3

    @property
    def dt(self) -> float:
        """Sample period [s] (the same for every record)."""
        return self.segments[0].dt

    def stack(self, key: str, mask: str | None = None) -> NDArray[np.float64]:
        """Concatenate ``observed`` or a signal over segments, optionally over a mask."""
        parts = []
        for s in self.segments:
            x = s.observed if key == "observed" else s.signals[key]
            parts.append(x if mask is None else x[getattr(s, mask)])
        return np.concatenate(parts)

    def floor_variance(self, linear: tuple[float, float, float] | None = None) -> float:
        """Variance of the residual a perfect model would leave (white noise only).

        Actuator channel: ``s_y^2 + g^2 s_u^2 sum(h_G^2)`` (displacement noise plus command
        noise through the nominal TF).  Specimen channel: ``s_F^2 sum(k_F^2) + s_x^2
        sum(k_x^2)`` with ``k_F = h`` and ``k_x = h L h``, ``L = m D2 + c D1 + k`` the linear
        part of the (re-calibrated) specimen ``linear = (m, c, k)``.
        """
        return float(np.sum(self.floor_psd(linear)[1]) * self.psd_df)

    @property
    def psd_df(self) -> float:
        """Frequency step [Hz] of :meth:`floor_psd`."""
        return 1.0 / (_KERNEL_LENGTH * self.dt)

    def floor_psd(
        self, linear: tuple[float, float, float] | None = None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """One-sided PSD [unit^2/Hz] of the noise floor (see :meth:`floor_variance`)."""
        n, dt = _KERNEL_LENGTH, self.dt
        f = np.fft.rfftfreq(n, dt)
        scale = np.full(f.size, 2.0 * dt)
        scale[0] = scale[-1] = dt
        if self.subsystem == "actuator":
            g = self.nominal.actuator
            impulse = np.zeros(n)
            impulse[0] = 1.0
            k_u = actuator_replay(g.num, g.den, dt, impulse)
            psd = (
                self.noise["measured"] ** 2
                + self.noise["command"] ** 2 * np.abs(np.fft.rfft(k_u)) ** 2
            )
            return np.asarray(f, dtype=np.float64), psd * scale
        sos = self.segments[0].sos
        assert sos is not None
        spec = self.nominal.specimen
        lin = linear or (spec.inertance, spec.damping, spec.stiffness)
        k_f = np.abs(np.fft.rfft(impulse_kernel(sos, dt))) ** 2
        k_x = np.abs(np.fft.rfft(impulse_kernel(sos, dt, lin))) ** 2
        psd = self.noise["force"] ** 2 * k_f + self.noise["drive"] ** 2 * k_x
        return np.asarray(f, dtype=np.float64), psd * scale


def split_roles(records: list[Record], cutoff: float) -> list[tuple[NDArray, NDArray]]:
    """``(ident, held)`` sample masks per record (module docstring)."""
    if not records:
        raise DataError("no records given")
    k = len(records)
    n_ident = math.ceil(k / 2) if k > 1 else 1
    masks = []
    for i, r in enumerate(records):
        edge = max(1, int(round(max(EDGE_SECONDS, 4.0 / cutoff) / r.dt)))
        inner = np.zeros(r.n, dtype=bool)
        inner[edge : r.n - edge] = True
        if k == 1:
            block = (np.arange(r.n) * TIME_BLOCKS) // r.n
            ident, held = inner & (block % 2 == 0), inner & (block % 2 == 1)
        elif i < n_ident:
            ident, held = inner, np.zeros(r.n, dtype=bool)
        else:
            ident, held = np.zeros(r.n, dtype=bool), inner
        masks.append((ident, held))
    return masks


def _noise(records: list[Record], key: str) -> float:
    """Pooled white-noise RMS of a column over records (weighted by length)."""
    total = sum(r.n for r in records)
    var = sum(r.n * white_noise_rms(getattr(r, key), r.dt) ** 2 for r in records) / total
    return math.sqrt(var)


def _check_rates(records: list[Record]) -> float:
    dt = records[0].dt
    for r in records[1:]:
        if abs(r.dt - dt) > 1e-6 * dt:
            raise DataError(
                f"all records must share one sampling rate; '{r.name}' has {r.rate:.6g} Hz, "
                f"'{records[0].name}' {records[0].rate:.6g} Hz"
            )
    return dt


def _noise_levels(records: list[Record]) -> dict[str, float]:
    return {k: _noise(records, k) for k in ("measured", "force", "command")}


def actuator_channel(records: list[Record], nominal: NominalModel, cutoff: float) -> Channel:
    """The ``measured`` channel: nominal TF (without its delay) replayed on each command."""
    dt = _check_rates(records)
    a = nominal.actuator
    segments = []
    for r, (ident, held) in zip(records, split_roles(records, cutoff), strict=True):
        replay = actuator_replay(a.num, a.den, dt, r.command)
        segments.append(
            Segment(r.name, dt, r.measured, {"command": r.command, "replay": replay}, ident, held)
        )
    return Channel("measured", "actuator", segments, nominal, _noise_levels(records))


def specimen_channel(
    records: list[Record],
    nominal: NominalModel,
    cutoff: float,
    drive: list[NDArray[np.float64]] | None = None,
) -> Channel:
    """The ``force`` channel: smoothed drive displacement, its derivatives, smoothed force.

    Parameters
    ----------
    records, nominal, cutoff
        As for :func:`actuator_channel`; ``cutoff`` [Hz] of the smoother.
    drive
        Drive displacement per record [m]; default the measured displacement.  A noise-free
        drive (the transfer model's replay of the command, see :mod:`rths.diagnose.verdict`)
        has no noise of its own, so the floor is then the force noise alone.
    """
    dt = _check_rates(records)
    sos = smoother(cutoff, dt)
    segments = []
    drives = drive if drive is not None else [r.measured for r in records]
    for r, d, (ident, held) in zip(records, drives, split_roles(records, cutoff), strict=True):
        x = smooth(d, sos)
        v, acc = derivatives(x, dt)
        segments.append(
            Segment(r.name, dt, smooth(r.force, sos), {"x": x, "v": v, "a": acc}, ident, held, sos)
        )
    noise = _noise_levels(records)
    noise["drive"] = noise["measured"] if drive is None else 0.0
    channel = Channel("force", "specimen", segments, nominal, noise, cutoff)
    # velocity noise after smoothing: s_x * ||D1 h||
    k = impulse_kernel(sos, dt)
    sigma_v = noise["drive"] * float(np.sqrt(np.sum(np.gradient(k, dt) ** 2)))
    v_all = channel.stack("v")
    channel.friction_scale = max(3.0 * sigma_v, 1e-3 * float(np.std(v_all)), 1e-6)
    return channel
