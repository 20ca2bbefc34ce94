"""How the loop reaches the specimen: the link protocol, the sample it answers with, and the
``fast`` clock's in-process link (the zenoh links are :mod:`rths.wire`'s)."""

from __future__ import annotations

from typing import Any, NamedTuple, Protocol

from rths.runtime.guard import CommandGuard

__all__ = ["InProcessLink", "LinkSample", "SpecimenLink"]


class LinkSample(NamedTuple):
    """What the specimen answers: measured displacement [m], force [N] (specimen scale), the age
    of the sample when the loop uses it [ns] (0 in lockstep/fast) and the specimen's step number
    (the ``seq`` of the command it answers; older than the step after a missed deadline).
    Immutable; a named tuple because one is built every step (cheaper than a frozen
    dataclass).

    Attributes
    ----------
    displacement : float
        Measured displacement [m], specimen scale.
    force : float
        Measured force [N], specimen scale.
    age_ns : int
        Age of the sample when the loop uses it [ns] (default 0: lockstep and fast).
    specimen_seq : int
        The specimen's step number, the ``seq`` of the command it answers (default -1: unknown).
    """

    displacement: float
    force: float
    age_ns: int = 0
    specimen_seq: int = -1


class SpecimenLink(Protocol):
    """How the loop reaches the specimen (in process, or over zenoh in lockstep or real time).

    A link may also offer ``safe_stop(reason)``: the controlled ramp-down the loop asks for
    after every stop."""

    def exchange(self, seq: int, t_ns: int, command: float) -> LinkSample:
        """Send command ``seq`` (to be held until ``t_ns``, simulated ns); return the measurement
        the loop should use for the end of the step."""
        ...


class _Lab(Protocol):
    def step(self, command: float) -> tuple[float, float]: ...


class InProcessLink:
    """The ``fast`` clock's link: calls an emulated lab directly in this process, through the
    same :class:`CommandGuard` the specimen process applies (so fast and lockstep agree).

    Parameters
    ----------
    lab
        The emulated lab (anything with ``step(command) -> (displacement, force)``).
    guard
        The specimen side's command guard; None: commands go to the lab unchecked.
    """

    def __init__(self, lab: _Lab, guard: CommandGuard | None = None) -> None:
        self.lab = lab
        self.guard = guard

    def exchange(self, seq: int, t_ns: int, command: float) -> LinkSample:
        if self.guard is not None:
            command = self.guard.apply(command)
        displacement, force = self.lab.step(command)
        return LinkSample(displacement, force, 0, seq)

    def fused(self) -> tuple[Any, CommandGuard | None, Any] | None:
        """The lab, the guard and where the lab's rows go (None: nowhere) for the fast clock's
        compiled path (:mod:`rths.runtime.fastpath`); None when a subclass changes
        :meth:`exchange` without saying how (it then keeps the Python path)."""
        if type(self).exchange is not InProcessLink.exchange:
            return None
        return self.lab, self.guard, None

    def safe_stop(self, reason: str) -> int:
        """Ramp the lab's actuator to zero through the guard; returns the steps it took.

        Parameters
        ----------
        reason
            Why the run stopped (latched in the guard).
        """
        if self.guard is None:
            return 0
        self.guard.trip(reason)
        steps = 0
        while not self.guard.at_rest:
            self.lab.step(self.guard.ramp())
            steps += 1
        return steps
