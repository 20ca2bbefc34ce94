"""Whether a specimen channel's unexplained gap is only its identification records' coverage.

The specimen's baseline is identified on some records and scored on the others
(:func:`rths.diagnose.channels.channel.split_roles`).  When the identification records hold
one tone, or one tone and a weak broadband record, the split of ``k - m w^2`` between the
inertance and the stiffness is barely determined there (at one frequency not at all: the
inertance then keeps NOMINAL.toml's value, :func:`rths.diagnose.effects.drive.single_tone`),
and a held-out record at other frequencies shows the nominal's own mis-calibration as a gap no
effect closes.  Such a gap is calibration, not structure the nominal lacks: the baseline
re-calibrated on *every* record reaches the noise floor.  The test (:func:`covered`)
re-calibrates the baseline by two-fold cross-validation over time blocks of every record
(:func:`rths.diagnose.search.crossval.cross_fit`: each sample predicted by the fold that did
not see it, every fold seeing every excitation) and asks whether its out-of-sample residual
over all scored samples is significant against the same floor.  It is asked of every
significant force-channel gap before any candidate effect is tried: a candidate would
otherwise carry the calibration the baseline may not make on one tone (a near-rigid contact or
a series spring held the inertance the single-tone rule keeps at its nominal, 7 % low, and
"closed" the held-out record's gap at another frequency).  An effect the nominal lacks leaves
a gap no calibration of the nominal's own parameters over all records closes -- an
amplitude law, friction, a clearance, a resonance in the band -- and is searched as before.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from rths.diagnose.channels.channel import Channel
from rths.diagnose.effects import baseline_for
from rths.diagnose.search.crossval import cross_fit
from rths.diagnose.search.decomposed import decompose_fit
from rths.diagnose.search.identify import Fit

__all__ = ["COVERAGE_CHANNELS", "covered"]

#: Channels whose unexplained gap is tested for coverage (the actuator channel is already
#: scored by cross-validation over time blocks).
COVERAGE_CHANNELS: tuple[str, ...] = ("force",)


def _scored_everywhere(channel: Channel) -> Channel:
    """``channel`` with every scored sample (identification and held-out) held out."""
    segments = [
        replace(s, ident=np.zeros_like(s.ident), held=s.ident | s.held, cache=s.cache)
        for s in channel.segments
    ]
    return replace(channel, segments=segments)


def covered(channel: Channel, base: Fit, floor_scale: float = 1.0) -> Fit | None:
    """The baseline cross-validated over every record's time blocks when its out-of-sample
    residual over all scored samples reaches the noise floor (module docstring), else None.

    Parameters
    ----------
    channel
        The specimen channel.
    base
        The baseline identified on the identification records (its re-calibration starts the
        folds' and its floor model is the channel's).
    floor_scale
        Factor on the channel's floor PSD (as for
        :func:`rths.diagnose.search.decomposed.decompose_fit`).
    """
    if channel.name not in COVERAGE_CHANNELS:
        return None
    fit = cross_fit(baseline_for(channel.name), channel, base.baseline)
    everywhere = _scored_everywhere(channel)
    if decompose_fit(everywhere, fit, floor_scale).significant:
        return None
    return fit
