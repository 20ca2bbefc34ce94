"""The model interface of the diagnosis: a channel's baseline and its extensions by effects.

Every model predicts its channel's observation as

.. math:: \\hat y(\\theta, \\beta) = X(\\theta)\\,\\beta + f(\\theta) + b_r

with a few nonlinear parameters ``theta`` (named, searched globally over orders of magnitude
and refined by :mod:`rths.diagnose.search.identify`), linear ones ``beta`` (least squares for
each ``theta``: variable projection; those that are NOMINAL.toml's own within the model's
:meth:`Model.tolerance`, :mod:`rths.diagnose.search.bounded`) and one offset ``b_r`` per record
(the fitter's).  A model holds the baseline -- the nominal model's own parameters re-calibrated
within a stated tolerance -- and a set of effects
(possibly empty): effects are always fitted *jointly* with the re-calibrated baseline, so none
gets credit for a mis-calibration.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar, Literal

import numpy as np
from numpy.typing import NDArray

from rths.diagnose.channels.channel import Channel, Segment

__all__ = ["Columns", "Model", "Param", "Theta"]

Columns = tuple[NDArray[np.float64], NDArray[np.float64]]
#: Nonlinear parameters by name.
Theta = dict[str, float]


@dataclass(frozen=True)
class Param:
    """One nonlinear parameter of a model and how the global search treats it.

    Attributes
    ----------
    name
        Name (unique within the model).
    lo, hi
        Bounds (SI units of the parameter).
    log
        Searched and refined on a logarithmic scale (then ``lo > 0``).
    grid
        Points of the global grid along this parameter (geometric for ``log``); 0: the
        parameter stays at ``start`` in the global stage and is only refined.
    start
        Starting value when not gridded (default the geometric or arithmetic middle).
    """

    name: str
    lo: float
    hi: float
    log: bool = True
    grid: int = 0
    start: float | None = None

    def middle(self) -> float:
        """The start value."""
        if self.start is not None:
            return float(np.clip(self.start, self.lo, self.hi))
        return float(np.sqrt(self.lo * self.hi) if self.log else 0.5 * (self.lo + self.hi))

    def values(self) -> NDArray[np.float64]:
        """The grid values (``[start]`` when not gridded)."""
        if self.grid <= 1:
            return np.array([self.middle()])
        if self.log:
            return np.geomspace(self.lo, self.hi, self.grid)
        return np.linspace(self.lo, self.hi, self.grid)


class Model(ABC):
    """A channel's re-calibrated baseline extended by a set of effects (module docstring).

    Parameters
    ----------
    effects
        Names of the effects the model holds (empty: the baseline).
    """

    #: ``"actuator"`` or ``"specimen"``: the channel the model explains.
    subsystem: ClassVar[Literal["actuator", "specimen"]]
    #: Polish the refinement with Nelder-Mead (cost surfaces with kinks: limiters, dead zones).
    polish: bool = False
    #: Structure tag (two models of one effect set may differ in structure).
    structure: str = ""
    #: Largest global grid (a larger Cartesian grid is subsampled, seeded).
    max_grid: int = 240
    #: Linear parameters NOMINAL.toml declares that this structure frees beyond their
    #: tolerance (a damping a dissipation law may replace); the selection takes it only when
    #: it buys them against the structure that holds them (``freedoms`` 0) on held-out data.
    freedoms: int = 0
    #: The global search and refinement score short windows where the drive moves most
    #: (:mod:`rths.diagnose.search.identify`); False: the whole identification records, for a
    #: law whose parameters only the records' whole range of amplitude shows.
    windowed: bool = True
    #: Coordinate sweeps over every parameter's range before the refinement
    #: (:func:`rths.diagnose.search.refine.coordinate_sweep`; 0: none).
    sweeps: int = 0

    def __init__(self, effects: tuple[str, ...] = ()) -> None:
        self.effects = tuple(effects)

    @property
    def name(self) -> str:
        """``"baseline"`` or the effects joined by ``+``."""
        return "+".join(self.effects) if self.effects else "baseline"

    def prepare(self, channel: Channel, base: dict[str, float]) -> None:
        """Take what the model needs from the re-calibrated baseline (default: nothing)."""

    def applicable(self, channel: Channel, base: dict[str, float]) -> bool:
        """Whether the structure can describe the channel at all (default: yes)."""
        return True

    def space(self, channel: Channel) -> list[Param]:
        """The nonlinear parameters (empty: none)."""
        return []

    def starts(self, channel: Channel) -> list[Theta]:
        """Extra starting points of the global search (e.g. the nominal values)."""
        return []

    @abstractmethod
    def columns(self, channel: Channel, seg: Segment, theta: Theta) -> Columns:
        """Regressors ``X`` (shape ``(n, p)``) and fixed part ``f`` (shape ``(n,)``)."""

    def nuisance(self, channel: Channel, seg: Segment, theta: Theta) -> NDArray[np.float64] | None:
        """Per-record nuisance columns besides the offset (initial states, a load cell's
        offset), calibrated on each record itself, held-out ones included (default: none)."""
        return None

    @abstractmethod
    def prior(self, channel: Channel) -> NDArray[np.float64]:
        """Nominal values of ``beta`` (the ridge pulls towards them where the data do not
        determine ``beta``, e.g. inertance against stiffness under a single sine)."""

    def tolerance(self, channel: Channel) -> NDArray[np.float64]:
        """Relative tolerance of each linear parameter ``beta`` that is NOMINAL.toml's own,
        NaN where free (an effect's level; default all free): the re-calibration keeps such a
        parameter within it (:mod:`rths.diagnose.search.bounded`)."""
        return np.full(self.prior(channel).size, np.nan)

    def limits(self, channel: Channel) -> NDArray[np.float64]:
        """Absolute bound ``|beta_j| <= l_j`` of each linear parameter, NaN where none
        (default none): a calibration whose range is a fixed figure rather than a share of a
        nominal value (a force's alignment to its drive of at most one sample,
        :func:`rths.diagnose.effects.alignment.alignment_column`)."""
        return np.full(self.prior(channel).size, np.nan)

    def unanchored(self, channel: Channel) -> NDArray[np.bool_]:
        """Which linear parameters ``beta`` are an effect's level with no nominal value (a
        friction force, an amplitude law's ``c1``): the ridge does not pull them (default
        none).  A pull towards zero would split a level that trades with a nominal parameter
        (``c1/(A + c2)`` with the viscous damping over a narrow range of amplitude) between
        the two by their energy, moving the nominal's one beyond what the data ask."""
        return np.zeros(self.prior(channel).size, dtype=bool)

    #: How many leading linear parameters ``beta`` cannot be negative (a passive specimen's
    #: inertance and damping: no re-calibration may turn them into a source); default none.
    passive_terms: int = 0

    #: Pairs ``(i, j)`` of linear parameters with ``beta_i <= beta_j`` (a body's inertance
    #: behind a series element never exceeds the total: the mass ahead of it is not
    #: negative); default none.
    ordered: tuple[tuple[int, int], ...] = ()

    def nonnegative(self, channel: Channel) -> NDArray[np.bool_]:
        """Which linear parameters ``beta`` cannot be negative (:attr:`passive_terms`)."""
        out = np.zeros(self.prior(channel).size, dtype=bool)
        out[: self.passive_terms] = True
        return out

    @abstractmethod
    def describe(
        self, channel: Channel, theta: Theta, beta: NDArray[np.float64]
    ) -> tuple[dict[str, dict[str, float]], dict[str, float]]:
        """``({effect: its parameters}, re-calibrated baseline)`` named in SI units."""

    def physical(self, channel: Channel, params: dict[str, dict[str, float]]) -> bool:
        """False when identified effect parameters are unphysical or contradicted by the data."""
        return True

    def resolution(self, channel: Channel, prediction: list[NDArray[np.float64]]) -> float:
        """Model-form resolution [unit^2]: a reducible held-out gap at most this large, which
        no candidate effect closes any useful share of, is the baseline's model form, not an
        effect (:mod:`rths.diagnose.search.selection`).  Default 0: no allowance.

        Parameters
        ----------
        channel
            The channel.
        prediction
            The baseline's prediction per record (whole records).
        """
        return 0.0
