"""Two-fold cross-validation over time blocks of every record (:func:`cross_fit`): the
actuator channel's score, so that it does not hinge on which record happens to be held out;
and the paired comparison of two cross-validated fits over those blocks
(:func:`paired_gain`).
"""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np
from scipy import stats

from rths.diagnose.channels.channel import TIME_BLOCKS, Channel
from rths.diagnose.effects.model import Model, Theta
from rths.diagnose.search.identify import Fit, fit_model

__all__ = ["blocked", "cross_fit", "paired_gain"]


def blocked(channel: Channel, parity: int) -> Channel:
    """``channel`` with every record's scored samples (identification and held-out alike) cut
    into :data:`rths.diagnose.channels.channel.TIME_BLOCKS` equal blocks in time: the blocks of
    ``parity`` (0: even, 1: odd) identify, the others are held out (replay caches shared).

    Parameters
    ----------
    channel
        The channel.
    parity
        0 or 1.
    """
    segments = []
    for s, block in zip(channel.segments, _blocks(channel), strict=True):
        inner = s.ident | s.held
        even = block % 2 == parity
        segments.append(replace(s, ident=inner & even, held=inner & ~even, cache=s.cache))
    return replace(channel, segments=segments)


def _blocks(channel: Channel) -> list[np.ndarray]:
    """Per record, the block (0 .. TIME_BLOCKS - 1, equal lengths in time) of every sample."""
    return [
        (np.arange(s.observed.size) * TIME_BLOCKS) // max(s.observed.size, 1)
        for s in channel.segments
    ]


def cross_fit(
    model: Model,
    channel: Channel,
    base: dict[str, float] | None = None,
    starts: list[Theta] | None = None,
) -> Fit:
    """:func:`fit_model` on both folds of :func:`blocked` (module docstring): the first
    fold's fit, its ``held_mse`` the mean squared residual over both folds' held-out samples
    and its ``prediction`` the cross-validated one (each sample predicted by the fold that did
    not see it), so that the residuals a caller reads on any samples are out of sample.

    Parameters
    ----------
    model, channel, base, starts
        As for :func:`fit_model` (the same starts serve both folds).
    """
    folds = [blocked(channel, 0), blocked(channel, 1)]
    first = fit_model(model, folds[0], base, starts)
    second = fit_model(copy.deepcopy(model), folds[1], base, starts)
    n1 = sum(int(np.sum(s.held)) for s in folds[0].segments)
    n2 = sum(int(np.sum(s.held)) for s in folds[1].segments)
    pooled = (first.held_mse * n1 + second.held_mse * n2) / max(n1 + n2, 1)
    prediction = [
        np.where(s.held, p1, np.where(t.held, p2, p1))
        for s, t, p1, p2 in zip(
            folds[0].segments, folds[1].segments, first.prediction, second.prediction, strict=True
        )
    ]
    return replace(first, held_mse=pooled, prediction=prediction)


def paired_gain(channel: Channel, reference: Fit, trial: Fit) -> tuple[float, float]:
    """How much better ``trial`` predicts the channel than ``reference``, out of sample: the
    mean of ``d = r_ref^2 - r_trial^2`` over every scored sample (both fits cross-validated by
    :func:`cross_fit`, so each sample's residual comes from the fold that did not see it), and
    the one-sided Wilcoxon signed-rank test of the cross-validation blocks' means of ``d``
    (each block of each record: seconds long, nearly independent of its neighbours, whereas
    a residual is correlated over a cycle of the drive) -- a test of equal predictive
    accuracy in the spirit of Diebold and Mariano (J. Bus. Econ. Stat. 13, 1995, 253-263)
    that does not take the spread of a real improvement between records (a delay shows where
    the drive is fast) for noise, as a t statistic over the blocks would.  It needs no noise
    floor: a paired difference of two models' squared residuals on the same samples is
    significant, or not, whatever the floor's level.

    Parameters
    ----------
    channel
        The channel both fits were cross-validated on (:func:`cross_fit`).
    reference, trial
        The two fits.

    Returns
    -------
    tuple
        ``(mean of d [unit^2], z [-])``: ``z`` the standard normal quantile of the test's
        one-sided p-value (0 with fewer than two blocks).
    """
    means, total, count = [], 0.0, 0
    for s, blocks, p0, p1 in zip(
        channel.segments, _blocks(channel), reference.prediction, trial.prediction, strict=True
    ):
        scored = s.ident | s.held
        r0, r1 = (s.observed - p0)[scored], (s.observed - p1)[scored]
        d, b = r0 * r0 - r1 * r1, blocks[scored]
        total, count = total + float(np.sum(d)), count + d.size
        means += [float(np.mean(d[b == k])) for k in np.unique(b)]
    if len(means) < 2 or not np.any(means):
        return 0.0, 0.0
    p = float(stats.wilcoxon(means, alternative="greater").pvalue)
    return total / max(count, 1), float(stats.norm.isf(max(p, 1e-300)))
