"""The fully numerical "mock" run of a scenario (S0 Fig.34: RTHS vs. mock RTHS).

The substructure carries a numerical model of the device implicitly and no specimen is involved
(the force correction is zero), so the run is exactly what the simulation predicts.  Two models:

``"model"``       the scenario's ``[model]`` device (for the seed: the S0 Eq.12 IMD with internal
                  stiffness and fixed damping -- the "proposed model");
``"simplified"``  the same inertance and damping attached rigidly (S0 Eq.1, the "simplified model");
``"monolithic"``  (TMDI only) the S1 Eq.12 model with the ``[specimen]`` inerter inside -- what a
                  perfect RTHS reproduces (:class:`plants.tmdi.structure.TMDIStructure`).

All returned signals use the same scales as an RTHS log: the interface displacement and the device
force at specimen scale, structure responses at prototype scale.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from plants.cable.model import InterfaceDevice
from plants.excitation.stepped_sine import stepped_sine_acceleration
from rths.config import build
from rths.config.scenario import Scenario, TMDISpec
from rths.core.errors import ConfigError

__all__ = ["VARIANTS", "numerical_run"]

VARIANTS = ("model", "simplified", "monolithic")


def variants(scn: Scenario) -> tuple[str, ...]:
    """The mock variants that make sense for the scenario's substructure."""
    return ("model", "monolithic") if isinstance(scn.substructure, TMDISpec) else (
        "model", "simplified")  # fmt: skip


def _device(scn: Scenario, variant: str) -> object:
    if variant == "model" or isinstance(scn.substructure, TMDISpec):
        return build.nominal_device(scn)  # a TMDI's nominal inerter has no simplified form
    m, lam = scn.model, scn.scaling.impedance
    if m.kind == "none":
        return None
    return InterfaceDevice(inertance=lam * m.inertance, damping=lam * m.damping)


def numerical_run(
    scn: Scenario, variant: str = "model", steps: int | None = None
) -> dict[str, NDArray[np.float64]]:
    """Run the substructure with a numerical device and no specimen.

    Parameters
    ----------
    scn
        The scenario.
    variant
        ``"model"`` or ``"simplified"`` (module docstring).
    steps
        Number of steps (default: the scenario's).

    Returns
    -------
    dict
        Arrays of shape ``(steps,)``: ``t`` [s] (end of each step), ``target`` (interface
        displacement, specimen scale) [m], ``force`` (device restoring force, specimen scale) [N]
        and the substructure's ``outputs()`` (e.g. ``midspan_displacement`` [m], prototype).
    """
    if variant not in variants(scn):
        raise ConfigError(f"mock variant must be one of {variants(scn)}; got {variant!r}")
    n = scn.run.steps if steps is None else steps
    if variant == "monolithic":
        return _monolithic(scn, n)
    sub = build.substructure(scn, device=_device(scn, variant))
    lam_u, lam_f = scn.scaling.displacement, scn.scaling.force
    out: dict[str, NDArray[np.float64]] = {
        "t": scn.run.dt * np.arange(1, n + 1),
        "target": np.empty(n),
        "force": np.empty(n),
    }
    for k in range(n):
        kin = sub.step(0.0)
        out["target"][k] = lam_u * kin.displacement
        out["force"][k] = sub.device_force / lam_f
        for name, value in sub.outputs().items():
            out.setdefault(name, np.empty(n))[k] = value
    return out


def _monolithic(scn: Scenario, n: int) -> dict[str, NDArray[np.float64]]:
    """The TMDI with the physical inerter model inside (S1 Eq.12), same excitation and step."""
    from plants.tmdi.structure import TMDIStructure, s1_configuration
    s = scn.substructure
    assert isinstance(s, TMDISpec)
    dt = scn.run.dt
    params, _ = s1_configuration(s.mass, s.flywheel, s.isolators, hdrb=s.hdrb)
    ground = stepped_sine_acceleration(s.frequencies, s.pga, s.cycles)
    response = TMDIStructure(params, build.specimen(scn), dt).run(
        np.array([ground(k * dt) for k in range(n + 1)])
    )
    out = {"t": dt * np.arange(1, n + 1)}
    out["target"] = scn.scaling.displacement * np.asarray(response.u_T)[1:]
    out["force"] = np.asarray(response.F_B)[1:] / scn.scaling.force
    out["u_I"] = np.asarray(response.u_I)[1:]
    return out
