"""Ground motions of the vRTHS benchmark: three recorded earthquakes and a chirp.

The benchmark (``F1_input_file.m``, Simulink subsystem *GROUND ACCELERATION*) drives the frame
with one of

* ``"el_centro"``, ``"kobe"``, ``"morgan"`` -- records read by *From File* blocks from
  ``ElCentroAccelNoScaling.mat`` etc. (row 0 time [s], row 1 ground acceleration [m/s^2];
  a ~10 s tail of zeros lets the response decay; linear interpolation between samples, the
  last value held after the end);
* ``"chirp"`` -- the *Chirp Signal* block: unit amplitude [m/s^2], linear sweep from
  ``f_ini = 0.1 Hz`` to ``f_end = 40 Hz`` at the target time ``tend = 90 s`` (the ``otherwise``
  branch of ``F1_input_file.m``), ``sin(2 pi (f_ini t + (f_end - f_ini) t^2 / (2 tend)))``;

scaled by the gain *SCALING* = ``eq_intensity`` (0.4 by default).  The run lasts ``tend``: the
record's last time stamp, or the chirp's target time.

The records are data of the benchmark's companion package and are *not* shipped with this
project.  They are read from the user's copy, whose folder is given by the environment variable
:data:`PACKAGE_ENV` (or an explicit path); without it :func:`load_record` raises a one-line
:class:`~rths.core.errors.ConfigError` saying where to get the package and that the chirp runs
without it.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rths.core.errors import ConfigError, DataError, ParameterError, check_positive, format_choices

__all__ = [
    "DEFAULT_INTENSITY",
    "GROUND_MOTIONS",
    "PACKAGE_ENV",
    "PACKAGE_SOURCE",
    "RECORDS",
    "DATA_ENV",
    "DATA_SUBDIR",
    "ChirpMotion",
    "GroundMotion",
    "RecordedMotion",
    "ground_motion",
    "load_record",
    "package_dir",
]

FloatArray = NDArray[np.float64]

#: Environment variable naming the folder of the benchmark's companion package.
PACKAGE_ENV = "RTHS_VRTHS_PACKAGE"
#: Environment variable naming the project's data folder (the one holding ``vrths-benchmark/``),
#: used when :data:`PACKAGE_ENV` is not set.
DATA_ENV = "RTHS_DATA"
#: The package's folder name under :data:`DATA_ENV`.
DATA_SUBDIR = "vrths-benchmark"
#: Where the package is published.
PACKAGE_SOURCE = "public GitHub repository MECHS-RCN/BENCHMARKS, archive 'RTHS code RT V23.zip'"
#: ``eq_intensity`` of ``F1_input_file.m``.
DEFAULT_INTENSITY = 0.4
#: Record name -> (file in the package, MATLAB variable).
RECORDS: dict[str, tuple[str, str]] = {
    "el_centro": ("ElCentroAccelNoScaling.mat", "ElCentroAccel"),
    "kobe": ("KobeAccelNoScaling.mat", "KobeAccel"),
    "morgan": ("MorganAccelNoScaling.mat", "MorganAccel"),
}
#: Every ground-motion name a scenario may use.
GROUND_MOTIONS: tuple[str, ...] = (*RECORDS, "chirp")


class GroundMotion:
    """Base of the benchmark's unscaled ground accelerations (``intensity`` applied on sampling).

    Subclasses define :attr:`name`, :attr:`duration` [s] (the run's ``tend``) and
    :meth:`_acceleration` [m/s^2] at given times.
    """

    name: str
    duration: float

    def _acceleration(self, t: FloatArray) -> FloatArray:  # pragma: no cover - abstract
        raise NotImplementedError

    def acceleration(self, t: ArrayLike, intensity: float = DEFAULT_INTENSITY) -> FloatArray:
        """Ground acceleration [m/s^2] at times ``t`` [s], times ``intensity`` [-].

        Parameters
        ----------
        t
            Times [s], any shape, >= 0.
        intensity
            ``eq_intensity`` gain [-], >= 0.
        """
        gain = float(intensity)
        if not (math.isfinite(gain) and gain >= 0.0):
            raise ParameterError(f"ground motion intensity must be >= 0; got {intensity!r}")
        return gain * self._acceleration(np.asarray(t, dtype=float))

    def sampled(self, dt: float, n: int, intensity: float = DEFAULT_INTENSITY) -> FloatArray:
        """Samples ``a_g(k dt)``, ``k = 0 .. n-1`` [m/s^2] (times ``intensity``)."""
        dt = check_positive(dt, "time step dt")
        return self.acceleration(np.arange(int(n)) * dt, intensity)

    def steps(self, dt: float) -> int:
        """Loop steps of ``dt`` [s] in the run: ``floor(duration / dt)`` (``tend`` of F1)."""
        dt = check_positive(dt, "time step dt")
        return int(math.floor(self.duration / dt + 1e-9))


@dataclass(frozen=True, eq=False)
class RecordedMotion(GroundMotion):
    """A recorded ground acceleration, linearly interpolated (Simulink *From File*).

    Attributes
    ----------
    name
        Record name (``"el_centro"``, ...).
    time
        Sample times [s], shape ``(n,)``, strictly increasing from 0.
    samples
        Ground acceleration [m/s^2], shape ``(n,)``; held at its last value after the end.
    """

    name: str
    time: FloatArray = field(repr=False)
    samples: FloatArray = field(repr=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.time, dtype=float)
        a = np.asarray(self.samples, dtype=float)
        if t.ndim != 1 or t.shape != a.shape or t.size < 2:
            raise DataError(
                f"record {self.name!r} needs time and acceleration rows of equal length >= 2; "
                f"got shapes {t.shape} and {a.shape}"
            )
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(a))):
            raise DataError(f"record {self.name!r} has non-finite samples")
        if t[0] != 0.0 or np.any(np.diff(t) <= 0.0):
            raise DataError(
                f"record {self.name!r} time must start at 0 and increase; got t[0] = {t[0]!r}"
            )
        object.__setattr__(self, "time", t)
        object.__setattr__(self, "samples", a)

    @property
    def duration(self) -> float:  # type: ignore[override]
        """Last time stamp [s] (``tend`` of ``F1_input_file.m``)."""
        return float(self.time[-1])

    def _acceleration(self, t: FloatArray) -> FloatArray:
        return np.interp(t, self.time, self.samples)


@dataclass(frozen=True, eq=False)
class ChirpMotion(GroundMotion):
    """Linear sine sweep of unit amplitude [m/s^2] (Simulink *Chirp Signal*).

    ``a(t) = sin(2 pi (f_start t + (f_end - f_start) t^2 / (2 duration)))``: the instantaneous
    frequency rises linearly from ``f_start`` at 0 to ``f_end`` at ``duration``.

    Attributes
    ----------
    f_start, f_end
        Initial frequency and frequency at the target time [Hz] (benchmark 0.1 and 40).
    duration
        Target time and run length [s] (benchmark 90).
    name : str
        Record name (default ``"chirp"``).
    """

    f_start: float = 0.1
    f_end: float = 40.0
    duration: float = 90.0
    name: str = "chirp"

    def __post_init__(self) -> None:
        check_positive(self.duration, "chirp duration")
        for label, value in (("chirp f_start", self.f_start), ("chirp f_end", self.f_end)):
            if not (math.isfinite(value) and value >= 0.0):
                raise ParameterError(f"{label} must be >= 0 Hz; got {value!r}")

    def _acceleration(self, t: FloatArray) -> FloatArray:
        rate = (self.f_end - self.f_start) / self.duration
        return np.sin(2.0 * np.pi * (self.f_start * t + 0.5 * rate * t * t))


def package_dir(path: str | os.PathLike[str] | None = None) -> Path:
    """The folder of the benchmark's companion package.

    Parameters
    ----------
    path
        Explicit folder; by default the environment variable :data:`PACKAGE_ENV`, else
        ``$RTHS_DATA/vrths-benchmark`` (:data:`DATA_ENV`, :data:`DATA_SUBDIR`).

    Raises
    ------
    ConfigError
        One line: neither given, or not a folder holding the ground-motion files.
    """
    given = os.environ.get(PACKAGE_ENV) if path is None else os.fspath(path)
    if not given and path is None and os.environ.get(DATA_ENV):
        given = os.path.join(os.environ[DATA_ENV], DATA_SUBDIR)
    if not given:
        raise ConfigError(
            "the vRTHS benchmark records need the benchmark's companion package "
            f"({PACKAGE_SOURCE}): set {PACKAGE_ENV} to its folder (or {DATA_ENV} to the folder "
            f'holding {DATA_SUBDIR}/); ground_motion = "chirp" runs without it'
        )
    folder = Path(given).expanduser()
    if not (folder / RECORDS["el_centro"][0]).is_file():
        raise ConfigError(
            f"{str(folder)!r} is not the vRTHS benchmark package (no "
            f"{RECORDS['el_centro'][0]} there; get it from the {PACKAGE_SOURCE}); "
            f'ground_motion = "chirp" runs without it'
        )
    return folder


def load_record(name: str, package: str | os.PathLike[str] | None = None) -> RecordedMotion:
    """Read a benchmark earthquake record from the user's copy of the package.

    Parameters
    ----------
    name
        ``"el_centro"``, ``"kobe"`` or ``"morgan"``.
    package
        Package folder (default: :func:`package_dir`).
    """
    from scipy.io import loadmat

    if name not in RECORDS:
        raise ParameterError(
            f"unknown benchmark record {name!r}; choose one of {format_choices(list(RECORDS))}"
        )
    file, variable = RECORDS[name]
    path = package_dir(package) / file
    try:
        data = loadmat(path, variable_names=[variable])[variable]
    except (OSError, ValueError, KeyError) as exc:
        raise DataError(f"{path}: cannot read variable {variable!r} ({exc})") from None
    data = np.asarray(data, dtype=float)
    if data.ndim != 2 or data.shape[0] != 2:
        raise DataError(
            f"{path}: {variable} must have 2 rows (time, acceleration); got {data.shape}"
        )
    return RecordedMotion(name, data[0].copy(), data[1].copy())


def ground_motion(
    name: str, package: str | os.PathLike[str] | None = None, **chirp: float
) -> GroundMotion:
    """A benchmark ground motion by name (:data:`GROUND_MOTIONS`).

    Parameters
    ----------
    name
        A record name, or ``"chirp"``.
    package
        Package folder for the records (default: :func:`package_dir`); unused by the chirp.
    **chirp
        ``f_start``, ``f_end``, ``duration`` of the chirp (only with ``name = "chirp"``).
    """
    if name == "chirp":
        unknown = sorted(set(chirp) - {"f_start", "f_end", "duration"})
        if unknown:
            raise ParameterError(f"unknown chirp option(s) {format_choices(unknown)}")
        d = ChirpMotion()
        return ChirpMotion(
            f_start=chirp.get("f_start", d.f_start),
            f_end=chirp.get("f_end", d.f_end),
            duration=chirp.get("duration", d.duration),
        )
    if chirp:
        raise ParameterError(
            f"chirp options {format_choices(sorted(chirp))} given for ground motion {name!r}"
        )
    if name not in RECORDS:
        raise ParameterError(
            f"unknown ground motion {name!r}; choose one of {format_choices(GROUND_MOTIONS)}"
        )
    return load_record(name, package)
