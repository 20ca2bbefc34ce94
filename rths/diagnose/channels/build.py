"""The channels of a diagnosis, built from records against a nominal model.

``measured`` (subsystem ``actuator``)
    The nominal actuator TF (+ its delay) driven by the recorded command, against the measured
    displacement (raw: the command is noise-free, so the residual noise is the displacement
    transducer's own).  Carries the force deviation ``dF = F - Z_0 x`` (measured force minus
    the nominal specimen on the measured displacement) for the control-structure interaction
    path of the actuator models (:mod:`rths.diagnose.effects.actuator`).
``force`` (subsystem ``specimen``)
    The specimen models driven by the drive displacement (measured, or the actuator model's
    noise-free replay) through a light low-pass (:data:`DRIVE_CUTOFF`), against the measured
    force; the measured force and every model's output go through the same zero-phase low-pass
    at the channel's cutoff (see :mod:`rths.diagnose.channels.signals`).  Nonlinear models see
    the motion's fast content (a contact closes within milliseconds); the comparison is made
    where the noise allows.
``displacement`` (subsystem ``specimen``)
    The specimen seen the other way round: the measured displacement predicted from the
    measured force (:mod:`rths.diagnose.effects.compliance`).

Every channel's records share one sampling rate; each holds the white-noise levels estimated
on the records themselves (and their colour, read where the records start at rest:
:mod:`rths.diagnose.channels.rest`) and the identification / held-out masks of
:func:`rths.diagnose.channels.channel.split_roles`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from rths.core.errors import DataError
from rths.diagnose.channels.channel import (
    DEFAULT_CUTOFF,
    DRIVE_CUTOFF,
    Channel,
    Segment,
    split_roles,
)
from rths.diagnose.channels.rest import rest_spectra
from rths.diagnose.channels.signals import (
    derivatives,
    impulse_kernel,
    smooth,
    smoother,
    white_noise_rms,
)
from rths.diagnose.data.nominal import NominalModel
from rths.diagnose.data.records import Record

__all__ = [
    "actuator_channel",
    "displacement_channel",
    "force_deviation",
    "load_flow",
    "reactive_force",
    "specimen_channel",
]


def _noise(records: list[Record], key: str) -> float:
    """Pooled white-noise RMS of a column over records (weighted by length)."""
    total = sum(r.n for r in records)
    var = sum(r.n * white_noise_rms(getattr(r, key), r.dt) ** 2 for r in records) / total
    return math.sqrt(var)


def _check_rates(records: list[Record]) -> float:
    dt = records[0].dt
    for r in records[1:]:
        if abs(r.dt - dt) > 1e-5 * dt:  # 1e-5: < 0.04 samples of drift over 60 min
            raise DataError(
                f"all records must share one sampling rate; '{r.name}' has {r.rate:.6g} Hz, "
                f"'{records[0].name}' {records[0].rate:.6g} Hz"
            )
    return dt


def _noise_levels(records: list[Record]) -> dict[str, float]:
    return {k: _noise(records, k) for k in ("measured", "force", "command")}


def _with_colour(channel: Channel, records: list[Record]) -> Channel:
    """``channel`` with its noise colour read at the records' rest (:mod:`.rest`)."""
    channel.noise_shape.update(rest_spectra(records, channel.noise))
    return channel


def displacement_channel(
    records: list[Record],
    nominal: NominalModel,
    held_out: tuple[str, ...] | None = None,
) -> Channel:
    """The ``displacement`` channel: the measured displacement predicted from the measured
    force (:mod:`rths.diagnose.effects.compliance`).

    Both are used as sampled, unsmoothed: the model is nonlinear in the force (the clearance's
    sign, a contact law), scored only where the force is live, and a smoother would mix the
    samples where a contact is open -- where the displacement is the piston's, not the
    specimen's -- into the scored ones next to them (a rattling contact is open most of the
    time); the converters' anti-alias filters act alike on both channels.  Samples where the
    force, as sampled or low-passed at :data:`DRIVE_CUTOFF` of the sampling rate, is within
    ``2 F_0`` of zero are not scored; ``F_0`` (signal ``f0``) is five times the low-passed
    force's noise or 1 % of its RMS.

    Parameters
    ----------
    records
        The records (one sampling rate).
    nominal
        The nominal model (its specimen predicts the displacement from the force).
    held_out
        Names of the held-out records (:func:`split_roles`); None holds out the second half.
    """
    dt = _check_rates(records)
    cutoff = DRIVE_CUTOFF / dt
    sos = smoother(cutoff, dt)
    noise = _noise_levels(records)
    segments = []
    forces = [smooth(r.force, sos) for r in records]
    rms = float(np.sqrt(np.mean(np.concatenate(forces) ** 2)))
    gain = float(np.sqrt(np.sum(impulse_kernel(sos, dt) ** 2)))
    f0 = max(5.0 * noise["force"] * gain, 0.01 * rms, 1e-12)
    roles = split_roles(records, cutoff, held_out)
    for i, (r, f, (ident, held)) in enumerate(zip(records, forces, roles, strict=True)):
        raw = np.asarray(r.force, dtype=float)
        # live in the low-passed force (not a noise spike) and in the sampled one (the
        # low-pass spreads a contact's force over the samples where it has opened)
        live = (np.abs(f - np.median(f)) >= 2.0 * f0) & (np.abs(raw - np.median(f)) >= 2.0 * f0)
        signals = {"f": raw, "f0": np.full(1, f0)}
        segments.append(
            Segment(
                r.name, i, dt, np.asarray(r.measured, float), signals, ident & live, held & live
            )
        )
    noise["drive"] = 0.0
    return _with_colour(
        Channel("displacement", "specimen", segments, nominal, noise, cutoff), records
    )


def force_deviation(record: Record, nominal: NominalModel) -> NDArray[np.float64]:
    """``dF = F - (m x'' + c x' + k x)`` [N]: the force the nominal specimen does not explain.

    The force goes through a zero-phase low-pass at :data:`DRIVE_CUTOFF` of the sampling rate
    (contacts and stick-slip stay in it), the displacement through one at
    :data:`DEFAULT_CUTOFF` (its second derivative is noisy; the inertial force of a drive is
    slow).  Nominal friction is not subtracted.

    Parameters
    ----------
    record
        One record: measured displacement [m] and force [N].
    nominal
        The nominal model whose specimen (inertance, damping, stiffness) is subtracted.
    """
    x = smooth(record.measured, smoother(min(DEFAULT_CUTOFF, 0.2 / record.dt), record.dt))
    force = smooth(record.force, smoother(DRIVE_CUTOFF / record.dt, record.dt))
    v, a = derivatives(x, record.dt)
    s = nominal.specimen
    return force - (s.inertance * a + s.damping * v + s.stiffness * x)


def _interaction_motion(record: Record) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """``(x, v, a, F)``: the measured displacement [m], its speed [m/s] and acceleration
    [m/s^2], and the measured force [N], through one zero-phase low-pass at
    :data:`DRIVE_CUTOFF` of the sampling rate, at most 100 Hz (the loop's poles, where the
    force's interaction shows, lie below; the acceleration's noise above)."""
    sos = smoother(min(DRIVE_CUTOFF / record.dt, 100.0), record.dt)
    x = smooth(record.measured, sos)
    v, a = derivatives(x, record.dt)
    return x, v, a, smooth(record.force, sos)


def reactive_force(
    motion: tuple[NDArray, NDArray, NDArray, NDArray], nominal: NominalModel
) -> NDArray[np.float64]:
    """``m x'' + k x`` [N]: the nominal specimen's reactive (inertial and elastic) force on the
    measured displacement.  It pins the loop's compliance
    (:mod:`rths.diagnose.effects.actuator`): its interaction is even in frequency, which no
    delay mimics.

    Parameters
    ----------
    motion
        ``(x, v, a, F)`` of one record, low-passed (:func:`_interaction_motion`).
    nominal
        The nominal model whose specimen (inertance, stiffness) acts.
    """
    x, _, a, _ = motion
    s = nominal.specimen
    return s.inertance * a + s.stiffness * x


def load_flow(motion: tuple[NDArray, NDArray, NDArray, NDArray]) -> NDArray[np.float64]:
    """``|v| F`` [W]: the measured speed times the measured force.

    A servo-valve's orifice law ``Q = K_q x_v sqrt(1 - sign(x_v) p_L/P_s)`` (Merritt,
    Hydraulic Control Systems, 1967, Eq. 5-21) linearised at ``p_L = 0`` moves the piston at
    ``v_0 - |v_0| p_L/(2 P_s)``: the speed lost to the load pressure is proportional to this
    signal (``p_L A ~ F``).

    Parameters
    ----------
    motion
        ``(x, v, a, F)`` of one record, low-passed (:func:`_interaction_motion`).
    """
    _, v, _, force = motion
    return np.abs(v) * force


def actuator_channel(
    records: list[Record],
    nominal: NominalModel,
    cutoff: float,
    held_out: tuple[str, ...] | None = None,
) -> Channel:
    """The ``measured`` channel: the recorded commands and force deviations per record.

    Parameters
    ----------
    records, nominal
        The data and the nominal model.
    cutoff
        The specimen channel's cutoff [Hz] (the unscored edges are the same on both channels).
    held_out
        Names of the held-out records (:func:`split_roles`).
    """
    dt = _check_rates(records)
    segments = []
    for i, (r, (ident, held)) in enumerate(
        zip(records, split_roles(records, cutoff, held_out), strict=True)
    ):
        motion = _interaction_motion(r)
        signals = {
            "command": r.command,
            "dforce": force_deviation(r, nominal),
            "reactive": reactive_force(motion, nominal),
            "load_flow": load_flow(motion),
        }
        segments.append(Segment(r.name, i, dt, r.measured, signals, ident, held))
    channel = Channel("measured", "actuator", segments, nominal, _noise_levels(records))
    return _with_colour(channel, records)


def specimen_channel(
    records: list[Record],
    nominal: NominalModel,
    cutoff: float,
    drive: list[NDArray[np.float64]] | None = None,
    held_out: tuple[str, ...] | None = None,
) -> Channel:
    """The ``force`` channel: smoothed drive displacement, its derivatives, smoothed force.

    Parameters
    ----------
    records, nominal
        As for :func:`actuator_channel`.
    cutoff
        Cutoff [Hz] of the smoother.
    drive
        Drive displacement per record [m]; default the measured displacement.  A noise-free
        drive (the transfer model's replay of the command, see :mod:`rths.diagnose.verdict`)
        has no noise of its own, so the floor is then the force noise alone.
    held_out
        Names of the held-out records (:func:`split_roles`).
    """
    dt = _check_rates(records)
    sos = smoother(cutoff, dt)
    drive_sos = smoother(max(DRIVE_CUTOFF / dt, cutoff), dt)
    segments = []
    drives = drive if drive is not None else [r.measured for r in records]
    roles = split_roles(records, cutoff, held_out)
    for i, (r, d, (ident, held)) in enumerate(zip(records, drives, roles, strict=True)):
        x = smooth(d, drive_sos)
        v, acc = derivatives(x, dt)
        segments.append(
            Segment(
                r.name, i, dt, smooth(r.force, sos), {"x": x, "v": v, "a": acc}, ident, held, sos
            )
        )
    noise = _noise_levels(records)
    noise["drive"] = noise["measured"] if drive is None else 0.0
    channel = Channel("force", "specimen", segments, nominal, noise, cutoff, drive_sos)
    return _with_colour(channel, records)
