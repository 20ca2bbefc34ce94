"""The results table of a campaign: one row per run, Parquet or CSV, written as rows arrive.

Columns, in order: ``run`` (the run's key), ``index`` (its position in the campaign), the run's
inputs, the task's results, then ``status`` (``ok``, ``interlock`` or ``error``), ``error`` (the
exception of a failed run), ``wall_s`` and ``cpu_s`` (the run's wall and CPU time [s] on its
worker) and ``worker``.
Rows are kept sorted by ``index``, so the table does not depend on the order in which runs
finished.  :data:`TIMING_COLUMNS` depend on the machine and the schedule; every other column
depends only on the run's inputs, and :func:`digest` hashes exactly those: equal digests mean
bit-identical results (floats are hashed through ``repr``, which round-trips every bit).

The file format follows the suffix: ``.parquet`` (pyarrow; types kept) or ``.csv`` (floats
written with ``repr``, so re-reading gives the same bits; an empty cell is None; a cell that
reads as a number is one, except in the ``run``, ``status``, ``error`` and ``worker``
columns).  Each :meth:`ResultTable.flush` rewrites the file atomically (a temporary file
renamed over it): an interrupted campaign leaves a valid table holding every row flushed before
the interruption.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import os
import time
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from rths.campaign.runs import Scalar
from rths.core.errors import DataError

__all__ = ["FORMATS", "TIMING_COLUMNS", "ResultTable", "Row", "digest"]

Row = dict[str, Scalar]

#: Columns that depend on where and when a run executed, not on its inputs.
TIMING_COLUMNS = ("wall_s", "cpu_s", "worker")
#: File formats by suffix.
FORMATS = (".parquet", ".csv")
_HEAD = ("run", "index")
#: Columns read back from CSV as text whatever they look like (a key may read as a number).
_TEXT_COLUMNS = ("run", "status", "error", "worker")
_TAIL = ("status", "error", "wall_s", "cpu_s", "worker")


def _cell(value: Any) -> Any:
    """Canonical JSON form of a cell for :func:`digest`: numbers by the ``repr`` of their float
    value (a Parquet column mixing 1 and 1.5 reads back as 1.0 and 1.5: same digest)."""
    if isinstance(value, int | float) and not isinstance(value, bool):
        x = float(value)
        return {"f": repr(x) if math.isfinite(x) else str(x)}
    return value


def digest(rows: Iterable[Mapping[str, Scalar]], exclude: Iterable[str] = TIMING_COLUMNS) -> str:
    """SHA-256 (hex) of the rows' deterministic columns (empty cells left out), order-free.

    Parameters
    ----------
    rows
        Table rows.
    exclude
        Columns left out (default: :data:`TIMING_COLUMNS`).
    """
    skip = set(exclude)
    canon = sorted(
        json.dumps(
            {k: _cell(v) for k, v in row.items() if k not in skip and v is not None},
            sort_keys=True,
        )
        for row in rows
    )
    return hashlib.sha256("\n".join(canon).encode()).hexdigest()


def _csv_cell(value: Scalar) -> Scalar:
    """A cell as written to CSV: None empty, floats by ``repr`` (every bit kept)."""
    if value is None:
        return ""
    return repr(value) if isinstance(value, float) else value


def _parse_csv_cell(column: str, text: str) -> Scalar:
    if text == "":
        return None
    if column in _TEXT_COLUMNS:
        return text
    if text in ("True", "False"):
        return text == "True"
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


class ResultTable:
    """Rows of a campaign, kept in memory and written to ``path``.

    Parameters
    ----------
    path
        ``*.parquet`` or ``*.csv``; None keeps the table in memory only.
    flush_interval
        Least time [s] between two automatic writes (:meth:`flush`); 0 writes on every row.
    """

    def __init__(self, path: str | Path | None, flush_interval: float = 2.0) -> None:
        self.path = None if path is None else Path(path)
        if self.path is not None and self.path.suffix not in FORMATS:
            raise DataError(
                f"{self.path}: a campaign table must end in .parquet or .csv; "
                f"got {self.path.suffix or 'no suffix'!r}"
            )
        self.flush_interval = flush_interval
        self._rows: dict[str, Row] = {}
        self._columns: list[str] = []
        self._dirty = False
        self._last = 0.0
        if self.path is not None and self.path.exists():
            for row in self._read(self.path):
                self._put(row)
            self._dirty = False

    # ------------------------------------------------------------------------------ content
    def __len__(self) -> int:
        return len(self._rows)

    def __contains__(self, key: object) -> bool:
        return key in self._rows

    def keys(self) -> set[str]:
        """Keys of the runs the table holds."""
        return set(self._rows)

    def rows(self, keys: Iterable[str] | None = None) -> list[Row]:
        """Rows ordered by ``index`` then key, each with every column of the table (None where a
        row has no value).

        Parameters
        ----------
        keys
            Keys of the rows wanted (those absent are left out); None: every row.
        """
        if keys is None:
            chosen: Iterable[Row] = self._rows.values()
        else:
            chosen = (self._rows[k] for k in keys if k in self._rows)
        columns = self.columns
        rows = [{c: r.get(c) for c in columns} for r in chosen]
        return sorted(rows, key=lambda r: (_index(r), str(r.get("run"))))

    @property
    def columns(self) -> list[str]:
        """Column names in table order."""
        middle = [c for c in self._columns if c not in _HEAD and c not in _TAIL]
        present = set(self._columns)
        return [*_HEAD, *middle, *(c for c in _TAIL if c in present)]

    def add(self, row: Mapping[str, Scalar]) -> None:
        """Add (or replace) the row of run ``row["run"]``; writes if the flush interval passed.

        Parameters
        ----------
        row
            The row; its ``run`` column is the run's key.
        """
        self._put(dict(row))
        self._dirty = True
        self.flush(force=False)

    def _put(self, row: Row) -> None:
        key = row.get("run")
        if not isinstance(key, str) or not key:
            raise DataError(f"a campaign row needs a 'run' key; got {row!r}")
        for column in row:
            if column not in self._columns:
                self._columns.append(column)
        self._rows[key] = row

    def reindex(self, positions: Mapping[str, int]) -> None:
        """Give the rows of these runs their position in the current campaign (``index``): a
        campaign resumed with more runs (e.g. another compensator) orders its table, and hashes
        it, as if it had run straight through.

        Parameters
        ----------
        positions
            Run key -> index; keys the table does not hold are ignored.
        """
        for key, index in positions.items():
            row = self._rows.get(key)
            if row is not None and row.get("index") != index:
                row["index"] = index
                self._dirty = True

    def discard(self, keys: Iterable[str]) -> None:
        """Drop rows (e.g. failed runs about to be retried).

        Parameters
        ----------
        keys
            Keys of the rows to drop.
        """
        for k in keys:
            if self._rows.pop(k, None) is not None:
                self._dirty = True

    def digest(self, keys: Iterable[str] | None = None) -> str:
        """:func:`digest` of the rows.

        Parameters
        ----------
        keys
            Keys of the rows hashed; None: every row.
        """
        return digest(self.rows(keys))

    # ------------------------------------------------------------------------------ files
    def flush(self, force: bool = True) -> None:
        """Write the table to its file if it changed.

        Parameters
        ----------
        force
            Write now; False: only if the flush interval has passed since the last write.
        """
        if self.path is None or not self._dirty:
            return
        now = time.monotonic()
        if not force and now - self._last < self.flush_interval:
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp")
        columns, rows = self.columns, self.rows()
        if self.path.suffix == ".parquet":
            import pyarrow as pa
            import pyarrow.parquet as pq

            data = {c: [r.get(c) for r in rows] for c in columns}
            pq.write_table(pa.table(data), tmp)
        else:
            with open(tmp, "w", newline="", encoding="utf-8") as f:
                writer = csv.writer(f)
                writer.writerow(columns)
                for r in rows:
                    writer.writerow([_csv_cell(r.get(c)) for c in columns])
        os.replace(tmp, self.path)
        self._dirty = False
        self._last = now

    @staticmethod
    def _read(path: Path) -> list[Row]:
        try:
            if path.suffix == ".parquet":
                import pyarrow.parquet as pq

                rows: list[Row] = pq.read_table(path).to_pylist()
                return rows
            with open(path, newline="", encoding="utf-8") as f:
                reader = csv.reader(f)
                header = next(reader, None)
                if header is None:
                    return []
                return [
                    {c: _parse_csv_cell(c, v) for c, v in zip(header, line, strict=True)}
                    for line in reader
                ]
        except (OSError, ValueError) as exc:
            raise DataError(f"{path}: cannot read the campaign table: {exc}") from None
        except Exception as exc:  # pyarrow's own errors (a corrupt or foreign file)
            raise DataError(f"{path}: cannot read the campaign table: {exc}") from None


def _index(row: Mapping[str, Scalar]) -> int:
    value = row.get("index")
    return value if isinstance(value, int) and not isinstance(value, bool) else 1 << 62
