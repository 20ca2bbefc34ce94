"""Ruler reading of friction-damper loops with backlash: slip force, clearance, stick stiffness.

Pure functions on arrays (SI units: s, m, N); ``friction_damper_loops.py`` is the command line.

Method (what a lab engineer does with a ruler on each force-displacement loop):

1. Reversals: the extrema of the displacement with a hysteresis ``h`` = max(2 % of the record's
   displacement range, 0.2 mm); wiggles smaller than ``h`` do not start a new half-cycle.
   Between two reversals the damper moves one way, direction ``s = +-1``.
2. The force is smoothed by a centred 21-sample (20 ms at 1024 Hz) moving median only to
   *locate* levels; every level and slope is read from the raw samples.  Within a half-cycle
   ``g = s (F_smooth - F0)`` runs from the previous contact (g < 0) through the backlash
   plateau (g ~ 0) to the new contact, stick and slip (g > 0).
3. "Near zero" is ``|g| <= b``, ``b = max(5 % of L, 5 sigma)``: ``L`` the friction amplitude
   (mean of the median positive and negative slip levels from ``F0``; first pass: half the
   2nd-98th percentile span of the smoothed force) and ``sigma`` the white noise of the raw
   force on the near-zero samples (1.4826 median|diff F| / sqrt 2).  ``F0``, the force read with
   no contact, is the median raw force on the plateaus.  Three passes from ``F0 = 0``.
4. Plateau: on a half-cycle that starts in back contact (``g < -b`` at the reversal), the
   samples from the first near-zero one to the last near-zero one before firm front contact
   (first ``g >= 3 b``).  Clearance = its travel; ``k_gap`` = the slope of the raw force over
   it (the plateau is not force-free on this device).  Tangent clearance: the distance between
   the x-intercepts (at ``F0``) of the lines fitted to the unloading flank (first passages of 80 %
   then 20 % of the force at the reversal) and to the loading flank (20 % then 80 % of ``P``);
   it is the gap of an equivalent dead zone with linear contacts and does not depend on ``b``.
5. Stick (presliding) stiffness ``k_load``: the slope of the loading-flank line; ``k_unload``,
   that of the unloading flank at the reversal.  A flank line counts only with ``k > 0`` and
   ``R^2 >= 0.9``.
6. Slip: ``P`` = 90th percentile of ``g`` after the plateau; the slip phase runs from the first
   passage of ``0.7 P`` to the next reversal.  The half-cycle slips when ``P >= 5 b`` and that
   travel is at least 1.5x the flank travel from ``0.2 P`` to ``0.7 P`` (a linear elastic ramp
   up to the reversal gives about 0.6x).  Slip level = median raw force over the slip phase,
   read separately for positive and negative slip; the friction amplitude is half their
   difference, the loop centre their mean; ``breakaway`` = peak of ``g`` / slip level from
   ``F0``.

Per record: median and interquartile range across half-cycles; sine and eq records alike (eq
records are read reversal by reversal, so only their large excursions give readings).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path

import numpy as np
from scipy.ndimage import median_filter
from scipy.signal import savgol_filter

sys.path.insert(0, str(Path(__file__).resolve().parent))
from friction_damper_data import Record

SMOOTH_N = 21  #: moving-median window for locating force levels [samples] (20 ms at 1024 Hz)
BAND_FRAC = 0.05  #: near-zero band, fraction of the friction amplitude
BAND_SIGMA = 5.0  #: near-zero band, minimum in noise sigmas
HYST_FRAC, HYST_MIN = 0.02, 2.0e-4  #: reversal hysteresis: fraction of range, minimum [m]
FLANK = (0.2, 0.8)  #: force window of the flank fits, fractions of P (or of the force at reversal)
LEVEL_PCT = 90.0  #: percentile of the force after the plateau that sets the contact level P
ONSET = 0.7  #: slip onset, fraction of P
R2_MIN = 0.9  #: a flank fit must explain this share of the force variance
CONTACT = 3.0  #: firm front contact: first passage of this many bands (ends the plateau search)
SLIP_RATIO = 1.5  #: slip travel / flank travel (0.2P -> 0.7P) needed to call it slip


def noise_sigma(f: np.ndarray) -> float:
    """White-noise standard deviation of ``f`` (same unit) from the MAD of its first difference."""
    return float(1.4826 * np.median(np.abs(np.diff(f))) / np.sqrt(2.0))


def reversals(x: np.ndarray, h: float) -> np.ndarray:
    """Indices of the alternating extrema of ``x`` that are followed by a move of more than ``h``.

    The start counts as an extremum when ``x`` first moves away from it by more than ``h``.

    Parameters
    ----------
    x : ndarray
        Displacement [m].
    h : float
        Hysteresis [m]: an extremum counts once ``x`` has come back from it by more than ``h``.
    """
    idx: list[int] = []
    d, hi, lo = 0, 0, 0
    for i, xi in enumerate(x):
        if d >= 0 and xi > x[hi]:
            hi = i
        if d <= 0 and xi < x[lo]:
            lo = i
        if d >= 0 and x[hi] - xi > h:
            idx.append(hi)
            d, lo = -1, i
        elif d <= 0 and xi - x[lo] > h:
            idx.append(lo)
            d, hi = 1, i
    return np.asarray(idx, dtype=int)


def _first(mask: np.ndarray) -> int | None:
    hits = np.flatnonzero(mask)
    return int(hits[0]) if hits.size else None


def flank_line(
    x: np.ndarray, f: np.ndarray, g: np.ndarray, lo: float, hi: float
) -> tuple[float, float] | None:
    """Line ``F = k x + q`` fitted to a flank; ``None`` when it is not a clean straight flank.

    The raw samples from the first passage of ``g >= lo`` to the first passage of ``g >= hi``
    (``g`` rising, same unit as ``lo``/``hi``) are fitted by least squares.  Returns ``(k, q)``
    [N/m, N] when there are at least 4 samples, ``k > 0`` and the fit explains at least
    ``R2_MIN`` of the force variance, else ``None``.
    """
    a, b = _first(g >= lo), _first(g >= hi)
    if a is None or b is None or b - a + 1 < 4 or np.ptp(x[a : b + 1]) <= 0:
        return None
    xs, fs = x[a : b + 1], f[a : b + 1]
    k, q = np.polyfit(xs, fs, 1)
    r2 = 1.0 - np.var(fs - (k * xs + q)) / max(np.var(fs), 1e-300)
    return (float(k), float(q)) if k > 0 and r2 >= R2_MIN else None


@dataclass
class HalfCycle:
    """Reading of one half-cycle (SI: s, m, N, N/m; ``nan`` where it cannot be read)."""

    t0: float
    t1: float
    direction: int
    travel: float
    peak: float = float("nan")  #: max of s (F_smooth - F0) after the plateau [N]
    slips: bool = False
    slip_level: float = float("nan")  #: median raw F over the slip phase (signed) [N]
    slip_travel: float = float("nan")
    clearance: float = float("nan")  #: near-zero plateau width [m]
    clearance_tangent: float = float("nan")  #: between the flank-line intercepts [m]
    k_load: float = float("nan")  #: loading-flank slope [N/m]
    k_unload: float = float("nan")  #: unloading-flank slope [N/m]
    k_gap: float = float("nan")  #: slope of the raw force over the near-zero plateau [N/m]
    plateau: tuple[int, int] | None = field(default=None, repr=False)


def read_half_cycle(
    x: np.ndarray, f: np.ndarray, fs: np.ndarray, t: np.ndarray, f0: float, band: float
) -> HalfCycle:
    """Read one half-cycle (arrays cut from one reversal to the next; see the module text).

    Parameters
    ----------
    x, f, fs, t : ndarray
        Displacement [m], raw force [N], smoothed force [N], time [s].
    f0 : float
        Force read with no contact [N].
    band : float
        Half-width of the near-zero band [N].
    """
    s = 1 if x[-1] >= x[0] else -1
    hc = HalfCycle(float(t[0]), float(t[-1]), s, float(abs(x[-1] - x[0])))
    g = s * (fs - f0)
    contact = _first(g >= CONTACT * band)
    if contact is None:
        return hc  # never in firm contact on the front side: nothing to read
    inb = np.flatnonzero(np.abs(g[:contact]) <= band)
    last_in = int(inb[-1]) if inb.size else -1
    unload = None
    if inb.size and g[0] < -band:  # back contact -> plateau -> front contact: complete
        j0 = int(inb[0])
        hc.clearance = float(abs(x[last_in] - x[j0]))
        hc.plateau = (j0, last_in)
        if last_in - j0 >= 3 and np.ptp(x[j0 : last_in + 1]) > 0:
            hc.k_gap = float(np.polyfit(x[j0 : last_in + 1], f[j0 : last_in + 1], 1)[0])
        g0 = -g[0]
        if g0 >= band / FLANK[0]:
            unload = flank_line(
                x[: j0 + 1], f[: j0 + 1], g[: j0 + 1], -FLANK[1] * g0, -FLANK[0] * g0
            )
            hc.k_unload = unload[0] if unload else float("nan")
    gf, xf, ff = g[last_in + 1 :], x[last_in + 1 :], f[last_in + 1 :]
    hc.peak = float(gf.max())
    level = float(np.percentile(gf, LEVEL_PCT))
    if level < band / FLANK[0]:
        return hc
    load = flank_line(xf, ff, gf, FLANK[0] * level, FLANK[1] * level)
    if load is not None:
        hc.k_load = load[0]
        if unload is not None:
            x_load, x_unload = (f0 - load[1]) / load[0], (f0 - unload[1]) / unload[0]
            hc.clearance_tangent = float(s * (x_load - x_unload))
    a, on = _first(gf >= FLANK[0] * level), _first(gf >= ONSET * level)
    assert a is not None and on is not None  # level <= max(gf)
    hc.slip_travel = float(abs(xf[-1] - xf[on]))
    hc.slips = bool(level >= 5 * band and hc.slip_travel >= SLIP_RATIO * abs(xf[on] - xf[a]))
    if hc.slips:
        hc.slip_level = float(np.median(ff[on:]))
    return hc


@dataclass
class Reading:
    """Reading of one record: settings found, half-cycles, channel checks (SI)."""

    name: str
    f0: float
    band: float
    sigma: float
    hysteresis: float
    half_cycles: list[HalfCycle]
    checks: dict[str, float]


def read_record(rec: Record, band_frac: float = BAND_FRAC) -> Reading:
    """Read every half-cycle of ``rec`` (module text) and check the channels against each other.

    Three passes refine ``F0``, the noise ``sigma`` (first-difference MAD of the raw force on the
    near-zero samples) and the band ``b = max(band_frac * L, BAND_SIGMA * sigma)``; ``L`` is the
    mean of the median positive and median negative slip levels from ``F0`` (before any slip is
    read: half the 2nd-98th percentile span of the smoothed force).
    """
    x, f, t = rec.x, rec.force, rec.t
    fs = median_filter(f, size=SMOOTH_N, mode="nearest")
    scale = 0.5 * float(np.percentile(fs, 98) - np.percentile(fs, 2))
    band = band_frac * scale
    h = max(HYST_FRAC * float(np.ptp(x)), HYST_MIN)
    cuts = np.unique(np.concatenate([[0], reversals(x, h), [x.size - 1]]))
    f0, sigma = 0.0, noise_sigma(f)
    for _ in range(3):
        near = np.abs(fs - f0) <= band
        sigma = noise_sigma(f[near]) if near.sum() > 10 else noise_sigma(f)
        band = max(band_frac * scale, BAND_SIGMA * sigma)
        hcs = [
            read_half_cycle(x[i : j + 1], f[i : j + 1], fs[i : j + 1], t[i : j + 1], f0, band)
            for i, j in pairwise(cuts)
        ]
        on_plateau = [
            f[i + p[0] : i + p[1] + 1]
            for i, hc in zip(cuts[:-1], hcs)
            if (p := hc.plateau) is not None
        ]
        if on_plateau:
            f0 = float(np.median(np.concatenate(on_plateau)))
        levels = [
            np.median(
                [abs(hc.slip_level - f0) for hc in hcs if hc.slips and hc.direction == d]
                or [np.nan]
            )
            for d in (1, -1)
        ]
        if np.any(np.isfinite(levels)):
            scale = float(np.nanmean(levels))
    return Reading(rec.name, f0, band, sigma, h, hcs, channel_checks(rec))


def velocity(x: np.ndarray, dt: float) -> np.ndarray:
    """Velocity [m/s] from the displacement [m]: 31-sample quadratic Savitzky-Golay derivative."""
    return savgol_filter(x, 31, 2, deriv=1, delta=dt)


def channel_checks(rec: Record) -> dict[str, float]:
    """Gains, correlations and signs relating the channels of ``rec`` (module text, part d).

    Returns ``force_per_act_diff`` (LS gain of the friction force on ``act2 - act1``, N/N),
    ``corr_act`` (their correlation), ``lag_act_samples`` (shift of ``act2 - act1`` that best
    matches the force, +-30 samples; positive = the actuator difference lags),
    ``velocity_gain`` / ``corr_velocity`` (velocity channel on the derivative of the
    displacement), ``dissipating_fraction`` (share of samples with ``|v| > 30 % max |v|``
    where ``F v > 0``), ``power_sign`` (sign of the mean ``F v`` there),
    ``force_rest_start`` / ``force_rest_end`` (mean force over the first/last 0.2 s, N) and
    ``act_rest_start`` (mean of each actuator channel over the first 0.2 s, N).
    """
    v = velocity(rec.x, rec.dt)
    d = rec.act2 - rec.act1
    n = max(1, round(0.2 / rec.dt))
    moving = np.abs(v) > 0.3 * np.abs(v).max()
    p = rec.force[moving] * v[moving]
    lags = np.arange(-30, 31)
    core = slice(30, rec.force.size - 30)
    xc = [np.dot(rec.force[core], np.roll(d, k)[core]) for k in lags]
    return {
        "force_per_act_diff": float(np.dot(rec.force, d) / np.dot(d, d)),
        "lag_act_samples": int(lags[int(np.argmax(xc))]),
        "corr_act": float(np.corrcoef(rec.force, d)[0, 1]),
        "velocity_gain": float(np.dot(rec.velocity, v) / np.dot(v, v)),
        "corr_velocity": float(np.corrcoef(rec.velocity, v)[0, 1]),
        "dissipating_fraction": float(np.mean(p > 0)),
        "power_sign": float(np.sign(np.mean(p))),
        "force_rest_start": float(np.mean(rec.force[:n])),
        "force_rest_end": float(np.mean(rec.force[-n:])),
        "act1_rest_start": float(np.mean(rec.act1[:n])),
        "act2_rest_start": float(np.mean(rec.act2[:n])),
    }


def stats(values: list[float] | np.ndarray) -> dict[str, float]:
    """``n``, ``median``, ``q25``, ``q75`` of the finite ``values`` (``nan`` if there are none)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"n": 0, "median": float("nan"), "q25": float("nan"), "q75": float("nan")}
    q25, med, q75 = np.percentile(v, [25, 50, 75])
    return {"n": int(v.size), "median": float(med), "q25": float(q25), "q75": float(q75)}


def summarize(r: Reading) -> dict[str, dict[str, float]]:
    """Per-record statistics across half-cycles, SI (N, m, N/m; ``breakaway`` is a ratio).

    ``slip_pos`` / ``slip_neg``: signed slip levels; ``friction`` / ``centre``: half the
    difference and the mean of the slip levels of every two consecutive *slipping* half-cycles
    of opposite directions (non-slipping half-cycles between them are skipped; each may enter
    two pairs); ``clearance``,
    ``clearance_tangent``, ``k_load``, ``k_unload``, ``k_gap``; ``breakaway`` (peak / slip
    level, both from ``F0``).
    """
    hcs = r.half_cycles
    slips = [h for h in hcs if h.slips]
    pairs = [
        (a.slip_level, b.slip_level) if a.direction > 0 else (b.slip_level, a.slip_level)
        for a, b in pairwise(slips)
        if a.direction != b.direction
    ]
    out = {
        "slip_pos": stats([h.slip_level for h in hcs if h.slips and h.direction > 0]),
        "slip_neg": stats([h.slip_level for h in hcs if h.slips and h.direction < 0]),
        "friction": stats([0.5 * (p - q) for p, q in pairs]),
        "centre": stats([0.5 * (p + q) for p, q in pairs]),
        "clearance": stats([h.clearance for h in hcs]),
        "clearance_tangent": stats([h.clearance_tangent for h in hcs]),
        "k_load": stats([h.k_load for h in hcs]),
        "k_unload": stats([h.k_unload for h in hcs]),
        "k_gap": stats([h.k_gap for h in hcs]),
        "breakaway": stats(
            [h.peak / (h.direction * (h.slip_level - r.f0)) for h in hcs if h.slips]
        ),
    }
    return out
