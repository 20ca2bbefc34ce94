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

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from plants.base import Substructure
from rths.config import build
from rths.config.kinds import registry
from rths.config.scenario import Scenario
from rths.core.errors import ConfigError

__all__ = ["VARIANTS", "numerical_run"]

VARIANTS = ("model", "simplified", "monolithic")


def variants(scn: Scenario) -> tuple[str, ...]:
    """The mock variants that make sense for the scenario: ``model`` always; ``simplified`` when
    the ``[model]`` has a rigid form distinct from a grounded inerter; ``monolithic`` when the
    substructure kind can carry the physical specimen inside (its ``monolithic`` hook)."""
    target = registry("substructure").get(scn.substructure.kind).target
    out = ["model"]
    if scn.model is None or scn.model.kind != "inerter":
        out.append("simplified")
    if hasattr(target, "monolithic"):
        out.append("monolithic")
    return tuple(out)


def _substructure(scn: Scenario, variant: str) -> Substructure:
    if variant == "monolithic":
        target = registry("substructure").get(scn.substructure.kind).target
        built: Substructure = target.monolithic(
            scn.substructure.options, build.specimen(scn), scn.run.dt
        )
        return built
    if variant == "simplified" and scn.model is not None:
        scn = replace(scn, model=scn.model.rigid())
    return build.substructure(scn)


def numerical_run(
    scn: Scenario, variant: str = "model", steps: int | None = None
) -> dict[str, NDArray[np.float64]]:
    """Run the substructure with a numerical device and no specimen.

    Parameters
    ----------
    scn
        The scenario.
    variant
        One of :func:`variants` (module docstring).
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
    sub = _substructure(scn, variant)
    lam_u, lam_f = scn.scaling.displacement, scn.scaling.force
    out: dict[str, NDArray[np.float64]] = {
        "t": scn.run.dt * np.arange(1, n + 1, dtype=np.float64),
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
