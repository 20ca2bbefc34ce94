"""Shared reading of the public friction-damper-with-backlash records (no data in the project).

The records (ARTS Laboratory, University of South Carolina; Downey et al., Engineering
Structures 113 (2016) 287-298; CC BY-SA 4.0) are gzip JSON files with ``data`` rows
``time [s], damper displacement [in], friction force [kip], velocity [in/s], actuator force 1
[lb], actuator force 2 [lb]`` at 1024 Hz.  Sine tests are named
``<f>Hz<T>lbtension<A>amplitude.json.gz``, earthquake profiles ``eq_<name>.json.gz``.

The folder is never part of the project: tools find it from ``--data DIR`` or the environment
variable ``RTHS_DATA`` (the folder that *contains* ``friction-damper/``; the
``friction-damper`` folder itself is accepted too).  :func:`find_data_dir` returns ``None``
when neither is given or the folder is absent, and the tools then print one ``skipped: ...``
line and exit 0.
"""

from __future__ import annotations

import argparse
import gzip
import json
import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn

import numpy as np

__all__ = [
    "IN_M",
    "KIP_N",
    "LB_N",
    "SUBDIR",
    "OneLineParser",
    "Record",
    "find_data_dir",
    "list_records",
    "load_record",
    "parse_name",
]

IN_M = 0.0254  #: one inch [m]
LB_N = 4.4482216152605  #: one pound-force [N]
KIP_N = 1000.0 * LB_N  #: one kip [N]
SUBDIR = "friction-damper"
SKIP_MESSAGE = f"skipped: {SUBDIR} data not found (give --data DIR or set RTHS_DATA)"

_SINE = re.compile(r"^(?P<f>[0-9.]+)Hz(?P<T>[0-9.]+)lbtension(?P<A>[0-9.]+)amplitude$")


class OneLineParser(argparse.ArgumentParser):
    """:class:`argparse.ArgumentParser` whose usage errors are one line on stderr, exit 2."""

    def error(self, message: str) -> NoReturn:
        print(f"{self.prog}: error: {message}", file=sys.stderr)
        raise SystemExit(2)


@dataclass(frozen=True)
class Record:
    """One record in SI units (raw channels kept for the channel checks).

    Attributes
    ----------
    name : str
        File name without ``.json.gz``.
    kind : str
        ``"sine"`` or ``"eq"``.
    frequency_hz, tension_lb, amplitude_in : float or None
        Parsed from a sine test's name (``None`` for eq records; their band tension is 36 lb
        by the README, stored in ``tension_lb``).
    t : ndarray
        Time [s].
    x : ndarray
        Damper displacement [m].
    force : ndarray
        Friction-force channel [N], sign as recorded.
    velocity : ndarray
        Velocity channel [m/s].
    act1, act2 : ndarray
        Actuator force channels [N].
    """

    name: str
    kind: str
    frequency_hz: float | None
    tension_lb: float | None
    amplitude_in: float | None
    t: np.ndarray
    x: np.ndarray
    force: np.ndarray
    velocity: np.ndarray
    act1: np.ndarray
    act2: np.ndarray

    @property
    def dt(self) -> float:
        """Sampling interval [s] (median step of ``t``)."""
        return float(np.median(np.diff(self.t)))


def find_data_dir(arg: str | os.PathLike[str] | None) -> Path | None:
    """The ``friction-damper`` folder from ``--data`` or ``RTHS_DATA``, or ``None``.

    Parameters
    ----------
    arg : path or None
        The ``--data`` value; when ``None`` the environment variable ``RTHS_DATA`` is used.

    Returns
    -------
    Path or None
        A folder holding ``*.json.gz`` records, or ``None`` when nothing usable is given.
    """
    base = arg if arg is not None else os.environ.get("RTHS_DATA") or None
    if base is None:
        return None
    base = Path(base)
    for cand in (base / SUBDIR, base):
        if cand.is_dir() and any(cand.glob("*.json.gz")):
            return cand
    return None


def parse_name(name: str) -> tuple[str, float | None, float | None, float | None]:
    """``(kind, frequency [Hz], tension [lb], amplitude [in])`` from a record name.

    Earthquake records (``eq_*``) get ``kind = "eq"``, no frequency or amplitude and the
    README's band tension of 36 lb.  Any other name raises :class:`ValueError`.
    """
    if name.startswith("eq_"):
        return "eq", None, 36.0, None
    m = _SINE.match(name)
    if m is None:
        raise ValueError(f"record name {name!r} is neither <f>Hz<T>lbtension<A>amplitude nor eq_*")
    return "sine", float(m["f"]), float(m["T"]), float(m["A"])


def list_records(folder: Path) -> list[str]:
    """Record names (without ``.json.gz``) in ``folder``: sine tests first, then eq records."""
    names = [p.name[: -len(".json.gz")] for p in folder.glob("*.json.gz")]
    good = []
    for n in names:
        try:
            kind, fr, ten, amp = parse_name(n)
        except ValueError:
            continue
        good.append((kind == "eq", ten or 0.0, fr or 0.0, amp or 0.0, n))
    return [g[-1] for g in sorted(good)]


def load_record(folder: Path, name: str) -> Record:
    """Read ``folder/name.json.gz`` and convert it to SI (m, N, m/s, s).

    Raises
    ------
    ValueError
        When the file does not hold six columns of finite numbers with increasing time.
    """
    with gzip.open(folder / f"{name}.json.gz", "rt", encoding="utf-8") as f:
        raw = json.load(f)
    a = np.asarray(raw["data"], dtype=float)
    if a.ndim != 2 or a.shape[1] != 6 or a.shape[0] < 3:
        raise ValueError(f"{name}: expected rows of 6 columns, got shape {a.shape}")
    if not np.all(np.isfinite(a)) or np.any(np.diff(a[:, 0]) <= 0):
        raise ValueError(f"{name}: non-finite values or non-increasing time")
    kind, fr, ten, amp = parse_name(name)
    return Record(
        name,
        kind,
        fr,
        ten,
        amp,
        a[:, 0],
        a[:, 1] * IN_M,
        a[:, 2] * KIP_N,
        a[:, 3] * IN_M,
        a[:, 4] * LB_N,
        a[:, 5] * LB_N,
    )
