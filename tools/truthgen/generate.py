"""Generate one case: hardware, records, effects, strength check, files, labels."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from . import daq, design, excitation
from .hardware import sample_actuator, sample_specimen
from .integrator import Simulator
from .plant import Actuator, Plant, Specimen, nominal_linear_model

SNR_VISIBLE = 3.0  # effect difference rms / channel noise rms for a record to count as affected
MIN_DURATION = 3.0  # s


def substeps(plant: Plant, fs: float, effects: dict) -> int:
    """Internal steps per output sample.

    At least 4096 Hz internally; for contact/presliding dynamics at least 8
    steps per period of the fastest mechanical mode (guard screening and event
    location); for amplitude damping the explicit force's c h / m <= 0.1.
    """
    h = 1.0 / (fs * math.ceil(4096.0 / fs))
    idx = list(range(3, plant.i_fx))
    modes = [(0, 0, 0)] + ([(1, 0, 0)] if plant.has_backlash else [])
    wmax = 0.0
    for md in modes:
        F = plant.system(md)["F"][:, : plant.n]
        wmax = max(wmax, float(np.max(np.abs(np.linalg.eigvals(F[np.ix_(idx, idx)])))))
    if (plant.has_backlash or plant.has_friction) and wmax > 0:
        h = min(h, 2 * math.pi / (8 * wmax))
    if "amplitude_damping" in effects:
        p = effects["amplitude_damping"]
        h = min(h, 0.1 * plant.spec.inertance / (p["c1"] / p["c2"]))
    return int(min(64, math.ceil(1.0 / (fs * h) - 1e-9)))


def simulate(
    act: Actuator,
    spec: Specimen,
    effects: dict,
    aa: float,
    fs: float,
    commands: list[np.ndarray],
    truth: bool = True,
) -> tuple[list[dict], dict]:
    """Simulate every record of a case for one effect configuration."""
    plant = Plant(act, spec, {k: v for k, v in effects.items() if k != "actuator_delay"}, aa)
    M = substeps(plant, fs, effects)
    delay = act.latency + effects.get("actuator_delay", {}).get("delay", 0.0)
    sim = Simulator(plant, fs, M, delay)
    outs = [sim.run(c, truth=truth) for c in commands]
    return outs, {
        "substeps": M,
        "internal_step": sim.h,
        "events": sim.events,
        "cap_hits": sim.cap_hits,
        "delay_applied": sim.delay,
    }


def _rms(x: np.ndarray) -> float:
    """Root mean square (same unit as x)."""
    return float(np.sqrt(np.mean(np.square(x))))


def _design_records(
    rng: np.random.Generator, act: Actuator, spec: Specimen, fs: float, max_duration: float
) -> tuple[list[np.ndarray], list[dict]]:
    """Excitation shapes scaled by the nominal model to force/stroke/speed budgets."""
    R = int(rng.integers(3, 5))
    fams = [
        str(rng.choice(["sine", "stepped_sine"])),
        str(rng.choice(["sweep", "random", "earthquake"])),
    ]
    fams += [str(rng.choice(excitation.FAMILIES)) for _ in range(R - 2)]
    fams = [fams[i] for i in rng.permutation(R)]
    phi0 = design.loguniform(rng, 0.08, 0.4)
    factors = [design.loguniform(rng, 0.15, 1.0) for _ in range(R)]
    factors[int(rng.integers(R))] = 1.0
    num, den = nominal_linear_model(act, spec)
    m = spec.total_inertance
    shapes, infos = [], []
    for fam, fac in zip(fams, factors):
        dur = max(MIN_DURATION, min(round(rng.uniform(10.0, 40.0), 1), max_duration))
        y, info = excitation.make(rng, fam, fs, dur)
        nf = 2 * len(y)
        f = np.fft.rfftfreq(nf, 1 / fs)
        s = 2j * np.pi * f
        X = np.fft.rfft(y, nf) * np.polyval(num, s) / np.polyval(den, s)
        x = np.fft.irfft(X, nf)[: len(y)]
        v = np.fft.irfft(X * s, nf)[: len(y)]
        F = np.fft.irfft(X * (m * s * s + spec.damping * s + spec.stiffness), nf)[: len(y)]
        scale = min(
            fac * phi0 * act.force_capacity / np.max(np.abs(F)),
            0.4 * act.stroke / np.max(np.abs(x)),
            0.6 * act.velocity_capacity / np.max(np.abs(v)),
        )
        info["target_force_fraction"] = fac * phi0
        shapes.append(scale * y)
        infos.append(info)
    return shapes, infos


def _strength(
    name: str, with_e: list[dict], without: list[dict], noise: dict, ranges: dict
) -> dict:
    """Per-record NRMSE of the effect on both channels and its SNR on the affected one."""
    primary = "measured" if design.CHANNEL[name] == "actuator" else "force"
    res = {
        "primary_channel": primary,
        "nrmse": [],
        "nrmse_other_channel": [],
        "snr": [],
        "noise_nrmse": [],
    }
    for i, (a, b) in enumerate(zip(with_e, without)):
        other = "force" if primary == "measured" else "measured"
        fs_ = ranges["force"][i] if primary == "force" else ranges["disp"]
        sig = noise["force_sigma"] if primary == "force" else noise["displacement_sigma"]
        nrms = math.sqrt(sig**2 + daq.lsb(fs_) ** 2 / 12)
        d = _rms(a[primary] - b[primary])
        ref = max(_rms(b[primary]), 1e-30)
        res["nrmse"].append(d / ref)
        res["nrmse_other_channel"].append(_rms(a[other] - b[other]) / max(_rms(b[other]), 1e-30))
        res["snr"].append(d / nrms)
        res["noise_nrmse"].append(nrms / ref)
    need = min(2, len(with_e))
    res["records_above_noise"] = int(sum(s >= SNR_VISIBLE for s in res["snr"]))
    res["weak"] = res["records_above_noise"] < need
    return res


def build_case(
    ss: np.random.SeedSequence,
    plan: tuple[str, ...],
    rates: list[float],
    max_duration: float,
    out_dir: Path | None,
    max_attempts: int = 5,
    ranges: str = "default",
) -> dict:
    """Generate one case, write its folder (if ``out_dir``) and return its label.

    Parameters
    ----------
    ss : numpy.random.SeedSequence
        The case's own seed sequence (cases are independent of each other).
    plan : tuple of str
        Effect classes of the case (empty for ``none``).
    rates : list of float
        Output rates to draw from, Hz.
    max_duration : float
        Cap on each record's length, s.
    out_dir : pathlib.Path or None
        Case folder to write (created); None to only compute.
    max_attempts : int
        Redraws of too-weak (or diverging) effect parameters before labelling
        the effect ``weak``.
    ranges : str
        Effect parameter ranges, ``"default"`` or ``"wide"`` (:mod:`design`).
    """
    r_hw, r_exc, r_eff, r_noise, r_nom = (np.random.default_rng(s) for s in ss.spawn(5))
    fs = float(r_hw.choice(rates))
    spec = sample_specimen(r_hw)
    act = sample_actuator(r_hw, spec)
    aa = float(r_hw.uniform(0.2, 0.3) * fs)
    shapes, infos = _design_records(r_exc, act, spec, fs, max_duration)
    disp_fs = daq.displacement_range(max(float(np.max(np.abs(s))) for s in shapes), act.stroke)
    commands = [daq.quantize(s, disp_fs) for s in shapes]
    noise = {
        "displacement_sigma": design.loguniform(r_noise, 0.3e-6, 3e-6),
        "force_sigma": design.loguniform(r_noise, 0.3, 5.0),
        "converter_bits": daq.BITS,
    }
    nom_out, nom_int = simulate(act, spec, {}, aa, fs, commands)
    med = lambda key: float(np.median([np.max(np.abs(o[key])) for o in nom_out]))
    fref = []
    for c in commands:
        V = np.abs(np.fft.rfft(np.diff(c))) ** 2
        fref.append(float(np.sum(np.fft.rfftfreq(len(c) - 1, 1 / fs) * V) / np.sum(V)))
    ref = {
        "inertance": spec.inertance,
        "rod_mass": spec.rod_mass,
        "peak_force": med("force"),
        "peak_speed": med("vP"),
        "peak_disp": med("xI"),
        "fs": fs,
        "f_ref": float(np.median(fref)),
        "min_peak_cmd": min(float(np.max(np.abs(c))) for c in commands),
    }
    params = {e: design.effect_params(r_eff, e, ref, ranges) for e in plan}
    strengths: dict = {}
    full, full_int = nom_out, nom_int
    attempts = 0
    redraws = 0
    while plan:
        attempts += 1
        full, full_int = simulate(act, spec, params, aa, fs, commands)
        if any(o["diverged"] for o in full):
            # an unstable draw (motion beyond 20 strokes) is not a test a lab would run
            redraws += 1
            if redraws > 10:
                raise RuntimeError(f"effects {plan} diverge for 10 parameter draws")
            params = {e: design.effect_params(r_eff, e, ref, ranges) for e in plan}
            attempts -= 1
            continue
        ranges = {
            "disp": disp_fs,
            "force": [daq.force_range(np.max(np.abs(o["force"]))) for o in full],
        }
        for e in plan:
            rest = {k: v for k, v in params.items() if k != e}
            without = (
                nom_out if not rest else simulate(act, spec, rest, aa, fs, commands, truth=False)[0]
            )
            strengths[e] = _strength(e, full, without, noise, ranges)
        weak = [e for e in plan if strengths[e]["weak"]]
        if not weak or attempts >= max_attempts:
            break
        for e in weak:
            params[e] = design.effect_params(r_eff, e, ref, ranges)
    sensitivity = None
    if "backlash" in params:
        pert = {
            **params,
            "backlash": {**params["backlash"], "gap": params["backlash"]["gap"] * (1 + 1e-6)},
        }
        o2 = simulate(act, spec, pert, aa, fs, commands[:1], truth=False)[0][0]
        sensitivity = _rms(o2["force"] - full[0]["force"]) / max(_rms(full[0]["force"]), 1e-30)
    # ---- acquisition
    records = []
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
    for i, (c, o, info) in enumerate(zip(commands, full, infos)):
        ffs = daq.force_range(float(np.max(np.abs(o["force"]))))
        xo, fo = float(r_noise.uniform(-20e-6, 20e-6)), float(r_noise.uniform(-10.0, 10.0))
        meas = daq.acquire(o["measured"], disp_fs, noise["displacement_sigma"], xo, r_noise)
        force = daq.acquire(o["force"], ffs, noise["force_sigma"], fo, r_noise)
        name = f"rec_{i + 1}.csv"
        if out_dir is not None:
            daq.write_csv(out_dir / name, fs, c, meas, force)
        records.append(
            {
                "file": name,
                "excitation": info,
                "duration": len(c) / fs,
                "samples": len(c),
                "peak_command": float(np.max(np.abs(c))),
                "displacement_full_scale": disp_fs,
                "force_full_scale": ffs,
                "displacement_offset": xo,
                "force_offset": fo,
                "peak_force_clean": float(np.max(np.abs(o["force"]))),
                "peak_speed_clean": float(np.max(np.abs(o["vP"]))),
                "max_pressure_over_supply": float(np.max(np.abs(o["pl"])) / act.supply_pressure),
                "max_valve_current": float(np.max(np.abs(o["current"]))),
                "vs_nominal_nrmse": {
                    ch: _rms(o[ch] - nom_out[i][ch]) / max(_rms(nom_out[i][ch]), 1e-30)
                    for ch in ("measured", "force")
                },
            }
        )
    # ---- nominal model
    num, den = nominal_linear_model(act, spec)
    true_delay = act.latency + Plant(act, spec, {}, aa).aa_group_delay
    spec_true = {
        "inertance": spec.total_inertance,
        "damping": spec.damping,
        "stiffness": spec.stiffness,
    }
    n2, d2, dl2, sp2, errs = design.miscalibrate(r_nom, num, den, true_delay, fs, spec_true)
    if out_dir is not None:
        daq.write_nominal(
            out_dir / "NOMINAL.toml",
            n2,
            d2,
            dl2,
            sp2["inertance"],
            sp2["damping"],
            sp2["stiffness"],
        )
    effects = []
    for e in plan:
        item = {
            "effect": e,
            "channel": design.CHANNEL[e],
            "params": params[e],
            "derived": design.derived(e, params[e], ref),
            "strength": strengths.get(e),
        }
        if e == "rate_limit":
            # the limit is on flow (valve opening): with an inertial load the oil column
            # rings at reversals, so the actual peak speed can exceed it
            vl = params[e]["velocity_limit"]
            item["derived"]["limit_over_record_peak_speed"] = [
                vl / float(np.max(np.abs(o["vP"]))) for o in nom_out
            ]
            item["derived"]["record_peak_speed_over_limit"] = [
                float(np.max(np.abs(o["vP"]))) / vl for o in full
            ]
        if e == "backlash":
            item["chaos_sensitivity_nrmse"] = sensitivity
        effects.append(item)
    effects.sort(key=lambda it: -max(it["strength"]["nrmse"]) if it["strength"] else 0.0)
    if not effects:
        effects = [{"effect": "none", "channel": None, "params": {}}]
    return {
        "effects": effects,
        "rate": fs,
        "records": records,
        "noise": noise,
        "nominal_miscalibration": errs,
        "true_nominal": {
            "num": list(map(float, num)),
            "den": list(map(float, den)),
            "delay": true_delay,
            **spec_true,
        },
        "nominal_written": {
            "num": list(map(float, n2)),
            "den": list(map(float, d2)),
            "delay": dl2,
            **sp2,
        },
        "actuator": {k: float(v) for k, v in act.__dict__.items()},
        "specimen": {k: float(v) for k, v in spec.__dict__.items()},
        "aa_filter": {
            "type": "analog 4-pole Bessel on both ADC channels",
            "cutoff": aa,
            "group_delay": Plant(act, spec, {}, aa).aa_group_delay,
        },
        "integration": {
            "nominal": nom_int,
            "truth": full_int,
            "attempts": attempts,
            "diverged_redraws": redraws,
        },
        "references": ref,
    }
