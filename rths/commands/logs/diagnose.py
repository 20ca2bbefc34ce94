"""``rths diagnose``: where the sim-to-real gap lies, which effect causes it, how far it shrinks.

Contract (design.md section 7; the README section "Sim-to-real diagnosis" has the details)::

    rths diagnose DATA... --nominal NOMINAL.toml [--json OUT.json] [--plots DIR]
                          [--held-out NAMES] [--effects NAMES] [--drive measured|auto]

DATA are CSV records (header ``time,command,measured,force``, SI, uniform sampling; row k holds
the command applied from t_k and the displacement and force sampled at t_k) or MCAP logs of
``rths run`` (aligned to that convention on reading).  With several files the first half
identify and the rest are held out (``--held-out`` names them instead); one file is split in
alternating time blocks.  The baseline re-calibrates only NOMINAL.toml's own parameters (and a
shift of up to one sample between command and measured); every channel then adds effects one
at a time while the next one buys its parameters on held-out data.

JSON (``--json``): ``verdict`` (``internal_stiffness``, ``backlash``, ``coulomb_friction``,
``amplitude_damping``, ``actuator_delay``, ``rate_limit``, ``none`` or ``unexplained``): the
first effect of the channel with the largest reducible gap; ``where`` = {``subsystem``
(specimen | actuator | none), ``band_hz`` [lo, hi], ``phase`` (reversals | zero_crossings |
broadband | none)}; ``params`` of the verdict (``stiffness`` [N/m], ``gap`` [m], ``friction``
[N], ``delay`` [s] beyond the nominal, ``velocity_limit`` [m/s], ``c1`` [N s] and ``c2`` [m]);
``effects``: the ordered effects of every channel with their parameters; ``gap`` =
{``channel``, ``before``, ``after``}: held-out NRMSE as fractions of the observed RMS;
``shrink``: fraction of the reducible gap (above the noise floor) closed; ``candidates``: every
model tried, ranked; ``channels``: per channel its effects, verdict, NRMSEs, floor, band,
phase; ``files``; ``structure`` (MCAP logs).

Examples::

    rths diagnose run1.csv run2.csv --nominal NOMINAL.toml --json diagnosis.json
    rths diagnose cable.mcap --nominal scenarios/nominal/nominal_seed_simplified.toml --plots figs
"""

from __future__ import annotations

import argparse
import json
from typing import Any

__all__ = ["add_parser", "run"]


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``rths diagnose``.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``rths`` parser's sub-command group (``ArgumentParser.add_subparsers()``);
        the new sub-parser is returned.
    """
    p = subparsers.add_parser(
        "diagnose",
        help="locate, attribute and shrink the sim-to-real gap of test records",
        description=__doc__.split("\n\n", 1)[0],
    )
    p.add_argument("data", nargs="+", metavar="DATA", help="CSV records or MCAP logs")
    p.add_argument("--nominal", required=True, metavar="TOML", help="NOMINAL.toml")
    p.add_argument("--json", metavar="OUT", help="write the diagnosis as JSON")
    p.add_argument("--plots", metavar="DIR", help="write the figures (PNG) into DIR")
    p.add_argument(
        "--cutoff",
        type=float,
        default=None,
        metavar="HZ",
        help="specimen-channel smoothing cutoff [Hz] (default 30)",
    )
    p.add_argument(
        "--effects",
        metavar="NAMES",
        help="comma-separated candidate effects to try (default: all)",
    )
    p.add_argument(
        "--drive",
        choices=("auto", "measured"),
        default="measured",
        help="specimen drive: the measured displacement (default) or the transfer model's "
        "replay of the command when it explains the measured displacement to its noise floor",
    )
    p.add_argument(
        "--held-out",
        metavar="NAMES",
        help="comma-separated file names to hold out (default: the second half)",
    )
    p.add_argument("--quiet", action="store_true", help="print only the verdict line")
    return p


def run(args: argparse.Namespace) -> int:
    """Load the records and the nominal model, diagnose, print and write the outputs.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line of ``rths diagnose`` (the options :func:`add_parser`
        declares).
    """
    from rths.diagnose import Options, diagnose, load_nominal, load_record
    from rths.diagnose.channels import DEFAULT_CUTOFF
    from rths.diagnose.effects import EFFECTS
    from rths.diagnose.report import table, write_figures

    effects = (
        tuple(EFFECTS)
        if args.effects is None
        else tuple(e.strip() for e in args.effects.split(",") if e.strip())
    )
    options = Options(  # the options first: an argument error is named before the data's
        cutoff=DEFAULT_CUTOFF if args.cutoff is None else args.cutoff,
        effects=effects,
        drive=args.drive,
        held_out=None
        if args.held_out is None
        else tuple(h.strip() for h in args.held_out.split(",") if h.strip()),
    )
    nominal = load_nominal(args.nominal)
    records = [load_record(path) for path in args.data]
    result = diagnose(records, nominal, options)
    text = table(result)
    verdict_line = next(line for line in text.splitlines() if line.startswith("verdict:"))
    print(verdict_line if args.quiet else text)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(result.to_dict(), f, indent=2)
            f.write("\n")
    if args.plots:
        for path in write_figures(result, args.plots):
            print(f"wrote {path}")
    return 0
