"""Specimen-channel models without a series element: the re-calibrated nominal specimen and its
rigid extensions by friction, amplitude-dependent damping and friction behind a clearance.

.. math::

    F = m\\,\\ddot x + c\\,\\dot x + k\\,x + F_c\\,\\varphi(x; \\delta, g)
        + \\frac{c_1}{A(t) + c_2}\\,\\dot x + b_r

* baseline: ``m, c, k`` (and the nominal friction ``F_r sign(x')`` or amplitude law when
  NOMINAL.toml declares them) re-calibrated, S0 Eq.1 with a parallel spring, and the force's
  alignment to its drive within one sample (:mod:`rths.diagnose.effects.alignment`: every
  model of the channel holds it, when it buys itself);
* ``coulomb_friction``: ``F_c phi``, ``phi`` the elasto-plastic operator of
  :func:`rths.diagnose.effects.kernels.friction_operator` (presliding displacement ``delta``,
  presliding stiffness ``F_c/delta``; ``delta -> 0`` is Coulomb's ``sign(x')`` with memory);
* ``amplitude_damping``: ``c_1/(A + c_2)``, S0 Eq.17-18's form, ``A`` the load amplitude
  with memory ``tau``: ``(1 - p)`` times the running amplitude of
  :func:`rths.diagnose.channels.signals.running_amplitude` plus ``p`` times the decaying peak
  hold of :func:`rths.diagnose.channels.signals.peak_amplitude` (S0 defines ``A`` for a
  harmonic motion, where both agree; under a non-stationary one a device may follow its mean
  square or its last peak, and the share ``p`` in [0, 1] is fitted);
* ``backlash`` together with friction (a friction device of negligible inertia): the friction
  element sits behind a clearance ``g``; its stiffness ``F_c/delta`` is the contact's in series
  with the presliding spring.

Every term but the offsets is linear in its level for given ``delta, g, c_2, tau``: one
least-squares solve per point of the (small) nonlinear search.  Model outputs pass through the
channel's smoother like the observed force.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from rths.core.errors import ParameterError, format_choices
from rths.diagnose.channels.channel import Channel, Segment
from rths.diagnose.channels.signals import (
    peak_amplitude,
    running_amplitude,
)
from rths.diagnose.effects.alignment import alignment_column, alignment_limits
from rths.diagnose.effects.drive import drive_scale, single_tone, smoothed
from rths.diagnose.effects.kernels import friction_operator, reversal_amplitude
from rths.diagnose.effects.model import Columns, Model, Param, Theta

__all__ = [
    "DAMPINGS",
    "NOMINAL_TOLERANCE",
    "RESOLVED_CLEARANCE",
    "RigidSpecimen",
    "clearance_resolved",
    "friction_resolved",
]

#: Presliding displacement of the nominal friction ``F_r sign(x')``, as a fraction of the
#: drive's standard deviation (a sign with memory, immune to noise reversals).
NOMINAL_PRESLIDING: float = 1e-3


#: A clearance is resolved by the displacement when it exceeds this many times the measured
#: displacement's white-noise RMS (converter noise and 16-bit quantisation, estimated from the
#: records): a dead band narrower than the noise band (+/-1 sigma) leaves no plateau the data
#: can show, and a contact behind it is a series spring (``internal_stiffness``).
RESOLVED_CLEARANCE: float = 2.0


#: Relative tolerance of the re-calibration of NOMINAL.toml's own specimen parameters
#: (inertance, damping, stiffness, a declared friction or amplitude law): a lab's identified
#: nominal is off by up to 10-15 %, and the records' own model form (sensor dynamics, a
#: simulator's discretisation: the emulated lab's IMD shows 9 % less damping at 1024 Hz than
#: it holds) adds a few per cent; what lies beyond is structure the nominal lacks, not
#: calibration.  A parameter the nominal sets to zero may take a term of at most this share of
#: the force's standard deviation (:mod:`rths.diagnose.search.bounded`).
NOMINAL_TOLERANCE: float = 0.2


#: Shortest memory [s] of the running load amplitude (a cycle at 10 Hz).
MIN_MEMORY: float = 0.1
#: Hysteresis of the half-cycle amplitude reading: a reversal is a retreat from the running
#: extremum by more than this share of the record's displacement standard deviation (its
#: noise and small ripples are no load reversals: at no hysteresis the measured noise on a
#: 0.8 Hz, 2.3 mm sine collapsed the reading to a few micrometres) ...
REVERSAL_FLOOR: float = 0.02
#: ... and by more than this share of the current amplitude.
REVERSAL_SHARE: float = 0.05


def clearance_resolved(channel: Channel, gap: float) -> bool:
    """Whether a total clearance ``gap`` [m] is wider than the displacement's resolution,
    :data:`RESOLVED_CLEARANCE` times its white-noise RMS (a backlash whose clearance is below
    the resolution is not a backlash).

    Parameters
    ----------
    channel
        The specimen channel (its ``noise["measured"]``: displacement white-noise RMS [m]).
    gap
        Total clearance [m].
    """
    noise = float(channel.noise.get("measured", 0.0))
    return gap > RESOLVED_CLEARANCE * noise


def friction_resolved(channel: Channel, friction: float) -> bool:
    """Whether a friction level ``friction`` [N] exceeds the force's resolution,
    :data:`RESOLVED_CLEARANCE` times its white-noise RMS (``noise["force"]``): a friction
    inside the load cell's noise band is no lab's friction, only a patch of a model-form
    difference.

    Parameters
    ----------
    channel
        The specimen channel.
    friction
        Friction level [N].
    """
    return friction > RESOLVED_CLEARANCE * float(channel.noise.get("force", 0.0))


def rigid_columns(seg: Segment) -> list[NDArray]:
    """``h a, h v, h x`` of the drive."""
    s = seg.signals
    return [
        smoothed(seg, "a", lambda: s["a"]),
        smoothed(seg, "v", lambda: s["v"]),
        smoothed(seg, "x", lambda: s["x"]),
    ]


def friction_column(seg: Segment, delta: float, gap: float = 0.0) -> NDArray:
    """``h phi(x; delta, gap)`` (cached per parameter pair)."""
    return smoothed(
        seg, f"phi:{delta!r}:{gap!r}", lambda: friction_operator(seg.signals["x"], delta, gap)
    )


def amplitude(seg: Segment, tau: float, peak: float = 0.0, reversal: float = 0.0) -> NDArray:
    """Load amplitude of the drive [m]: ``(1 - peak)`` running amplitude plus ``peak`` decaying
    peak hold, both of memory ``tau``, blended with the share ``reversal`` of the half-cycle
    reading (module docstring; each cached).  On a window of a record
    (:attr:`rths.diagnose.channels.channel.Segment.window`) the record's own amplitude, sliced:
    restarted at rest at the window's start it would take several memories to settle, longer
    than a search window's warm-up."""
    if seg.window is not None:
        whole, lo = seg.window
        return amplitude(whole, tau, peak, reversal)[lo : lo + seg.observed.size]
    key = f"amp:{tau!r}"
    if key not in seg.cache:
        seg.cache[key] = running_amplitude(seg.signals["x"], seg.dt, tau)
    out = seg.cache[key]
    if peak > 0.0:
        hold = f"peak:{tau!r}"
        if hold not in seg.cache:
            seg.cache[hold] = peak_amplitude(seg.signals["x"], seg.dt, tau)
        out = (1.0 - peak) * out + peak * seg.cache[hold]
    if reversal > 0.0:
        if "reversal" not in seg.cache:
            d = seg.signals["x"] - np.mean(seg.signals["x"])
            floor = max(REVERSAL_FLOOR * float(np.std(d)), 1e-12)
            seg.cache["reversal"] = reversal_amplitude(d, floor, REVERSAL_SHARE)
        out = (1.0 - reversal) * out + reversal * seg.cache["reversal"]
    return out


def amplitude_column(
    seg: Segment, c2: float, tau: float, peak: float = 0.0, reversal: float = 0.0
) -> NDArray:
    """``h (x' / (A + c2))`` [1/s]: the regressor of ``c1``."""
    return smoothed(
        seg,
        f"ad:{c2!r}:{tau!r}:{peak!r}:{reversal!r}",
        lambda: seg.signals["v"] / (amplitude(seg, tau, peak, reversal) + c2),
    )


def amplitude_space(channel: Channel, grid: bool = True, envelopes: bool = True) -> list[Param]:
    """``c2`` [m], the amplitude memory ``tau`` [s] (orders of magnitude around the drive), the
    peak-hold share ``peak`` [-] and the half-cycle share ``reversal`` [-] of the amplitude.

    The memory is at least :data:`MIN_MEMORY`: an amplitude is a property of a cycle, and a
    shorter memory would turn the law into a position-dependent damping.  With ``envelopes``
    the global grid tries the readings of the amplitude (``peak`` 0 and 1, ``reversal`` 0
    and 1); else the peak share starts half-way and is only refined, and the half-cycle
    reading is left out (a chain's replay costs).
    """
    scale = drive_scale(channel)
    out = [
        Param("c2", 1e-3 * scale, 30.0 * scale, grid=8 if grid else 0),
        Param("memory", MIN_MEMORY, 3.0, grid=6 if grid else 0, start=0.3),
        Param("peak", 0.0, 1.0, log=False, grid=2 if grid and envelopes else 0, start=0.5),
    ]
    if envelopes:
        out.append(Param("reversal", 0.0, 1.0, log=False, grid=2 if grid else 0, start=0.0))
    return out


def friction_space(channel: Channel, backlash: bool, grid: bool = True) -> list[Param]:
    """Presliding displacement ``delta`` [m] (and the clearance ``gap`` [m] for backlash)."""
    scale = drive_scale(channel)
    out = [Param("presliding", 1e-8, 0.5 * scale, grid=14 if grid else 0)]
    if backlash:
        hi = max(scale, 5e-3)  # up to the travel's RMS (>= 5 mm)
        out.append(Param("gap", min(1e-6, 1e-3 * hi), hi, grid=14 if grid else 0))
    return out


#: Choices of :class:`RigidSpecimen`'s ``damping`` beside a dissipation law.
DAMPINGS: tuple[str, ...] = ("free", "nominal")


class RigidSpecimen(Model):
    """The rigid specimen family (module docstring).

    Parameters
    ----------
    effects
        The effects the model holds.
    damping
        Beside a dissipation law (friction, amplitude-dependent damping): ``"free"`` (the law
        may replace the viscous share of a nominal fitted to the same loops; one freedom the
        selection prices, :attr:`rths.diagnose.effects.model.Model.freedoms`) or
        ``"nominal"`` (NOMINAL.toml's damping within its tolerance, like the baseline's: an
        identified nominal of the device's linear part).  Without a law the damping is always
        the nominal's.
    """

    subsystem = "specimen"
    passive_terms = 2  # inertance and damping (S0 Eq.1: m, c >= 0)

    def __init__(self, effects: tuple[str, ...] = (), damping: str = "free") -> None:
        if damping not in DAMPINGS:
            raise ParameterError(
                f"specimen damping must be one of {format_choices(DAMPINGS)}; got {damping!r}"
            )
        super().__init__(effects)
        self.friction = "coulomb_friction" in effects
        self.backlash = "backlash" in effects
        self.amplitude = "amplitude_damping" in effects
        self.structure = "massless" if self.backlash else "rigid"
        self.polish = self.backlash
        self.free_damping = (self.friction or self.amplitude) and damping == "free"
        # the amplitude law's c2 and memory show only over the records' range of amplitude,
        # which the search windows (where the drive moves most) leave out
        self.windowed = not self.amplitude
        self.freedoms = int(self.free_damping)

    def _nominal_friction(self, channel: Channel) -> bool:
        return channel.nominal.specimen.friction > 0.0 and not self.friction

    def _nominal_amplitude(self, channel: Channel) -> bool:
        return channel.nominal.specimen.declares_amplitude_damping and not self.amplitude

    def space(self, channel: Channel) -> list[Param]:
        out: list[Param] = []
        if self.friction:
            out += friction_space(channel, self.backlash)
        if self.amplitude:
            out += amplitude_space(channel)
        elif self._nominal_amplitude(channel):
            c2 = channel.nominal.specimen.amplitude_c2
            out += [
                Param("c2", c2 / 30, 30 * c2, start=c2),
                Param("memory", MIN_MEMORY, 3.0, start=0.3),
            ]
        return out

    def columns(self, channel: Channel, seg: Segment, theta: Theta) -> Columns:
        cols = rigid_columns(seg)
        if self.friction:
            cols.append(friction_column(seg, theta["presliding"], theta.get("gap", 0.0)))
        elif self._nominal_friction(channel):
            cols.append(friction_column(seg, NOMINAL_PRESLIDING * drive_scale(channel)))
        if self.amplitude or self._nominal_amplitude(channel):
            cols.append(
                amplitude_column(
                    seg,
                    theta["c2"],
                    theta["memory"],
                    theta.get("peak", 0.0),
                    theta.get("reversal", 0.0),
                )
            )
        cols.append(alignment_column(channel, seg))
        return np.column_stack(cols), np.zeros_like(seg.observed)

    def prior(self, channel: Channel) -> NDArray[np.float64]:
        s = channel.nominal.specimen
        out = [s.inertance, s.damping, s.stiffness]
        if self.friction or self._nominal_friction(channel):
            out.append(s.friction)
        if self.amplitude or self._nominal_amplitude(channel):
            out.append(s.amplitude_c1)
        out.append(0.0)  # the force's alignment to its drive [samples]
        return np.array(out, dtype=float)

    def tolerance(self, channel: Channel) -> NDArray[np.float64]:
        """:data:`NOMINAL_TOLERANCE` for inertance, damping, stiffness and the friction or
        amplitude law NOMINAL.toml declares; an effect's level is free, and so is the damping
        beside a friction or amplitude effect in the ``"free"`` structure (a dissipation law
        replaces the viscous share of a nominal fitted to the same loops: a viscous fit of a
        friction damper).  When every identification record is one sine of the same frequency
        (:func:`rths.diagnose.effects.drive.single_tone`) the inertance keeps its nominal
        value: its force ``-m w^2 x`` is the stiffness's shape, only harmonics (an unmodelled
        effect's, as often as not) would split them."""
        out = [NOMINAL_TOLERANCE] * 3
        if single_tone(channel):
            out[0] = 0.0  # m and k are one number, k - m w^2, at one drive frequency
        if self.free_damping:
            out[1] = math.nan  # a dissipation law replaces the nominal's viscous share
        if self.friction or self._nominal_friction(channel):
            out.append(NOMINAL_TOLERANCE if self._nominal_friction(channel) else math.nan)
        if self.amplitude or self._nominal_amplitude(channel):
            out.append(NOMINAL_TOLERANCE if self._nominal_amplitude(channel) else math.nan)
        out.append(math.nan)  # the alignment: bounded by :meth:`limits`
        return np.array(out, dtype=float)

    def unanchored(self, channel: Channel) -> NDArray[np.bool_]:
        """The friction effect's level and the amplitude effect's ``c1`` (after inertance,
        damping and stiffness, in :meth:`prior`'s order)."""
        out = np.zeros(self.prior(channel).size, dtype=bool)
        i = 3
        if self.friction or self._nominal_friction(channel):
            out[i] = self.friction
            i += 1
        if self.amplitude:
            out[i] = True
        return out

    def limits(self, channel: Channel) -> NDArray[np.float64]:
        """The force's alignment to its drive within
        :data:`rths.diagnose.effects.alignment.ALIGNMENT_SAMPLES`; none when every
        identification record is one tone (:func:`rths.diagnose.effects.drive.tonal`): at one
        frequency a lead ``s`` is a damping ``-m w^2 s dt`` (and a stiffness ``c w^2 s dt``),
        and over sines of several frequencies and amplitudes it trades with an amplitude law's
        level (fitted beside one on six steady sines it went to its bound and took c1 10 %
        low, on a stepped sine 18 %; 3 and 8 % without it)."""
        return alignment_limits(channel, self.prior(channel).size)

    def describe(self, channel: Channel, theta: Theta, beta: NDArray[np.float64]):
        b = [float(q) for q in beta[:-1]]
        base = {"inertance": b[0], "damping": b[1], "stiffness": b[2]}
        base["alignment"] = float(beta[-1]) * channel.dt  # [s]
        params: dict[str, dict[str, float]] = {}
        i = 3
        if self.friction:
            fc, delta = b[i], theta["presliding"]
            params["coulomb_friction"] = {"friction": fc, "presliding_stiffness": fc / delta}
            if self.backlash:
                params["backlash"] = {
                    "gap": theta["gap"],
                    "stiffness": fc / delta,
                    "contact_damping": 0.0,
                }
            i += 1
        elif self._nominal_friction(channel):
            base["friction"] = b[i]
            i += 1
        if self.amplitude:
            params["amplitude_damping"] = {
                "c1": b[i],
                "c2": theta["c2"],
                "memory": theta["memory"],
                "peak": theta["peak"],
                "reversal": theta["reversal"],
            }
        elif self._nominal_amplitude(channel):
            base["amplitude_c1"], base["amplitude_c2"] = b[i], theta["c2"]
        return params, base

    def physical(self, channel: Channel, params: dict[str, dict[str, float]]) -> bool:
        if self.friction and not friction_resolved(channel, params["coulomb_friction"]["friction"]):
            return False
        if self.backlash and not clearance_resolved(channel, params["backlash"]["gap"]):
            return False
        return not (self.amplitude and params["amplitude_damping"]["c1"] <= 0.0)
