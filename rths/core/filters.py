"""Causal per-sample filters for the loop's hot path.

``scipy.signal`` designs the filter (``butter(..., output="sos")``); this module only runs the
second-order sections one sample at a time (transposed direct form II, the recursion
``scipy.signal.sosfilt`` uses), because calling ``sosfilt`` per sample costs ~10 µs.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from rths.core.compiled import CompiledStep
from rths.core.errors import ParameterError, check_positive, check_positive_int

__all__ = ["LowPass"]


class LowPass:
    """Butterworth low-pass, one sample per call.

    Parameters
    ----------
    cutoff : float
        -3 dB frequency [Hz]; must lie below the Nyquist frequency ``0.5/dt``.
    dt : float
        Sample time [s].
    order : int
        Filter order (default 2).

    Notes
    -----
    ``filter(x)`` returns the same sequence as ``scipy.signal.sosfilt(self.sos, x)`` (tested).
    """

    def __init__(self, cutoff: float, dt: float, order: int = 2) -> None:
        cutoff = check_positive(cutoff, "filter cutoff [Hz]")
        dt = check_positive(dt, "time step dt")
        order = check_positive_int(order, "filter order")
        if cutoff >= 0.5 / dt:
            raise ParameterError(
                f"filter cutoff must lie below the Nyquist frequency {0.5 / dt:g} Hz; "
                f"got {cutoff!r}"
            )
        self.cutoff, self.dt, self.order = cutoff, dt, order
        self.sos: np.ndarray = signal.butter(order, cutoff, fs=1.0 / dt, output="sos")
        self._coef = [tuple(float(c) for c in row) for row in self.sos]
        self._z = [[0.0, 0.0] for _ in self._coef]

    def reset(self) -> None:
        """Zero the filter state."""
        for z in self._z:
            z[0] = z[1] = 0.0

    def compiled_step(self) -> CompiledStep:
        """This filter for the loop's fused kernel (family ``"low_pass"``: constants the
        sections ``(n, 6)``, state their ``(n, 2)`` delays)."""
        c = np.array(self._coef, dtype=float)
        z = np.array(self._z, dtype=float)

        def commit() -> None:
            for row, values in zip(self._z, z.tolist(), strict=True):
                row[:] = values

        return CompiledStep("low_pass", (c,), (z,), commit)

    def __call__(self, x: float) -> float:
        """Filter one sample."""
        for (b0, b1, b2, _a0, a1, a2), z in zip(self._coef, self._z, strict=True):
            y = b0 * x + z[0]
            z[0] = b1 * x - a1 * y + z[1]
            z[1] = b2 * x - a2 * y
            x = y
        return x

    def group_delay(self, frequency: float) -> float:
        """Group delay [s] at ``frequency`` [Hz] (for documenting the lag a filter adds)."""
        w, gd = signal.group_delay(signal.sos2tf(self.sos), w=[frequency], fs=1.0 / self.dt)
        return float(gd[0]) * self.dt
