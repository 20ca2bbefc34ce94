"""A fit's held-out residual decomposed against its channel's noise floor (significance,
band, phase of the cycle: :func:`rths.diagnose.residuals.decompose`)."""

from __future__ import annotations

import numpy as np

from rths.diagnose.channels.channel import Channel
from rths.diagnose.residuals import Decomposition, decompose
from rths.diagnose.search.identify import Fit
from rths.diagnose.search.results import held_parts

__all__ = ["decompose_fit", "floor_psd"]


def floor_psd(channel: Channel, fit: Fit) -> tuple[np.ndarray, np.ndarray]:
    """``(frequency [Hz], one-sided PSD)`` of the channel's noise floor (the force channel's
    drive noise through the fit's re-calibrated rigid specimen).

    Parameters
    ----------
    channel
        The channel.
    fit
        A fit holding the re-calibrated baseline.
    """
    if channel.name == "force":
        b = fit.baseline
        return channel.floor_psd((b["inertance"], b["damping"], b["stiffness"]))
    return channel.floor_psd(None)


def decompose_fit(channel: Channel, fit: Fit, floor_scale: float = 1.0) -> Decomposition:
    """Where a fit's held-out residual lies (:func:`rths.diagnose.residuals.decompose`): the
    force channel's drive and tested band are the specimen's (1.5 times its smoother's cutoff),
    the other channels' the observation's.

    Parameters
    ----------
    channel
        The channel.
    fit
        The fitted model.
    floor_scale
        Factor on the channel's floor PSD (the fit's own floor over the baseline's).
    """
    if channel.name == "force":
        drive = [s.signals["x"] for s in channel.segments]
        f_max = 1.5 * float(channel.cutoff or 0.0)
    elif channel.name == "displacement":
        drive = [s.observed for s in channel.segments]
        f_max = 1.5 * float(channel.cutoff or 0.0)
    else:
        drive = [s.observed for s in channel.segments]
        f_max = 0.45 / channel.dt
    f, psd = floor_psd(channel, fit)
    times = [np.arange(s.observed.size) * s.dt for s in channel.segments]
    return decompose(
        held_parts(channel, fit.residuals(channel)),
        held_parts(channel, [s.observed for s in channel.segments]),
        held_parts(channel, drive),
        held_parts(channel, times),
        channel.dt,
        (f, psd * floor_scale),
        f_max,
    )
