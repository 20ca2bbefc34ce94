"""The force's alignment to its drive: a shift of up to one sample between the load cell's and
the displacement transducer's signals, re-calibrated with the specimen's baseline.

Each specimen model (:class:`rths.diagnose.effects.specimen.RigidSpecimen`,
:class:`rths.diagnose.effects.chain.SeriesChain`, :class:`rths.diagnose.effects.compliance.
ComplianceModel`) holds it as its last linear parameter, bounded by
:func:`alignment_limits`; the selection keeps it only when it buys itself
(:func:`rths.diagnose.search.alignment.aligned_baseline`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from rths.diagnose.channels.channel import Channel, Segment
from rths.diagnose.effects.drive import smoothed, tonal

__all__ = ["ALIGNMENT_SAMPLES", "alignment_column", "alignment_limits"]


#: Largest alignment of the force to its drive [samples] the baseline re-calibrates: the
#: load cell's and the displacement transducer's conditioners delay their signals by
#: different group delays (an LVDT demodulator's low-pass at some hundred hertz against a
#: load-cell amplifier's kilohertz: 0.4 ms apart), and a shift of up to one sample is
#: calibration, never an effect (README, "Baseline"; like the actuator channel's).
ALIGNMENT_SAMPLES: float = 1.0


def alignment_column(channel: Channel, seg: Segment) -> NDArray:
    """``dt h d/dt F_n`` [N], ``F_n = m a + c v + k x`` the nominal's linear force on the
    drive: the regressor of the force's alignment ``s`` [samples] to its drive, to first
    order ``F(t + s dt) = F(t) + s dt F'(t)`` (its level ``s`` is bounded by
    :data:`ALIGNMENT_SAMPLES`, :meth:`rths.diagnose.effects.model.Model.limits`).  Positive
    ``s``: the force is read ahead of the displacement.  The nominal's values stand in for
    the re-calibrated ones (within their tolerance: a second-order difference).

    Parameters
    ----------
    channel
        The specimen channel (its nominal).
    seg
        One record's segment (drive ``x, v, a``).
    """
    spec, s = channel.nominal.specimen, seg.signals

    def make() -> NDArray:
        force = spec.inertance * s["a"] + spec.damping * s["v"] + spec.stiffness * s["x"]
        return seg.dt * np.gradient(force, seg.dt)

    return smoothed(seg, "alignment", make)


def alignment_limits(channel: Channel, size: int, key: str = "x") -> NDArray[np.float64]:
    """Absolute limits (:meth:`rths.diagnose.effects.model.Model.limits`) of ``size`` linear
    parameters whose last is the alignment: :data:`ALIGNMENT_SAMPLES`, or 0 when every
    identification record's drive ``key`` is one tone (:func:`tonal`) or the channel's
    alignment is off (:attr:`rths.diagnose.channels.channel.Channel.alignment`); NaN (none)
    elsewhere.

    Parameters
    ----------
    channel
        The specimen channel.
    size
        Number of the model's linear parameters.
    key
        The drive's signal (``"f"``: the force driving the ``displacement`` channel).
    """
    out = np.full(size, np.nan)
    off = not channel.alignment or tonal(channel, key)
    out[-1] = 0.0 if off else ALIGNMENT_SAMPLES
    return out
