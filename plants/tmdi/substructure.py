"""The TMDI structure as an RTHS numerical substructure with an optional nominal interface device
(private; re-exported by :mod:`plants.tmdi.structure`, which documents the model)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Final

from numpy.typing import ArrayLike

from plants.base import Specimen
from plants.device_model import DeviceModel
from plants.tmdi.configuration import TMDIOptions, s1_configuration
from plants.tmdi.engine import S1Structure
from plants.tmdi.inerter import IdealInerter, RackPinionInerter
from plants.tmdi.integration import layout
from plants.tmdi.structure import TMDIStructure
from rths.core.errors import ParameterError, check_nonnegative
from rths.core.registry import SUBSTRUCTURES

if TYPE_CHECKING:
    from plants.tmdi.parameters import TMDIParameters

__all__ = ["NominalInerter", "TMDISubstructure"]


@dataclass(frozen=True, slots=True)
class NominalInerter:
    """Nominal model of a grounded inerter specimen, carried implicitly by the substructure.

    Restoring force (sign convention of :mod:`plants.base`)
    ``F_n = b_n ü_T + c_n u̇_T``: an ideal inerter (S1 Fig.1a) with an optional parallel
    dashpot, between the interface DOF ``u_T`` and the ground.

    Parameters
    ----------
    inertance
        ``b_n`` [kg], >= 0.
    damping
        ``c_n`` [N s/m], >= 0.
    """

    inertance: float
    damping: float = 0.0

    def __post_init__(self) -> None:
        check_nonnegative(self.inertance, "nominal inertance b_n")
        check_nonnegative(self.damping, "nominal damping c_n")

    @classmethod
    def matching(cls, specimen: Specimen) -> NominalInerter:
        """The rigid-limit model of an inerter specimen.

        Parameters
        ----------
        specimen
            :class:`~plants.tmdi.inerter.IdealInerter`: ``b_n = b``, ``c_n = 0``;
            :class:`~plants.tmdi.inerter.RackPinionInerter` (S1 Eq.9-10 with ``k_S → ∞``, no play,
            no friction): ``b_n = J_B / r_P²`` and ``c_n = c_B / r_P²``.  Other specimens
            raise :class:`~rths.core.errors.ParameterError`.
        """
        if isinstance(specimen, IdealInerter):
            return cls(specimen.inertance)
        if isinstance(specimen, RackPinionInerter):
            p = specimen.parameters
            return cls(p.nominal_inertance, p.flywheel_damping / p.pinion_radius**2)
        raise ParameterError(
            f"no nominal inerter for a {type(specimen).__name__}; give NominalInerter(b_n, c_n)"
        )


@SUBSTRUCTURES.register("tmdi", TMDIOptions)
class TMDISubstructure(S1Structure):
    """PS + TMD of S1 Eq.12 as the numerical substructure of an RTHS with the inerter physical.

    The interface DOF is ``u_T`` (relative to the ground, where the inerter is fixed); the loop
    supplies the inerter's restoring force ``F_B``, held constant over each step.  The
    substructure owns the base excitation.

    Nominal device.  An inerter of ``b/m_T = 4.8`` (S1 IM-IF) fed back one step late turns
    into a negative mass that destabilises the secondary DOF, whatever the step.  With
    ``device`` the substructure carries a :class:`NominalInerter` ``F_n = b_n ü_T + c_n u̇_T``
    in its implicit system (``b_n`` joins ``m_T`` in the mass matrix, ``c_n`` the damping), so
    the step is as stable as the structure alone; :attr:`device_force` is ``F_n`` now, and the
    force passed to :meth:`step` is the *correction* ``F_B - F_n`` (the loop's
    ``force_scale * F - device_force``, :mod:`rths.runtime.loop`).  A specimen equal to the nominal
    device then gives a zero correction and the partitioned run is the monolithic one.

    Parameters
    ----------
    parameters
        The structure; it must have a secondary mass.
    ground_acceleration
        ``ü_G`` [m/s²]: a callable of time [s], or samples at spacing ``excitation_dt``.
    dt
        Loop step [s].
    excitation_dt
        Spacing [s] of sampled ``ground_acceleration``; defaults to ``dt``.
    device
        Nominal interface device integrated with the structure, or None (plain RTHS: the
        step's force is the whole ``F_B``).
    """

    def __init__(
        self,
        parameters: TMDIParameters,
        ground_acceleration: Callable[[float], float] | ArrayLike,
        dt: float,
        excitation_dt: float | None = None,
        device: NominalInerter | None = None,
    ) -> None:
        if not parameters.has_tmd:
            raise ParameterError("the TMDI substructure needs a secondary mass; got 0.0 kg")
        if device is not None and not isinstance(device, NominalInerter):
            raise ParameterError(f"device must be a NominalInerter or None; got {device!r}")
        self.device: Final[NominalInerter | None] = device
        nominal = device or NominalInerter(0.0)
        packed = layout.pack_parameters(
            parameters, inertance=nominal.inertance, grounded_damping=nominal.damping
        )
        super().__init__(parameters, packed, ground_acceleration, dt, excitation_dt)

    @classmethod
    def from_options(
        cls, options: TMDIOptions, *, dt: float, device: NominalInerter | None = None, **_: object
    ) -> TMDISubstructure:
        """The ``tmdi`` kind: the S1 Table 1 structure under the stepped sine, carrying
        ``device``."""
        top = max(options.excitation.frequencies)
        if top >= 0.5 / dt:
            raise ParameterError(
                f"excitation frequency {top:g} Hz must lie below the Nyquist frequency "
                f"{0.5 / dt:g} Hz of the loop rate"
            )
        params, _inerter = s1_configuration(
            options.mass, options.flywheel, options.isolators, hdrb=options.hdrb
        )
        return cls(params, options.excitation.acceleration(), dt, device=device)

    @staticmethod
    def nominal_device(model: DeviceModel | None) -> NominalInerter | None:
        """The nominal inerter (prototype scale) for a ``[model]`` of kind ``inerter``.

        Raises
        ------
        ParameterError
            For a model kind the TMDI cannot carry (``imd``, ``linear``).
        """
        if model is None:
            return None
        if model.kind != "inerter":
            raise ParameterError(
                f"a tmdi substructure takes a model of kind 'inerter' (or 'none'); got "
                f"{model.kind!r}"
            )
        return NominalInerter(model.inertance, model.damping)

    @classmethod
    def monolithic(cls, options: TMDIOptions, specimen: Specimen, dt: float) -> TMDIStructure:
        """The same structure and excitation with the physical ``specimen`` (an S1 inerter)
        inside (S1 Eq.12): what a perfect RTHS of this substructure reproduces."""
        params, _ = s1_configuration(
            options.mass, options.flywheel, options.isolators, hdrb=options.hdrb
        )
        return TMDIStructure(params, specimen, dt, options.excitation.acceleration())

    @property
    def device_force(self) -> float:
        """Restoring force [N] of the nominal device now, ``b_n ü_T + c_n u̇_T`` (0 without one);
        ``ü_T`` is the equilibrium acceleration with the last correction."""
        if self.device is None:
            return 0.0
        kin = self.interface
        return self.device.inertance * kin.acceleration + self.device.damping * kin.velocity

    def outputs(self) -> dict[str, float]:
        """S1 Eq.7 quantities now, plus ``a_G``; ``F_B`` is the last interface force (with a
        nominal device: :attr:`device_force` plus the last correction)."""
        return super().outputs()
