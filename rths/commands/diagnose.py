"""``rths diagnose``: where the sim-to-real gap lies, which effect causes it, how far it shrinks.

Contract (design.md section 7)::

    rths diagnose DATA... --nominal NOMINAL.toml [--json OUT.json] [--plots DIR]

DATA are CSV records (header ``time,command,measured,force``, SI, uniform sampling) or MCAP logs
of ``rths run``.  With several files the first half identify and the rest are held out; one file
is split in time (first two thirds identify).  The verdict is one of ``internal_stiffness``,
``backlash``, ``coulomb_friction``, ``actuator_delay``, ``rate_limit`` or ``none``.

JSON (``--json``): ``verdict``; ``where`` = {``subsystem`` (specimen | actuator | none),
``band_hz`` [lo, hi], ``phase`` (reversals | zero_crossings | broadband | none)}; ``params``
named per verdict (``stiffness`` [N/m], ``gap`` [m], ``friction`` [N], ``delay`` [s] beyond the
nominal, ``velocity_limit`` [m/s]; series models add their ``frequency`` [Hz]); ``gap`` =
{``channel`` (measured | force), ``before``, ``after``}: held-out NRMSE as fractions of the
observed RMS; ``shrink``: fraction of the reducible gap (above the noise floor) closed;
``candidates``: every effect tried, ranked, with its held-out NRMSE, ``closed`` fraction and
score; ``channels``: the decomposition of both channels; ``files``; ``structure`` (MCAP logs).

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
        default="auto",
        help="specimen drive: the transfer model's replay when it explains the measured "
        "displacement to its noise floor (auto, default) or always the measured displacement",
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
    )
    nominal = load_nominal(args.nominal)
    records = [load_record(path) for path in args.data]
    result = diagnose(records, nominal, options)
    text = table(result)
    print(text.splitlines()[-2] if args.quiet else text)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(result.to_dict(), f, indent=2)
            f.write("\n")
    if args.plots:
        for path in write_figures(result, args.plots):
            print(f"wrote {path}")
    return 0
