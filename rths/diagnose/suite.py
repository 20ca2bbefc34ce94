"""A case folder of a labelled suite as one campaign task.

A case folder holds ``rec_1.csv``, ``rec_2.csv``, ... (the CSV contract of
:mod:`rths.diagnose.data.records`) and ``NOMINAL.toml``; the shared labels schema of the blind
suites (``tools/blind_suite.py``, ``python -m tools.truthgen``) puts one such folder per case
beside ``labels.json``.  :func:`diagnose_case` is the task ``tools/score_diagnosis.py`` runs on
:mod:`rths.campaign` (one row per case, resumable, a failed case a row), so a suite of hundreds
of cases runs on every core of a machine or on a cluster unchanged.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

from rths.core.errors import DataError

__all__ = ["case_files", "case_key", "diagnose_case"]


def case_files(folder: str | os.PathLike[str]) -> list[Path]:
    """The records of a case folder in their numeric order (``rec_2`` before ``rec_10``).

    Parameters
    ----------
    folder
        The case folder.

    Raises
    ------
    DataError
        No ``rec_*.csv`` or no ``NOMINAL.toml`` in the folder.
    """
    path = Path(folder)

    def number(p: Path) -> int:
        tail = p.stem.rsplit("_", 1)[-1]
        return int(tail) if tail.isdigit() else 0

    files = sorted(path.glob("rec_*.csv"), key=lambda p: (number(p), p.name))
    if not files:
        raise DataError(f"{path}: no rec_*.csv records in the case folder")
    if not (path / "NOMINAL.toml").is_file():
        raise DataError(f"{path}: no NOMINAL.toml in the case folder")
    return files


def case_key(folder: str | os.PathLike[str], held_out: tuple[str, ...] | None) -> str:
    """A key that changes when the case's content or its split does (SHA-1 of the files).

    Parameters
    ----------
    folder
        The case folder.
    held_out
        Names of the held-out records; None: the default split.
    """
    h = hashlib.sha1()
    path = Path(folder)
    for f in [*case_files(path), path / "NOMINAL.toml"]:
        h.update(f.name.encode())
        h.update(f.read_bytes())
    h.update(json.dumps(held_out).encode())
    return f"{path.name}-{h.hexdigest()[:16]}"


def diagnose_case(payload: tuple[str, tuple[str, ...] | None]) -> dict[str, str]:
    """Diagnose one case folder: the campaign task of a suite.

    Parameters
    ----------
    payload
        ``(folder, held_out)``: the case folder and the names of the held-out records (None:
        the default split, the second half of the records).

    Returns
    -------
    dict
        ``verdict`` and ``diagnosis`` (the ``rths diagnose --json`` document as text) --
        scalars, so the row goes into a campaign table.  A case the diagnosis refuses (bad
        data) is a row with ``verdict = "error"`` and the one-line reason.
    """
    from rths.core.errors import RTHSError
    from rths.diagnose import Options, diagnose, load_nominal, load_record

    folder, held = payload
    try:
        files = case_files(folder)
        d = diagnose(
            [load_record(f) for f in files],
            load_nominal(Path(folder) / "NOMINAL.toml"),
            Options(held_out=held),
        )
        doc = d.to_dict()
    except RTHSError as exc:
        doc = {"verdict": "error", "error": str(exc), "effects": []}
    return {"verdict": str(doc["verdict"]), "diagnosis": json.dumps(doc)}
