"""The specimen seen the other way round: the measured displacement predicted from the measured
force (the ``displacement`` channel), for stiff series elements.

A stiff contact or series spring makes the force a stiff function of the drive displacement:
driven by a measured displacement (micrometres of converter noise, an anti-alias filter, the
sampling of a contact that closes within a millisecond) a model's force errs by the contact
stiffness times those micrometres, and no replay reproduces the contact sample by sample.  Driven
by the measured force the same physics is well posed: the body (inertance ``m``, damping ``c``,
spring ``k``) integrates the force, and the element's deflection is a smooth function of it:

.. math::

    \\hat x = \\underbrace{\\frac{F}{m s^2 + c s + k}}_{\\text{body}}
        + \\underbrace{\\frac{F_0 \\mathrm{sgn}(F) |F/F_0|^{1/n}}{k_e (1+\\tau s)}}_{\\text{elem}}
        + \\frac{g}{2}\\tanh\\frac{F}{F_0} + \\text{free response}

with ``tau = c_e/k_e`` (Kelvin-Voigt element: ``internal_stiffness`` without clearance,
``backlash`` with a total clearance ``g`` crossed while the force changes sign, and a contact
law ``F ~ p^n`` whose exponent ``n`` in [1, 2] is searched: 3/2 for a Hertz contact; ``k_e``
is then the secant stiffness at ``F_0``; a Hunt-Crossley contact ``F = k p^n (1 + a p')``
deflects ``u - (a/n) u u'`` to first order, ``u = (F/k)^(1/n)``: one more linear column).
The body's initial state is unknown, so each record is cut into blocks of
:data:`BLOCK_SECONDS`; every block integrates from rest and its free response (two columns) is
calibrated on the block itself, like the per-record offsets and the load cell's offset (the
body's response to a constant force).
Samples where ``|F| < 2 F_0`` (the clearance being crossed: the piston's motion there is the
actuator's, not the specimen's) are not scored.  ``1/m``, ``1/k_e`` and ``g/2`` are linear and
bounded at zero (a body or element that gives way against the force would be a source; a
contact stiffer than the noise resolves is a rigid one, ``k_e`` infinite);
``c/m``, ``k/m`` and ``tau`` are searched.  The baseline is the body alone (the nominal rigid
specimen) with the displacement's alignment to the force within one sample, the force
channel's calibration seen from the other side (a last column, ``dt/m_n`` times the body's
velocity: to first order ``x(t - s dt) = x - s dt x'``).  Friction and amplitude damping
are left to the ``force`` channel's models.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import linalg, signal

from rths.diagnose.channels.channel import Channel, Segment
from rths.diagnose.effects.alignment import alignment_limits
from rths.diagnose.effects.chain import CONTACT_EXPONENT
from rths.diagnose.effects.model import Columns, Model, Param, Theta
from rths.diagnose.effects.specimen import RESOLVED_CLEARANCE, clearance_resolved

__all__ = ["BLOCK_SECONDS", "ComplianceModel", "blocks"]

#: Length [s] of the blocks the body integrates over from rest.
BLOCK_SECONDS: float = 4.0


def blocks(n: int, dt: float) -> list[slice]:
    """Consecutive blocks of about :data:`BLOCK_SECONDS` covering ``n`` samples.

    Parameters
    ----------
    n
        Samples of the record.
    dt
        Sample period [s].
    """
    size = max(16, int(round(BLOCK_SECONDS / dt)))
    edges = list(range(0, n, size))
    if len(edges) > 1 and n - edges[-1] < size // 2:
        edges.pop()
    edges.append(n)
    return [slice(a, b) for a, b in zip(edges[:-1], edges[1:], strict=True)]


def _foh(num: tuple, den: tuple, dt: float) -> tuple[NDArray, NDArray]:
    """``(b, a)`` of ``num/den`` for a sampled input taken piecewise linear between samples
    (first-order hold: force and displacement are sampled together), exact."""
    b, a, _ = signal.cont2discrete((num, den), dt, method="foh")
    return np.ravel(b), np.asarray(a, dtype=float)


def _blockwise(u: NDArray, dt: float, num: tuple, den: tuple) -> NDArray:
    """``num/den`` driven by ``u`` from rest in every block (first-order hold)."""
    b, a = _foh(num, den, dt)
    out = np.empty_like(u)
    for sl in blocks(u.size, dt):
        out[sl] = signal.lfilter(b, a, u[sl])
    return out


def _free(n: int, dt: float, c: float, k: float) -> NDArray:
    """Free responses of the body ``1/(s^2 + c s + k)`` per block: two columns per block (from
    a unit initial displacement and a unit initial velocity)."""
    a = np.array([[0.0, 1.0], [-k, -c]])
    phi = linalg.expm(a * dt)
    tr, det = float(np.trace(phi)), float(np.linalg.det(phi))
    parts = blocks(n, dt)
    longest = max(sl.stop - sl.start for sl in parts)
    impulse = np.zeros(longest)
    impulse[0] = 1.0
    seqs = []
    for z0 in (np.array([1.0, 0.0]), np.array([0.0, 1.0])):
        y0, y1 = z0[0], (phi @ z0)[0]
        seqs.append(signal.lfilter([y0, y1 - tr * y0], [1.0, -tr, det], impulse))
    out = np.zeros((n, 2 * len(parts)))
    for j, sl in enumerate(parts):
        m = sl.stop - sl.start
        out[sl, 2 * j] = seqs[0][:m]
        out[sl, 2 * j + 1] = seqs[1][:m]
    return out


class ComplianceModel(Model):
    """The ``displacement`` channel's models (module docstring).

    Parameters
    ----------
    effects
        ``()`` (the body alone), ``("internal_stiffness",)`` or ``("backlash",)``.
    """

    subsystem = "specimen"
    structure = "force-driven"

    def __init__(self, effects: tuple[str, ...] = ()) -> None:
        super().__init__(effects)
        self.element = bool(effects)
        self.backlash = "backlash" in effects
        # 1/m, 1/k_e and g/2 cannot be negative: a body or an element that gives way
        # against the force would be a source, and a clearance is a length
        self.passive_terms = 1 + int(self.element) + int(self.backlash)
        self._base: dict[str, float] = {}

    def prepare(self, channel: Channel, base: dict[str, float]) -> None:
        self._base = dict(base)

    def _ratios(self, channel: Channel) -> tuple[float, float]:
        s = channel.nominal.specimen
        m = self._base.get("inertance", s.inertance) or s.inertance
        if m <= 0.0:
            return 0.0, 0.0
        return (
            self._base.get("damping", s.damping * m / s.inertance if s.inertance else 0.0) / m,
            self._base.get("stiffness", s.stiffness) / m,
        )

    def space(self, channel: Channel) -> list[Param]:
        c0, k0 = self._ratios(channel)
        w = 2.0 * math.pi * float(channel.cutoff or 10.0)
        out = [
            Param("body_damping", 0.0, max(10.0 * c0, 0.1 * w), log=False, start=max(c0, 0.0)),
            Param(
                "body_stiffness",
                -abs(k0) - 1.0,
                10.0 * abs(k0) + (0.02 * w) ** 2,
                log=False,
                start=k0,
            ),
        ]
        if self.element:
            out.append(Param("tau", 1e-6, 5e-3, grid=6, start=1e-4))
        if self.backlash:  # linear columns: a fine grid is cheap
            out.append(Param("exponent", *CONTACT_EXPONENT, log=False, grid=5, start=1.0))
        return out

    def columns(self, channel: Channel, seg: Segment, theta: Theta) -> Columns:
        f = seg.signals["f"]
        c, k = max(float(theta["body_damping"]), 0.0), float(theta["body_stiffness"])
        key = f"body:{c!r}:{k!r}"
        if key not in seg.cache:
            seg.cache[key] = seg.h(_blockwise(f, seg.dt, (1.0,), (1.0, c, k)))
        cols = [seg.cache[key]]
        key = f"rate:{c!r}:{k!r}"
        if key not in seg.cache:  # dt/m_n times the body's velocity: the alignment's regressor
            inv_m = self.prior(channel)[0]
            rate = _blockwise(f, seg.dt, (1.0, 0.0), (1.0, c, k))
            seg.cache[key] = seg.h(seg.dt * inv_m * rate)
        alignment = seg.cache[key]
        if self.element:
            tau, n = float(theta["tau"]), float(theta.get("exponent", 1.0))
            key = f"elem:{tau!r}:{n!r}"
            if key not in seg.cache:
                f0 = float(seg.signals["f0"][0])
                law = f if n == 1.0 else f0 * np.sign(f) * (np.abs(f) / f0) ** (1.0 / n)
                seg.cache[key] = seg.h(_blockwise(law, seg.dt, (1.0,), (tau, 1.0)))
            cols.append(seg.cache[key])
        if self.backlash:
            if "sign" not in seg.cache:
                seg.cache["sign"] = seg.h(np.tanh(f / float(seg.signals["f0"][0])))
            cols.append(seg.cache["sign"])
            n = float(theta.get("exponent", 1.0))
            key = f"hc:{n!r}"
            if key not in seg.cache:
                f0 = float(seg.signals["f0"][0])
                law = f0 * np.sign(f) * (np.abs(f) / f0) ** (1.0 / n)
                seg.cache[key] = seg.h(law * np.gradient(law, seg.dt))
            cols.append(seg.cache[key])
        cols.append(alignment)
        return np.column_stack(cols), np.zeros_like(f)

    def nuisance(self, channel: Channel, seg: Segment, theta: Theta) -> NDArray[np.float64]:
        """Per block: the body's free responses; per record: its response to a constant force
        (the load cell's offset) -- calibrated on each record like the offsets."""
        c, k = max(float(theta["body_damping"]), 0.0), float(theta["body_stiffness"])
        key = f"free:{c!r}:{k!r}"
        if key not in seg.cache:
            n = seg.observed.size
            offset = _blockwise(np.ones(n), seg.dt, (1.0,), (1.0, c, k))
            seg.cache[key] = np.column_stack([_free(n, seg.dt, c, k), offset])
        return seg.cache[key]

    @staticmethod
    def _peak(channel: Channel) -> float:
        return max(float(np.max(np.abs(s.signals["f"]))) for s in channel.segments)

    @staticmethod
    def _f0(channel: Channel) -> float:
        return float(channel.segments[0].signals["f0"][0])

    def prior(self, channel: Channel) -> NDArray[np.float64]:
        s = channel.nominal.specimen
        out = [1.0 / s.inertance if s.inertance > 0.0 else 0.0]
        if self.element:
            out.append(0.0)
        if self.backlash:
            out += [0.0, 0.0]
        out.append(0.0)  # the displacement's alignment to the force [samples]
        return np.array(out)

    def limits(self, channel: Channel) -> NDArray[np.float64]:
        """The alignment within :data:`rths.diagnose.effects.alignment.ALIGNMENT_SAMPLES`, none
        when every identification record's force is one tone (as the force channel's:
        :meth:`rths.diagnose.effects.specimen.RigidSpecimen.limits`)."""
        return alignment_limits(channel, self.prior(channel).size, "f")

    def describe(self, channel: Channel, theta: Theta, beta: NDArray[np.float64]):
        # x(t - s dt) = x - s dt x': the force read s samples ahead of the displacement
        alignment, beta = -float(beta[-1]) * channel.dt, beta[:-1]
        inv_m = float(beta[0])
        m = 1.0 / inv_m if inv_m > 0.0 else math.inf
        base = {
            "inertance": m,
            "damping": m * max(float(theta["body_damping"]), 0.0) if inv_m > 0 else 0.0,
            "stiffness": m * float(theta["body_stiffness"]) if inv_m > 0 else 0.0,
            "alignment": alignment,
        }
        params: dict[str, dict[str, float]] = {}
        if self.element:
            inv_k = float(beta[1])
            k_e = 1.0 / inv_k if inv_k > 0.0 else math.inf
            c_e = float(theta["tau"]) * k_e
            if self.backlash:
                n, f0 = float(theta.get("exponent", 1.0)), self._f0(channel)
                params["backlash"] = {
                    "gap": 2.0 * float(beta[2]),
                    "stiffness": k_e,
                    "contact_damping": c_e,
                    "exponent": n,
                    # F = k p^n with p = (F0/k_e) (F/F0)^(1/n): k = F0 (k_e/F0)^n
                    "contact_law_stiffness": f0 * (k_e / f0) ** n,
                    "reference_force": f0,
                    # the contact's deflection at the peak force [m] (< 0: a negative
                    # compliance, unphysical beyond the displacement's resolution)
                    "peak_deflection": inv_k * f0 * (self._peak(channel) / f0) ** (1.0 / n),
                    # Hunt-Crossley: p = (F/(k (1 + a p')))^(1/n) ~ u - (a/n) u u' with
                    # u = (F/k)^(1/n): a = -n beta_hc / (1/k_e) [s/m]
                    "hunt_crossley": -n * float(beta[3]) / inv_k if inv_k > 0.0 else 0.0,
                }
            else:
                w = math.sqrt(k_e / m) if math.isfinite(k_e) and inv_m > 0 else math.inf
                params["internal_stiffness"] = {
                    "stiffness": k_e,
                    "series_damping": c_e,
                    "frequency": w / (2.0 * math.pi),
                }
        return params, base

    def physical(self, channel: Channel, params: dict[str, dict[str, float]]) -> bool:
        element = params.get("backlash") or params.get("internal_stiffness")
        if element is None:
            return True
        if self.backlash:
            # a contact stiffer than the displacement resolves is a rigid one: backlash still
            p = params["backlash"]
            resolution = RESOLVED_CLEARANCE * float(channel.noise.get("measured", 0.0))
            return clearance_resolved(channel, p["gap"]) and (
                p.get("peak_deflection", 0.0) >= -resolution
            )
        return 0.0 < element["stiffness"] < math.inf
