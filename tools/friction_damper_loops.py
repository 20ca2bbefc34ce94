"""Ruler reading of the friction-damper-with-backlash loops: slip force, clearance, stick stiffness.

    python tools/friction_damper_loops.py [--data DIR] [--json OUT] [--records NAME ...]
    python tools/friction_damper_loops.py --nominal viscous|coulomb --tension 30 [--data DIR]

Data: ARTS Laboratory, University of South Carolina; Downey et al., Engineering Structures 113
(2016) 287-298 (CC BY-SA 4.0), found from ``--data DIR`` or ``RTHS_DATA`` (the folder that holds
``friction-damper/``); without it the tool prints one ``skipped: ...`` line and exits 0.

The reading method is in ``friction_damper_reading.py``.  The table gives, per record, the
median [interquartile range] and count across half-cycles, in the units of the loop plot (kN,
mm, kN/mm): slip levels ``F+`` / ``F-``, friction amplitude ``f`` and loop centre ``ctr``, the
near-zero plateau width ``gap`` and the tangent clearance ``gapT``, the loading and unloading
flank stiffnesses ``kL`` / ``kU``, the plateau slope ``kG`` and the breakaway ratio; then the
channel checks.  ``--json OUT`` writes the same per record in SI and plot units, with every
half-cycle.

``--nominal viscous|coulomb --tension T`` prints a NOMINAL.toml for ``rths diagnose`` (identity
actuator; specimen ``F = c v`` or ``F = f sign(v)``), least squares over every sample of the sine
records with band tension ``T`` lb: ``c = sum F v / sum v^2``, ``f = mean F sign(v)``, with
``v`` the derivative of the displacement (the diagnosis sees only the displacement).
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import asdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from friction_damper_data import (
    SKIP_MESSAGE,
    OneLineParser,
    Record,
    find_data_dir,
    list_records,
    load_record,
)
from friction_damper_reading import Reading, read_record, summarize, velocity

ATTRIBUTION = (
    "ARTS Laboratory, University of South Carolina; Downey et al., Engineering "
    "Structures 113 (2016) 287-298 (CC BY-SA 4.0)"
)

_COLS = [  # (key, header, scale from SI to plot units, format)
    ("slip_pos", "F+ kN", 1e-3, "{:.2f}"),
    ("slip_neg", "F- kN", 1e-3, "{:.2f}"),
    ("friction", "f kN", 1e-3, "{:.2f}"),
    ("centre", "ctr kN", 1e-3, "{:.2f}"),
    ("clearance", "gap mm", 1e3, "{:.2f}"),
    ("clearance_tangent", "gapT mm", 1e3, "{:.2f}"),
    ("k_load", "kL kN/mm", 1e-6, "{:.2f}"),
    ("k_unload", "kU kN/mm", 1e-6, "{:.2f}"),
    ("k_gap", "kG kN/mm", 1e-6, "{:.3f}"),
    ("breakaway", "peak/slip", 1.0, "{:.2f}"),
]


def _cell(st: dict[str, float], scale: float, fmt: str) -> str:
    """``median [q25,q75] nN`` in plot units, ``-`` when nothing was read."""
    if st["n"] == 0:
        return "-"
    m, a, b = (fmt.format(st[q] * scale) for q in ("median", "q25", "q75"))
    return f"{m} [{a},{b}] n{st['n']}"


BAND_CHECK = (0.025, 0.05, 0.10)  #: near-zero bands (fractions of f) for the clearance check


def band_sensitivity(rec: Record) -> dict[str, float]:
    """Median plateau width [m] of ``rec`` read with each band of :data:`BAND_CHECK`.

    A flat, force-free plateau with steep flanks gives nearly the same width for every band; a
    width that grows with the band means a sloped plateau or rounded contact knees.
    """
    return {
        f"{b:g}": summarize(read_record(rec, band_frac=b))["clearance"]["median"]
        for b in BAND_CHECK
    }


def table(readings: list[Reading], sens: list[dict[str, float]] | None = None) -> str:
    """Text table: one block per record, median [IQR] count of each quantity in plot units.

    ``sens`` (one :func:`band_sensitivity` per reading) adds the clearance-vs-band line.
    """
    lines = []
    for i, r in enumerate(readings):
        s = summarize(r)
        lines.append(
            f"{r.name}: F0 {r.f0 * 1e-3:+.3f} kN, near-zero band +-{r.band * 1e-3:.3f} kN"
            f" (noise sigma {r.sigma * 1e-3:.3f} kN), hysteresis "
            f"{r.hysteresis * 1e3:.2f} mm, {len(r.half_cycles)} half-cycles"
        )
        for part in (_COLS[:4], _COLS[4:7], _COLS[7:]):
            cells = (f"{head} {_cell(s[key], sc, fmt)};" for key, head, sc, fmt in part)
            lines.append("    " + "  ".join(cells))
        if sens is not None:
            lines.append(
                "    gap mm with a band of "
                + ", ".join(f"{100 * float(b):g} %: {w * 1e3:.2f}" for b, w in sens[i].items())
                + " of f"
            )
        c = r.checks
        lines.append(
            f"    channels: F / (act2-act1) {c['force_per_act_diff']:.3f} (r "
            f"{c['corr_act']:.3f}, lag {c['lag_act_samples']:+d} samples); velocity / "
            f"dx/dt {c['velocity_gain']:.3f} (r {c['corr_velocity']:.4f}); F v > 0 on "
            f"{100 * c['dissipating_fraction']:.0f} % of |v| > 0.3 max; F at rest "
            f"{c['force_rest_start'] * 1e-3:+.3f} / {c['force_rest_end'] * 1e-3:+.3f} kN"
        )
    return "\n".join(lines)


def to_json(r: Reading, rec: Record, sens: dict[str, float]) -> dict:
    """JSON-ready dict of one reading: SI and plot-unit statistics, the clearance [m] for each
    band of :data:`BAND_CHECK` (``sens``), the channel checks and every half-cycle."""
    s = summarize(r)
    plot = {k: {q: (v * sc if q != "n" else v) for q, v in s[k].items()} for k, _, sc, _ in _COLS}
    return {
        "record": r.name,
        "kind": rec.kind,
        "frequency_hz": rec.frequency_hz,
        "tension_lb": rec.tension_lb,
        "amplitude_in": rec.amplitude_in,
        "f0_N": r.f0,
        "band_N": r.band,
        "noise_sigma_N": r.sigma,
        "hysteresis_m": r.hysteresis,
        "si": s,
        "plot_units": plot,
        "plot_units_legend": {k: h for k, h, _, _ in _COLS},
        "clearance_vs_band_m": sens,
        "channel_checks": r.checks,
        "half_cycles": [
            {k: v for k, v in asdict(h).items() if k != "plateau"} for h in r.half_cycles
        ],
    }


def _finite(obj):
    """``obj`` with every non-finite float replaced by ``None`` (strict JSON)."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_finite(v) for v in obj]
    return obj


def fit_nominal(records: list[Record], kind: str) -> tuple[float, float]:
    """Least-squares ``(parameter, nrmse)`` of ``F = c v`` (``c`` [N s/m]) or ``F = f sign(v)``
    (``f`` [N]) pooled over every sample of ``records``; ``nrmse`` = RMS residual / RMS force."""
    f = np.concatenate([r.force for r in records])
    v = np.concatenate([velocity(r.x, r.dt) for r in records])
    basis = v if kind == "viscous" else np.sign(v)
    p = float(np.dot(f, basis) / np.dot(basis, basis))
    return p, float(np.sqrt(np.mean((f - p * basis) ** 2) / np.mean(f**2)))


def nominal_toml(kind: str, tension: float, records: list[Record]) -> str:
    """NOMINAL.toml text (identity actuator) of the ``kind`` fit over ``records`` (module text).

    The header comments name the records, the fit's NRMSE and, for comparison, the median
    friction amplitude read from the loops (slip phases only) of the same records.
    """
    p, nrmse = fit_nominal(records, kind)
    damping, friction = (p, 0.0) if kind == "viscous" else (0.0, p)
    loops = [summarize(read_record(r))["friction"]["median"] for r in records]
    lines = [
        f"# Friction damper with backlash, {tension:g} lb band tension: {kind} nominal, least",
        "# squares over every sample of the sine records",
    ]
    lines += [f"#   {r.name}" for r in records]
    lines += [
        f"# NRMSE {nrmse:.2f} of the force RMS.  For comparison, the friction read on the",
        f"# loops (slip phases only, median over records): {np.nanmedian(loops):.1f} N.",
        "# Use: python tools/friction_damper_to_csv.py --out DIR, then",
        "#   rths diagnose DIR/<record>.csv --nominal <this file>",
        "# Data: " + ATTRIBUTION.split("; ")[0] + ";",
        "#   " + ATTRIBUTION.split("; ")[1] + ".",
    ]
    return "\n".join(lines) + (
        "\n[actuator]            # measured/command: identity (only the displacement is recorded)\n"
        "num = [1.0]\nden = [1.0]\ndelay = 0.0  # s\n\n"
        "[specimen]            # F = inertance*a + damping*v + stiffness*x + friction*sign(v)\n"
        f"inertance = 0.0  # kg\ndamping = {damping:.1f}  # N s/m\nstiffness = 0.0  # N/m\n"
        f"friction = {friction:.1f}  # N\n"
    )


def main(argv: list[str] | None = None) -> int:
    """Command line (module docstring); returns the exit code."""
    p = OneLineParser(prog="friction_damper_loops.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--data", help="folder holding friction-damper/ (default: $RTHS_DATA)")
    p.add_argument("--records", nargs="+", metavar="NAME", help="record names (default: all)")
    p.add_argument("--json", type=Path, metavar="OUT", help="write the per-record reading here")
    p.add_argument("--nominal", choices=("viscous", "coulomb"), help="print a NOMINAL.toml")
    p.add_argument("--tension", type=float, help="band tension [lb] of the --nominal fit")
    args = p.parse_args(argv)
    if args.nominal and args.tension is None:
        p.error("--nominal needs --tension (0, 30 or 36)")
    if args.tension is not None and not args.nominal:
        p.error("--tension is used only with --nominal")
    folder = find_data_dir(args.data)
    if folder is None:
        print(SKIP_MESSAGE)
        return 0
    names = list_records(folder)
    unknown = sorted(set(args.records or []) - set(names))
    if unknown:
        p.error(f"unknown record(s) {', '.join(unknown)}; have: {', '.join(names)}")
    names = [n for n in names if not args.records or n in args.records]
    if args.nominal:
        recs = [load_record(folder, n) for n in names]
        recs = [r for r in recs if r.kind == "sine" and r.tension_lb == args.tension]
        if not recs:
            p.error(f"no sine record with band tension {args.tension:g} lb")
        print(nominal_toml(args.nominal, args.tension, recs), end="")
        return 0
    out, readings, sens = [], [], []
    for n in names:
        rec = load_record(folder, n)
        readings.append(read_record(rec))
        sens.append(band_sensitivity(rec))
        out.append(to_json(readings[-1], rec, sens[-1]))
    print(f"Friction damper with backlash -- data: {ATTRIBUTION}")
    print(table(readings, sens))
    if args.json:
        try:
            args.json.write_text(
                json.dumps(_finite({"attribution": ATTRIBUTION, "records": out}), indent=1) + "\n"
            )
        except OSError as e:
            print(
                f"friction_damper_loops.py: error: cannot write {args.json}: {e.strerror}",
                file=sys.stderr,
            )
            return 2
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
