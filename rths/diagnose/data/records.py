"""Records for the diagnosis: CSV files of the section-7 contract and ``rths run`` MCAP logs.

CSV contract (design.md section 7): a header line naming at least the columns ``time``,
``command``, ``measured`` and ``force`` (any order; other columns are ignored), then one row per
sample, SI units, uniform sampling.

Timing convention (the DAQ one): row ``k`` holds the command applied from ``time[k]`` (a
zero-order-hold DAC updated at ``t_k``) and the measured displacement [m] and force [N]
sampled at ``time[k]``.  A lab record whose converters are not exactly simultaneous differs
from this by a fraction of a sample; a shift of up to one sample between command and measured
is calibration (the baseline's alignment), never an effect.

MCAP logs written by ``rths run`` are read through :func:`rths.log.reader.read_loop` (topic
``rths/loop``: ``t``, ``target``, ``command``, ``measured``, ``force``).  A log row holds the
command held over the step *ending* at ``t`` and the measurement at ``t``, so on reading the
measurement columns move one row later (row ``k``: the command applied from ``t_k``, the
measurement at ``t_k``; the first row is the rest state before the first step, the last
command is dropped): :func:`align_log`.  The scenario text in the log's metadata is kept for
the structure channel.
"""

from __future__ import annotations

import csv
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from rths.core.errors import DataError

__all__ = [
    "COLUMNS",
    "MIN_DURATION",
    "SAMPLING_TOLERANCE",
    "Record",
    "align_log",
    "load_record",
    "read_csv",
    "read_mcap",
    "write_csv",
]

#: Columns every CSV record must have (design.md section 7).
COLUMNS: tuple[str, ...] = ("time", "command", "measured", "force")
#: Largest departure of a time step from the median step, as a fraction of it.  CSV writers
#: print times with 7-9 significant digits, i.e. <= 1e-4 dt jitter at 60 s and 2 kHz; a
#: dropped sample is a 100 % departure.
SAMPLING_TOLERANCE: float = 0.01
#: Shortest usable record [s]: a few cycles of the slowest structural mode of interest.
MIN_DURATION: float = 2.0
#: Largest magnitude of a value in a record: beyond it a number is not an SI measurement.
MAX_MAGNITUDE: float = 1e12
#: Smallest peak-to-peak swing [m, m, N] of command, measured and force: below it a column is
#: constant to any sensor (a nanometre, a micronewton) and there is nothing to diagnose.
MIN_SWING: dict[str, float] = {"command": 1e-9, "measured": 1e-9, "force": 1e-6}


@dataclass(frozen=True)
class Record:
    """One uniformly sampled test record at the specimen interface (SI units).

    Attributes
    ----------
    name
        File name (for messages and reports).
    dt
        Sample period [s].
    time
        Sample times [s], shape ``(n,)``.
    command
        Actuator command [m] applied from each sample time on (DAQ convention), shape ``(n,)``.
    measured
        Measured displacement of the specimen end [m], shape ``(n,)``.
    force
        Measured specimen restoring force [N], shape ``(n,)``.
    target
        Target displacement [m] from the numerical substructure at each sample time (MCAP logs
        only), else None.
    scenario_text
        The scenario TOML the run was made from (MCAP logs with metadata only), else None.
    """

    name: str
    dt: float
    time: NDArray[np.float64]
    command: NDArray[np.float64]
    measured: NDArray[np.float64]
    force: NDArray[np.float64]
    target: NDArray[np.float64] | None = None
    scenario_text: str | None = field(default=None, repr=False)

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.time.size)

    @property
    def rate(self) -> float:
        """Sampling rate [Hz]."""
        return 1.0 / self.dt

    @property
    def duration(self) -> float:
        """``n * dt`` [s]."""
        return self.n * self.dt


def _check_arrays(name: str, time: NDArray, columns: dict[str, NDArray]) -> float:
    """Validate finiteness, length and uniform sampling; return the sample period [s]."""
    for column, values in {"time": time, **columns}.items():
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise DataError(
                f"{name}: column '{column}' must be finite; got {float(values[bad[0]])!r} at "
                f"sample {bad[0]} ({bad.size} non-finite values)"
            )
        big = np.flatnonzero(np.abs(values) > MAX_MAGNITUDE)
        if big.size:
            raise DataError(
                f"{name}: column '{column}' holds {float(values[big[0]])!r} at sample {big[0]}: "
                f"beyond any SI measurement (|x| <= {MAX_MAGNITUDE:g}); wrong units?"
            )
    if time.size < 3:
        raise DataError(f"{name}: needs at least 3 samples; got {time.size}")
    steps = np.diff(time)
    dt = float(np.median(steps))
    if dt > 0.0 and time.size > 2:  # the mean step: free of the print rounding of each time
        mean = float((time[-1] - time[0]) / (time.size - 1))
        if abs(mean - dt) <= SAMPLING_TOLERANCE * dt:
            dt = mean
    if not dt > 0.0:
        raise DataError(f"{name}: column 'time' must increase; median step is {dt!r} s")
    worst = int(np.argmax(np.abs(steps - dt)))
    if abs(steps[worst] - dt) > SAMPLING_TOLERANCE * dt:
        raise DataError(
            f"{name}: non-uniform sampling: time step {steps[worst]!r} s between samples "
            f"{worst} and {worst + 1} (t = {time[worst]!r} s) departs from the median step "
            f"{dt!r} s by more than {SAMPLING_TOLERANCE:.0%}"
        )
    if time.size * dt < MIN_DURATION - 0.5 * dt:  # half a sample: t is rounded to whole ns
        raise DataError(
            f"{name}: record too short for a diagnosis: {time.size * dt:.3g} s; need at least "
            f"{MIN_DURATION} s"
        )
    for column, values in columns.items():
        swing = float(np.ptp(values))
        if column in MIN_SWING and swing < MIN_SWING[column]:
            raise DataError(
                f"{name}: column '{column}' is constant (swing {swing:.3g}, first value "
                f"{float(values[0])!r}): nothing moves there to diagnose"
            )
    return dt


def _bad_cell(path: Path, index: dict[str, int]) -> DataError:
    """Find the first non-numeric cell of a CSV (slow path, only on error)."""
    with open(path, newline="", encoding="utf-8") as f:
        reader = csv.reader(f)
        next(reader)
        for line, row in enumerate(reader, start=2):
            for column, j in index.items():
                if j >= len(row):
                    return DataError(f"{path}: line {line}: missing column '{column}'")
                try:
                    float(row[j])
                except ValueError:
                    return DataError(
                        f"{path}: line {line}: column '{column}' is not a number: {row[j]!r}"
                    )
    return DataError(f"{path}: cannot read the numeric rows")


def read_csv(path: str | os.PathLike[str]) -> Record:
    """Read a CSV record of the section-7 contract (module docstring).

    Parameters
    ----------
    path
        The CSV file: header ``time,command,measured,force`` (s, m, m, N).

    Raises
    ------
    DataError
        Missing file or column, a non-numeric or non-finite value (naming line and column),
        non-uniform sampling, or a record shorter than :data:`MIN_DURATION`.
    """
    p = Path(path)
    try:
        with open(p, newline="", encoding="utf-8") as f:
            header = next(csv.reader(f), None)
    except OSError as exc:
        raise DataError(f"cannot open CSV record '{p}': {exc.strerror}") from None
    except UnicodeDecodeError:
        raise DataError(f"{p}: not a text CSV file") from None
    if not header:
        raise DataError(f"{p}: empty file; expected the header {','.join(COLUMNS)}")
    names = [h.strip() for h in header]
    missing = [c for c in COLUMNS if c not in names]
    if missing:
        raise DataError(
            f"{p}: missing column '{missing[0]}' in the header {','.join(names)!r}; expected "
            f"{','.join(COLUMNS)}"
        )
    index = {c: names.index(c) for c in COLUMNS}
    try:
        table = np.loadtxt(p, delimiter=",", skiprows=1, usecols=list(index.values()), ndmin=2)
    except (ValueError, IndexError):
        raise _bad_cell(p, index) from None
    cols = {c: np.ascontiguousarray(table[:, k]) for k, c in enumerate(COLUMNS)}
    dt = _check_arrays(str(p), cols["time"], {c: cols[c] for c in COLUMNS[1:]})
    return Record(p.name, dt, cols["time"], cols["command"], cols["measured"], cols["force"])


def align_log(
    time: NDArray[np.float64],
    command: NDArray[np.float64],
    measured: NDArray[np.float64],
    force: NDArray[np.float64],
    target: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], ...]:
    """Log rows (command held over the step ending at ``t``) to the DAQ convention.

    Row ``k`` of the result: time ``t_k = time[k] - dt`` (the step's start), the command applied
    from it (``command[k]``), and the measurement at ``t_k``: the previous log row's, or the
    rest state (0) for the first row.

    Parameters
    ----------
    time
        Log time [s] of each row: the end of the step.
    command
        Command [m] held over the step ending at ``time[k]``.
    measured
        Measured displacement [m] at ``time[k]``.
    force
        Measured force [N] at ``time[k]``.
    target
        Target displacement [m] at ``time[k]``, if logged.

    Returns
    -------
    tuple of numpy.ndarray
        ``(time, command, measured, force[, target])`` in the DAQ convention.
    """
    dt = float(time[1] - time[0]) if time.size > 1 else 0.0

    def later(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.concatenate([[0.0], x[:-1]])

    out = (time - dt, np.asarray(command, float), later(measured), later(force))
    return out if target is None else (*out, later(target))


def read_mcap(path: str | os.PathLike[str]) -> Record:
    """Read topic ``rths/loop`` (and the scenario metadata) of an ``rths run`` MCAP log.

    The rows are aligned to the DAQ timing convention (:func:`align_log`).

    Parameters
    ----------
    path
        The ``.mcap`` log.

    Raises
    ------
    DataError
        Unreadable log, no ``rths/loop`` topic, a missing field, or bad sampling.
    """
    from rths.log.reader import read_loop, read_metadata

    p = Path(path)
    loop = read_loop(p, ("t", "command", "measured", "force"))
    cols = {c: np.asarray(loop[c], dtype=float) for c in ("t", "command", "measured", "force")}
    dt = _check_arrays(str(p), cols["t"], {c: cols[c] for c in ("command", "measured", "force")})
    target = loop.get("target")
    target = (
        np.asarray(target, dtype=float)
        if target is not None and target.dtype.kind in "fi"
        else None
    )
    aligned = align_log(cols["t"], cols["command"], cols["measured"], cols["force"], target)
    scenario = read_metadata(p).get("scenario", {}).get("text")
    return Record(
        p.name,
        dt,
        aligned[0],
        aligned[1],
        aligned[2],
        aligned[3],
        aligned[4] if target is not None else None,
        scenario,
    )


def load_record(path: str | os.PathLike[str]) -> Record:
    """A CSV or MCAP record, chosen by content (MCAP magic bytes) rather than by suffix.

    Parameters
    ----------
    path
        The data file.

    Raises
    ------
    DataError
        Unreadable file, or the errors of :func:`read_csv` / :func:`read_mcap`.
    """
    p = Path(path)
    try:
        with open(p, "rb") as f:
            magic = f.read(8)
    except OSError as exc:
        raise DataError(f"cannot open data file '{p}': {exc.strerror}") from None
    if magic.startswith(b"\x89MCAP"):
        return read_mcap(p)
    return read_csv(p)


def write_csv(
    path: str | os.PathLike[str],
    time: NDArray[np.float64],
    command: NDArray[np.float64],
    measured: NDArray[np.float64],
    force: NDArray[np.float64],
) -> None:
    """Write a record in the CSV contract (17 significant digits: lossless for float64).

    Parameters
    ----------
    path
        The CSV file to write.
    time
        Sample times [s], uniform.
    command
        Command [m], row ``k`` applied from ``t_k``.
    measured
        Measured displacement [m] at ``t_k``.
    force
        Measured force [N] at ``t_k``.

    Raises
    ------
    DataError
        Columns of unequal length or non-finite values.
    """
    table = np.column_stack([time, command, measured, force])
    if table.ndim != 2 or table.shape[1] != 4:
        raise DataError(f"write_csv needs four equal 1-D columns; got shape {table.shape}")
    if not np.all(np.isfinite(table)):
        raise DataError(f"write_csv: non-finite values in the record for '{path}'")
    np.savetxt(path, table, delimiter=",", header=",".join(COLUMNS), comments="", fmt="%.17g")
