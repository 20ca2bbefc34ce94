"""Displacement-command shapes (unit peak) for the test records.

Every shape starts and ends with 0.5 s of rest and is tapered in and out, so
the actuator starts and ends at rest.  Amplitudes are set later by the case
designer (:mod:`cases`) from the nominal model's predicted force and speed.

Families
--------
sine          one sine, 0.3-8 Hz, cosine taper over max(1 s, 2 cycles)
stepped_sine  three tapered sine blocks, 0.3-10 Hz, relative amplitudes 0.25-1
sweep         log sweep 0.2-0.5 Hz -> 8-25 Hz, displacement amplitude
              1 / (1 + (f / fc)^p), fc 1-3 Hz, p 1-2 (constant velocity or
              acceleration at high frequency)
random        Gaussian band-limited noise, 4-pole Butterworth band 0.1-0.3 Hz to
              4-25 Hz, Tukey taper
earthquake    Kanai-Tajimi/Clough-Penzien filtered white noise (ground frequency
              1-4 Hz, damping 0.3-0.7) under a rise/plateau/exponential-decay
              envelope, driving a storey (SDOF 0.7-4 Hz, damping 2-8 %) whose
              drift is the damper command (0.1 Hz high-pass, Tukey taper)
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

FAMILIES = ("sine", "stepped_sine", "sweep", "random", "earthquake")
REST = 0.5  # s of rest before and after the motion


def _taper(n: int, nt: int) -> np.ndarray:
    """Raised-cosine taper of ``nt`` samples at both ends of an ``n``-sample window."""
    w = np.ones(n)
    nt = max(1, min(nt, n // 2))
    ramp = 0.5 - 0.5 * np.cos(np.pi * np.arange(nt) / nt)
    w[:nt] = ramp
    w[n - nt :] = ramp[::-1]
    return w


def _loguni(rng: np.random.Generator, lo: float, hi: float) -> float:
    """Log-uniform draw in [lo, hi]."""
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def make(
    rng: np.random.Generator, family: str, fs: float, duration: float
) -> tuple[np.ndarray, dict]:
    """Unit-peak command shape.

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source.
    family : str
        One of :data:`FAMILIES`.
    fs : float
        Sample rate, Hz.
    duration : float
        Total record length incl. rest, s.

    Returns
    -------
    shape : ndarray
        Command shape with max |shape| == 1, dimensionless.
    info : dict
        Family and its drawn parameters (Hz, s).
    """
    n = int(round(duration * fs))
    nr = int(round(REST * fs))
    nm = n - 2 * nr
    t = np.arange(nm) / fs
    T = nm / fs
    info: dict = {"family": family}
    if family == "sine":
        f = _loguni(rng, 0.3, 8.0)
        y = np.sin(2 * np.pi * f * t) * _taper(nm, int(max(1.0, 2.0 / f) * fs))
        info["frequency"] = f
    elif family == "stepped_sine":
        nb = 3
        edges = np.linspace(0, nm, nb + 1).astype(int)
        y = np.zeros(nm)
        blocks = []
        amps = rng.uniform(0.25, 1.0, nb)
        amps[rng.integers(nb)] = 1.0
        for i in range(nb):
            f = _loguni(rng, 0.3, 10.0)
            gap = int(0.2 * fs)
            a, b = edges[i] + gap, edges[i + 1] - gap
            tb = np.arange(b - a) / fs
            taper = min(max(1.0, 2.0 / f), 0.3 * (b - a) / fs)  # s
            y[a:b] = amps[i] * np.sin(2 * np.pi * f * tb) * _taper(b - a, int(taper * fs))
            blocks.append({"frequency": f, "relative_amplitude": float(amps[i])})
        info["blocks"] = blocks
    elif family == "sweep":
        f0, f1 = rng.uniform(0.2, 0.5), rng.uniform(8.0, 25.0)
        fc, pw = rng.uniform(1.0, 3.0), rng.uniform(1.0, 2.0)
        k = math.log(f1 / f0) / T
        fi = f0 * np.exp(k * t)
        ph = 2 * np.pi * f0 * (np.exp(k * t) - 1) / k
        y = np.sin(ph) / (1 + (fi / fc) ** pw) * _taper(nm, int(max(1.0, 2.0 / f0) * fs))
        info.update(f_start=f0, f_end=f1, corner=fc, rolloff_power=pw)
    elif family == "random":
        flo, fhi = rng.uniform(0.1, 0.3), _loguni(rng, 4.0, 25.0)
        sos = signal.butter(4, [flo, min(fhi, 0.4 * fs)], btype="bandpass", fs=fs, output="sos")
        y = signal.sosfiltfilt(sos, rng.standard_normal(nm + 2 * int(fs)))[int(fs) : int(fs) + nm]
        y *= signal.windows.tukey(nm, min(1.0, 2.0 / T))
        info.update(f_low=flo, f_high=fhi)
    elif family == "earthquake":
        fg, zg = rng.uniform(1.0, 4.0), rng.uniform(0.3, 0.7)
        wg, wf = 2 * np.pi * fg, 2 * np.pi * 0.1 * fg
        kt = signal.lti([2 * zg * wg, wg**2], [1, 2 * zg * wg, wg**2])
        w = rng.standard_normal(nm)
        _, acc, _ = signal.lsim(kt, w, t)
        cp = signal.lti([1, 0, 0], [1, 2 * zg * wf, wf**2])
        _, acc, _ = signal.lsim(cp, acc, t)
        t1 = rng.uniform(0.08, 0.2) * T
        t2 = t1 + rng.uniform(0.2, 0.45) * T
        env = np.where(
            t < t1, (t / t1) ** 2, np.where(t < t2, 1.0, np.exp(-3.0 * (t - t2) / (T - t2)))
        )
        acc *= env
        # the damper sees the drift of a lightly damped storey (SDOF) under that ground motion
        fsd, zsd = rng.uniform(0.7, 4.0), rng.uniform(0.02, 0.08)
        ws = 2 * np.pi * fsd
        _, y, _ = signal.lsim(signal.lti([-1.0], [1, 2 * zsd * ws, ws**2]), acc, t)
        sos = signal.butter(2, 0.1, btype="highpass", fs=fs, output="sos")
        y = signal.sosfiltfilt(sos, y) * signal.windows.tukey(nm, min(1.0, 2.0 / T))
        info.update(
            ground_frequency=fg,
            ground_damping=zg,
            rise=t1,
            decay_start=t2,
            storey_frequency=fsd,
            storey_damping=zsd,
        )
    else:
        raise ValueError(f"unknown excitation family {family!r}")
    out = np.zeros(n)
    out[nr : nr + nm] = y
    out /= np.max(np.abs(out))
    return out, info
