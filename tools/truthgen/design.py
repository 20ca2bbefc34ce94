"""Case design: effect plans, effect parameters, amplitudes, nominal mis-calibration.

Parameter ranges (SI; "logU" = log-uniform)
--------------------------------------------
internal_stiffness  internal resonance f_i = sqrt(k_s / inertance) / 2 pi, logU 5-150 Hz;
                    series damping ratio c_s / (2 sqrt(k_s inertance)) logU 0.02-0.3
backlash            gap (total clearance) logU 20 um - 2 mm, capped at 0.3 x the smallest
                    record's peak command; contact stiffness logU 2e7-5e8 N/m; contact
                    damping ratio c_c / (2 sqrt(k_c (rod + inertance))) logU 0.01-0.3
coulomb_friction    friction logU 3-50 % of the median (over records) nominal peak force;
                    presliding displacement friction / presliding_stiffness logU 2-50 um
amplitude_damping   c2 logU 0.2-10 mm; c1 = c(A_ref) (A_ref + c2) with c(A_ref) logU
                    0.05-0.8 x (rod + inertance) 2 pi f_ref, A_ref the median record peak
                    displacement, f_ref the median record velocity-weighted mean frequency
actuator_delay      logU 1.5-20 ms beyond the nominal's, floored at 1.5 output samples
                    (at 1000-4096 Hz the floor never binds: 1.5 ms >= 1.5 samples)
rate_limit          velocity limit U 40-90 % of the median (over records) nominal peak speed

``ranges="wide"`` (the series elements of a lab's hardware, lightly damped): internal
stiffness logU 1e5-1e10 N/m with series damping ratio logU 0.005-0.1; backlash gap logU
1 um - 5 mm (same cap), contact stiffness logU 1e5-1e10 N/m, contact damping ratio logU
0.002-0.05; friction logU 0.5-60 % of the peak force; the other classes as above.
"""

from __future__ import annotations

import math

import numpy as np

EFFECTS = (
    "internal_stiffness",
    "backlash",
    "coulomb_friction",
    "amplitude_damping",
    "actuator_delay",
    "rate_limit",
)
CHANNEL = {
    "internal_stiffness": "specimen",
    "backlash": "specimen",
    "coulomb_friction": "specimen",
    "amplitude_damping": "specimen",
    "actuator_delay": "actuator",
    "rate_limit": "actuator",
}
PAIRS = (
    ("coulomb_friction", "backlash"),
    ("internal_stiffness", "amplitude_damping"),
    ("actuator_delay", "coulomb_friction"),
    ("rate_limit", "backlash"),
    ("internal_stiffness", "backlash"),
    ("coulomb_friction", "amplitude_damping"),
    ("actuator_delay", "backlash"),
    ("rate_limit", "coulomb_friction"),
    ("internal_stiffness", "coulomb_friction"),
    ("actuator_delay", "internal_stiffness"),
    ("rate_limit", "amplitude_damping"),
    ("backlash", "amplitude_damping"),
    ("actuator_delay", "amplitude_damping"),
    ("rate_limit", "internal_stiffness"),
    ("actuator_delay", "rate_limit"),
)
DOUBLE_FRACTION = 0.3


def loguniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    """Log-uniform draw in [lo, hi]."""
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def plan_cases(
    rng: np.random.Generator, n: int, only: tuple[str, ...] | None = None
) -> list[tuple[str, ...]]:
    """Effect sets of ``n`` cases: ceil(30 %) pairs (if n >= 2), singles cycle through
    ``none`` and every effect class, order shuffled.  ``only`` (effect classes, ``"none"``
    included or not) keeps the singles and pairs made of those classes alone (a focused
    suite, e.g. the specimen's series elements)."""
    singles = [()] + [(e,) for e in EFFECTS]
    pairs = list(PAIRS)
    if only is not None:
        keep = set(only)
        singles = [s for s in singles if (s and s[0] in keep) or (not s and "none" in keep)]
        pairs = [p for p in pairs if set(p) <= keep]
    n_double = math.ceil(DOUBLE_FRACTION * n) if n >= 2 and pairs else 0
    if not singles:
        n_double = n
    s_order = [singles[i] for i in rng.permutation(len(singles))]
    d_order = [pairs[i] for i in rng.permutation(len(pairs))]
    plan = [s_order[i % len(s_order)] for i in range(n - n_double)]
    plan += [d_order[i % len(d_order)] for i in range(n_double)]
    return [plan[i] for i in rng.permutation(n)]


def effect_params(
    rng: np.random.Generator, name: str, ref: dict, ranges: str = "default"
) -> dict[str, float]:
    """Draw one effect's labelled parameters.

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source.
    name : str
        Effect class.
    ref : dict
        Nominal-simulation references: ``inertance``, ``rod_mass`` (kg),
        ``peak_force`` (N), ``peak_speed`` (m/s), ``peak_disp`` and
        ``min_peak_cmd`` (m), ``f_ref`` (Hz), ``fs`` (Hz).
    ranges : str
        ``"default"`` or ``"wide"`` (module docstring).

    Returns
    -------
    dict
        Parameters in SI units, keyed as in the labels.
    """
    m_dev = ref["inertance"] + ref["rod_mass"]
    if ranges == "wide" and name == "internal_stiffness":
        k = loguniform(rng, 1e5, 1e10)
        return {
            "stiffness": k,
            "series_damping": 2 * loguniform(rng, 0.005, 0.1) * math.sqrt(k * ref["inertance"]),
        }
    if ranges == "wide" and name == "backlash":
        gap = loguniform(rng, 1e-6, max(2e-6, min(5e-3, 0.3 * ref["min_peak_cmd"])))
        kc = loguniform(rng, 1e5, 1e10)
        return {
            "gap": gap,
            "contact_stiffness": kc,
            "contact_damping": 2 * loguniform(rng, 0.002, 0.05) * math.sqrt(kc * m_dev),
        }
    if ranges == "wide" and name == "coulomb_friction":
        f = loguniform(rng, 0.005, 0.6) * ref["peak_force"]
        return {"friction": f, "presliding_stiffness": f / loguniform(rng, 2e-6, 50e-6)}
    if name == "internal_stiffness":
        k = ref["inertance"] * (2 * math.pi * loguniform(rng, 5.0, 150.0)) ** 2
        return {
            "stiffness": k,
            "series_damping": 2 * loguniform(rng, 0.02, 0.3) * math.sqrt(k * ref["inertance"]),
        }
    if name == "backlash":
        gap = loguniform(rng, 20e-6, max(25e-6, min(2e-3, 0.3 * ref["min_peak_cmd"])))
        kc = loguniform(rng, 2e7, 5e8)
        return {
            "gap": gap,
            "contact_stiffness": kc,
            "contact_damping": 2 * loguniform(rng, 0.01, 0.3) * math.sqrt(kc * m_dev),
        }
    if name == "coulomb_friction":
        f = loguniform(rng, 0.03, 0.5) * ref["peak_force"]
        return {"friction": f, "presliding_stiffness": f / loguniform(rng, 2e-6, 50e-6)}
    if name == "amplitude_damping":
        c2 = loguniform(rng, 0.2e-3, 10e-3)
        c_ref = loguniform(rng, 0.05, 0.8) * m_dev * 2 * math.pi * ref["f_ref"]
        return {"c1": c_ref * (ref["peak_disp"] + c2), "c2": c2}
    if name == "actuator_delay":
        return {"delay": max(loguniform(rng, 1.5e-3, 20e-3), 1.5 / ref["fs"])}
    if name == "rate_limit":
        return {"velocity_limit": rng.uniform(0.4, 0.9) * ref["peak_speed"]}
    raise ValueError(name)


def derived(name: str, p: dict, ref: dict) -> dict[str, float]:
    """Human-readable derived quantities of an effect (for the labels)."""
    m_dev = ref["inertance"] + ref["rod_mass"]
    if name == "internal_stiffness":
        return {
            "internal_resonance_hz": math.sqrt(p["stiffness"] / ref["inertance"]) / (2 * math.pi),
            "series_damping_ratio": p["series_damping"]
            / (2 * math.sqrt(p["stiffness"] * ref["inertance"])),
        }
    if name == "backlash":
        return {
            "contact_damping_ratio": p["contact_damping"]
            / (2 * math.sqrt(p["contact_stiffness"] * m_dev)),
            "gap_over_min_peak_command": p["gap"] / ref["min_peak_cmd"],
        }
    if name == "coulomb_friction":
        return {
            "friction_over_peak_force": p["friction"] / ref["peak_force"],
            "presliding_displacement": p["friction"] / p["presliding_stiffness"],
        }
    if name == "amplitude_damping":
        return {
            "damping_at_ref_amplitude": p["c1"] / (ref["peak_disp"] + p["c2"]),
            "damping_at_zero_amplitude": p["c1"] / p["c2"],
            "ref_amplitude": ref["peak_disp"],
        }
    if name == "actuator_delay":
        return {"delay_samples": p["delay"] * ref["fs"]}
    return {"limit_over_median_peak_speed": p["velocity_limit"] / ref["peak_speed"]}


def miscalibrate(
    rng: np.random.Generator, num: np.ndarray, den: np.ndarray, delay: float, fs: float, spec: dict
) -> tuple[np.ndarray, np.ndarray, float, dict, dict]:
    """Lab-identified nominal: the true linearisation with up to +/-10 % errors.

    Gain x (1 + e_g), all poles/zeros scaled in frequency by (1 + e_w), the
    damping ratio of every complex pole pair x (1 + e_z), delay + e_d / fs with
    e_d in +/-0.8 sample (floored at 0), inertance/damping/stiffness x (1 + e).
    Every e is U(-0.1, 0.1) (e_d U(-0.8, 0.8)).

    Returns
    -------
    num, den, delay, specimen, errors
        Mis-calibrated TF (den[0] == 1), delay (s), specimen dict, and the
        relative errors drawn.
    """
    e = {
        k: float(rng.uniform(-0.1, 0.1))
        for k in ("gain", "frequency", "pole_damping", "inertance", "damping", "stiffness")
    }
    e["delay_samples"] = float(rng.uniform(-0.8, 0.8))
    poles = np.roots(den)
    new = []
    for p in poles:
        if abs(p.imag) > 1e-9 * abs(p):
            wn = abs(p)
            z = min(0.99, -p.real / wn * (1 + e["pole_damping"]))
            new.append(complex(-z * wn, math.copysign(wn * math.sqrt(1 - z * z), p.imag)))
        else:
            new.append(p)
    den2 = np.real(np.poly(new))
    num2 = num * (den2[-1] / den[-1]) * (1 + e["gain"])
    a = 1 + e["frequency"]
    n = len(den2) - 1
    den2 = den2 * a ** np.arange(n + 1)
    num2 = num2 * a ** (n - np.arange(len(num2) - 1, -1, -1))
    num2, den2 = num2 / den2[0], den2 / den2[0]
    delay2 = max(0.0, delay + e["delay_samples"] / fs)
    spec2 = {
        "inertance": spec["inertance"] * (1 + e["inertance"]),
        "damping": spec["damping"] * (1 + e["damping"]),
        "stiffness": spec["stiffness"] * (1 + e["stiffness"]),
    }
    return num2, den2, delay2, spec2, e
