"""The physical models of S1 Table 1 (secondary mass x flywheel x identification x HDRB damping
model) and the options of the ``tmdi`` substructure kind."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final, Literal

from plants.base import Specimen
from plants.excitation.stepped_sine import SteppedSineOptions
from plants.tmdi.hdrb import (
    S1_PRIMARY,
    S1_PRIMARY_AMPLITUDE,
    S1_PRIMARY_IDEAL_INERTER,
    S1_PRIMARY_IDEAL_INERTER_AMPLITUDE,
    S1_PRIMARY_UNCONTROLLED,
    S1_SECONDARY,
    S1_SECONDARY_AMPLITUDE,
    S1_SECONDARY_IDEAL_INERTER,
    S1_SECONDARY_IDEAL_INERTER_AMPLITUDE,
)
from plants.tmdi.inerter import (
    IdealInerter,
    RackPinionInerter,
    ideal_inerter_preset,
    rack_pinion_preset,
)
from plants.tmdi.parameters import PRIMARY_MASS, SECONDARY_MASSES, TMDIParameters
from rths.core.errors import ParameterError, format_choices

__all__ = ["HDRB_MODELS", "TMDIOptions", "s1_configuration"]

#: HDRB damping models of :func:`s1_configuration`.
HDRB_MODELS: Final[tuple[str, ...]] = ("viscous", "amplitude")


def s1_configuration(
    mass: str | None,
    flywheel: str | None = None,
    inerter: str = "rack_pinion",
    hdrb: str = "viscous",
) -> tuple[TMDIParameters, Specimen | None]:
    """A physical model of S1 Table 1 as (structure, inerter specimen).

    Parameters
    ----------
    mass
        Secondary mass ``"SM"`` (6 kg), ``"IM"`` (10 kg), ``"LM"`` (20 kg), or None for the
        uncontrolled PS (``flywheel`` must then be None).
    flywheel
        ``"NF"``, ``"IF"``, ``"LF"`` (S1 Table 1), or None for a TMD without inerter.
    inerter
        ``"rack_pinion"``: the S1 Eq.9-11 device (:func:`plants.tmdi.inerter.rack_pinion_preset`)
        with the isolators identified with it (c_I = 538.13, c_T = 409.15 N s/m);
        ``"ideal"``: the ideal-inerter variant of S1 §4.2 (b = 48.7 kg for IF, scaled for NF/LF;
        c_I = 743.3, c_T = 324.7 N s/m).  Ignored for the uncontrolled PS.
    hdrb
        ``"viscous"``: the S1 §4.2 isolators as identified (constant dashpots); for the
        uncontrolled PS the TMDI's primary bearing (S1 identifies no PS-alone model).
        ``"amplitude"``: the dashpots follow the amplitude law of :mod:`plants.tmdi.hdrb` -- with a
        TMDI the S1 §4.2 bearings anchored where S1 identified them (``S1_*_AMPLITUDE``
        presets), for the uncontrolled PS the bearing calibrated on S1's uncontrolled tests
        (:data:`~plants.tmdi.hdrb.S1_PRIMARY_UNCONTROLLED`).
    """
    if inerter not in ("rack_pinion", "ideal"):
        raise ParameterError(f"inerter must be 'rack_pinion' or 'ideal'; got {inerter!r}")
    if hdrb not in HDRB_MODELS:
        raise ParameterError(f"hdrb must be one of {format_choices(HDRB_MODELS)}; got {hdrb!r}")
    ideal = inerter == "ideal"
    amplitude = hdrb == "amplitude"
    if mass is None:
        if flywheel is not None:
            raise ParameterError(f"the uncontrolled PS has no inerter; got flywheel {flywheel!r}")
        return TMDIParameters(
            PRIMARY_MASS, S1_PRIMARY_UNCONTROLLED if amplitude else S1_PRIMARY
        ), None
    if mass not in SECONDARY_MASSES:
        raise ParameterError(
            f"secondary mass must be one of {format_choices(list(SECONDARY_MASSES))} or None; "
            f"got {mass!r}"
        )
    if ideal and amplitude:
        primary = S1_PRIMARY_IDEAL_INERTER_AMPLITUDE
        secondary = S1_SECONDARY_IDEAL_INERTER_AMPLITUDE
    elif ideal:
        primary, secondary = S1_PRIMARY_IDEAL_INERTER, S1_SECONDARY_IDEAL_INERTER
    elif amplitude:
        primary, secondary = S1_PRIMARY_AMPLITUDE, S1_SECONDARY_AMPLITUDE
    else:
        primary, secondary = S1_PRIMARY, S1_SECONDARY
    structure = TMDIParameters(PRIMARY_MASS, primary, SECONDARY_MASSES[mass], secondary)
    if flywheel is None:
        return structure, None
    if ideal:
        return structure, IdealInerter(ideal_inerter_preset(flywheel))
    return structure, RackPinionInerter(rack_pinion_preset(flywheel))


@dataclass(frozen=True)
class TMDIOptions:
    """The S1 primary structure + TMD (numerical) with the grounded inerter physical, under a
    stepped-sine base acceleration (S1 §2.3).

    Parameters
    ----------
    mass
        S1 Table 1 secondary mass: ``"SM"`` (6 kg), ``"IM"`` (10 kg), ``"LM"`` (20 kg).
    flywheel
        S1 Table 1 flywheel of the nominal inerter: ``"NF"``, ``"IF"``, ``"LF"``.
    isolators
        Which S1 §4.2 identification of the HDRBs: ``"rack_pinion"`` or ``"ideal"``.
    hdrb
        ``"viscous"`` (S1 §4.2 dashpots) or ``"amplitude"`` (amplitude-dependent damping).
    excitation
        The stepped sine (``[substructure.excitation]``).
    """

    mass: Literal["SM", "IM", "LM"]
    flywheel: Literal["NF", "IF", "LF"]
    excitation: SteppedSineOptions
    isolators: Literal["rack_pinion", "ideal"] = "rack_pinion"
    hdrb: Literal["viscous", "amplitude"] = "viscous"

    @property
    def excitation_period(self) -> float:
        """Period [s] of the last step of the stepped sine."""
        return 1.0 / self.excitation.frequencies[-1]
