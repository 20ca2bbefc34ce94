"""``rths run SCENARIO``: run an RTHS scenario and write its MCAP log."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from rths.commands._campaign import add_options, cluster, summary_line
from rths.core.errors import ConfigError

if TYPE_CHECKING:
    from rths.config.scenario import Scenario

__all__ = ["add_parser", "run"]


class _KindsFormatter(argparse.HelpFormatter):
    """Help that ends with the registered kinds (read from the registries only when the help is
    printed, so ``rths --help`` stays fast)."""

    def format_help(self) -> str:
        from rths.config.kinds import registry

        lines = ["kinds a scenario can name (details: rths kinds):"]
        for family in ("substructure", "specimen", "actuator", "compensator"):
            lines.append(f"  [{family}] " + ", ".join(registry(family).names()))
        return super().format_help() + "\n" + "\n".join(lines) + "\n"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``rths run``.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``rths`` parser's sub-command group (``ArgumentParser.add_subparsers()``);
        the new sub-parser is returned.
    """
    p = subparsers.add_parser(
        "run",
        formatter_class=_KindsFormatter,
        help="run a scenario (RTHS over zenoh, or in process) and record it to MCAP",
        description="Run an RTHS scenario. The specimen process is started on loopback unless "
        "--external-specimen is given. Prints a one-line summary: J1, J2, J3, sync-subspace RMSE, "
        "overruns, recording gaps (on the vRTHS benchmark frame: its own J1-J9 as "
        "F4_evaluation.m computes them; --json prints them as keys J1..J9).",
    )
    p.add_argument("scenario", type=Path, help="scenario TOML file")
    p.add_argument(
        "--clock", choices=("lockstep", "realtime", "fast"), help="override the scenario's clock"
    )
    p.add_argument("--out", type=Path, help="MCAP log path (default runs/<run-id>.mcap)")
    p.add_argument(
        "--compensator",
        help="override the compensator kind (see the list below); with --monte-carlo also 'all'",
    )
    p.add_argument(
        "--monte-carlo",
        type=int,
        metavar="N",
        default=None,
        nargs="?",
        const=0,
        help="run N perturbed draws of the lab on the fast clock instead (no N: the "
        "scenario's [monte_carlo] draws)",
    )
    p.add_argument("--seed", type=int, help="noise seed (default: the scenario's)")
    p.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="zenoh endpoint to listen on (default tcp/127.0.0.1:<free port>)",
    )
    p.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="zenoh endpoint to connect to",
    )
    p.add_argument(
        "--external-specimen",
        action="store_true",
        help="do not start 'rths specimen'; wait for one started elsewhere",
    )
    p.add_argument("--run-id", help="run id (zenoh keys rths/<run-id>/); default generated")
    p.add_argument(
        "--ready-timeout",
        type=float,
        default=30.0,
        metavar="S",
        help="how long to wait for the specimen process [s]",
    )
    p.add_argument(
        "--step-timeout",
        type=float,
        default=1.0,
        metavar="S",
        help="lockstep: how long a silent specimen process may take for one step before the run "
        "is aborted as hung [s] (a step takes ~0.5 ms)",
    )
    p.add_argument(
        "--secret-file",
        type=Path,
        metavar="FILE",
        help="run secret (hex, mode 600) shared with an external specimen; default: a fresh "
        "one, written to <log>.secret when --external-specimen is given",
    )
    p.add_argument(
        "--live",
        nargs="?",
        const="127.0.0.1:8765",
        metavar="HOST:PORT",
        help="serve the run to Foxglove over WebSocket while it runs (default "
        "127.0.0.1:8765); open it with the layout in foxglove/rths_layout.json",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    add_options(p)
    p.add_argument(
        "--no-figures",
        action="store_true",
        help="with --monte-carlo: no J2 figure beside the table",
    )
    return p


def run(args: argparse.Namespace) -> int:
    """Run the scenario (or its Monte Carlo).

    Exit codes: 0 it ran to the end; 3 an interlock, a diverging model, a lost specimen or a
    full disk stopped it (:class:`rths.core.errors.RunFault`); 128 + N a signal N stopped it
    (SIGINT 130, SIGTERM 143, SIGHUP 129) -- in every case after the log was finished with its
    summary.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line of ``rths run`` (the options :func:`add_parser`
        declares).
    """
    from rths.config.scenario import load_scenario

    scn = load_scenario(args.scenario)
    if args.monte_carlo is not None:
        return _monte_carlo(scn, args)
    from tqdm import tqdm

    from rths.session.runner import RunOptions, StopRequest, run_scenario

    # disable=None: no bar when stderr is not a terminal (CI logs stay free of carriage returns)
    bar = (
        None
        if args.no_progress
        else tqdm(
            total=scn.run.steps,
            unit="step",
            leave=False,
            desc=scn.run.name,
            file=sys.stderr,
            disable=None,
        )
    )

    def progress(done: int, total: int) -> None:
        if bar is not None:
            bar.update(done - bar.n)

    stop = StopRequest()
    options = RunOptions(
        clock=args.clock,
        out=args.out,
        compensator=args.compensator,
        listen=tuple(args.listen),
        connect=tuple(args.connect),
        external_specimen=args.external_specimen,
        ready_timeout=args.ready_timeout,
        progress=progress if bar else None,
        seed=args.seed,
        run_id=args.run_id,
        secret_file=args.secret_file,
        live=args.live,
        on_waiting=lambda cmd: print(
            f"waiting for the specimen; start it with:  {cmd}", file=sys.stderr, flush=True
        ),
        step_timeout=args.step_timeout,
        stop=stop,
    )
    try:
        with stop.installed():
            outcome = run_scenario(scn, options)
    finally:
        if bar is not None:
            bar.close()
    if args.json:
        doc = {
            "path": str(outcome.path),
            "run_id": outcome.run_id,
            "clock": outcome.clock,
            "steps": outcome.result.steps,
            "stopped": outcome.result.stopped,
            "overruns": outcome.result.timing.overruns,
            "deadline_misses": outcome.result.misses,
            "metrics": outcome.metrics.to_dict() if outcome.metrics else None,
        }
        if outcome.benchmark is not None:  # F4's J1 [ms], J2-J9 [%] (vRTHS benchmark frame)
            doc.update(outcome.benchmark.to_dict())
        print(json.dumps(doc, indent=2))
    else:
        print(outcome.line())
    if outcome.result.stopped:
        print(f"rths run: stopped early: {outcome.result.stopped}", file=sys.stderr)
        if stop.signum is not None and not stop.fault:
            return 128 + stop.signum
        return 3
    if stop.signum is not None:  # a signal during the teardown: the run itself was complete
        return 128 + stop.signum
    return 0


def _monte_carlo(scn: Scenario, args: argparse.Namespace) -> int:
    """``rths run SCENARIO --monte-carlo N [--compensator KIND|all] [--json]``: a campaign of
    draws x compensators; the table (default ``runs/<name>-mc<N>-seed<S>.parquet``) and the J2
    figure beside it."""
    from controllers.factory import kinds
    from rths.analysis.montecarlo import j2_figure, run_draws
    from rths.campaign import ResultTable
    from rths.config import build
    from rths.core.errors import format_choices
    from rths.session.budget import check_budget, step_cost

    draws = args.monte_carlo or scn.monte_carlo_draws
    if draws < 1:
        raise ConfigError(f"--monte-carlo needs a number of draws >= 1; got {args.monte_carlo!r}")
    kind = args.compensator or scn.compensator.kind
    known = list(kinds())
    if kind != "all" and kind not in known:
        raise ConfigError(
            f"--compensator must be one of {format_choices([*known, 'all'])}; got {kind!r}"
        )
    chosen = known if kind == "all" else [kind]
    seed = scn.run.seed if args.seed is None else args.seed
    if seed < 0:
        raise ConfigError(f"--seed must be >= 0; got {seed}")
    cost = step_cost(build.substructure(scn), build.compensator(scn, chosen[0]), build.lab(scn))
    check_budget(scn, "fast", cost, runs=draws * len(chosen))
    where = cluster(args)
    path = args.table or Path("runs") / f"{scn.run.name}-mc{draws}-seed{seed}.parquet"
    table = ResultTable(path)
    result = run_draws(
        scn,
        chosen,
        draws,
        seed,
        progress=not args.no_progress,
        cluster=where,
        table=table,
        retry_failed=args.retry_failed,
    )
    figure = None
    if not args.no_figures:
        figure = j2_figure(
            result,
            path.with_name(path.stem + "_j2.png"),
            f"{scn.run.name}: J2 over {draws} perturbed labs (seed {seed})",
        )
    rows = result.table()
    keys = [str(r["run"]) for r in result.rows]
    if args.json:
        print(
            json.dumps(
                {
                    "scenario": scn.run.name,
                    "draws": draws,
                    "seed": seed,
                    "rows": rows,
                    "j2": {k: v.tolist() for k, v in result.j2.items()},
                    "table": str(path),
                    "digest": table.digest(keys),
                    "wall_s": result.stats.wall,
                    "workers": result.stats.workers,
                },
                indent=2,
            )
        )
    else:
        print(f"{scn.run.name}: J2 over {draws} perturbed labs (seed {seed})")
        print(f"{'compensator':<12} {'median %':>9} {'worst %':>9} {'stopped':>8}")
        for r in rows:
            med = "-" if r["median"] is None else f"{100 * r['median']:.3f}"
            worst = "-" if r["worst"] is None else f"{100 * r['worst']:.3f}"
            print(f"{r['kind']:<12} {med:>9} {worst:>9} {r['stopped']:>8}")
        print(
            summary_line(result.stats, table, where, keys)
            + ("" if figure is None else f"; figure {figure}")
        )
    return 0
