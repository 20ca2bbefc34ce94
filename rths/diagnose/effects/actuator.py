"""Actuator-channel models: the re-calibrated nominal transfer system, extra delay, rate limit.

.. math::

    y = \\mathrm{RL}_{v_{max}}\\big(g\\, e^{-s(\\tau_0 + \\tau)}\\, G_{\\lambda}(s)\\, u\\big)
        - \\kappa\\, e^{-s\\tau_0} G_{\\lambda}(s)\\, (m_0 \\ddot y + k_0 y)
        + \\sum_j h_j\\, \\Lambda_j(s)\\, \\Delta F + b_r

Baseline (NOMINAL.toml's own parameters, re-calibrated): the gain ``g``; the frequency of every
pole and zero scaled by one factor ``lambda_w`` and the damping ratio of every complex pole by
one factor ``lambda_z`` (``G_lambda``: the nominal TF with its DC gain kept); an alignment
``tau`` of at most one sample either way; the record offsets ``b_r``. Control-structure
interaction (Dyke et al. 1995): the specimen's force pushes the piston back through the loop's
compliance, ``y = G (u - F/K)``. A nominal TF may be that of the bare actuator, ``G``, or the
one identified *with the nominal specimen installed*, ``G/(1 + G Z_0/K)`` (``Z_0``: the nominal
specimen's impedance). The nominal specimen's reactive force ``m_0 y'' + k_0 y`` on the measured
displacement (:func:`rths.diagnose.channels.build.reactive_force`) through ``G_lambda`` is a
column: its coefficient ``kappa = 1/K`` (reported ``loop_compliance`` [m/N]) is the bare TF's,
zero for an installed one. Without it, a bare nominal's interaction -- its inertial force adds
``b_0 m/K`` to the ``s^2`` coefficient of the loop's denominator (``b_0``: the numerator; a 29
Hz real pole and an 82 Hz pair with 240 kg on 54 MN/m: +26 %) -- is taken for a slower, more
damped loop and a longer delay. The dissipative part's interaction, ``c s G/K``, is a lag
``c/K`` that a delay makes as well (tens of microseconds on a stiff loop): a dissipative column
would trade with the delay, the reactive one, even in frequency, cannot. The force the nominal
specimen does not explain, ``dF`` (:func:`rths.diagnose.channels.build.force_deviation`), moves
the piston through a linear path expanded on :data:`CSI_TERMS` Laguerre functions ``Lambda_j``
at the nominal TF's bandwidth (strictly proper: the path is as slow as the loop; a servo-valve's
pressure feedback shapes it differently from ``G/K``). Neither carries an actuator effect (an
effect acts on the command); they keep a specimen effect seen through the actuator from posing
as one.

The servo-valve's orifice law ``Q = K_q x_v sqrt(1 - sign(x_v) p_L/P_s)`` (Merritt, Hydraulic
Control Systems, Eq. 5-21), which a linear nominal TF (a linearisation at ``p_L = 0``) lacks,
costs the piston the speed ``|v| F/(2 P_s A)`` to first order: the signal ``|v| F``
(:func:`rths.diagnose.channels.build.load_flow`) through the loop's sensitivity over ``s``,
``S(s)/s = (1 - G(s)/G(0))/s``, and through :data:`FLOW_TERMS` ``- 1`` Laguerre functions
(the delta-P feedback reshapes that path) gives linear columns of the baseline (reported
``load_flow``: the first one's coefficient, ``-1/(2 P_s A)`` [1/N] for the ideal loop).

Effects: ``actuator_delay`` frees ``tau`` beyond one sample of lag (reported ``delay = tau``
[s] beyond the nominal; an advance is the nominal's model form, never a delay);
``rate_limit`` caps the speed of the motion at ``v_max``, the gain moving inside the limit,
in one of two structures (the one that fits the identification data better is taken): a
limiter on the output (``limiter="output"``, Simulink Rate Limiter semantics,
:func:`plants.lines.rate_limited`: a piston held back catches up within a sample once the
limit lets go) or a limit *inside* the servo loop (``limiter="loop"``,
:func:`rths.diagnose.effects.kernels.loop_rate_limited`: the valve's flow saturates and the
piston recovers through the loop's last stage, the re-calibrated TF's slowest real pole --
a servo-hydraulic loop's first-order flow pole; the output limiter when the TF has none).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from plants.lines import rate_limited
from rths.core.errors import ParameterError
from rths.diagnose.channels.channel import Channel, Segment
from rths.diagnose.channels.signals import discrete_tf, sampled_tf, shifted
from rths.diagnose.effects.kernels import loop_rate_limited
from rths.diagnose.effects.model import Columns, Model, Param, Theta

#: Cache-key prefixes of :meth:`ActuatorModel._through` (its loop columns: "reactive:block:").
_THROUGH: tuple[str, ...] = ("command:", "reactive:")

__all__ = [
    "CALIBRATION_TOLERANCE",
    "CSI_TERMS",
    "FLOW_TERMS",
    "IDLE_SNR",
    "LEAST_EXCESS",
    "LIMIT_EXCESS",
    "MAX_DELAY",
    "SECANT_WINDOW",
    "ActuatorModel",
    "scaled_tf",
]

#: Laguerre terms of the control-structure interaction path (plus a direct term).
CSI_TERMS: int = 4
#: Columns of the orifice-law term: ``S(s)/s`` and ``FLOW_TERMS - 1`` Laguerre functions.
FLOW_TERMS: int = 3
#: Longest extra delay searched [s].
MAX_DELAY: float = 0.1
#: Window [s] of the secant slope the rate-limit candidate is checked against.
SECANT_WINDOW: float = 0.01
#: Least ratio of a linear secant speed to its noise for the gain it calibrates (a 5 % error
#: per sample at most, before the median).
IDLE_SNR: float = 20.0
#: Excess of the linear secant speed over a rate limit where the limit is checked: 20 % above
#: it, or half the largest excess when that is below 40 %, but never less than
#: :data:`LEAST_EXCESS` (within the gain's calibration a limit shows nothing of its own).
LIMIT_EXCESS: float = 0.2
LEAST_EXCESS: float = 0.05
#: Calibration tolerance of the nominal transfer function's pole frequencies and damping
#: (design.md section 7: nominal mis-calibration up to +/-10 %).  The baseline re-calibrates
#: the poles within it; beyond it the change is structure the nominal lacks -- a delay's lag
#: would otherwise hide in slower poles (a 5th-order actuator 12 % slower mimics a 4 ms delay
#: to the noise floor under band-limited excitation).
CALIBRATION_TOLERANCE: float = 0.1
_FREQ_RANGE = (1.0 - CALIBRATION_TOLERANCE, 1.0 + CALIBRATION_TOLERANCE)
_DAMP_RANGE = (1.0 - CALIBRATION_TOLERANCE, 1.0 + CALIBRATION_TOLERANCE)


def _move(roots: NDArray, freq: float, damp: float) -> list[complex]:
    out: list[complex] = []
    for q in roots:
        w = abs(q)
        if w == 0.0:
            out.append(0.0)
        elif abs(q.imag) <= 1e-9 * w:
            out.append(q.real * freq)
        elif q.imag > 0.0:
            zeta, w2 = -q.real / w * damp, w * freq
            if zeta < 1.0:
                im = w2 * math.sqrt(1.0 - zeta * zeta)
                out += [complex(-zeta * w2, im), complex(-zeta * w2, -im)]
            else:
                root = w2 * math.sqrt(zeta * zeta - 1.0)
                out += [complex(-zeta * w2 + root, 0.0), complex(-zeta * w2 - root, 0.0)]
    return out


def scaled_tf(
    num: tuple[float, ...], den: tuple[float, ...], freq: float, damp: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``num/den`` with every pole and zero frequency times ``freq`` and every complex pole's
    damping ratio times ``damp``; the DC gain (or, with a pole at 0, the high-frequency
    asymptote's scaling) is kept.

    Parameters
    ----------
    num, den
        Continuous-time transfer function, descending powers of ``s``.
    freq
        Factor [-] on every pole and zero frequency.
    damp
        Factor [-] on every complex pole's damping ratio.
    """
    if freq == 1.0 and damp == 1.0:
        return np.asarray(num, float), np.asarray(den, float)
    z = np.roots(num) if len(num) > 1 else np.array([])
    p = np.roots(den) if len(den) > 1 else np.array([])
    new_num = np.real(np.poly(_move(z, freq, 1.0))) if z.size else np.array([1.0])
    new_den = np.real(np.poly(_move(p, freq, damp))) if p.size else np.array([1.0])
    if den[-1] != 0.0 and num[-1] != 0.0:
        k = (num[-1] / den[-1]) / (new_num[-1] / new_den[-1])
    else:
        k = num[0] / den[0] * freq ** (p.size - z.size)
    return k * new_num, new_den


def _bandwidth(num: tuple[float, ...], den: tuple[float, ...]) -> float | None:
    """-3 dB frequency [rad/s] of ``num/den`` relative to its DC gain (None: static TF)."""
    if len(den) <= 1:
        return None
    w = np.geomspace(1e-2, 1e6, 2000)
    g = np.abs(np.polyval(num, 1j * w) / np.polyval(den, 1j * w))
    below = np.flatnonzero(g < g[0] / math.sqrt(2.0))
    return float(w[below[0]]) if below.size else None


class ActuatorModel(Model):
    """The transfer system's model with any of ``actuator_delay``, ``rate_limit`` (module
    docstring).

    Parameters
    ----------
    effects
        The actuator effects it holds (none: the re-calibrated baseline).
    limiter
        Structure of a ``rate_limit``: ``"output"`` (a rate limiter on the motion) or
        ``"loop"`` (a flow limit inside the servo loop).
    nominal_poles
        Hold every pole and zero at NOMINAL.toml's values (no common frequency or damping
        factor; the gain, offsets and loop columns stay calibrated): a delay judged by the
        lag it needs with the nominal's own dynamics
        (:mod:`rths.diagnose.search.lag`).
    """

    subsystem = "actuator"
    max_grid = 2000  # one replay per pole pair, then cheap shifts

    def __init__(
        self, effects: tuple[str, ...] = (), limiter: str = "output", nominal_poles: bool = False
    ) -> None:
        super().__init__(effects)
        self.nominal_poles = nominal_poles
        self.delay = "actuator_delay" in effects
        self.limit = "rate_limit" in effects
        if limiter not in ("output", "loop"):
            raise ParameterError(f"limiter must be 'output' or 'loop'; got {limiter!r}")
        self.limiter = limiter
        if self.limit:
            self.structure = f"limit {'inside the loop' if limiter == 'loop' else 'on the output'}"
        if nominal_poles:
            self.structure = ", ".join([s for s in (self.structure,) if s] + ["nominal poles"])
        self.polish = self.limit
        self._base: dict[str, float] = {}

    # -- structure -----------------------------------------------------------------------
    @staticmethod
    def _dynamic(channel: Channel) -> bool:
        return len(channel.nominal.actuator.den) > 1

    @staticmethod
    def _complex(channel: Channel) -> bool:
        den = channel.nominal.actuator.den
        return len(den) > 2 and bool(np.any(np.abs(np.roots(den).imag) > 0.0))

    @staticmethod
    def _csi(channel: Channel) -> bool:
        return _bandwidth(channel.nominal.actuator.num, channel.nominal.actuator.den) is not None

    def prepare(self, channel: Channel, base: dict[str, float]) -> None:
        self._base = dict(base)

    def space(self, channel: Channel) -> list[Param]:
        out = []
        grid = 3 if self.delay else 0  # a delay trades against the poles' lag: search both
        if self._dynamic(channel) and not self.nominal_poles:
            base_f = self._base.get("frequency_scale", 1.0)
            out.append(Param("frequency_scale", *_FREQ_RANGE, grid=grid, start=base_f))
            if self._complex(channel):
                base_z = self._base.get("damping_scale", 1.0)
                out.append(Param("damping_scale", *_DAMP_RANGE, grid=grid, start=base_z))
        start = self._base.get("alignment", 0.0) / channel.dt
        if self.delay:
            lo = -channel.nominal.actuator.delay / channel.dt - 1.0
            hi = MAX_DELAY / channel.dt
            out.append(Param("shift", lo, hi, log=False, grid=int(min(hi - lo, 200)) + 1))
        else:
            out.append(
                Param("shift", -1.0, 1.0, log=False, grid=5 if self.limit else 0, start=start)
            )
        if self.limit:
            peak = self._peak_velocity(channel)
            gain = float(np.clip(self._base.get("gain", 1.0), 0.5, 1.5))
            out.append(Param("gain", 0.5, 1.5, log=False, start=gain))
            out.append(Param("velocity_limit", 0.02 * peak, 2.0 * peak, grid=31, start=peak))
        return out

    def starts(self, channel: Channel) -> list[Theta]:
        """The nominal TF (unit scales, no shift) besides the re-calibrated baseline."""
        return [{"frequency_scale": 1.0, "damping_scale": 1.0, "shift": 0.0, "gain": 1.0}]

    # -- simulation ----------------------------------------------------------------------
    def _transfer_key(self, channel: Channel, theta: Theta) -> str:
        """A cache key of the re-calibrated transfer function ``theta`` selects."""
        return f"lin:{float(theta.get('frequency_scale', 1.0))!r}:" + repr(
            float(theta.get("damping_scale", 1.0))
        )

    def _transfer(
        self, channel: Channel, theta: Theta
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The re-calibrated transfer function (continuous, descending powers of ``s``)."""
        a = channel.nominal.actuator
        freq = float(theta.get("frequency_scale", 1.0))
        damp = float(theta.get("damping_scale", 1.0))
        return scaled_tf(a.num, a.den, freq, damp)

    def _through(self, channel: Channel, seg: Segment, theta: Theta, drive: str) -> NDArray:
        """The segment's signal ``drive`` through the re-calibrated transfer function (no
        delay), cached per calibration."""
        key = f"{drive}:{self._transfer_key(channel, theta)}"
        if key not in seg.cache:
            num, den = self._transfer(channel, theta)
            hold = discrete_tf if drive == "command" else sampled_tf
            b, aa = hold(tuple(num), tuple(den), seg.dt)
            seg.cache[key] = signal.lfilter(b, aa, seg.signals[drive])
            if len(seg.cache) > 64:  # keep the cache bounded during a search
                for k in [k for k in seg.cache if k.startswith(_THROUGH)][:32]:
                    del seg.cache[k]
        return seg.cache[key]

    def _linear(self, channel: Channel, seg: Segment, theta: Theta) -> NDArray:
        total = channel.nominal.actuator.delay / seg.dt + float(theta["shift"])
        return shifted(self._through(channel, seg, theta, "command"), total)

    def _compliant(self, channel: Channel) -> bool:
        """Whether the model holds the loop's compliance ``kappa`` (a dynamic nominal TF and
        a reactive-force signal)."""
        return "reactive" in channel.segments[0].signals and self._csi(channel)

    def _compliance_column(self, channel: Channel, seg: Segment, theta: Theta) -> NDArray:
        """Minus the nominal specimen's reactive force through the re-calibrated transfer
        function, ``(n, 1)`` (``(n, 0)`` without :meth:`_compliant`), for a nominal TF without
        the specimen: ``y = G (u - F/K)`` (module docstring; its coefficient is ``kappa``)."""
        if not self._compliant(channel):
            return np.empty((seg.observed.size, 0))
        f = self._through(channel, seg, theta, "reactive")
        return -shifted(f, channel.nominal.actuator.delay / seg.dt)[:, None]

    def _compliance_index(self) -> int:
        """Position of ``kappa`` in ``beta`` (after the gain unless the gain is nonlinear)."""
        return 0 if self.limit else 1

    def nonnegative(self, channel: Channel) -> NDArray[np.bool_]:
        """The loop's compliance ``kappa`` cannot be negative: a force pulling the piston
        along would be a source in the loop."""
        out = super().nonnegative(channel)
        if self._compliant(channel):
            out[self._compliance_index()] = True
        return out

    def _csi_columns(self, channel: Channel, seg: Segment) -> list[NDArray]:
        if "csi" not in seg.cache:
            a = channel.nominal.actuator
            w = _bandwidth(a.num, a.den)
            cols = []
            if w is not None:
                df = seg.signals["dforce"]
                b0, a0 = discrete_tf((math.sqrt(2 * w),), (1.0, w), seg.dt)
                b1, a1 = discrete_tf((-1.0, w), (1.0, w), seg.dt)
                g = signal.lfilter(b0, a0, df)
                for _ in range(CSI_TERMS):
                    cols.append(g)
                    g = signal.lfilter(b1, a1, g)
            seg.cache["csi"] = np.column_stack(cols) if cols else np.empty((seg.observed.size, 0))
        return [seg.cache["csi"]]

    def _flow_column(self, channel: Channel, seg: Segment) -> NDArray:
        """The orifice law's displacement error: ``|v| F`` through ``S(s)/s`` (module
        docstring), shape ``(n, 1)``; ``(n, 0)`` for a static nominal TF."""
        if "flow" not in seg.cache:
            a = channel.nominal.actuator
            out = np.empty((seg.observed.size, 0))
            if len(a.den) > 1 and a.den[-1] != 0.0 and a.num[-1] != 0.0:
                t0 = a.num[-1] / a.den[-1]
                num = np.asarray(a.num, float) / t0
                den = np.asarray(a.den, float)
                sens = den - np.concatenate([np.zeros(den.size - num.size), num])
                b, aa = discrete_tf(tuple(sens[:-1]), tuple(den), seg.dt)
                q = seg.signals["load_flow"]
                cols = [signal.lfilter(b, aa, q)]
                w = _bandwidth(a.num, a.den)
                if w is not None and FLOW_TERMS > 1:
                    b0, a0 = discrete_tf((math.sqrt(2 * w),), (1.0, w), seg.dt)
                    b1, a1 = discrete_tf((-1.0, w), (1.0, w), seg.dt)
                    g = signal.lfilter(b0, a0, q)
                    for _ in range(FLOW_TERMS - 1):
                        cols.append(g)
                        g = signal.lfilter(b1, a1, g)
                out = np.column_stack(cols)
            seg.cache["flow"] = out
        return seg.cache["flow"]

    def _loop_columns(self, channel: Channel, seg: Segment, theta: Theta) -> NDArray:
        """The loop's linear columns beside the replay -- compliance, CSI, orifice law --
        ``(n, p)``, cached per calibration (the shift does not move them), read-only."""
        key = f"reactive:block:{self._transfer_key(channel, theta)}"
        if key not in seg.cache:
            block = np.hstack(
                [
                    self._compliance_column(channel, seg, theta),
                    self._csi_columns(channel, seg)[0],
                    self._flow_column(channel, seg),
                ]
            )
            block.flags.writeable = False
            seg.cache[key] = block
        return seg.cache[key]

    def columns(self, channel: Channel, seg: Segment, theta: Theta) -> Columns:
        y = self._linear(channel, seg, theta)
        csi = self._loop_columns(channel, seg, theta)
        if self.limit:
            g, v_max = float(theta["gain"]), float(theta["velocity_limit"])
            if self.limiter == "loop":
                moved = loop_rate_limited(g * y, self._loop_pole(channel, theta), v_max, seg.dt)
            else:
                moved = rate_limited(g * y, v_max, seg.dt)
            return csi, moved
        return np.column_stack([y, csi]), np.zeros_like(y)

    def _loop_pole(self, channel: Channel, theta: Theta) -> float:
        """The re-calibrated TF's slowest real (stable) pole [rad/s]; ``inf`` without one."""
        roots = np.roots(self._transfer(channel, theta)[1])
        real = roots[(np.abs(roots.imag) <= 1e-9 * np.abs(roots)) & (roots.real < 0.0)]
        return float(np.min(-real.real)) if real.size else math.inf

    def _peak_velocity(self, channel: Channel) -> float:
        theta = {"shift": 0.0}
        return max(
            float(np.max(np.abs(np.diff(self._linear(channel, s, theta))))) / s.dt
            for s in channel.segments
        )

    def prior(self, channel: Channel) -> NDArray[np.float64]:
        seg = channel.segments[0]
        n_csi = (
            int(self._compliant(channel))
            + self._csi_columns(channel, seg)[0].shape[1]
            + self._flow_column(channel, seg).shape[1]
        )
        return np.concatenate([[] if self.limit else [1.0], np.zeros(n_csi)])

    # -- reporting -----------------------------------------------------------------------
    def describe(self, channel: Channel, theta: Theta, beta: NDArray[np.float64]):
        shift = float(theta["shift"]) * channel.dt
        base = {
            "gain": float(theta["gain"]) if self.limit else float(beta[0]),
            "frequency_scale": float(theta.get("frequency_scale", 1.0)),
            "damping_scale": float(theta.get("damping_scale", 1.0)),
            "alignment": 0.0 if self.delay else shift,
        }
        if self._compliant(channel):
            base["loop_compliance"] = float(beta[self._compliance_index()])
        if self._flow_column(channel, channel.segments[0]).shape[1]:
            base["load_flow"] = float(
                beta[-self._flow_column(channel, channel.segments[0]).shape[1]]
            )
        params: dict[str, dict[str, float]] = {}
        if self.delay:
            params["actuator_delay"] = {"delay": shift}
        if self.limit:
            params["rate_limit"] = {"velocity_limit": float(theta["velocity_limit"])}
        return params, base

    def physical(self, channel: Channel, params: dict[str, dict[str, float]]) -> bool:
        """A delay must exceed one sample (less is alignment) and be a lag: an *advance* beyond
        the nominal's delay is no reference-path effect (nothing can act before its command)
        but a nominal slower than the actuator -- pole calibration beyond the common
        re-calibration, model form -- and a rate limit must be a speed the
        measured displacement reaches and holds: the median of its secant speed over
        :data:`SECANT_WINDOW` at or above 90 % of the limit where the linear motion would
        exceed it by :data:`LIMIT_EXCESS` (a limiter that only mimics a linear attenuation
        in a sweep is never reached; a flow-limited actuator's oil column may ring above the
        limit at reversals and its plateau sags with the load pressure, so the check is
        one-sided and on the median).  Where the drive exceeds the limit by less than twice
        that, the check takes the samples above half its largest excess, and at least
        :data:`LEAST_EXCESS` above the limit: a limit the drive exceeded by 11 % at most had
        been refused although the measured speed sat on it.  The linear motion is the
        nominal TF's with its gain calibrated on the record the limit touches least (a gain
        calibrated where the limiter acts is biased low)."""
        if self.delay and params["actuator_delay"]["delay"] <= channel.dt:
            return False
        if self.limit:
            v_max = params["rate_limit"]["velocity_limit"]
            k = max(1, int(round(0.5 * SECANT_WINDOW / channel.dt)))
            window = 2 * k * channel.dt
            theta = {"shift": 0.0}
            lines = [self._linear(channel, s, theta) for s in channel.segments]
            gain = self._free_gain(channel, lines, v_max, k)
            wants = [gain * np.abs(y[2 * k :] - y[: -2 * k]) / window for y in lines]
            excess = max(float(np.max(w)) for w in wants) / v_max - 1.0
            over = 1.0 + max(LEAST_EXCESS, min(LIMIT_EXCESS, 0.5 * excess))
            reached = []
            for s, want in zip(channel.segments, wants, strict=True):
                got = np.abs(s.observed[2 * k :] - s.observed[: -2 * k]) / window
                reached.append(got[want > over * v_max])
            speeds = np.concatenate(reached)
            if speeds.size < 10 or float(np.median(speeds)) < 0.9 * v_max:
                return False
        return True

    @staticmethod
    def _free_gain(channel: Channel, lines: list[NDArray], v_max: float, k: int) -> float:
        """The actuator's gain where the limiter is idle: the median ratio of measured to
        linear secant speed over the samples of the record the limit touches least whose linear
        speed is below 80 % of the limit and above :data:`IDLE_SNR` times the secant speed's
        noise, and at least 0.1 % of the limit (no division by a resting piston when the noise
        is unknown); 1 when fewer than 10 such samples.  A record driven well below the limit
        gives the gain as well as one near it: the noise, not the limit, sets the lower bound."""
        window = 2 * k * channel.dt
        speeds = [np.abs(y[2 * k :] - y[: -2 * k]) / window for y in lines]
        least = int(np.argmin([float(np.max(v)) for v in speeds]))
        want = speeds[least]
        obs = channel.segments[least].observed
        got = np.abs(obs[2 * k :] - obs[: -2 * k]) / window
        noise = math.sqrt(2.0) * float(channel.noise.get("measured", 0.0)) / window
        idle = (want > max(IDLE_SNR * noise, 1e-3 * v_max)) & (want < 0.8 * v_max)
        return float(np.median(got[idle] / want[idle])) if np.sum(idle) >= 10 else 1.0

    def resolution(self, channel: Channel, prediction: list[NDArray[np.float64]]) -> float:
        """The mean square [m^2] a one-sample shift of the predicted motion leaves over the
        scored samples: the finest gap the channel separates from calibration (the contract
        calls a shift of up to one sample calibration, and an effect a delay of more)."""
        sq, n = 0.0, 0
        for s, p in zip(channel.segments, prediction, strict=True):
            scored = (s.ident | s.held)[1:]
            d = np.diff(p)[scored]
            sq, n = sq + float(np.sum(d * d)), n + d.size
        return sq / max(n, 1)
