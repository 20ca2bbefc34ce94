"""The structure channel of an ``rths run`` log: the RTHS against the fully numerical run.

For an MCAP log that carries the scenario text in its metadata (``scenario.text``), the
scenario is re-run with :func:`rths.session.mock.numerical_run` (variant ``"model"``: the scenario's
own ``[model]`` device, no specimen) for as many steps as the log holds, and the logged ``target``
(the interface displacement of the numerical substructure) is compared with the mock's.  This
channel says how far the specimen's departure from the model moved the structure; it has no
candidate effects of its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rths.core.errors import RTHSError
from rths.diagnose.data.records import Record
from rths.diagnose.residuals import nrmse

__all__ = ["StructureGap", "structure_gap"]


@dataclass(frozen=True)
class StructureGap:
    """NRMSE [-] of the logged interface displacement against the numerical run, per record.

    Attributes
    ----------
    records
        ``{record name: NRMSE}`` for every log that could be replayed.
    notes
        ``{record name: why not}`` for the others (CSV records, logs without a scenario).
    """

    records: dict[str, float]
    notes: dict[str, str]

    def to_dict(self) -> dict[str, object]:
        """JSON form: ``{"nrmse": {...}, "notes": {...}}``."""
        return {"nrmse": dict(self.records), "notes": dict(self.notes)}


def structure_gap(records: list[Record]) -> StructureGap:
    """Replay every MCAP record's scenario numerically and compare the interface motion.

    Parameters
    ----------
    records
        The records; CSV records and logs without target or scenario are noted, not compared.
    """
    out: dict[str, float] = {}
    notes: dict[str, str] = {}
    for r in records:
        if r.target is None or r.scenario_text is None:
            notes[r.name] = "no target/scenario in the record (CSV or bare log)"
            continue
        try:
            from rths.config.scenario import parse_scenario
            from rths.session.mock import numerical_run

            scn = parse_scenario(r.scenario_text, f"{r.name}:scenario")
            mock = numerical_run(scn, "model", steps=r.n)
        except (RTHSError, ImportError) as exc:
            notes[r.name] = f"numerical run unavailable: {exc}"
            continue
        target = np.asarray(mock["target"], dtype=float)
        n = min(target.size, r.n)
        out[r.name] = nrmse(r.target[:n] - target[:n], target[:n])
    return StructureGap(out, notes)
