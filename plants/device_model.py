"""What the numerical side believes about the specimen: the nominal device model of ``[model]``.

The same belief serves three consumers: the substructure integrates it implicitly at the interface
(the force correction of :mod:`rths.runtime.loop`), the compensator's nominal plant is the actuator
linearised with it installed, and the fully numerical "mock" run uses it in place of the specimen.

Kinds (specimen scale, SI):

``linear``   ``F = m a + c v + k x`` (``inertance`` = m, ``damping``, ``stiffness``)
``imd``      S0 Eq.1 (``inertance`` m_e, ``damping`` c_d) or, with ``series_stiffness`` k0, S0
Eq.12:
             the flywheel ``m_e, c_d`` behind the spring ``k0``
``inerter``  ``F = b a + c v`` (``inertance`` b, ``damping`` c), for the S1 TMDI
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Literal

from rths.core.errors import ParameterError, check_in_range, check_positive

__all__ = ["DEVICE_KINDS", "DeviceModel"]

DeviceKind = Literal["imd", "linear", "inerter"]

#: Kinds of nominal device.
DEVICE_KINDS: tuple[str, ...] = ("imd", "linear", "inerter")
#: Largest inertance [kg], damping [N s/m] or stiffness [N/m] of a device (prototype scale
#: included): 1e12 is a mountain's mass; beyond it the structure's matrices lose all precision.
MAX_VALUE = 1e12


@dataclass(frozen=True)
class DeviceModel:
    """A nominal device (see the module docstring).

    Parameters
    ----------
    kind
        ``"imd"``, ``"linear"`` or ``"inerter"``.
    inertance
        Inertance or mass [kg], >= 0.
    damping
        Viscous coefficient [N s/m], >= 0.
    stiffness
        Parallel stiffness [N/m], >= 0 (``linear`` only).
    series_stiffness
        Internal series stiffness k0 [N/m] of an ``imd`` (S0 Eq.12), > 0, or None (S0 Eq.1).
    """

    kind: DeviceKind
    inertance: float
    damping: float = 0.0
    stiffness: float = 0.0
    series_stiffness: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in DEVICE_KINDS:
            raise ParameterError(
                f"device model kind must be one of {DEVICE_KINDS}; got {self.kind!r}"
            )
        for name in ("inertance", "damping", "stiffness"):
            check_in_range(getattr(self, name), f"device {name}", 0.0, MAX_VALUE)
        if self.stiffness and self.kind != "linear":
            raise ParameterError(
                f"only a linear device has a parallel stiffness; got {self.kind!r}"
            )
        if self.series_stiffness is not None:
            check_positive(self.series_stiffness, "device series stiffness")
            check_in_range(self.series_stiffness, "device series stiffness", 0.0, MAX_VALUE)
            if self.kind != "imd":
                raise ParameterError(f"only an imd has a series stiffness; got {self.kind!r}")

    def scaled(self, impedance: float) -> DeviceModel:
        """The device seen from the prototype: every impedance times ``impedance`` [-]."""
        k = check_positive(impedance, "impedance scale factor")
        series = None if self.series_stiffness is None else k * self.series_stiffness
        return replace(
            self,
            inertance=k * self.inertance,
            damping=k * self.damping,
            stiffness=k * self.stiffness,
            series_stiffness=series,
        )

    def rigid(self) -> DeviceModel:
        """The same inertance and damping attached rigidly (S0 Eq.1, the "simplified model")."""
        return replace(self, stiffness=0.0, series_stiffness=None)

    def dynamic_stiffness(self) -> Any:
        """``K(s) = F(s)/x(s)`` [N/m] as a python-control transfer function (or a float 0)."""
        import control  # kept out of the import of plants that never linearise

        s = control.tf("s")
        if self.kind == "linear":
            return self.inertance * s**2 + self.damping * s + self.stiffness
        if self.series_stiffness is None:
            return self.inertance * s**2 + self.damping * s
        k, flywheel = self.series_stiffness, self.inertance * s**2 + self.damping * s
        return k * flywheel / (flywheel + k)
