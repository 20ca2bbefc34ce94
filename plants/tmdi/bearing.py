"""A high-damping rubber bearing (S1 Eq.8) as a physical specimen: the ``hdrb`` specimen kind.

Isolation bearings are tested as physical substructures; driven at one end with the other fixed,
the bearing's restoring force is ``F = F_E(u) + c(A) v`` (:class:`plants.tmdi.hdrb.HDRB`).  With an
amplitude law the dashpot ``c(A)`` follows the online amplitude estimate of
:func:`plants.tmdi.integration.laws.track_amplitude` -- half the distance between the last two
reversals,
updated with each sample -- so this specimen and the compiled S1 kernel give the same force for the
same deformation history (a test drives both).
"""

from __future__ import annotations

from dataclasses import fields

from plants.base import Specimen
from plants.tmdi import hdrb as presets
from plants.tmdi.hdrb import HDRB
from rths.core.errors import ParameterError, format_choices
from rths.core.registry import SPECIMENS

__all__ = ["BearingOptions", "HDRBSpecimen"]

_PRESETS: dict[str, HDRB] = {
    "s1_primary": presets.S1_PRIMARY,
    "s1_secondary": presets.S1_SECONDARY,
    "s1_primary_ideal_inerter": presets.S1_PRIMARY_IDEAL_INERTER,
    "s1_secondary_ideal_inerter": presets.S1_SECONDARY_IDEAL_INERTER,
    "s1_primary_uncontrolled": presets.S1_PRIMARY_UNCONTROLLED,
    "s1_primary_amplitude": presets.S1_PRIMARY_AMPLITUDE,
    "s1_secondary_amplitude": presets.S1_SECONDARY_AMPLITUDE,
}


class BearingOptions(HDRB):
    """Options of the ``hdrb`` specimen kind: the fields of :class:`plants.tmdi.hdrb.HDRB`
    (``k1``, ``k2``, ``k3``, ``c``, ``damping_law``), or a preset of S1 §4.2 with overrides.

    The bearing force is ``F = k1 u + k2 u^2 sign(u) + k3 u^3 + c v`` (S1 Eq.8), with ``u`` [m]
    the deformation and ``v`` [m/s] its rate.  S1 §4.2 identifies, for the primary bearing,
    ``k1 = 3.94e4 N/m``, ``k2 = -6.46e5 N/m^2``, ``k3 = 4.52e6 N/m^3``, ``c = 538.13 N s/m``
    (preset ``s1_primary``, see :meth:`presets`).

    Parameters
    ----------
    k1 : float
        Linear stiffness coefficient ``k_1`` [N/m], > 0 (S1 Eq.8).
    k2 : float, default 0.0
        Coefficient ``k_2`` [N/m^2] of ``u^2 sign(u)`` (S1 Eq.8); negative softens.
    k3 : float, default 0.0
        Cubic coefficient ``k_3`` [N/m^3] (S1 Eq.8); positive stiffens.
    c : float, default 0.0
        Dashpot coefficient [N s/m], >= 0 (S1 Eq.8); with a ``damping_law``, its value at the
        law's reference amplitude.
    damping_law : AmplitudeDamping or None, default None
        Amplitude-dependent dashpot ``c(A)`` (:class:`plants.tmdi.hdrb.AmplitudeDamping`);
        None keeps the constant ``c`` of S1.
    """

    __slots__ = ()

    @staticmethod
    def presets() -> tuple[str, ...]:
        """The S1 bearings of :mod:`plants.tmdi.hdrb`."""
        return tuple(_PRESETS)

    @classmethod
    def from_preset(cls, name: str, **overrides: object) -> BearingOptions:
        """The preset bearing with some fields replaced."""
        if name not in _PRESETS:
            raise ParameterError(
                f"unknown hdrb preset {name!r}; choose one of {format_choices(list(_PRESETS))}"
            )
        base = _PRESETS[name]
        values = {f.name: getattr(base, f.name) for f in fields(HDRB)} | overrides
        return cls(**values)


@SPECIMENS.register("hdrb", BearingOptions)
class HDRBSpecimen(Specimen):
    """An HDRB isolator driven at one end, S1 Eq.8 (with the amplitude-dependent dashpot).

    Parameters
    ----------
    bearing
        The bearing law.
    """

    def __init__(self, bearing: HDRB) -> None:
        super().__init__()
        if not isinstance(bearing, HDRB):
            raise ParameterError(f"bearing must be an HDRB; got {bearing!r}")
        self.bearing = bearing
        law = bearing.damping_law
        self._tolerance = law.reversal_tolerance if law is not None else 0.0
        self.reset()

    @classmethod
    def from_options(cls, options: BearingOptions, **_: object) -> HDRBSpecimen:
        """The ``hdrb`` kind."""
        return cls(options)

    def _reset_impl(self) -> None:
        self._direction = 0.0
        self._extremum = 0.0
        self._turn = 0.0
        self._seen = False
        self.amplitude = 0.0
        self._c = float(self.bearing.damping_coefficient(0.0))

    def _step_impl(self, u: float, v: float, a: float, dt: float) -> float:
        if self.bearing.damping_law is not None:
            self._track(u)  # as the kernel's outputs: the estimate includes this sample
        return float(self.bearing.elastic_force(u)) + self._c * v

    def _track(self, u: float) -> None:
        """The reversal rule of :func:`plants.tmdi.integration.laws.track_amplitude`."""
        if self._direction == 0.0:
            if abs(u - self._extremum) > self._tolerance:
                self._direction = 1.0 if u > self._extremum else -1.0
                self._extremum = u
            return
        if (u - self._extremum) * self._direction >= 0.0:
            self._extremum = u
            return
        if abs(u - self._extremum) <= self._tolerance:
            return
        self._direction = -self._direction
        if self._seen:
            self.amplitude = 0.5 * abs(self._extremum - self._turn)
            self._c = float(self.bearing.damping_coefficient(self.amplitude))
        self._turn = self._extremum
        self._extremum = u
        self._seen = True

    def state(self) -> dict[str, float]:
        """``amplitude`` [m] estimate and the current ``damping`` coefficient [N s/m]."""
        return {"amplitude": self.amplitude, "damping": self._c}
