"""The model interface of the diagnosis's baseline and candidate effects (see
:mod:`rths.diagnose.effects` for the form and the registry)."""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar, Literal

import numpy as np
from numpy.typing import NDArray

from rths.diagnose.channels import Channel, Segment

__all__ = ["Columns", "Model"]

Columns = tuple[NDArray[np.float64], NDArray[np.float64]]


class Model(ABC):
    """A baseline or candidate model of one channel (module docstring for the form)."""

    #: Verdict name (``"baseline"`` for the re-calibrated nominal).
    name: ClassVar[str] = ""
    #: ``"actuator"`` or ``"specimen"``: the channel the model explains.
    subsystem: ClassVar[Literal["actuator", "specimen"]]
    #: Effect parameters counted by the complexity penalty (0 for a baseline).
    n_effect: ClassVar[int] = 0
    #: Polish the search with Nelder-Mead (cost surfaces with kinks: limiters, dead zones).
    polish: ClassVar[bool] = False

    @abstractmethod
    def columns(self, channel: Channel, seg: Segment, theta: NDArray[np.float64]) -> Columns:
        """Regressors ``X`` (shape ``(n, p)``) and fixed part ``f`` (shape ``(n,)``)."""

    def starts(self, channel: Channel, base: dict[str, float]) -> list[NDArray[np.float64]]:
        """Starting points of the search over ``theta`` (empty: no nonlinear parameters).

        ``base`` is the re-calibrated baseline (:meth:`describe` of the baseline model).
        """
        return []

    def bounds(
        self, channel: Channel, base: dict[str, float]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Lower and upper bounds of ``theta``."""
        return np.empty(0), np.empty(0)

    @abstractmethod
    def describe(
        self, channel: Channel, theta: NDArray[np.float64], beta: NDArray[np.float64]
    ) -> tuple[dict[str, float], dict[str, float]]:
        """``(effect parameters, re-calibrated baseline)`` named in SI units."""

    def physical(self, channel: Channel, params: dict[str, float]) -> bool:
        """False when the identified effect parameters are unphysical (e.g. negative) or
        contradicted by the record."""
        return True

    def prepare(self, channel: Channel, base: dict[str, float]) -> None:
        """Take what the model needs from the re-calibrated baseline (default: nothing)."""

    @abstractmethod
    def prior(self, channel: Channel) -> NDArray[np.float64]:
        """The nominal values of ``beta`` (what the re-calibration shrinks towards where the
        data do not determine it, e.g. inertance against stiffness under a single sine)."""
