"""servogen - a servo-hydraulic actuator suite with the square-root flow law (actuator channel).

    python tools/servogen.py --out DIR --cases N --seed S [--duration 8] [--rates 1000,2048]
    python tools/score_diagnosis.py suite DIR --jobs 1

Written from the physics of a servo-hydraulic loop with numpy/scipy/numba only; it imports
nothing from the rths project (an independent check of the actuator channel of
``rths diagnose``).  Each case holds ``rec_1.csv`` ... (2-3 records, header
``time,command,measured,force``, the DAQ convention: row k = the command applied from t_k,
displacement and force sampled at t_k, 16-bit converters, white noise, offsets) and
``NOMINAL.toml``; the answers go to ``DIR/labels.json`` (the truthgen schema:
``{case: {"effects": [{"effect", "channel", "params"}], "rate", ...}}``).

Physics (continuous states: spool ``x_v`` (normalised), load pressure ``p_L``, piston ``x``,
``v``; a PI position controller with delta-P feedback sampled at 16x the DAQ rate):

* controller: ``i = K_p e + K_i int(e) - K_dp p_L/P_s``, ``e = r(t - tau_0 - tau_x) - x``,
  ``i`` clipped to ``+/- i_max`` (``i_max < 1``: the rate-limit case -- a servo-amplifier
  current, hence valve-opening, hence flow saturation; label ``velocity_limit = i_max v_cap``,
  the no-load speed);
* spool: first order, ``tau_v x_v' = i - x_v``, bandwidth 40-150 Hz;
* flow: ``Q = K_q x_v sqrt(1 - sign(x_v) p_L / P_s)`` (orifice law: the effective flow gain
  changes with load pressure, by roughly +/-10-30 % at the test levels drawn);
* oil column: ``(V/4 beta) p_L' = Q - A v - C_l p_L`` (hydraulic resonance 40-120 Hz with the
  load's mass);
* piston + specimen (an inertial mass damper rigidly fixed): ``(m_p + m_s) v' = A p_L -
  (c_p + c_s) v``; the load cell reads ``F = m_s v' + c_s v``.

Integrated by RK4 at 32x the DAQ rate (two steps per controller period).  The nominal model
(NOMINAL.toml) is the linearisation at ``p_L = 0`` (continuous PI, controller half-period in
the delay), mis-calibrated within the contract's +/-10 %: every pole and zero frequency by a
common factor within +/-6 % and its own within +/-4 %, complex damping likewise, DC gain
+/-4 %, delay by up to +/-0.4 sample; specimen inertance and damping +/-10 %.  These are
calibration errors, never effects.  (Suites made before this cap drew the common factor within
+/-8 %: up to 12 % per pole, beyond the tolerance the diagnosis re-calibrates.)

Cases cycle through ``none``, ``actuator_delay`` (1.2-8 ms and at least 1.5 samples beyond the
nominal, in the reference path) and ``rate_limit`` (40-80 % of the linear peak speed of the
largest record).  Records: sines (0.5-5 Hz), two-tone sines and band-limited random
(0.2-6 Hz), amplitudes set from the linear model to a peak load pressure of 10-55 % of P_s.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
from numba import njit
from scipy import signal

SUB = 32  # RK4 steps per DAQ sample
CTRL = 16  # controller updates per DAQ sample
KINDS = ("none", "actuator_delay", "rate_limit")


@njit(cache=True)
def _deriv(s, i, p):  # s = [xv, pl, x, v]
    tau_v, kq, ps, area, cap, cl, mass, damp = p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]
    xv, pl, v = s[0], s[1], s[3]
    ratio = 1.0 - (pl / ps if xv >= 0.0 else -pl / ps)
    q = kq * xv * math.sqrt(ratio if ratio > 0.0 else 0.0)
    out = np.empty(4)
    out[0] = (i - xv) / tau_v
    out[1] = (q - area * v - cl * pl) / cap
    out[2] = v
    out[3] = (area * pl - damp * v) / mass
    return out


@njit(cache=True)
def _simulate(ref, dt, p, kp, ki, kdp, i_max):
    """Fine-step simulation; ``ref`` is the (delayed) reference at the controller rate."""
    n = ref.size // CTRL
    s = np.zeros(4)
    z = 0.0
    h = dt / SUB
    x_out = np.empty(n)
    a_out = np.empty(n)
    v_out = np.empty(n)
    ps = p[2]
    clipped = 0
    for k in range(n):
        x_out[k] = s[2]
        v_out[k] = s[3]
        a_out[k] = _deriv(s, 0.0, p)[3]
        for c in range(CTRL):
            e = ref[k * CTRL + c] - s[2]
            i = kp * e + ki * z - kdp * s[1] / ps
            if i > i_max:
                i = i_max
                clipped += 1
            elif i < -i_max:
                i = -i_max
                clipped += 1
            else:
                z += e * dt / CTRL  # anti-windup: integrate only while unsaturated
            for _ in range(SUB // CTRL):
                k1 = _deriv(s, i, p)
                k2 = _deriv(s + 0.5 * h * k1, i, p)
                k3 = _deriv(s + 0.5 * h * k2, i, p)
                k4 = _deriv(s + h * k3, i, p)
                s = s + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return x_out, v_out, a_out, clipped / (n * CTRL)


def _linear(p, kp, ki, kdp):
    """State space of the loop linearised at p_L = 0, states [xv, pl, x, v, z], input r."""
    tau_v, kq, ps, area, cap, cl, mass, damp = p
    a = np.zeros((5, 5))
    b = np.zeros((5, 1))
    a[0] = [-1 / tau_v, -kdp / ps / tau_v, -kp / tau_v, 0.0, ki / tau_v]
    b[0, 0] = kp / tau_v
    a[1] = [kq / cap, -cl / cap, 0.0, -area / cap, 0.0]
    a[2, 3] = 1.0
    a[3] = [0.0, area / mass, 0.0, -damp / mass, 0.0]
    a[4, 2] = -1.0
    b[4, 0] = 1.0
    c = np.array([[0.0, 0.0, 1.0, 0.0, 0.0]])
    return a, b, c


def _perturb(roots, common_f, common_z, rng):
    out = []
    for q in roots:
        w = abs(q)
        if abs(q.imag) <= 1e-9 * w:
            out.append(q.real * common_f * (1 + rng.uniform(-0.04, 0.04)))
        elif q.imag > 0:
            w2 = w * common_f * (1 + rng.uniform(-0.04, 0.04))
            zeta = min(-q.real / w * common_z * (1 + rng.uniform(-0.04, 0.04)), 0.99)
            im = w2 * math.sqrt(1 - zeta * zeta)
            out += [complex(-zeta * w2, im), complex(-zeta * w2, -im)]
    return out


def _draw_plant(rng):
    while True:
        area = rng.uniform(1.5e-3, 5e-3)
        ps = 21e6
        m_s = math.exp(rng.uniform(math.log(500), math.log(8000)))
        m_p = rng.uniform(10, 40)
        mass = m_s + m_p
        c_s = rng.uniform(0.0, 1.0) * m_s * 2 * math.pi * 2.0
        damp = c_s + rng.uniform(200, 2000)
        f_h = rng.uniform(40, 120)
        beta = rng.uniform(1.0e9, 1.4e9)
        volume = 4 * beta * area**2 / (mass * (2 * math.pi * f_h) ** 2)
        cap = volume / (4 * beta)
        v_cap = rng.uniform(0.15, 0.5)
        kq = v_cap * area
        cl = rng.uniform(0.2, 2.0) * 1e-12
        tau_v = 1 / (2 * math.pi * rng.uniform(40, 150))
        wc = 2 * math.pi * rng.uniform(6, 16)
        kp = wc / v_cap
        ki = kp * wc / rng.uniform(4, 8)
        kdp = rng.uniform(0.1, 0.6)
        p = np.array([tau_v, kq, ps, area, cap, cl, mass, damp])
        a, _, _ = _linear(p, kp, ki, kdp)
        ev = np.linalg.eigvals(a)
        zeta = -ev.real / np.maximum(np.abs(ev), 1e-9)
        if np.all(ev.real < 0) and np.min(zeta) > 0.08:
            return p, kp, ki, kdp, m_s, c_s, v_cap


def _command(kind, n, dt, rng):
    t = np.arange(n) * dt
    ramp = np.clip(np.minimum(t, t[-1] - t) / 0.5, 0, 1)
    if kind == "sine":
        u = np.sin(2 * np.pi * rng.uniform(1.0, 6.0) * t)
    elif kind == "two_tone":
        f1 = rng.uniform(1.0, 3.0)
        u = np.sin(2 * np.pi * f1 * t) + 0.5 * np.sin(2 * np.pi * f1 * rng.uniform(2.2, 4.0) * t)
    else:
        sos = signal.butter(4, [0.2, rng.uniform(3.0, 8.0)], "bandpass", fs=1 / dt, output="sos")
        u = signal.sosfiltfilt(sos, rng.standard_normal(n))
    return ramp * u / np.max(np.abs(u))


def _quantise(x, full):
    q = 2 * full / 2**16
    return np.clip(np.round(x / q) * q, -full, full - q)


def build_case(rng, kind, out: Path, duration: float = 8.0, rate: float | None = None) -> dict:
    """Write one case of ``kind`` to ``out`` (module docstring); its label (``rate`` [Hz]
    overrides the drawn sampling rate)."""
    rate = float(rng.choice([1000.0, 1024.0, 2048.0, 4096.0])) if rate is None else rate
    dt = 1 / rate
    p, kp, ki, kdp, m_s, c_s, v_cap = _draw_plant(rng)
    a, b, c = _linear(p, kp, ki, kdp)
    num, den = signal.ss2tf(a, b, c, np.zeros((1, 1)))
    num = np.trim_zeros(np.where(np.abs(num[0]) < 1e-9 * np.max(np.abs(num[0])), 0, num[0]), "f")
    tau0 = rng.uniform(0.2e-3, 1.5e-3)
    extra = max(rng.uniform(1.2e-3, 8e-3), 1.5 * dt) if kind == "actuator_delay" else 0.0
    n = int(duration * rate)
    n_rec = int(rng.integers(2, 4))
    kinds = rng.permutation(["sine", "two_tone", "random"])[:n_rec]
    top = rng.uniform(0.25, 0.55)
    levels = [top] + list(top * rng.uniform(0.3, 0.7, n_rec - 1))
    rng.shuffle(levels)
    # linear model of the load pressure (row 1) to set amplitudes
    lin_p = signal.StateSpace(a, b, np.eye(5), np.zeros((5, 1)))
    cmds, peak_speed, peak_pl = [], [], []
    for k, lv in zip(kinds, levels, strict=True):
        u = _command(k, n, dt, rng)
        _, y, _ = signal.lsim(lin_p, u, np.arange(n) * dt)
        # the load pressure drawn, within the valve's speed (60 % of the no-load capacity)
        scale = min(lv * p[2] / np.max(np.abs(y[:, 1])), 0.6 * v_cap / np.max(np.abs(y[:, 3])))
        cmds.append(u * scale)
        peak_speed.append(np.max(np.abs(y[:, 3])) * scale)
        peak_pl.append(np.max(np.abs(y[:, 1])) * scale / p[2])
    i_max = 1.0  # full valve opening
    effects = [{"effect": "none", "channel": None, "params": {}}]
    if kind == "rate_limit":
        v_lim = rng.uniform(0.4, 0.8) * max(peak_speed)
        i_max = v_lim / v_cap
        effects = [{"effect": kind, "channel": "measured", "params": {"velocity_limit": v_lim}}]
    elif kind == "actuator_delay":
        effects = [{"effect": kind, "channel": "measured", "params": {"delay": extra}}]
    noise_x, noise_f = rng.uniform(0.3e-6, 2e-6), rng.uniform(1.0, 10.0)
    out.mkdir(parents=True, exist_ok=True)
    records = []
    for r, u in enumerate(cmds, 1):
        u = np.round(u / 1e-7) * 1e-7  # DAC resolution
        fine_t = np.arange(n * CTRL) * dt / CTRL - tau0 - extra
        idx = np.floor(fine_t / dt).astype(int)
        ref = np.where(idx >= 0, u[np.clip(idx, 0, n - 1)], 0.0)
        x, v, acc, clipped = _simulate(ref, dt, p, kp, ki, kdp, i_max)
        force = m_s * acc + c_s * v
        full_x = 2.5 * max(np.max(np.abs(x)), 1e-3)
        full_f = 1.5 * max(np.max(np.abs(force)), 1.0)
        xm = _quantise(x + noise_x * rng.standard_normal(n) + rng.uniform(-2e-5, 2e-5), full_x)
        fm = _quantise(force + noise_f * rng.standard_normal(n) + rng.uniform(-10, 10), full_f)
        t = np.arange(n) * dt
        np.savetxt(
            out / f"rec_{r}.csv",
            np.column_stack([t, u, xm, fm]),
            delimiter=",",
            header="time,command,measured,force",
            comments="",
            fmt="%.9g",
        )
        records.append(
            {
                "file": f"rec_{r}.csv",
                "excitation": str(kinds[r - 1]),
                "peak_pl_over_ps": float(peak_pl[r - 1]),
                "peak_linear_speed": float(peak_speed[r - 1]),
                "clipped_share": float(clipped),
            }
        )
    # the nominal: linearisation, mis-calibrated
    cf, cz = 1 + rng.uniform(-0.06, 0.06), 1 + rng.uniform(-0.06, 0.06)
    zn = np.real(np.poly(_perturb(np.roots(num), cf, cz, rng))) if num.size > 1 else np.ones(1)
    pn = np.real(np.poly(_perturb(np.roots(den), cf, cz, rng)))
    dc = (num[-1] / den[-1]) * (1 + rng.uniform(-0.04, 0.04))
    zn = zn * dc / (zn[-1] / pn[-1])
    delay_n = max(0.0, tau0 + dt / (2 * CTRL) + rng.uniform(-0.4, 0.4) * dt)
    fmt = lambda v: "[" + ", ".join(f"{q:.10g}" for q in v) + "]"
    (out / "NOMINAL.toml").write_text(
        "[actuator]\n"
        f"num = {fmt(zn)}\nden = {fmt(pn)}\ndelay = {delay_n:.9g}\n\n"
        "[specimen]\n"
        f"inertance = {m_s * (1 + rng.uniform(-0.1, 0.1)):.9g}\n"
        f"damping = {c_s * (1 + rng.uniform(-0.1, 0.1)):.9g}\n"
        "stiffness = 0.0\nfriction = 0.0\n"
    )
    return {
        "effects": effects,
        "rate": rate,
        "records": records,
        "actuator": {
            "tau_v": p[0],
            "v_cap": v_cap,
            "area": p[3],
            "mass": p[6],
            "kp": kp,
            "ki": ki,
            "kdp": kdp,
            "tau0": tau0,
            "i_max": i_max,
        },
        "specimen": {"inertance": m_s, "damping": c_s},
    }


def main(argv=None) -> int:
    """Command line (module docstring); the exit status."""
    ap = argparse.ArgumentParser(prog="servogen", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--cases", required=True, type=int)
    ap.add_argument("--seed", required=True, type=int)
    ap.add_argument("--duration", type=float, default=8.0, help="record length [s] (2-60)")
    args = ap.parse_args(argv)
    if args.cases < 1 or not 2.0 <= args.duration <= 60.0:
        print("servogen: --cases must be >= 1 and --duration within 2-60 s", file=sys.stderr)
        return 2
    if args.out.exists() and any(args.out.iterdir()):
        print(f"servogen: {args.out} exists and is not empty", file=sys.stderr)
        return 2
    rng = np.random.default_rng(args.seed)
    labels = {}
    for i in range(args.cases):
        name = f"case_{i:03d}"
        labels[name] = build_case(rng, KINDS[i % len(KINDS)], args.out / name, args.duration)
        print(f"[{i + 1}/{args.cases}] {name}: {KINDS[i % len(KINDS)]}", file=sys.stderr)
    (args.out / "labels.json").write_text(json.dumps(labels, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
