"""Data acquisition: ranges, 16-bit converters, sensor noise, offsets, file writers.

Conventions
-----------
* Row k: ``time`` t_k = k / fs (s); ``command`` the DAC value applied over
  [t_k, t_k+1) (m); ``measured`` and ``force`` the ADC samples at t_k (m, N).
* DAC and displacement ADC share one full scale per case (the LVDT conditioner
  range: smallest of 2/5/10/25/50/100/125/150/250 mm at or above 1.25 x the
  case's peak command, never above the actuator half stroke).
* The force conditioner auto-ranges per record: full scale is the smallest of
  {1, 2, 2.5, 5} x 10^n N at or above 1.1 x the record's noise-free peak force.
* Converters are 16-bit bipolar, mid-tread, saturating at full scale.
* Noise is white Gaussian added at the ADC input after the analog anti-alias
  filter (electronics noise), plus a constant offset per channel and record.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

BITS = 16
DISP_RANGES = (0.002, 0.005, 0.01, 0.025, 0.05, 0.1, 0.125, 0.15, 0.25)


def displacement_range(peak: float, stroke: float) -> float:
    """LVDT/DAC full scale for a case, m."""
    for r in DISP_RANGES:
        if r >= 1.25 * peak and r <= stroke + 1e-12:
            return r
    return stroke


def force_range(peak: float) -> float:
    """Auto-ranged load-cell conditioner full scale, N."""
    need = max(1.1 * peak, 1.0)
    dec = 10.0 ** math.floor(math.log10(need))
    for m in (1.0, 2.0, 2.5, 5.0, 10.0):
        if m * dec >= need * (1 - 1e-12):
            return m * dec
    return 10.0 * dec


def lsb(full_scale: float) -> float:
    """Converter resolution for a bipolar +/- full scale, same unit."""
    return 2.0 * full_scale / 2**BITS


def quantize(x: np.ndarray, full_scale: float) -> np.ndarray:
    """16-bit bipolar mid-tread quantisation with saturation."""
    q = lsb(full_scale)
    codes = np.clip(np.round(np.asarray(x) / q), -(2 ** (BITS - 1)), 2 ** (BITS - 1) - 1)
    return codes * q + 0.0  # + 0.0: no negative zeros in the files


def acquire(
    clean: np.ndarray, full_scale: float, sigma: float, offset: float, rng: np.random.Generator
) -> np.ndarray:
    """ADC reading of a noise-free analog signal: offset + white noise, then quantise."""
    return quantize(clean + offset + sigma * rng.standard_normal(len(clean)), full_scale)


def write_csv(
    path: Path, fs: float, command: np.ndarray, measured: np.ndarray, force: np.ndarray
) -> None:
    """Record file with header ``time,command,measured,force`` (SI)."""
    t = np.arange(len(command)) / fs
    data = np.column_stack([t, command, measured, force])
    np.savetxt(
        path,
        data,
        delimiter=",",
        header="time,command,measured,force",
        comments="",
        fmt=["%.15g", "%.10g", "%.10g", "%.10g"],
    )


def _num(x: float) -> str:
    """TOML float literal."""
    r = repr(float(x))
    return r if ("." in r or "e" in r or "inf" in r or "nan" in r) else r + ".0"


def write_nominal(
    path: Path,
    num: np.ndarray,
    den: np.ndarray,
    delay: float,
    inertance: float,
    damping: float,
    stiffness: float,
) -> None:
    """NOMINAL.toml: the simulation's (lab-identified, mis-calibrated) linear model."""
    lines = [
        "[actuator]",
        "num = [" + ", ".join(_num(v) for v in num) + "]",
        "den = [" + ", ".join(_num(v) for v in den) + "]",
        f"delay = {_num(delay)}",
        "",
        "[specimen]",
        f"inertance = {_num(inertance)}",
        f"damping = {_num(damping)}",
        f"stiffness = {_num(stiffness)}",
        "friction = 0.0",
        "",
    ]
    path.write_text("\n".join(lines))
