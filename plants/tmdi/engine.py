"""The shared engine of the S1 substructures: the S1 Eq.12 structure stepped by the compiled
kernel (:mod:`plants.tmdi.integration.kernel`) under a base excitation, with one interface DOF."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from plants.base import Kinematics, Substructure
from plants.tmdi.integration import kernel as kern
from plants.tmdi.integration import laws, layout
from plants.tmdi.integration.kernel import IntegrationError
from plants.tmdi.linear import EQ7_QUANTITIES
from plants.tmdi.parameters import TMDIParameters
from rths.core.errors import ParameterError, check_positive

__all__ = ["S1Structure"]


class S1Structure(Substructure):
    """The S1 Eq.12 structure stepped by the compiled S1 kernel under a base excitation (the
    shared engine of :class:`TMDISubstructure` and :class:`plants.tmdi.structure.TMDIStructure`).

    The interface DOF is ``u_T`` (relative to the ground) when there is a secondary mass, else
    ``u_I``; the force passed to :meth:`step` acts on it, held over the step (it enters both ends
    of the trapezoidal rule).  :meth:`outputs` gives the S1 Eq.7 quantities and ``a_G``.

    Parameters
    ----------
    parameters
        The structure.
    packed
        The kernel's parameter vector (:func:`plants.tmdi.integration.layout.pack_parameters`).
    ground_acceleration
        ``ü_G`` [m/s²]: a callable of time [s], or samples at spacing ``excitation_dt``
        (linearly interpolated, zero after the last sample).
    dt
        Loop step [s].
    excitation_dt
        Spacing [s] of sampled ``ground_acceleration``; defaults to ``dt``.
    substeps
        Kernel sub-steps per step.
    initial_mode
        Contact mode of the inerter's gap at rest
        (:data:`plants.tmdi.integration.layout.FORWARD` when it has no play).
    """

    def __init__(
        self,
        parameters: TMDIParameters,
        packed: NDArray[np.float64],
        ground_acceleration: Callable[[float], float] | ArrayLike,
        dt: float,
        excitation_dt: float | None = None,
        substeps: int = 1,
        initial_mode: int = layout.OPEN,
    ) -> None:
        super().__init__(dt)
        self.parameters: Final[TMDIParameters] = parameters
        spacing = self.dt if excitation_dt is None else excitation_dt
        self._ground = _ground_motion(ground_acceleration, spacing)
        self._p = packed
        self.substeps: Final[int] = substeps
        self._initial_mode = initial_mode
        self._state = np.zeros(layout.N_STATE)
        self._input = np.zeros(layout.N_INPUT)
        self._out = np.zeros(layout.N_OUTPUT)
        self._dof = layout.S_U_T if parameters.has_tmd else layout.S_U_I
        self.reset()

    def _reset_impl(self) -> None:
        """Rest at ``t = 0`` with no interface force."""
        self._state[:] = 0.0
        self._state[layout.S_MODE] = self._initial_mode
        self._force = 0.0
        self._ag_now = self._ground(0.0)

    @property
    def interface(self) -> Kinematics:
        """Interface displacement, velocity, acceleration (relative to the ground) now."""
        return self._kinematics(self._state, self._ag_now, self._force)

    def _kinematics(self, s: NDArray[np.float64], ag: float, force: float) -> Kinematics:
        a_i, a_t, _ = laws.accelerations(s, ag, force, self._p)
        a = a_t if self._dof == layout.S_U_T else a_i
        return Kinematics(float(s[self._dof]), float(s[self._dof + 1]), float(a))

    def _advance(self, s: NDArray[np.float64], force: float) -> float:
        ag1 = self._ground((self.steps + 1) * self.dt)
        inp = self._input
        inp[layout.I_AG0] = self._ag_now
        inp[layout.I_AG1] = ag1
        inp[layout.I_FEXT] = force
        if kern.step(s, self.dt, self.substeps, inp, self._p) or not np.all(np.isfinite(s)):
            raise IntegrationError(
                f"{type(self).__name__} step failed at t={self.time!r} s with force {force!r} N"
            )
        return ag1

    def _step_impl(self, restoring_force: float) -> Kinematics:
        ag1 = self._advance(self._state, restoring_force)
        self._ag_now = ag1
        self._force = restoring_force
        return self._kinematics(self._state, ag1, restoring_force)

    def predict(self, restoring_force: float) -> Kinematics:
        """What :meth:`step` would return for ``restoring_force`` [N]; no state changes."""
        trial = self._state.copy()
        ag1 = self._advance(trial, float(restoring_force))
        return self._kinematics(trial, ag1, float(restoring_force))

    def outputs(self) -> dict[str, float]:
        """S1 Eq.7 quantities now, plus ``a_G``; ``F_B`` includes the last interface force."""
        kern.outputs(self._state, self._ag_now, self._force, self._p, self._out)
        result = {name: float(self._out[layout.OUTPUT_FIELDS[name]]) for name in EQ7_QUANTITIES}
        result["a_G"] = float(self._ag_now)
        return result


def _ground_motion(
    source: Callable[[float], float] | ArrayLike, spacing: float
) -> Callable[[float], float]:
    """``ü_G(t)`` from a callable or from samples (linear interpolation, 0 after the end)."""
    if callable(source):

        def checked(t: float) -> float:
            value = float(source(t))
            if not math.isfinite(value):
                raise ParameterError(
                    f"ground acceleration at t={t!r} s must be finite; got {value!r}"
                )
            return value

        return checked
    samples = np.asarray(source, dtype=float)
    if samples.ndim != 1 or samples.size == 0:
        raise ParameterError(
            f"ground acceleration samples must be a non-empty 1-D array; got shape {samples.shape}"
        )
    if not np.all(np.isfinite(samples)):
        raise ParameterError("ground acceleration samples must be finite; got NaN or inf")
    spacing = check_positive(spacing, "excitation_dt")
    values = samples.tolist()
    last = len(values) - 1

    def sampled(t: float) -> float:
        position = max(t, 0.0) / spacing
        i = int(position)
        if i >= last:
            return values[last] if position <= last + 1e-9 else 0.0
        frac = position - i
        return values[i] + frac * (values[i + 1] - values[i])

    return sampled
