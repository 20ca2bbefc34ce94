"""Scenario runs as campaign runs: scenario text + overrides + seed (+ compensator, draw).

A :class:`ScenarioRun` carries the scenario's *text* (not its path), the dotted-key overrides
(:func:`rths.config.scenario.parse_scenario`), the noise seed, an optional compensator kind and
an optional Monte-Carlo draw; :func:`scenario_task` runs it on the fast clock in the worker
(:func:`rths.session.batch.run_in_process`) and returns its row: J1 [s], J2, J3, the
sync-subspace RMSE (fractions), steps, and the interlock's reason.  :func:`scenario_run` makes
the campaign :class:`~rths.campaign.runs.Run` (key and input columns) of one.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from rths.campaign.runs import Run, Scalar, check_scalar, run_key
from rths.config.scenario import Scenario, parse_scenario
from rths.core.errors import DataError
from rths.metrics import summarize
from rths.session.batch import BatchRun, draw_lab, run_in_process

__all__ = ["ScenarioRun", "scenario_run", "scenario_task", "tracking_row"]


@dataclass(frozen=True)
class ScenarioRun:
    """The payload of one scenario run.

    Parameters
    ----------
    text
        The scenario's TOML text.
    source
        Where the text came from (named in error messages).
    overrides
        ``(dotted key, value)`` pairs replacing the text's values.
    seed
        Campaign seed: the lab's noise seed, or with ``draw`` the Monte-Carlo seed (default:
        the scenario's ``[run] seed``).
    compensator
        Compensator kind overriding the scenario's (default options).
    draw
        Monte-Carlo draw: the lab is perturbed by ``default_rng([seed, draw])`` and its noise
        seeded with ``seed + draw`` (:func:`rths.session.batch.draw_lab`); None: nominal lab.
    outputs
        Substructure outputs to keep for the task (e.g. ``("midspan_displacement",)``).
    """

    text: str
    source: str
    overrides: tuple[tuple[str, Scalar], ...] = ()
    seed: int | None = None
    compensator: str | None = None
    draw: int | None = None
    outputs: tuple[str, ...] = ()

    def scenario(self) -> Scenario:
        """The scenario with the overrides applied (validated)."""
        return parse_scenario(self.text, self.source, dict(self.overrides))

    def execute(self, scn: Scenario | None = None) -> BatchRun:
        """Run it on the fast clock in this process.

        Parameters
        ----------
        scn
            :meth:`scenario`, if already built.
        """
        scn = self.scenario() if scn is None else scn
        seed = scn.run.seed if self.seed is None else self.seed
        lab: dict[str, Any] = {"seed": seed} if self.draw is None else draw_lab(self.draw, seed)
        return run_in_process(scn, compensator=self.compensator, outputs=self.outputs, **lab)


def tracking_row(run: BatchRun) -> dict[str, Scalar]:
    """Tracking columns of a run: ``steps``, ``stopped`` and ``status`` (``ok`` or
    ``interlock``), and -- for a run that ran to the end -- ``j1_s`` (delay [s]), ``j2``,
    ``j3``, ``sync_rmse`` (fractions); None where not measured.

    Parameters
    ----------
    run
        The run's signals.
    """
    row: dict[str, Scalar] = {"steps": run.result.steps, "stopped": run.stopped}
    row.update(j1_s=None, j2=None, j3=None, sync_rmse=None)
    row["status"] = "interlock" if run.stopped else "ok"
    if run.stopped:
        return row
    k = run.result.steps
    try:
        m = summarize(run.target, run.measured, None, run.dt, max_delay=min(0.1, 0.25 * k * run.dt))
    except DataError:  # a record too short or too quiet for a metric: leave them unmeasured
        return row
    row.update(j1_s=m.j1_delay, j2=m.j2, j3=m.j3, sync_rmse=m.sync_rmse)
    return row


def scenario_task(spec: ScenarioRun) -> dict[str, Scalar]:
    """The campaign task of a scenario run: :func:`tracking_row` of :meth:`ScenarioRun.execute`.

    Parameters
    ----------
    spec
        The run.
    """
    return tracking_row(spec.execute())


def scenario_run(
    scn: Scenario,
    *,
    overrides: Mapping[str, Scalar] | None = None,
    seed: int | None = None,
    compensator: str | None = None,
    draw: int | None = None,
    outputs: tuple[str, ...] = (),
    extra: tuple[Any, ...] = (),
) -> Run:
    """The campaign run of ``scn`` (its text) with these settings.

    Parameters
    ----------
    scn
        The scenario (its ``text``, ``source`` and own ``overrides`` travel; overrides are
        applied on the worker).
    overrides, seed, compensator, draw, outputs
        As :class:`ScenarioRun` (applied after the scenario's own overrides); ``seed`` defaults
        to the scenario's.
    extra
        Anything else that determines the row (e.g. the response a study measures): part of
        the key.

    Returns
    -------
    Run
        Inputs ``scenario`` (name), ``compensator``, ``seed``, ``draw`` and one column per
        override key.
    """
    merged = {**dict(scn.overrides), **(overrides or {})}
    items = tuple((k, check_scalar(v, f"override {k!r}")) for k, v in merged.items())
    seed = scn.run.seed if seed is None else seed
    kind = compensator or scn.compensator_kind
    payload = ScenarioRun(scn.text, scn.source, items, seed, compensator, draw, outputs)
    key = run_key(scn.text, items, seed, kind, draw, outputs, extra)
    inputs: dict[str, Scalar] = {
        "scenario": scn.run.name,
        "compensator": kind,
        "seed": seed,
        "draw": draw,
    }
    inputs.update(items)
    return Run(key, inputs, payload)
