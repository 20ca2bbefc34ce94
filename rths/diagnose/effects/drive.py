"""What the specimen channel's drive shows: its scale, its tones, and cached smoothed columns.

Shared by the specimen models (:mod:`rths.diagnose.effects.specimen`, :mod:`.chain`,
:mod:`.compliance`) and the alignment (:mod:`.alignment`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from rths.diagnose.channels.channel import Channel, Segment
from rths.diagnose.channels.signals import TONE_BAND, dominant_tone

__all__ = ["drive_scale", "single_tone", "smoothed", "tonal"]


def _tones(channel: Channel, key: str) -> list[float]:
    """The dominant tone [Hz] of every identification record's drive ``key`` (NaN: none;
    :func:`rths.diagnose.channels.signals.dominant_tone`), cached per segment."""
    tones = []
    for seg in channel.segments:
        if not np.any(seg.ident):
            continue
        if "tone" not in seg.cache:
            f = dominant_tone(seg.signals[key], seg.dt)
            seg.cache["tone"] = np.array([math.nan if f is None else f])
        tones.append(float(seg.cache["tone"][0]))
    return tones


def single_tone(channel: Channel, key: str = "x") -> bool:
    """Whether the drive of every identification record is one tone
    (:func:`rths.diagnose.channels.signals.dominant_tone`) and all of them lie within a
    factor :data:`rths.diagnose.channels.signals.TONE_BAND` of each other: inertia and
    stiffness then act at one frequency and only their sum ``k - m w^2`` is determined.

    Parameters
    ----------
    channel
        The specimen channel (drive displacement ``x`` in every segment's signals).
    key
        The drive's signal (``"f"``: the force driving the ``displacement`` channel).
    """
    tones = _tones(channel, key)
    if not tones or not all(math.isfinite(f) and f > 0.0 for f in tones):
        return False
    return max(tones) <= TONE_BAND * min(tones)


def tonal(channel: Channel, key: str = "x") -> bool:
    """Whether the drive of every identification record is one tone, of whatever frequency
    (a sine per record): a lag then shows only as a phase per record, which a damping (or any
    law of amplitude and frequency, one value per record) takes as well; only a record that
    spans frequencies shows a phase growing with them (:func:`alignment_column`).

    Parameters
    ----------
    channel
        The specimen channel.
    key
        The drive's signal (``"f"``: the force driving the ``displacement`` channel).
    """
    tones = _tones(channel, key)
    return bool(tones) and all(math.isfinite(f) and f > 0.0 for f in tones)


def smoothed(seg: Segment, key: str, make: Callable[[], NDArray]) -> NDArray:
    """Cached ``h * make()`` on a segment.

    Parameters
    ----------
    seg
        The record's segment (its smoother ``h`` and cache).
    key
        Cache key of the signal.
    make
        Computes the unsmoothed signal (called once per segment and key).
    """
    if key not in seg.cache:
        seg.cache[key] = seg.h(make())
    return seg.cache[key]


def drive_scale(channel: Channel) -> float:
    """Standard deviation of the drive displacement over all records [m] (at least 1 nm).

    Parameters
    ----------
    channel
        A specimen channel (signal ``x``: the smoothed drive).
    """
    return max(float(np.std(channel.stack("x"))), 1e-9)
