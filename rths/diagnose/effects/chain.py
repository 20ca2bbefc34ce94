"""Specimen-channel models with a series element: the inertial chain drive -> element -> body.

.. math::

    F = m\\,e(x; \\omega, \\zeta, g, c/m, k/m, F_c/m, \\delta, c_1/m, c_2) + m_r\\,\\ddot x + b_r

with ``e`` the force per unit body inertance of :func:`rths.diagnose.effects.kernels.
series_chain`: the element (``internal_stiffness``: a series spring ``k_e = m omega^2`` with its
own damping ``c_e = 2 zeta omega m``, S0 Eq.12 with a Kelvin-Voigt element; ``backlash``: a
clearance ``g`` before a contact which only pushes, S0 Table 6, S1 Eq.11, whose force grows
as the penetration to a power ``n``: 1 a linear contact, 3/2 a Hertz contact with damping
that vanishes at first touch (two structures) -- :func:`rths.diagnose.effects.kernels.
series_chain`; stiffness and damping are reported at :func:`reference_penetration`)
drives the body, which carries the re-calibrated nominal damping and spring and, as
further effects, an elasto-plastic friction and an amplitude-dependent damping ``c_1/(A +
c_2)`` (S0 Eq.17-18).  The body inertance ``m`` and a direct inertance ``m_r`` ahead of the
element (a rod, a load-cell adapter) are linear; the rest is searched.  For fixed per-mass
parameters the force is linear in ``m``.  Friction may also sit at the driven end, ahead of the
element (a seal, a guide: S0 Eq.1's ``F_r``), as a second structure (``friction_at="drive"``):
then it is the rigid family's linear term ``F_c phi(x; delta)``.  The force's alignment to
its drive (within one sample) is the rigid baseline's linear term
(:func:`rths.diagnose.effects.alignment.alignment_column`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import linalg, signal

from rths.diagnose.channels.channel import Channel, Segment
from rths.diagnose.effects.alignment import alignment_column, alignment_limits
from rths.diagnose.effects.drive import drive_scale, single_tone
from rths.diagnose.effects.kernels import series_chain
from rths.diagnose.effects.model import Columns, Model, Param, Theta
from rths.diagnose.effects.specimen import (
    NOMINAL_PRESLIDING,
    NOMINAL_TOLERANCE,
    amplitude,
    amplitude_space,
    clearance_resolved,
    friction_column,
    friction_resolved,
    rigid_columns,
)
from rths.diagnose.effects.zero_terms import zero_term_scale

__all__ = [
    "CONTACT_EXPONENT",
    "HERTZ_EXPONENT",
    "MIN_INERTIAL_SHARE",
    "REFERENCE_PENETRATION",
    "STIFFNESS_RANGE",
    "SeriesChain",
    "element_resolved",
    "free_response",
    "reference_penetration",
]

#: Smallest share of the force the body's inertia must carry for a chain to apply.
MIN_INERTIAL_SHARE: float = 0.05
#: Element stiffness searched [N/m] (issue range), mapped to frequencies with the inertance.
STIFFNESS_RANGE: tuple[float, float] = (1e5, 1e10)
#: Exponents ``n`` of the contact law ``F ~ p^n`` searched for backlash by the force-driven
#: view: 1 a linear (Kelvin-Voigt) contact, 3/2 Hertz's sphere on a flat (Johnson, Contact
#: Mechanics, Eq. 4.23), up to 2 (conforming, rough or layered contacts).
CONTACT_EXPONENT: tuple[float, float] = (1.0, 2.0)
#: The replayed chain's contact laws are two structures, not a searched exponent (which trades
#: against the clearance in a replay's rough cost surface): linear, and Hertz's 3/2.
HERTZ_EXPONENT: float = 1.5
#: Reference penetration of the contact law, as a fraction of the drive's standard deviation:
#: where the reported ``stiffness`` and ``contact_damping`` hold (the secant ``F/p`` there).
REFERENCE_PENETRATION: float = 0.01


def element_resolved(channel: Channel, element: dict[str, float]) -> bool:
    """Whether a series spring shows in the data: its resonance ``frequency`` [Hz] lies in the
    band the channel tests (up to 1.5 times its smoother's cutoff), or its deflection under the
    RMS force exceeds the displacement's resolution (:data:`rths.diagnose.effects.specimen.
    RESOLVED_CLEARANCE` times its white-noise RMS).  A stiffer element is a rigid link to the
    data -- a resonance above the band is filtered out and a static deflection inside the
    noise band is none -- and a fit that places one there (at the top of the frequency range,
    say) buys its free response's nuisance terms, not an element.

    Parameters
    ----------
    channel
        The specimen's ``force`` channel.
    element
        ``stiffness`` [N/m] and ``frequency`` [Hz] of the series element.
    """
    band = 1.5 * float(channel.cutoff) if channel.cutoff else 0.45 / channel.dt
    if float(element.get("frequency", 0.0)) <= band:
        return True
    force = float(np.sqrt(np.mean(channel.stack("observed") ** 2)))
    return clearance_resolved(channel, force / float(element["stiffness"]))


def reference_penetration(channel: Channel) -> float:
    """Reference penetration ``p_r`` [m] of the contact law (:data:`REFERENCE_PENETRATION`
    times the drive's standard deviation).

    Parameters
    ----------
    channel
        The specimen channel.
    """
    return REFERENCE_PENETRATION * drive_scale(channel)


def free_response(
    n: int, dt: float, w2: float, ce: float, c: float, k: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Element force per unit inertance [m/s^2] of a linear chain whose drive stands still,
    from a unit initial body displacement [m] and from a unit initial body velocity [m/s]:
    ``x'' + (c + c_e) x' + (k + w^2) x = 0`` and ``e = -(w^2 x + c_e x')``, exact per sample
    (matrix exponential), shape ``(n,)`` each.

    Parameters
    ----------
    n
        Samples.
    dt
        Sample period [s].
    w2, ce
        Element stiffness and damping per unit inertance [1/s^2], [1/s].
    c, k
        Body damping and spring per unit inertance [1/s], [1/s^2].
    """
    phi = linalg.expm(np.array([[0.0, 1.0], [-(k + w2), -(c + ce)]]) * dt)
    tr, det = float(np.trace(phi)), float(np.linalg.det(phi))
    row = -np.array([w2, ce])
    impulse = np.zeros(n)
    impulse[0] = 1.0
    out = []
    for z0 in (np.array([1.0, 0.0]), np.array([0.0, 1.0])):
        # e_i = row . phi^i z0 obeys phi's characteristic recursion (Cayley-Hamilton)
        y0, y1 = float(row @ z0), float(row @ (phi @ z0))
        out.append(signal.lfilter([y0, y1 - tr * y0], [1.0, -tr, det], impulse))
    return out[0], out[1]


class SeriesChain(Model):
    """The inertial chain with a series element (module docstring).

    Parameters
    ----------
    effects
        The effects (one of backlash / internal stiffness, optionally friction and amplitude
        damping).
    friction_at
        ``"body"`` (behind the element) or ``"drive"`` (ahead of it).
    contact
        Contact law of a backlash: ``"linear"`` or ``"hertz"`` (:data:`HERTZ_EXPONENT`).
    """

    subsystem = "specimen"
    passive_terms = 2  # the body's and the total inertance
    ordered = ((0, 1),)  # the direct inertance m_r (a rod, an adapter) is not negative

    def __init__(
        self, effects: tuple[str, ...] = (), friction_at: str = "body", contact: str = "linear"
    ) -> None:
        super().__init__(effects)
        self.backlash = "backlash" in effects
        self.exponent = HERTZ_EXPONENT if contact == "hertz" and self.backlash else 1.0
        self.friction = "coulomb_friction" in effects
        self.on_body = self.friction and friction_at == "body"
        self.structure = "chain" if not self.friction else f"chain, friction at the {friction_at}"
        if self.exponent != 1.0:
            self.structure += ", Hertz contact"
        self.amplitude = "amplitude_damping" in effects
        self.polish = self.backlash
        self._base: dict[str, float] = {}

    def prepare(self, channel: Channel, base: dict[str, float]) -> None:
        self._base = dict(base)

    def applicable(self, channel: Channel, base: dict[str, float]) -> bool:
        """Only for a specimen whose inertia matters: the re-calibrated inertance times the
        drive's RMS acceleration at least :data:`MIN_INERTIAL_SHARE` of the RMS force."""
        m = base.get("inertance", 0.0)
        if m <= 0.0:
            return False
        a = float(np.sqrt(np.mean(channel.stack("a") ** 2)))
        f = float(np.sqrt(np.mean(channel.stack("observed") ** 2)))
        return m * a >= MIN_INERTIAL_SHARE * f

    def _mass(self, channel: Channel) -> float:
        m = self._base.get("inertance", 0.0)
        return m if m > 0.0 else max(channel.nominal.specimen.inertance, 1e-6)

    @staticmethod
    def _per_mass(channel: Channel, name: str, m: float) -> tuple[float, float]:
        """Range of the body's ``damping`` or ``stiffness`` per unit inertance: NOMINAL.toml's
        value within :data:`rths.diagnose.effects.specimen.NOMINAL_TOLERANCE` (a term the
        nominal sets to zero: at most that share of the force's spread), over the re-calibrated
        inertance ``m`` within the same tolerance (the body's share of it is the fit's)."""
        t = NOMINAL_TOLERANCE
        nominal = float(getattr(channel.nominal.specimen, name))
        if nominal != 0.0:
            lo, hi = nominal - t * abs(nominal), nominal + t * abs(nominal)
        else:
            key = "v" if name == "damping" else "x"
            hi = t * zero_term_scale(
                [s.signals[key] for s in channel.segments],
                [s.observed for s in channel.segments],
            )
            lo = -hi
        if name == "damping":
            lo = max(lo, 0.0)
        lo = lo / (m * (1.0 + t)) if lo >= 0.0 else lo * (1.0 + t) / m
        hi = hi * (1.0 + t) / m if hi >= 0.0 else hi / (m * (1.0 + t))
        return lo, max(hi, lo + 1e-12 * max(abs(lo), 1.0))

    def space(self, channel: Channel) -> list[Param]:
        m = self._mass(channel)
        f_lo = max(0.5, math.sqrt(STIFFNESS_RANGE[0] / m) / (2 * math.pi))
        f_hi = min(0.45 / channel.dt, math.sqrt(STIFFNESS_RANGE[1] / m) / (2 * math.pi))
        f_lo = min(f_lo, 0.5 * f_hi)
        c0 = max(self._base.get("damping", 0.0), 0.0) / m
        k0 = self._base.get("stiffness", 0.0) / m
        out = [
            Param("frequency", f_lo, f_hi, grid=12 if self.backlash else 24),
            Param("zeta", 0.005, 2.0, grid=4 if self.backlash else 5, start=0.1),
        ]
        if self.backlash:
            hi = max(drive_scale(channel), 5e-3)  # up to the travel's RMS (>= 5 mm)
            out.append(Param("gap", min(1e-6, 1e-3 * hi), hi, grid=10))
        out += [
            Param("body_damping", *self._per_mass(channel, "damping", m), log=False, start=c0),
            Param("body_stiffness", *self._per_mass(channel, "stiffness", m), log=False, start=k0),
        ]
        if self.on_body:
            # friction level per unit inertance: 0.5-60 % of the peak inertial force per mass
            peak = max(float(np.max(np.abs(s.signals["a"]))) for s in channel.segments)
            out += [
                Param("friction_level", 0.005 * peak, 0.6 * peak, grid=6),
                Param("presliding", 1e-8, 0.5 * drive_scale(channel), grid=4),
            ]
        elif self.friction:
            out.append(Param("presliding", 1e-8, 0.5 * drive_scale(channel), grid=6))
        if self.amplitude:
            out += amplitude_space(channel, envelopes=False)  # a chain's replay costs
            peak_c = max(c0, 1.0) * 10.0 * drive_scale(channel)
            out.append(Param("c1_per_mass", 1e-4 * peak_c, 10.0 * peak_c, grid=5))
        return out

    def _damping(self, seg: Segment, theta: Theta) -> float | NDArray[np.float64]:
        c = max(float(theta["body_damping"]), 0.0)
        if not self.amplitude:
            return c
        a = amplitude(seg, theta["memory"], theta.get("peak", 0.0))
        return c + theta["c1_per_mass"] / (a + theta["c2"])

    def columns(self, channel: Channel, seg: Segment, theta: Theta) -> Columns:
        s = seg.signals
        per_mass = series_chain(
            s["x"],
            s["v"],
            seg.dt,
            omega=2.0 * math.pi * theta["frequency"],
            zeta=theta["zeta"],
            gap=theta.get("gap", 0.0),
            damping=self._damping(seg, theta),
            stiffness=float(theta["body_stiffness"]),
            friction=theta.get("friction_level", 0.0) if self.on_body else 0.0,
            presliding=theta.get("presliding", 1.0),
            exponent=self.exponent,
            reference=reference_penetration(channel),
        )
        accel = rigid_columns(seg)[0]
        cols = [seg.h(per_mass) - accel, accel]  # m e + m_r a = m (e - a) + (m + m_r) a
        if self.friction and not self.on_body:
            cols.append(friction_column(seg, theta["presliding"]))
        elif channel.nominal.specimen.friction > 0.0 and not self.friction:
            cols.append(friction_column(seg, NOMINAL_PRESLIDING * drive_scale(channel)))
        cols.append(alignment_column(channel, seg))
        return np.column_stack(cols), np.zeros_like(seg.observed)

    def nuisance(self, channel: Channel, seg: Segment, theta: Theta) -> NDArray[np.float64] | None:
        """The body's free response for a linear chain (a series spring, no clearance,
        friction or amplitude law): its initial state relative to the drive is unknown at the
        start of a record or a search window, and a lightly damped element rings for
        ``1/(zeta omega)`` seconds -- longer than any warm-up.  Two columns, from a unit initial
        body displacement and velocity, calibrated per segment like its offset."""
        if self.backlash or self.friction or self.amplitude:
            return None
        w = 2.0 * math.pi * theta["frequency"]
        w2, ce = w * w, 2.0 * theta["zeta"] * w
        c, k = max(float(theta["body_damping"]), 0.0), float(theta["body_stiffness"])
        key = f"free:{w!r}:{ce!r}:{c!r}:{k!r}"
        if key not in seg.cache:
            seg.cache[key] = np.column_stack(
                [seg.h(col) for col in free_response(seg.observed.size, seg.dt, w2, ce, c, k)]
            )
        return seg.cache[key]

    def prior(self, channel: Channel) -> NDArray[np.float64]:
        s = channel.nominal.specimen
        out = [s.inertance, s.inertance]
        if (s.friction > 0.0 and not self.friction) or (self.friction and not self.on_body):
            out.append(s.friction)
        out.append(0.0)  # the force's alignment to its drive [samples]
        return np.array(out, dtype=float)

    def unanchored(self, channel: Channel) -> NDArray[np.bool_]:
        """A friction effect's level ahead of the element (after the two inertances)."""
        out = np.zeros(self.prior(channel).size, dtype=bool)
        out[2] = self.friction and not self.on_body
        return out

    def tolerance(self, channel: Channel) -> NDArray[np.float64]:
        """The total inertance ``m + m_r`` and a nominal friction ahead of the element within
        :data:`rths.diagnose.effects.specimen.NOMINAL_TOLERANCE`; the split between body and
        drive (the element's place) and a friction effect's level are free.  When every
        identification record is one sine of the same frequency the total inertance keeps
        NOMINAL.toml's value, as the rigid baseline's does
        (:func:`rths.diagnose.effects.drive.single_tone`): a near-rigid contact had carried
        the inertance the baseline may not re-calibrate there (7 % of it) and "closed" a
        held-out gap at another frequency that was only that calibration."""
        out = [math.nan, 0.0 if single_tone(channel) else NOMINAL_TOLERANCE]
        if self.friction and not self.on_body:
            out.append(math.nan)
        elif channel.nominal.specimen.friction > 0.0 and not self.friction:
            out.append(NOMINAL_TOLERANCE)
        out.append(math.nan)  # the alignment: bounded by :meth:`limits`
        return np.array(out, dtype=float)

    def limits(self, channel: Channel) -> NDArray[np.float64]:
        """The force's alignment to its drive within
        :data:`rths.diagnose.effects.alignment.ALIGNMENT_SAMPLES`, none when every
        identification record is one tone (the rigid baseline's:
        :meth:`rths.diagnose.effects.specimen.RigidSpecimen.limits`)."""
        return alignment_limits(channel, self.prior(channel).size)

    def describe(self, channel: Channel, theta: Theta, beta: NDArray[np.float64]):
        alignment, beta = float(beta[-1]) * channel.dt, beta[:-1]
        m, m_r = float(beta[0]), float(beta[1]) - float(beta[0])
        w = 2.0 * math.pi * theta["frequency"]
        k_e, c_e = m * w * w, 2.0 * theta["zeta"] * w * m
        base = {
            "inertance": m,
            "direct_inertance": m_r,
            "damping": m * max(float(theta["body_damping"]), 0.0),
            "stiffness": m * float(theta["body_stiffness"]),
            "alignment": alignment,
        }
        if len(beta) > 2 and not self.friction:
            base["friction"] = float(beta[2])
        params: dict[str, dict[str, float]] = {}
        if self.backlash:
            n, p_r = self.exponent, reference_penetration(channel)
            params["backlash"] = {
                "gap": theta["gap"],
                "stiffness": k_e,
                "contact_damping": c_e,
                "exponent": n,
                "contact_law_stiffness": k_e * p_r ** (1.0 - n),
                "reference_penetration": p_r,
            }
            if n != 1.0:  # Hunt-Crossley's alpha [s/m] of k p^n (1 + alpha p')
                # a massless body carries no element (k_e = c_e = 0): no damping law either
                params["backlash"]["hunt_crossley"] = c_e / (k_e * p_r) if k_e > 0.0 else 0.0
        else:
            params["internal_stiffness"] = {
                "stiffness": k_e,
                "series_damping": c_e,
                "frequency": theta["frequency"],
            }
        if self.friction:
            fc = m * theta["friction_level"] if self.on_body else float(beta[2])
            params["coulomb_friction"] = {
                "friction": fc,
                "presliding_stiffness": fc / theta["presliding"],
            }
        if self.amplitude:
            params["amplitude_damping"] = {
                "c1": m * theta["c1_per_mass"],
                "c2": theta["c2"],
                "memory": theta["memory"],
                "peak": theta["peak"],
            }
        return params, base

    def physical(self, channel: Channel, params: dict[str, dict[str, float]]) -> bool:
        element = params.get("backlash") or params.get("internal_stiffness") or {}
        if self.friction and not friction_resolved(channel, params["coulomb_friction"]["friction"]):
            return False
        if self.backlash and not clearance_resolved(channel, params["backlash"]["gap"]):
            return False
        if element.get("stiffness", 0.0) <= 0.0:
            return False
        if not self.backlash and not element_resolved(channel, element):
            return False
        return True
