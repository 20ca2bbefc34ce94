"""What a diagnosis compares: a channel (:class:`Channel`: per-record segments of observed
signal, drive and masks, the noise levels and the noise floor a perfect model would leave) and
the split of its records into identification and held-out data (:func:`split_roles`).  The
channels themselves -- ``measured``, ``force``, ``displacement`` -- are built from records in
:mod:`rths.diagnose.channels.build`.

Split (design.md section 7): with several records the first ``ceil(k/2)`` identify and the rest
are held out, unless the caller names the held-out records; a single record is cut into
:data:`TIME_BLOCKS` equal blocks in time, the even ones identify and the odd ones are held out
-- alternating blocks rather than one cut, so that the held-out part of a sine sweep spans the
same frequencies as the identification part.  The replay always runs over the whole record from
its start; only the fitting and scoring are split.  :data:`EDGE_SECONDS` (at least ``4/f_c``)
at both ends of every record are left out of fitting and scoring (filter edge transients).
Every record has its own transducer offsets: they are calibrated on the record itself (the
fitter's per-record offset columns on identification data, the mean residual on held-out data).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from rths.core.errors import DataError
from rths.diagnose.channels.rest import NoiseShape
from rths.diagnose.channels.signals import (
    actuator_replay,
    impulse_kernel,
    smooth,
)
from rths.diagnose.data.nominal import NominalModel
from rths.diagnose.data.records import Record

__all__ = [
    "DEFAULT_CUTOFF",
    "DRIVE_CUTOFF",
    "EDGE_SECONDS",
    "TIME_BLOCKS",
    "Channel",
    "Segment",
    "split_roles",
]

#: Default cutoff [Hz] of the specimen channel's zero-phase low-pass when the drive is the noisy
#: measured displacement and no cutoff is given: twice the 10-14 Hz ripple band of S0 section 3.
DEFAULT_CUTOFF: float = 30.0
#: Number of alternating identification/held-out blocks of a single record.
TIME_BLOCKS: int = 6
#: Samples within this time [s] (or ``4/f_c`` if longer) of a record's ends are not scored.
EDGE_SECONDS: float = 0.1

#: Cutoff of the light low-pass on the specimen channel's drive, as a fraction of the sampling
#: rate: it keeps what nonlinear models (contacts, stick-slip) need from the motion and sheds the
#: converter noise near the Nyquist frequency.
DRIVE_CUTOFF: float = 0.2
#: Length of the impulse responses behind the noise-floor PSD.
_KERNEL_LENGTH = 8192

ChannelName = Literal["measured", "force", "displacement"]


@dataclass
class Segment:
    """One record as seen by one channel.

    Attributes
    ----------
    name
        Record name.
    index
        Record number (0-based; the per-record offsets).
    dt
        Sample period [s].
    observed
        What the models must reproduce: measured displacement [m] or smoothed force [N].
    signals
        Drive signals: ``command``, ``reactive`` (the nominal specimen's inertial and elastic
        force [N], :func:`rths.diagnose.channels.build.reactive_force`), ``dforce`` (force
        deviation [N]) and ``load_flow``
        (``|v| F`` [W], :func:`load_flow`) for the actuator channel; ``x``, ``v``, ``a``
        (smoothed drive displacement and its derivatives) for the specimen channel.
    ident, held
        Boolean masks of the samples used for identification and for held-out scoring.
    sos
        The smoother ``h`` applied to model outputs (specimen channel), else None.
    cache
        Per-model precomputed columns (filled lazily by the models).
    window
        For a window of a record (the identification's search windows): the record's whole
        segment and the window's first sample.  A state with a memory of seconds (a load
        amplitude) is computed on the whole record and sliced, not restarted at the window.
    """

    name: str
    index: int
    dt: float
    observed: NDArray[np.float64]
    signals: dict[str, NDArray[np.float64]]
    ident: NDArray[np.bool_]
    held: NDArray[np.bool_]
    sos: NDArray[np.float64] | None = None
    cache: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    window: tuple[Segment, int] | None = None

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
    drive_sos
        The light low-pass the specimen channel's drive goes through (:data:`DRIVE_CUTOFF`),
        else None.
    noise_shape
        The colour of the ``measured`` and ``force`` noise read at the records' rest
        (:func:`rths.diagnose.channels.rest.rest_spectra`): a factor >= 1 on the white PSD
        per frequency; a column without one is white.
    alignment
        Whether a specimen channel's models re-calibrate the force's alignment to its drive
        (:func:`rths.diagnose.effects.alignment.alignment_limits`); the selection switches it
        off when it does not buy itself on held-out data
        (:func:`rths.diagnose.search.alignment.aligned_baseline`).
    """

    name: ChannelName
    subsystem: Literal["actuator", "specimen"]
    segments: list[Segment]
    nominal: NominalModel
    noise: dict[str, float]
    cutoff: float | None = None
    drive_sos: NDArray[np.float64] | None = None
    noise_shape: dict[str, NoiseShape] = field(default_factory=dict)
    alignment: bool = True

    def colour(self, key: str, f: NDArray[np.floating]) -> NDArray[np.float64]:
        """Factor on the white PSD of column ``key``'s noise at frequencies ``f`` [Hz] (ones
        for white noise)."""
        shape = self.noise_shape.get(key)
        grid: NDArray[np.float64] = np.asarray(f, dtype=np.float64)
        return np.ones_like(grid) if shape is None else shape.at(grid)

    def coloured(self, key: str, white: NDArray[np.float64]) -> NDArray[np.float64]:
        """White noise samples ``white`` given column ``key``'s colour (its spectrum times the
        square root of :meth:`colour`; unchanged for white noise)."""
        if key not in self.noise_shape:
            return white
        f = np.fft.rfftfreq(white.size, self.dt)
        return np.fft.irfft(np.fft.rfft(white) * np.sqrt(self.colour(key, f)), white.size)

    def force_noise_variance(self) -> float:
        """Variance [N^2] of the force noise through the channel's smoother (specimen
        channels; its colour included)."""
        sos = self.segments[0].sos
        n, dt = _KERNEL_LENGTH, self.dt
        k = np.abs(np.fft.rfft(impulse_kernel(sos, dt) if sos is not None else _unit(n), n))
        f = np.fft.rfftfreq(n, dt)
        weight = np.full(f.size, 2.0)
        weight[0] = weight[-1] = 1.0
        return float(self.noise["force"] ** 2 * np.sum(weight * self.colour("force", f) * k**2) / n)

    @property
    def dt(self) -> float:
        """Sample period [s] (the same for every record)."""
        return self.segments[0].dt

    @property
    def n_records(self) -> int:
        """Number of records."""
        return len(self.segments)

    def stack(self, key: str, mask: str | None = None) -> NDArray[np.float64]:
        """Concatenate ``observed`` or a signal over segments, optionally over a mask."""
        parts = []
        for s in self.segments:
            x = s.observed if key == "observed" else s.signals[key]
            parts.append(x if mask is None else x[getattr(s, mask)])
        return np.concatenate(parts)

    def floor_variance(self, linear: tuple[float, float, float] | None = None) -> float:
        """Variance of the residual a perfect model would leave (the noise's colour read at
        rest included, :attr:`noise_shape`).

        Actuator channel: ``s_y^2 + g^2 s_u^2 sum(h_G^2)`` (displacement noise plus command
        noise through the nominal TF).  Specimen channel: ``s_F^2 sum(k_F^2) + s_x^2
        sum(k_x^2)`` with ``k_F = h`` and ``k_x = h L g`` (``g`` the drive's low-pass),
        ``L = m D2 + c D1 + k`` the linear
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
                self.noise["measured"] ** 2 * self.colour("measured", f)
                + self.noise["command"] ** 2 * np.abs(np.fft.rfft(k_u)) ** 2
            )
            return np.asarray(f, dtype=np.float64), psd * scale
        sos = self.segments[0].sos
        if self.name == "displacement":  # unsmoothed
            k_h = 1.0 if sos is None else np.abs(np.fft.rfft(impulse_kernel(sos, dt))) ** 2
            psd = self.noise["measured"] ** 2 * self.colour("measured", f) * k_h
            return np.asarray(f, dtype=np.float64), psd * scale
        assert sos is not None
        spec = self.nominal.specimen
        lin = linear or (spec.inertance, spec.damping, spec.stiffness)
        k_f = np.abs(np.fft.rfft(impulse_kernel(sos, dt))) ** 2
        k_x = np.abs(np.fft.rfft(impulse_kernel(sos, dt, lin, self.drive_sos))) ** 2
        psd = (
            self.noise["force"] ** 2 * self.colour("force", f) * k_f
            + self.noise["drive"] ** 2 * self.colour("measured", f) * k_x
        )
        return np.asarray(f, dtype=np.float64), psd * scale


def split_roles(
    records: list[Record], cutoff: float, held_out: tuple[str, ...] | None = None
) -> list[tuple[NDArray, NDArray]]:
    """``(ident, held)`` sample masks per record (module docstring).

    Parameters
    ----------
    records
        The records.
    cutoff
        Smoother cutoff [Hz] (sets the unscored edges).
    held_out
        Names of the records to hold out (the others identify); None: the default split.
    """
    if not records:
        raise DataError("no records given")
    k = len(records)
    names = [r.name for r in records]
    if held_out is not None:
        unknown = [h for h in held_out if h not in names]
        if unknown:
            raise DataError(f"held-out record '{unknown[0]}' is not among the data {names}")
        if len(set(held_out)) >= k:
            raise DataError("at least one record must identify; all were held out")
    n_ident = math.ceil(k / 2) if k > 1 else 1
    masks = []
    for i, r in enumerate(records):
        edge = max(1, int(round(max(EDGE_SECONDS, 4.0 / cutoff) / r.dt)))
        inner = np.zeros(r.n, dtype=bool)
        inner[edge : r.n - edge] = True
        if k == 1 and not held_out:
            block = (np.arange(r.n) * TIME_BLOCKS) // r.n
            ident, held = inner & (block % 2 == 0), inner & (block % 2 == 1)
        elif (r.name in held_out) if held_out is not None else i >= n_ident:
            ident, held = np.zeros(r.n, dtype=bool), inner
        else:
            ident, held = inner, np.zeros(r.n, dtype=bool)
        masks.append((ident, held))
    return masks


def _unit(n: int) -> NDArray[np.float64]:
    """A unit impulse of ``n`` samples."""
    out = np.zeros(n)
    out[0] = 1.0
    return out
