"""The fully numerical "mock" run of a scenario (S0 Fig.34: RTHS vs. mock RTHS).

The substructure carries a numerical model of the device implicitly and no specimen is involved
(the force correction is zero), so the run is exactly what the simulation predicts.  Two models:

``"model"``       the scenario's ``[model]`` device (for the seed: the S0 Eq.12 IMD with internal
                  stiffness and fixed damping -- the "proposed model");
``"simplified"``  the same inertance and damping attached rigidly (S0 Eq.1, the "simplified model").

All returned signals use the same scales as an RTHS log: the interface displacement and the device
force at specimen scale, structure responses at prototype scale.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from plants.cable import InterfaceDevice
from rths import build
from rths.errors import ConfigError
from rths.scenario import Scenario

__all__ = ["VARIANTS", "numerical_run"]

VARIANTS = ("model", "simplified")


def _device(scn: Scenario, variant: str) -> InterfaceDevice | None:
    if variant == "model":
        return build.nominal_device(scn)
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
    if variant not in VARIANTS:
        raise ConfigError(f"mock variant must be one of {VARIANTS}; got {variant!r}")
    n = scn.run.steps if steps is None else steps
    sub = build.cable(scn, device=_device(scn, variant))
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
