"""Candidate effects: grey-box extensions of the nominal model with few parameters.

Every model, baseline or effect, predicts its channel's observation as

.. math:: \\hat y(\\theta, \\beta) = X(\\theta)\\,\\beta + f(\\theta)

with few nonlinear parameters ``theta`` (searched by :mod:`rths.diagnose.identify`) and linear
ones ``beta`` (solved by least squares for each ``theta``: variable projection).  ``beta`` always
holds the nominal model's own parameters -- the baseline re-calibration of design.md section 7
(actuator gain; inertance, damping, stiffness) -- plus a sensor offset, so each effect is fitted
*jointly* with the re-calibrated baseline and never gets credit for a mis-calibration.

===================  =========  ===================================  ============================
model                subsystem  effect parameters (theta)            source
===================  =========  ===================================  ============================
baseline (actuator)  actuator   --                                   nominal TF + delay, gain
actuator_delay       actuator   extra delay tau [s]                  pure delay on the command
rate_limit           actuator   velocity_limit [m/s] (+ gain)        valve flow limit (Simulink)
baseline (specimen)  specimen   --                                   S0 Eq.1 + spring, c(A)
coulomb_friction     specimen   friction F_r [N] (linear)            S0 Eq.1 friction term
internal_stiffness   specimen   f_e = sqrt(k_s/m)/2pi, kappa         S0 Eq.12 (series spring)
backlash             specimen   gap, contact f_c, kappa              S0 Table 6, S1 Eq.11
===================  =========  ===================================  ============================

The specimen baseline re-calibrates the damping as ``c + c_A A_0/(A + A_0)`` with ``A`` the
load amplitude tracked on the drive (the form of S0 Eq.17-18, which calibrates ``c_d`` per
amplitude; ``A_0`` = 0.153 mm, Type II); the series models (internal stiffness, backlash) carry
that damping law on their flywheel, scaled by ``kappa``.  Models live in
:mod:`rths.diagnose._actuator_effects` and :mod:`rths.diagnose._specimen_effects`.

Adding an effect: subclass :class:`Model` (``name``, ``subsystem``, ``n_effect``,
``columns``, ``starts``, ``bounds``, ``describe``) and add it to :data:`EFFECTS`.  The name
is the verdict users see.
"""

from __future__ import annotations

from rths.diagnose._actuator_effects import ActuatorBaseline, ActuatorDelay, RateLimit
from rths.diagnose._model import Columns, Model
from rths.diagnose._specimen_effects import (
    Backlash,
    CoulombFriction,
    InternalStiffness,
    SpecimenBaseline,
    flywheel_displacement,
)

__all__ = [
    "EFFECTS",
    "ActuatorBaseline",
    "ActuatorDelay",
    "Backlash",
    "Columns",
    "CoulombFriction",
    "InternalStiffness",
    "Model",
    "RateLimit",
    "SpecimenBaseline",
    "baseline_for",
    "flywheel_displacement",
]


#: The candidate effects by verdict name ("room to add more": see the module docstring).
EFFECTS: dict[str, type[Model]] = {
    m.name: m for m in (InternalStiffness, Backlash, CoulombFriction, ActuatorDelay, RateLimit)
}


def baseline_for(subsystem: str) -> Model:
    """The re-calibrated nominal model of a subsystem's channel."""
    return ActuatorBaseline() if subsystem == "actuator" else SpecimenBaseline()
