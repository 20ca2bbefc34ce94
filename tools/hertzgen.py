"""A small independent truth generator for the diagnosis's hard cases: Hertz / Hunt-Crossley
backlash impacts, multi-sample actuator delays and soft series elements with their own damping.

    python tools/hertzgen.py --out DIR --cases N --seed S [--kinds backlash,delay,series,none]

Written from scratch for checking ``rths diagnose`` (numpy/scipy and ``tools/truthgen``'s DAQ
helpers only; nothing from ``rths/`` or ``plants/``).  Per case:

* actuator: command (DAQ convention, held over [t_k, t_k+1)) -> latency -> second-order
  position loop ``w^2/(s^2 + 2 z w s + w^2)`` (15-40 Hz, damping 0.5-0.8), simulated at
  ``M`` sub-steps per sample; ``delay`` cases add 1.2-3 samples to the latency;
* specimen (inertance 200-5000 kg, viscous damping, optional parallel spring) behind
  - ``backlash``: a clearance ``g`` (logU 200-460 um total) closed by a Hertz contact with
    Hunt-Crossley damping, ``F = k_c d^n (1 + alpha d')`` for penetration ``d > 0`` and never
    pulling (n = 1.5, k_c logU 4e9-7e10 N/m^1.5, alpha U 15-35 s/m); the excitation is scaled
    so that the peak deflection is 25-75 um;
  - ``series``: a series spring ``k_s`` (3-5 x the specimen's dynamic stiffness at the
    excitation's frequency) with a series damper of 100-600 N s/m;
  - otherwise rigid.  The load cell at the piston reads the element's force.
* integrator: classical RK4 on the body at ``M`` sub-steps per sample (``omega h < 0.3`` for
  the stiffest contact), the piston motion linear between sub-steps;
* DAQ: a 4-pole Bessel anti-alias filter at 0.2-0.3 of the output rate on both channels
  (an impact's force is shorter than a sample: the filter keeps its impulse), then
  ``tools/truthgen``'s converter model (16-bit, auto-ranged force, white noise, offsets);
  nominal: the true linear model mis-calibrated by ``tools/truthgen.design.miscalibrate``
  (+/-10 % gain, poles, damping, specimen; +/-0.8 sample delay).

Labels in ``DIR/labels.json`` (the shared schema of ``tools/score_diagnosis.py``).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
from scipy import signal

sys.path.insert(0, str(Path(__file__).resolve().parent))
from truthgen import daq, design

KINDS = ("backlash", "delay", "series", "none")


def _piston(cmd: np.ndarray, fs: float, m_sub: int, fa: float, za: float, delay: float):
    """Piston displacement at every sub-step (``len(cmd) * m_sub + 1`` points)."""
    h = 1.0 / (fs * m_sub)
    d = int(round(delay / h))
    u = np.concatenate([np.full(d, cmd[0]), np.repeat(cmd, m_sub)])[: len(cmd) * m_sub]
    w = 2 * math.pi * fa
    sysd = signal.cont2discrete(([w * w], [1.0, 2 * za * w, w * w]), h, method="zoh")
    b, a = np.ravel(sysd[0]), np.ravel(sysd[1])
    zi = signal.lfiltic(b, a, [cmd[0]] * 3, [cmd[0]] * 3)
    y = signal.lfilter(b, a, u, zi=zi)[0]
    return np.concatenate([[cmd[0]], y])


def _anti_alias(y: np.ndarray, fs: float, m_sub: int, cutoff: float) -> np.ndarray:
    """The ADC's analog anti-alias filter (4-pole Bessel at ``cutoff`` [Hz], bilinear at the
    sub-step rate, started at rest on the first value)."""
    b, a = signal.bessel(4, cutoff, fs=fs * m_sub, norm="mag")
    return signal.lfilter(b, a, y, zi=signal.lfilter_zi(b, a) * y[0])[0]


def _body(xp: np.ndarray, h: float, spec: dict, elem: dict) -> np.ndarray:
    """Element force on the body at every sub-step (RK4)."""
    m, c, k = spec["mass"], spec["damping"], spec["stiffness"]
    kind = elem["kind"]
    vp = np.gradient(xp, h)
    if kind == "backlash":
        hg, kc, n, al = elem["gap"] / 2, elem["k"], elem["n"], elem["alpha"]

        def force(xd: float, vd: float, y: float, v: float) -> float:
            r = xd - y
            if r > hg:
                f = kc * (r - hg) ** n * (1.0 + al * (vd - v))
                return f if f > 0.0 else 0.0
            if r < -hg:
                f = -kc * (-r - hg) ** n * (1.0 - al * (vd - v))
                return f if f < 0.0 else 0.0
            return 0.0
    else:
        ks, cs = elem["k"], elem["c"]

        def force(xd: float, vd: float, y: float, v: float) -> float:
            return ks * (xd - y) + cs * (vd - v)

    y, v = float(xp[0]), 0.0
    out = np.empty(len(xp))
    out[0] = force(xp[0], vp[0], y, v)
    xs, vs = xp.tolist(), vp.tolist()
    for i in range(1, len(xp)):
        x0, x1, v0, v1 = xs[i - 1], xs[i], vs[i - 1], vs[i]
        xm, vm = 0.5 * (x0 + x1), 0.5 * (v0 + v1)

        def acc(xd, vd, yy, vv):
            return (force(xd, vd, yy, vv) - c * vv - k * yy) / m

        k1y, k1v = v, acc(x0, v0, y, v)
        k2y, k2v = v + 0.5 * h * k1v, acc(xm, vm, y + 0.5 * h * k1y, v + 0.5 * h * k1v)
        k3y, k3v = v + 0.5 * h * k2v, acc(xm, vm, y + 0.5 * h * k2y, v + 0.5 * h * k2v)
        k4y, k4v = v + h * k3v, acc(x1, v1, y + h * k3y, v + h * k3v)
        y += h / 6 * (k1y + 2 * k2y + 2 * k3y + k4y)
        v += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
        out[i] = force(x1, v1, y, v)
    return out


def _excitation(rng: np.random.Generator, fs: float, dur: float, kind: str, f0: float):
    """Unit-peak command shape: a sine at ``f0`` or band-limited random up to ``3 f0``."""
    t = np.arange(int(dur * fs)) / fs
    ramp = np.clip(t / 0.5, 0, 1) * np.clip((t[-1] - t) / 0.5, 0, 1)
    if kind == "sine":
        y = np.sin(2 * np.pi * f0 * t)
    else:
        b, a = signal.butter(4, [0.3 * f0, 3 * f0], btype="band", fs=fs)
        y = signal.filtfilt(b, a, rng.standard_normal(t.size))
    y = y * ramp
    return y / np.max(np.abs(y))


def build_case(ss: np.random.SeedSequence, kind: str, out: Path, duration: float) -> dict:
    """Write one case folder and return its label."""
    rng = np.random.default_rng(ss)
    fs = float(rng.choice([1024.0, 2048.0]))
    mass = design.loguniform(rng, 200.0, 5000.0)
    damping = 0.0 if rng.random() < 0.3 else design.loguniform(rng, 0.05, 1.0) * mass * 4 * np.pi
    stiff = 0.0 if rng.random() < 0.7 else mass * (2 * np.pi * rng.uniform(0.5, 3.0)) ** 2
    fa, za = rng.uniform(15.0, 40.0), rng.uniform(0.5, 0.8)
    latency = rng.uniform(0.5e-3, 1.5e-3)
    f0 = design.loguniform(rng, 0.8, 4.0)
    w0 = 2 * np.pi * f0
    dyn = abs(complex(stiff - mass * w0 * w0, damping * w0))
    spec = {"mass": mass, "damping": damping, "stiffness": stiff}
    effect: dict = {"effect": "none", "channel": None, "params": {}}
    elem = {"kind": "rigid"}
    extra = 0.0
    if kind == "backlash":
        gap = design.loguniform(rng, 200e-6, 460e-6)
        kc = design.loguniform(rng, 4e9, 7e10)
        defl = rng.uniform(25e-6, 75e-6)
        elem = {"kind": "backlash", "gap": gap, "k": kc, "n": 1.5, "alpha": rng.uniform(15, 35)}
        amp = kc * defl**1.5 / (1.3 * dyn)
        amp = min(max(amp, 3.5 * gap), 0.05)  # within a lab stroke
        p = {"gap": gap, "contact_stiffness": kc, "exponent": 1.5, "hunt_crossley": elem["alpha"]}
        effect = {"effect": "backlash", "channel": "specimen", "params": p}
    elif kind == "series":
        ks = rng.uniform(3.0, 5.0) * dyn
        elem = {"kind": "series", "k": ks, "c": rng.uniform(100.0, 600.0)}
        amp = rng.uniform(2e-3, 10e-3)
        p = {"stiffness": ks, "series_damping": elem["c"]}
        effect = {"effect": "internal_stiffness", "channel": "specimen", "params": p}
    else:
        amp = rng.uniform(2e-3, 10e-3)
        if kind == "delay":
            extra = float(rng.choice([rng.uniform(1.2, 1.6), rng.uniform(2.0, 3.0)])) / fs
            effect = {"effect": "actuator_delay", "channel": "actuator", "params": {"delay": extra}}
    w_max = 2 * np.pi * 3 * f0
    if elem["kind"] == "backlash":
        w_max = max(w_max, math.sqrt(1.5 * elem["k"] * 100e-6**0.5 / mass))
    elif elem["kind"] == "series":
        w_max = max(w_max, math.sqrt(elem["k"] / mass))
    m_sub = int(min(256, max(8, math.ceil(w_max / (0.3 * fs)))))
    shapes = [
        ("sine", f0, 1.0),
        ("sine", f0 * rng.uniform(1.3, 2.0), rng.uniform(0.5, 0.8)),
        ("random", f0, rng.uniform(0.6, 1.0)),
    ]
    disp_fs = daq.displacement_range(1.1 * amp, 0.25)
    aa = rng.uniform(0.2, 0.3) * fs
    noise = {
        "displacement_sigma": design.loguniform(rng, 0.3e-6, 3e-6),
        "force_sigma": design.loguniform(rng, 0.3, 5.0),
    }
    out.mkdir(parents=True, exist_ok=True)
    h = 1.0 / (fs * m_sub)
    for i, (fam, f, scale) in enumerate(shapes):
        cmd = daq.quantize(amp * scale * _excitation(rng, fs, duration, fam, f), disp_fs)
        xp = _piston(cmd, fs, m_sub, fa, za, latency + extra)
        if elem["kind"] == "rigid":
            vp = np.gradient(xp, h)
            ap = np.gradient(vp, h)
            force = mass * ap + damping * vp + stiff * xp
        else:
            force = _body(xp, h, spec, elem)
        meas_c, force_c = (_anti_alias(y, fs, m_sub, aa)[:-1:m_sub] for y in (xp, force))
        ffs = daq.force_range(float(np.max(np.abs(force_c))))
        meas = daq.acquire(
            meas_c, disp_fs, noise["displacement_sigma"], rng.uniform(-2e-5, 2e-5), rng
        )
        fo = daq.acquire(force_c, ffs, noise["force_sigma"], rng.uniform(-10, 10), rng)
        daq.write_csv(out / f"rec_{i + 1}.csv", fs, cmd, meas, fo)
    w = 2 * np.pi * fa
    num, den = np.array([w * w]), np.array([1.0, 2 * za * w, w * w])
    b, a = signal.bessel(4, aa, fs=fs * m_sub, norm="mag")
    aa_delay = float(signal.group_delay((b, a), [1e-4])[1][0]) / (fs * m_sub)
    n2, d2, dl2, sp2, errs = design.miscalibrate(
        rng,
        num,
        den,
        latency + aa_delay,
        fs,
        {"inertance": mass, "damping": damping, "stiffness": stiff},
    )
    daq.write_nominal(out / "NOMINAL.toml", n2, d2, dl2, *sp2.values())
    return {
        "effects": [effect],
        "rate": fs,
        "substeps": m_sub,
        "specimen": spec,
        "actuator": {"frequency": fa, "zeta": za, "latency": latency},
        "excitation_frequency": f0,
        "amplitude": amp,
        "noise": noise,
        "aa_cutoff": aa,
        "nominal_miscalibration": errs,
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--cases", type=int, required=True)
    p.add_argument("--seed", type=int, required=True)
    p.add_argument("--kinds", default=",".join(KINDS))
    p.add_argument("--duration", type=float, default=8.0, help="record length, s")
    a = p.parse_args(argv)
    kinds = a.kinds.split(",")
    bad = [k for k in kinds if k not in KINDS]
    if bad or a.cases < 1:
        p.error(f"bad --kinds {bad} or --cases {a.cases}")
    seqs = np.random.SeedSequence(a.seed).spawn(a.cases)
    labels = {}
    for i, ss in enumerate(seqs):
        name = f"case_{i + 1:03d}"
        labels[name] = build_case(ss, kinds[i % len(kinds)], a.out / name, a.duration)
        print(name, labels[name]["effects"][0]["effect"], flush=True)
    (a.out / "labels.json").write_text(json.dumps(labels, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
