"""Blind suite of the project's own emulated lab for ``rths diagnose``: labelled cases.

    python tools/blind_suite.py generate --cases 28 --out /tmp/suite --seed 7
    python tools/score_diagnosis.py suite /tmp/suite

``generate`` runs the project's emulated lab (:class:`plants.lab.EmulatedLab`: 16-bit +/-10 V
converters with noise, :class:`plants.actuator.TransferFunctionActuator` with the
MTS-identified TF, an IMD specimen) and writes per case ``case_NNN/rec_1.csv`` ...
``rec_3.csv`` (two band-limited random tests and one sine; the first two identify, the third is
held out, in the CSV timing convention) and ``NOMINAL.toml``; the answers go to ``labels.json``
beside the case folders, in the schema of the independent generator ``tools/truthgen``
(``{case: {"effects": [{"effect", "channel", "params"}, ...], "rate", ...}}``, strongest effect
first), so that ``tools/score_diagnosis.py`` scores both alike.  The cases cycle through
``none`` and the six effect classes; every third case carries a second effect.

This suite proves self-consistency only: it is made by the same plants the diagnosis's own
tests use.  It no longer excludes lightly damped backlash contacts (a real lab's impacts are
lightly damped): the flywheel damping ratio, the only damping of the emulated contact, is
drawn from 0.02 to 0.3 for every class.

Random draws (uniform unless said):

==================  ============================================================================
every case          inertance 300-3000 kg; damping ``c = 2 zeta m (2 pi 20 Hz)``, zeta 0.02-0.3;
                    true actuator gain 0.95-1.05; random tests 0.3 Hz to 4-8 Hz, 1.5-4 mm RMS,
                    20 s at 2048 Hz; sine 0.5-4 Hz, 2-5 mm; converter noise 0.5-2x the seed
                    lab's (3.8 um, 1 N); nominal: MTS TF with unit gain, inertance x0.9-1.1 and
                    damping x0.85-1.15 of the truth (within the diagnosis's +/-20 %)
internal_stiffness  series k = m (2 pi f_e)^2, f_e 8-40 Hz (S0 Types I/II: 12.3, 13.8 Hz)
backlash            total clearance 0.03-0.5 mm (log-uniform) before a contact of 20-150 Hz
coulomb_friction    2-15 % of the RMS force of the test (S0 Eq.1 F_r, at the driven end)
amplitude_damping   S0 Eq.18 law alone: ``c1/(A + c2)`` equal to 0.5-2x the damping at 2 mm,
                    c2 0.1-2 mm (log-uniform)
actuator_delay      2-15 ms beyond the nominal
rate_limit          50-85 % of the peak velocity the linear actuator would reach
==================  ============================================================================
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from rths.diagnose.channels.signals import actuator_replay
from rths.diagnose.data.nominal import nominal_toml
from rths.diagnose.data.records import write_csv
from rths.diagnose.data.synthetic import (
    CLASSES,
    LabCase,
    band_limited_command,
    lab_record,
    seed_converters,
)

DT = 1.0 / 2048.0
DURATION = 20.0
#: Second effects of the combined cases (backlash and internal stiffness share the series
#: element of the emulated IMD and do not combine).
PAIRS: dict[str, str] = {
    "internal_stiffness": "amplitude_damping",
    "backlash": "coulomb_friction",
    "coulomb_friction": "actuator_delay",
    "amplitude_damping": "coulomb_friction",
    "actuator_delay": "internal_stiffness",
    "rate_limit": "backlash",
}
#: Label parameter names per effect (the schema of tools/truthgen).
LABEL_KEY: dict[str, str] = {
    "internal_stiffness": "stiffness",
    "backlash": "gap",
    "coulomb_friction": "friction",
    "amplitude_damping": "c1",
    "actuator_delay": "delay",
    "rate_limit": "velocity_limit",
}


def _value(rng: np.random.Generator, label: str, m: float, c: float, x: list[np.ndarray]) -> float:
    if label == "internal_stiffness":
        return m * (2.0 * math.pi * rng.uniform(8.0, 40.0)) ** 2
    if label == "backlash":
        return math.exp(rng.uniform(math.log(0.03e-3), math.log(0.5e-3)))
    if label == "coulomb_friction":
        v = [np.gradient(xi, DT) for xi in x]
        force = np.concatenate([m * np.gradient(vi, DT) + c * vi for vi in v])
        return rng.uniform(0.02, 0.15) * float(np.sqrt(np.mean(force**2)))
    if label == "amplitude_damping":
        return rng.uniform(0.5, 2.0) * c * 2e-3  # c1/(A + c2) ~ 0.5-2 c at A = 2 mm
    if label == "actuator_delay":
        return rng.uniform(0.002, 0.015)
    if label == "rate_limit":
        peak = max(float(np.max(np.abs(np.diff(xi)))) / DT for xi in x)
        return rng.uniform(0.5, 0.85) * peak
    raise ValueError(label)


def _commands(rng: np.random.Generator) -> list[np.ndarray]:
    f_hi = rng.uniform(4.0, 8.0)
    rms = rng.uniform(1.5e-3, 4e-3)
    out = [band_limited_command(rng, DURATION, DT, (0.3, f_hi), rms) for _ in range(2)]
    t = DT * np.arange(int(round(DURATION / DT)))
    ramp = np.clip(t / 1.0, 0.0, 1.0) * np.clip((DURATION - t) / 1.0, 0.0, 1.0)
    amp, f = rng.uniform(2e-3, 5e-3), rng.uniform(0.5, 4.0)
    out.append(amp * ramp * np.sin(2.0 * math.pi * f * t))
    return out


def draw(rng: np.random.Generator, label: str, second: str | None) -> tuple[LabCase, list]:
    """One case: the lab, its commands; ``second`` adds a second hidden effect."""
    commands = _commands(rng)
    m = rng.uniform(300.0, 3000.0)
    c = 2.0 * rng.uniform(0.02, 0.3) * m * 2.0 * math.pi * 20.0
    gain = rng.uniform(0.95, 1.05)
    scale = rng.uniform(0.5, 2.0)
    base = LabCase("none", 0.0, m, c, gain)
    x = [gain * actuator_replay(base.num, base.den, DT, u) for u in commands]
    effects = [] if label == "none" else [label] + ([second] if second else [])
    values = [_value(rng, e, m, c, x) for e in effects]
    case = LabCase(
        effects[0] if effects else "none",
        values[0] if values else 0.0,
        m,
        c,
        gain,
        contact_frequency=rng.uniform(20.0, 150.0),
        converters=seed_converters(5e-4 * scale, 1e-3 * scale),
        amplitude_c2=math.exp(rng.uniform(math.log(1e-4), math.log(2e-3))),
        extra=tuple(zip(effects[1:], values[1:], strict=True)),
    )
    return case, commands


def _label(case: LabCase) -> dict:
    effects = [
        {
            "effect": e,
            "channel": "actuator" if e in ("actuator_delay", "rate_limit") else "specimen",
            "params": {LABEL_KEY[e]: v}
            | ({"c2": case.amplitude_c2} if e == "amplitude_damping" else {}),
        }
        for e, v in case.effects.items()
    ]
    return {
        "effects": effects or [{"effect": "none", "channel": None, "params": {}}],
        "rate": 1.0 / DT,
        "specimen": {"inertance": case.inertance, "damping": case.damping},
        "generator": "tools/blind_suite.py (the project's emulated lab)",
    }


def generate(cases: int, out: Path, seed: int) -> None:
    """Write ``cases`` labelled cases and ``labels.json`` into ``out``."""
    rng = np.random.default_rng(seed)
    out.mkdir(parents=True, exist_ok=True)
    labels = {}
    for i in range(cases):
        label = CLASSES[i % len(CLASSES)]
        second = PAIRS.get(label) if i % 3 == 2 else None
        case, commands = draw(rng, label, second)
        folder = out / f"case_{i:03d}"
        folder.mkdir(exist_ok=True)
        for k, u in enumerate(commands, start=1):
            r = lab_record(case, u, DT, seed=int(rng.integers(2**31)), name=f"rec_{k}.csv")
            write_csv(folder / r.name, r.time, r.command, r.measured, r.force)
        # a lab-identified nominal: within the +/-20 % the diagnosis re-calibrates
        # (rths.diagnose.effects.specimen.NOMINAL_TOLERANCE; beyond it is an effect)
        nominal = case.nominal(
            case.inertance * rng.uniform(0.9, 1.1), case.damping * rng.uniform(0.85, 1.15), 1.0
        )
        (folder / "NOMINAL.toml").write_text(nominal_toml(nominal, "blind-suite case"))
        labels[folder.name] = _label(case)
        print(f"{folder.name}: {'+'.join(case.effects) or 'none'} written", flush=True)
    (out / "labels.json").write_text(json.dumps(labels, indent=2) + "\n")


def main(argv: list[str] | None = None) -> int:
    """Command line (module docstring)."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n", 1)[0])
    sub = p.add_subparsers(dest="action", required=True)
    g = sub.add_parser("generate", help="write labelled cases and labels.json")
    g.add_argument("--cases", type=int, default=28)
    g.add_argument("--out", type=Path, required=True)
    g.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    generate(args.cases, args.out, args.seed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
