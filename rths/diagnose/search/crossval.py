"""Two-fold cross-validation over time blocks of every record (:func:`cross_fit`): the
actuator channel's score, so that it does not hinge on which record happens to be held out.
"""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np

from rths.diagnose.channels.channel import TIME_BLOCKS, Channel
from rths.diagnose.effects.model import Model, Theta
from rths.diagnose.search.identify import Fit, fit_model

__all__ = ["blocked", "cross_fit"]


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
    for s in channel.segments:
        inner = s.ident | s.held
        block = (np.arange(inner.size) * TIME_BLOCKS) // max(inner.size, 1)
        even = block % 2 == parity
        segments.append(replace(s, ident=inner & even, held=inner & ~even, cache=s.cache))
    return replace(channel, segments=segments)


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
