"""Random lab hardware: actuator (with a tuned controller board) and specimen.

The controller board is tuned the way a lab technician would: delta-P
stabilisation raises the oil-column damping ratio to a target, then the
displacement P gain is set for a gain margin of 2-3.5 with the nominal specimen
installed.  Draws whose closed-loop low-frequency lag falls outside 8-30 ms are
rejected (the brief asks for ~10-25 ms).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

from .plant import Actuator, Specimen, nominal_linear_model


def loguniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    """Log-uniform draw in [lo, hi]."""
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def sample_specimen(rng: np.random.Generator) -> Specimen:
    """Lab-scale ball-screw inertial mass damper.

    Inertance 200-5000 kg (log-uniform), rod mass 3-30 kg, viscous damping 0
    (30 %) or 0.05-1 x the inertial impedance at 2 Hz, parallel stiffness 0
    (70 %) or a 0.5-3 Hz spring.
    """
    b = loguniform(rng, 200.0, 5000.0)
    mr = loguniform(rng, 3.0, 30.0)
    w2 = 2 * math.pi * 2.0
    c = 0.0 if rng.random() < 0.3 else loguniform(rng, 0.05, 1.0) * (b + mr) * w2
    k = 0.0 if rng.random() < 0.7 else (b + mr) * (2 * math.pi * rng.uniform(0.5, 3.0)) ** 2
    return Specimen(inertance=b, rod_mass=mr, damping=c, stiffness=k)


def open_loop_tf(act: Actuator, spec: Specimen) -> tuple[np.ndarray, np.ndarray]:
    """Valve-current -> displacement TF with delta-P loop closed and kp = 1 (num, den)."""
    a1 = Actuator(**{**act.__dict__, "kp": 1.0})
    num, den = nominal_linear_model(a1, spec)
    # closed loop T = L/(1+L) with L = n/d  ->  L = T/(1-T) = num/(den-num)
    num_p = np.pad(num, (len(den) - len(num), 0))
    return num, den - num_p


def tune(act: Actuator, spec: Specimen, zeta_target: float, gain_margin: float) -> Actuator:
    """Set delta-P and proportional gains.

    Parameters
    ----------
    act : Actuator
        Actuator with physical parameters (gains ignored).
    spec : Specimen
        Nominal specimen.
    zeta_target : float
        Target oil-column damping ratio, -.
    gain_margin : float
        Displacement-loop gain margin, - (absolute, not dB).

    Returns
    -------
    Actuator
        Copy with ``kdp`` and ``kp`` set.
    """
    m = act.piston_mass + spec.total_inertance
    root = math.sqrt(act.bulk_modulus * m / act.volume)
    zeta_other = (act.leakage / act.area) * root + (act.piston_damping + spec.damping) / (
        4 * act.area * root
    )
    kce_needed = max(0.0, (zeta_target - zeta_other) * act.area / root)
    kdp = max(0.0, kce_needed - act.leakage) / act.rated_flow
    act = Actuator(**{**act.__dict__, "kdp": kdp, "kp": 1.0})
    num, den = open_loop_tf(act, spec)
    w = 2 * math.pi * np.logspace(-1, 3.5, 4000)
    _, H = signal.freqs(num, den, worN=w)
    ph = np.unwrap(np.angle(H))
    idx = np.flatnonzero(ph <= -np.pi)
    if idx.size == 0:
        raise ValueError("no phase crossover")
    kp_max = 1.0 / abs(H[idx[0]])
    return Actuator(**{**act.__dict__, "kp": float(kp_max / gain_margin)})


def lag(act: Actuator, spec: Specimen, f: float = 1.0) -> float:
    """Closed-loop command->displacement lag at ``f`` Hz from the phase, s."""
    num, den = nominal_linear_model(act, spec)
    _, H = signal.freqs(num, den, worN=[2 * math.pi * f])
    return float(-np.angle(H[0]) / (2 * math.pi * f))


def sample_actuator(rng: np.random.Generator, spec: Specimen, tries: int = 400) -> Actuator:
    """Servo-hydraulic actuator sized and tuned for ``spec``.

    Ranges: supply 15-21 MPa, rated force 25-250 kN (log), half stroke 50-150 mm,
    dead volume 20-60 % of swept, bulk modulus 0.7-1.4 GPa, piston mass 10-60 kg,
    seal damping 200-3000 N s/m, leakage damping ratio 0.02-0.15, valve 60-200 Hz
    with damping 0.5-0.9, no-load speed at full valve opening 0.25-0.8 m/s,
    controller latency 0.1-1 ms, target oil-column damping 0.3-0.7, gain margin
    2-3.5.  Rejection: closed-loop lag at 1 Hz within 8-30 ms.
    """
    for _ in range(tries):
        ps = rng.uniform(15e6, 21e6)
        area = loguniform(rng, 25e3, 250e3) / ps
        stroke = float(rng.choice([0.05, 0.075, 0.1, 0.125, 0.15]))
        volume = 2 * area * stroke * (1 + rng.uniform(0.2, 0.6))
        beta = rng.uniform(0.7e9, 1.4e9)
        mp = loguniform(rng, 10.0, 60.0)
        m = mp + spec.total_inertance
        leak = rng.uniform(0.02, 0.15) * area / math.sqrt(beta * m / volume)
        act = Actuator(
            area=area,
            volume=volume,
            bulk_modulus=beta,
            piston_mass=mp,
            piston_damping=loguniform(rng, 200.0, 3000.0),
            leakage=leak,
            rated_flow=rng.uniform(0.25, 0.8) * area,
            valve_freq=rng.uniform(60.0, 200.0),
            valve_zeta=rng.uniform(0.5, 0.9),
            kp=1.0,
            kdp=0.0,
            latency=rng.uniform(1e-4, 1e-3),
            stroke=stroke,
            supply_pressure=ps,
        )
        try:
            act = tune(act, spec, rng.uniform(0.3, 0.7), rng.uniform(2.0, 3.5))
        except ValueError:
            continue
        if 8e-3 <= lag(act, spec) <= 30e-3:
            return act
    raise RuntimeError("could not draw an actuator meeting the lag window")
