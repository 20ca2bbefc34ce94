"""``rths damping``: complex modes of a taut cable with a point damper (exact and FE).

Examples::

    rths damping --mode 1 --xd 0.02 --cd 5.066
    rths damping --mode 3 --xd 0.02 --me 0.53 --cd 0.75 --json
    rths damping --mode 3 --xd 0.02 --length 100 --tension 1e6 --mass-per-length 50 \\
        --inertance 2650 --damping 1000
    rths damping --mode 3 --xd 0.02 --length 200 --tension 5e6 --mass-per-length 80 \\
        --inertance 8480 --damping 47124 --stiffness 6.4e7

The damper is given either normalised (``--me``, ``--cd``; S0 Eq.23) or physically (cable
length [m], tension [N], mass per length [kg/m], inertance [kg], damping [N s/m]); a missing
``--me``/``--cd`` or ``--inertance``/``--damping`` means zero.  ``--stiffness`` [N/m] (physical)
or ``--ke`` (normalised, ``k_e = K L/(pi^2 T)``) puts the damper's inertance and damping behind
an internal series spring (S0 Eq.12); without it the damper is rigid (simplified S0 Eq.1).  The
command prints, for every root of the exact frequency equation near mode N, its complex
wavenumber ``beta``, damping ratio and frequency ratio, paired with the nearest FE eigenvalue
(:mod:`plants.cable.frequency_equation`).  With a series spring it also says where the device's own
mode (node held, ``beta = pi sqrt(k_e/m_e)``) lies: a root of the device (a soft spring gives one)
is listed only when it falls in the window of mode N.
"""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from rths.core.errors import ParameterError

__all__ = ["add_parser", "run"]

_PHYSICAL = ("length", "tension", "mass_per_length")


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``rths damping``.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``rths`` parser's sub-command group (``ArgumentParser.add_subparsers()``);
        the new sub-parser is returned.
    """
    p = subparsers.add_parser(
        "damping",
        help="damping ratios of a cable with a point damper (exact equation and FE)",
        description=__doc__.split("\n\n", 1)[0],
    )
    p.add_argument("--mode", type=int, required=True, metavar="N", help="string mode number n")
    p.add_argument("--xd", type=float, required=True, metavar="X", help="damper position x_d/L")
    norm = p.add_argument_group("normalised damper (S0 Eq.23)")
    norm.add_argument("--me", type=float, metavar="M", help="normalised inertance m_e")
    norm.add_argument("--cd", type=float, metavar="C", help="normalised damping c_d")
    norm.add_argument(
        "--ke", type=float, metavar="KE", help="normalised series stiffness k_e = K L/(pi^2 T)"
    )
    phys = p.add_argument_group("physical cable and damper (SI)")
    phys.add_argument("--length", type=float, metavar="L", help="cable length [m]")
    phys.add_argument("--tension", type=float, metavar="T", help="cable tension [N]")
    phys.add_argument("--mass-per-length", type=float, metavar="m", help="mass per length [kg/m]")
    phys.add_argument("--inertance", type=float, metavar="MBAR", help="damper inertance [kg]")
    phys.add_argument("--damping", type=float, metavar="CBAR", help="damper damping [N s/m]")
    phys.add_argument(
        "--stiffness", type=float, metavar="K", help="internal series stiffness [N/m] (S0 Eq.12)"
    )
    p.add_argument("--elements", type=int, default=400, metavar="N", help="FE elements (400)")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    return p


def _normalised_parameters(args: argparse.Namespace) -> tuple[float, float, float | None]:
    """``(m_e, c_d, k_e)`` from exactly one of the two parameter sets (``k_e`` None: rigid)."""
    from plants.cable.model import (
        CableProperties,
        normalised_damper,
        normalised_stiffness,
    )

    normalised = [v for v in (args.me, args.cd, args.ke) if v is not None]
    physical = [
        v
        for v in (
            args.length,
            args.tension,
            args.mass_per_length,
            args.inertance,
            args.damping,
            args.stiffness,
        )
        if v is not None
    ]
    if normalised and physical:
        raise ParameterError(
            "give the damper either normalised (--me/--cd/--ke) or physically (--length, "
            "--tension, --mass-per-length, --inertance/--damping/--stiffness), not both"
        )
    if normalised:
        return (args.me or 0.0), (args.cd or 0.0), args.ke
    if not physical:
        raise ParameterError(
            "no damper given: use --me/--cd, or --length, --tension, --mass-per-length with "
            "--inertance/--damping"
        )
    missing = [f"--{n.replace('_', '-')}" for n in _PHYSICAL if getattr(args, n) is None]
    if missing:
        raise ParameterError(f"a physical damper also needs {', '.join(missing)}")
    cable = CableProperties(args.length, args.tension, args.mass_per_length)
    m_e, c_d = normalised_damper(cable, args.inertance or 0.0, args.damping or 0.0)
    k_e = None if args.stiffness is None else normalised_stiffness(cable, args.stiffness)
    return m_e, c_d, k_e


def _device_mode(mode: int, m_e: float, k_e: float | None) -> tuple[float | None, str]:
    """The device's own wavenumber (node held, undamped) and a sentence on where it lies."""
    if k_e is None:
        return None, ""
    if m_e == 0.0:
        return None, "no inertance behind the spring: the device has no oscillating mode of its own"
    beta = math.pi * math.sqrt(k_e / m_e)
    inside = (mode - 0.5) * math.pi <= beta < (mode + 0.5) * math.pi
    where = (
        "inside this window: a root of the device may be among those listed"
        if inside
        else "outside this window"
    )
    note = f"device's own mode (node held): beta = {beta:.6g} (~ mode {beta / math.pi:.4g}), "
    return beta, note + where


def _pairs(exact: tuple[Any, ...], fe: tuple[Any, ...]) -> list[tuple[Any | None, Any | None]]:
    """Exact roots each followed by the FE root nearest to it (optimal assignment)."""
    import numpy as np
    from scipy.optimize import linear_sum_assignment

    if not exact or not fe:
        return [(e, None) for e in exact] + [(None, f) for f in fe]
    cost = np.abs(np.subtract.outer([e.beta for e in exact], [f.beta for f in fe]))
    rows, cols = linear_sum_assignment(cost)
    match = dict(zip(rows.tolist(), cols.tolist(), strict=True))
    pairs = [(e, fe[match[i]] if i in match else None) for i, e in enumerate(exact)]
    return pairs + [(None, f) for j, f in enumerate(fe) if j not in match.values()]


def run(args: argparse.Namespace) -> int:
    """Compute and print the roots; returns 0.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line of ``rths damping`` (the options :func:`add_parser`
        declares).
    """
    from plants.cable.frequency_equation import (
        asymptotic_damping,
        exact_roots,
        fe_roots,
    )

    m_e, c_d, k_e = _normalised_parameters(args)
    fe = fe_roots(args.mode, args.xd, m_e, c_d, k_e=k_e, elements=args.elements)
    exact = exact_roots(args.mode, args.xd, m_e, c_d, k_e=k_e)
    rows = [r for pair in _pairs(exact, fe) for r in pair if r is not None]
    asymptotic = asymptotic_damping(args.mode, args.xd, m_e, c_d, k_e=k_e)
    device_beta, device_note = _device_mode(args.mode, m_e, k_e)
    if args.json:
        doc = {
            "mode": args.mode,
            "xd": args.xd,
            "me": m_e,
            "cd": c_d,
            "ke": k_e,
            "device_beta": device_beta,
            "elements": args.elements,
            "asymptotic_zeta": asymptotic,
            "roots": [
                {
                    "method": r.method,
                    "beta": [r.beta.real, r.beta.imag],
                    "zeta": r.zeta,
                    "freq_ratio": r.frequency_ratio,
                    "multiplicity": r.multiplicity,
                }
                for r in rows
            ],
        }
        print(json.dumps(doc, indent=2))
        return 0
    print(
        f"cable-damper modes near mode {args.mode}: x_d = {args.xd:g}, m_e = {m_e:.6g}, "
        f"c_d = {c_d:.6g} (c_d x_d = {c_d * args.xd:.6g})"
        + ("" if k_e is None else f", series k_e = {k_e:.6g} (S0 Eq.12)")
    )
    print(f"{'method':<8}{'beta':>26}{'zeta':>12}{'freq ratio':>12}")
    for r in rows:
        label = r.method if r.method == "exact" else f"fe/{args.elements}"
        beta = f"{r.beta.real:.6f} {'+' if r.beta.imag >= 0 else '-'} {abs(r.beta.imag):.6f}i"
        print(f"{label:<8}{beta:>26}{r.zeta:>12.6f}{r.frequency_ratio:>12.6f}")
    if device_note:
        print(device_note)
    print(f"asymptotic small-damper zeta: {asymptotic:.6f}")
    return 0
