"""Physics of the truth generator: servo-hydraulic actuator + inertial mass damper.

Everything here is written from first principles for this generator; nothing
is shared with the project's own plant models.

Mechanical chain (one axis, positions in m, positive = actuator extends)::

    valve -> oil column -> piston P (LVDT, load cell) --[link 1]-- rod R --[link 2]-- flywheel I
                                                                               |-- c, k, friction,
                                                                               |   amplitude damping
                                                                               ground

* link 1 is rigid, or a clearance (``backlash``) closed by a Kelvin-Voigt
  contact (spring ``contact_stiffness`` parallel to ``contact_damping``) that can
  only push (the contact force is clamped at zero: it never pulls).
* link 2 is rigid, or a series spring ``stiffness`` parallel to a series damper
  ``series_damping`` (``internal_stiffness``).
* Rigidly linked nodes are merged into one body.  With no effect the specimen
  is exactly ``F = m a + c v + k x`` with ``m = rod_mass + inertance``.

Friction (``coulomb_friction``) is an elasto-plastic (Prandtl stop operator /
single Maxwell-slip element) model acting between the flywheel body and ground:
a presliding spring ``presliding_stiffness`` whose force saturates at
``friction``; state ``z`` (presliding deflection, m) obeys ``dz/dt = v`` while
``|z| < friction/presliding_stiffness`` (stick) and is frozen at the bound while
sliding (slip), so the friction force is *exactly* the labelled level during
slip and linear-elastic in presliding.

Everything except amplitude damping is piecewise affine in the state, so the
plant is a hybrid automaton with a finite set of modes: the integrator
(:mod:`integrator`) propagates each mode exactly with matrix exponentials.
Amplitude damping enters as an explicit force input held over an internal step.

Input vector ``u = [r, f_ad, 1]``: delayed controller command r (m),
amplitude-damping force on the flywheel f_ad (N), constant 1 (affine terms).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import signal

NU = 3
U_R, U_FAD, U_ONE = 0, 1, 2


@dataclass(frozen=True)
class Actuator:
    """Servo-hydraulic actuator with its controller board.

    Attributes
    ----------
    area : float
        Piston annulus area, m^2 (double-ended, equal areas).
    volume : float
        Total trapped oil volume of both chambers incl. hoses, m^3.
    bulk_modulus : float
        Effective oil bulk modulus incl. hose compliance, Pa.
    piston_mass : float
        Piston + rod + load-cell mass, kg.
    piston_damping : float
        Seal viscous friction, N s/m.
    leakage : float
        Total flow-pressure coefficient (cross-port leakage + valve Kc), m^3/(s Pa).
    rated_flow : float
        Valve flow at full (normalised = 1) spool opening, m^3/s.
    valve_freq : float
        Servo-valve spool natural frequency, Hz.
    valve_zeta : float
        Servo-valve spool damping ratio, -.
    kp : float
        Displacement-loop proportional gain, 1/m (normalised valve current per m of error).
    kdp : float
        Delta-P stabilisation gain, 1/Pa (normalised current per Pa of load pressure).
    latency : float
        Controller-board transport latency between DAC and loop, s.
    stroke : float
        Half stroke, m.
    supply_pressure : float
        Supply pressure, Pa (only used for capacity checks).
    """

    area: float
    volume: float
    bulk_modulus: float
    piston_mass: float
    piston_damping: float
    leakage: float
    rated_flow: float
    valve_freq: float
    valve_zeta: float
    kp: float
    kdp: float
    latency: float
    stroke: float
    supply_pressure: float

    @property
    def velocity_capacity(self) -> float:
        """No-load piston speed at full valve opening, m/s."""
        return self.rated_flow / self.area

    @property
    def force_capacity(self) -> float:
        """Stall force at supply pressure, N."""
        return self.area * self.supply_pressure


@dataclass(frozen=True)
class Specimen:
    """Inertial mass damper (ball screw + flywheel) in its nominal form.

    Attributes
    ----------
    inertance : float
        Flywheel inertance J (2 pi / lead)^2, kg.
    rod_mass : float
        Physical translating mass of screw/rod/clevis, kg.
    damping : float
        Viscous damping to ground, N s/m.
    stiffness : float
        Parallel stiffness to ground, N/m.
    """

    inertance: float
    rod_mass: float
    damping: float
    stiffness: float

    @property
    def total_inertance(self) -> float:
        """Inertance seen at the load cell when all links are rigid, kg."""
        return self.inertance + self.rod_mass


@dataclass
class Plant:
    """Assembled hybrid plant: actuator + specimen + specimen/actuator effects.

    Parameters
    ----------
    act : Actuator
        Actuator.
    spec : Specimen
        Specimen.
    effects : dict
        ``{effect name: params}`` (SI).  ``actuator_delay`` is applied to the
        command by the integrator, ``amplitude_damping`` by the integrator's
        explicit force; the others change the mode structure here.
    aa_cutoff : float
        Analog anti-alias filter -3 dB frequency, Hz (4-pole Bessel on both
        recorded channels).
    """

    act: Actuator
    spec: Specimen
    effects: dict = field(default_factory=dict)
    aa_cutoff: float = 250.0

    def __post_init__(self) -> None:
        eff = self.effects
        self.has_backlash = "backlash" in eff
        self.has_series = "internal_stiffness" in eff
        self.has_friction = "coulomb_friction" in eff
        self.has_sat = "rate_limit" in eff
        # bodies: merge rigidly linked nodes (link P-R rigid unless backlash,
        # link R-I rigid unless internal stiffness)
        rod = ["R"]
        groups = []
        if self.has_backlash:
            groups.append(["P"])
        else:
            rod.insert(0, "P")
        groups.append(rod)
        if self.has_series:
            groups.append(["I"])
        else:
            rod.append("I")
        self.body_of = {nd: j for j, g in enumerate(groups) for nd in g}
        node_mass = {"P": self.act.piston_mass, "R": self.spec.rod_mass, "I": self.spec.inertance}
        self.body_mass = [sum(node_mass[n] for n in g) for g in groups]
        nb = len(groups)
        # state layout
        self.i_xv, self.i_vv, self.i_pl = 0, 1, 2
        self.i_x = [3 + 2 * j for j in range(nb)]
        self.i_v = [4 + 2 * j for j in range(nb)]
        k = 3 + 2 * nb
        self.i_z = k if self.has_friction else -1
        k += 1 if self.has_friction else 0
        b, a = signal.bessel(4, 2 * np.pi * self.aa_cutoff, analog=True, norm="mag")
        self.aa_a, self.aa_b, self.aa_c, _ = signal.tf2ss(b, a)
        na = self.aa_a.shape[0]
        self.i_fx = k
        self.i_ff = k + na
        self.n = k + 2 * na
        self.n_aug = self.n + NU
        self._cache: dict = {}
        # low-frequency group delay of b/a: a1/a0 - b1/b0 (s)
        self.aa_group_delay = float(a[-2] / a[-1] - (b[-2] / b[-1] if len(b) > 1 else 0.0))

    # ------------------------------------------------------------------ rows
    def _e(self, i: int) -> np.ndarray:
        """Unit row selecting augmented-state entry ``i``."""
        r = np.zeros(self.n_aug)
        r[i] = 1.0
        return r

    def _u(self, i: int) -> np.ndarray:
        """Unit row selecting input ``i``."""
        return self._e(self.n + i)

    def modes_of(self, kind: str) -> tuple[int, ...]:
        """Discrete states an element can take (0 only if absent)."""
        present = {
            "contact": self.has_backlash,
            "friction": self.has_friction,
            "sat": self.has_sat,
        }[kind]
        if not present:
            return (0,)
        return (-2, -1, 0, 1, 2) if kind == "contact" else (-1, 0, 1)

    def _kinematics(self) -> dict[str, np.ndarray]:
        """Rows of the node positions (m) and velocities (m/s): P, R, I."""
        e = self._e
        bp, br, bi = self.body_of["P"], self.body_of["R"], self.body_of["I"]
        out = {
            "xP": e(self.i_x[bp]),
            "vP": e(self.i_v[bp]),
            "xR": e(self.i_x[br]),
            "vR": e(self.i_v[br]),
            "xI": e(self.i_x[bi]),
            "vI": e(self.i_v[bi]),
        }
        return out

    def contact_rows(self) -> dict[str, np.ndarray]:
        """Penetrations and candidate contact-force magnitudes (rows over [x; u])."""
        kin = self._kinematics()
        p = self.effects["backlash"]
        half = 0.5 * p["gap"]
        one = self._u(U_ONE)
        delta, ddelta = kin["xP"] - kin["xR"], kin["vP"] - kin["vR"]
        pen_pos, pen_neg = delta - half * one, -delta - half * one
        f_pos = p["contact_stiffness"] * pen_pos + p["contact_damping"] * ddelta
        f_neg = p["contact_stiffness"] * pen_neg - p["contact_damping"] * ddelta
        return {
            "pen_pos": pen_pos,
            "pen_neg": pen_neg,
            "f_pos": f_pos,
            "f_neg": f_neg,
            "delta": delta,
        }

    def current_row(self) -> np.ndarray:
        """Unsaturated normalised valve current, row over [x; u]."""
        a = self.act
        return a.kp * (self._u(U_R) - self._kinematics()["xP"]) - a.kdp * self._e(self.i_pl)

    def system(self, mode: tuple[int, int, int]) -> dict:
        """Linear (affine) dynamics of one mode.

        Parameters
        ----------
        mode : tuple of int
            (contact, friction, saturation) discrete states.  contact: 0 free,
            +/-1 in contact on the +/- side, +/-2 separated-but-overlapping (the
            clamped damper force is <= 0 while the penetration is > 0);
            friction: 0 stick, +/-1 slip; saturation: 0 linear, +/-1 saturated.

        Returns
        -------
        dict
            ``F``: (n, n+NU) derivative matrix, ``load``: load-cell force row
            (N), ``fric``: friction force row (N), ``contact``: contact force on
            the rod row (N), ``current``: valve current row, ``guards``: (g, n+NU)
            guard rows, ``targets``: list of (element, new state) per guard.
        """
        if mode not in self._cache:
            self._cache[mode] = self._build(mode)
        return self._cache[mode]

    def _build(self, mode: tuple[int, int, int]) -> dict:
        """Assemble the rows of :meth:`system` (uncached)."""
        contact, fric, sat = mode
        a, s, eff = self.act, self.spec, self.effects
        e, u = self._e, self._u
        kin = self._kinematics()
        nb = len(self.body_mass)
        force = [np.zeros(self.n_aug) for _ in range(nb)]
        bp, br, bi = self.body_of["P"], self.body_of["R"], self.body_of["I"]
        force[bp] += a.area * e(self.i_pl) - a.piston_damping * kin["vP"]
        force[bi] -= s.damping * kin["vI"] + s.stiffness * kin["xI"] + u(U_FAD)
        f_fric = np.zeros(self.n_aug)
        if self.has_friction:
            fp = eff["coulomb_friction"]
            f_fric = (
                fp["presliding_stiffness"] * e(self.i_z)
                if fric == 0
                else fric * fp["friction"] * u(U_ONE)
            )
            force[bi] -= f_fric
        if self.has_series:
            sp = eff["internal_stiffness"]
            fs = sp["stiffness"] * (kin["xR"] - kin["xI"]) + sp["series_damping"] * (
                kin["vR"] - kin["vI"]
            )
            force[bi] += fs
            force[br] -= fs
        f_con = np.zeros(self.n_aug)
        guards: list[np.ndarray] = []
        targets: list[tuple[str, int]] = []
        tols: list[float] = []
        if self.has_backlash:
            c = self.contact_rows()
            if contact == 1:
                f_con = c["f_pos"]
            elif contact == -1:
                f_con = -c["f_neg"]
            force[br] += f_con
            force[bp] -= f_con
            tp, tf = 1e-12, 1e-4  # guard tolerances: penetration (m), force (N)
            g = {
                0: [(c["pen_pos"], 1, tp), (c["pen_neg"], -1, tp)],
                1: [(-c["f_pos"], 2, tf)],
                2: [(c["f_pos"], 1, tf), (-c["pen_pos"], 0, tp)],
                -1: [(-c["f_neg"], -2, tf)],
                -2: [(c["f_neg"], -1, tf), (-c["pen_neg"], 0, tp)],
            }[contact]
            for row, tgt, tol in g:
                guards.append(row)
                targets.append(("contact", tgt))
                tols.append(tol)
        acc = [f / m for f, m in zip(force, self.body_mass)]
        cur = self.current_row()
        if self.has_sat:
            imax = self.i_max
            i_eff = cur if sat == 0 else sat * imax * u(U_ONE)
            g = {
                0: [(cur - imax * u(U_ONE), 1), (-cur - imax * u(U_ONE), -1)],
                1: [(imax * u(U_ONE) - cur, 0)],
                -1: [(cur + imax * u(U_ONE), 0)],
            }[sat]
            for row, tgt in g:
                guards.append(row)
                targets.append(("sat", tgt))
                tols.append(1e-10)  # normalised current
        else:
            i_eff = cur
        if self.has_friction:
            zmax = (
                eff["coulomb_friction"]["friction"]
                / eff["coulomb_friction"]["presliding_stiffness"]
            )
            g = {
                0: [(e(self.i_z) - zmax * u(U_ONE), 1), (-e(self.i_z) - zmax * u(U_ONE), -1)],
                1: [(-kin["vI"], 0)],
                -1: [(kin["vI"], 0)],
            }[fric]
            for row, tgt in g:
                guards.append(row)
                targets.append(("friction", tgt))
                tols.append(1e-12 if fric == 0 else 1e-10)  # z (m) or velocity (m/s)
        wv = 2 * np.pi * a.valve_freq
        F = np.zeros((self.n, self.n_aug))
        F[self.i_xv] = e(self.i_vv)
        F[self.i_vv] = wv * wv * (i_eff - e(self.i_xv)) - 2 * a.valve_zeta * wv * e(self.i_vv)
        F[self.i_pl] = (
            4
            * a.bulk_modulus
            / a.volume
            * (a.rated_flow * e(self.i_xv) - a.area * kin["vP"] - a.leakage * e(self.i_pl))
        )
        for j in range(nb):
            F[self.i_x[j]] = e(self.i_v[j])
            F[self.i_v[j]] = acc[j]
        if self.has_friction and fric == 0:
            F[self.i_z] = kin["vI"]
        load = a.area * e(self.i_pl) - a.piston_damping * kin["vP"] - a.piston_mass * acc[bp]
        na = self.aa_a.shape[0]
        for base, sig in ((self.i_fx, kin["xP"]), (self.i_ff, load)):
            for r in range(na):
                row = np.zeros(self.n_aug)
                row[base : base + na] = self.aa_a[r]
                F[base + r] = row + self.aa_b[r, 0] * sig
        G = np.array(guards).reshape(len(guards), self.n_aug)
        return {
            "F": F,
            "load": load,
            "fric": f_fric,
            "contact": f_con,
            "current": i_eff,
            "guards": G,
            "targets": targets,
            "tols": np.array(tols),
            "acc_I": acc[bi],
            "acc_P": acc[bp],
        }

    @property
    def i_max(self) -> float:
        """Valve-current saturation giving the labelled no-load velocity limit (normalised)."""
        return self.effects["rate_limit"]["velocity_limit"] * self.act.area / self.act.rated_flow

    def initial_mode(self) -> tuple[int, int, int]:
        """Mode at rest at the origin (contact free, friction stick, valve linear)."""
        return (0, 0, 0)

    def outputs(self) -> np.ndarray:
        """Rows of the two recorded (anti-alias filtered) channels: displacement, force."""
        na = self.aa_a.shape[0]
        C = np.zeros((2, self.n_aug))
        C[0, self.i_fx : self.i_fx + na] = self.aa_c[0]
        C[1, self.i_ff : self.i_ff + na] = self.aa_c[0]
        return C


def nominal_linear_model(act: Actuator, spec: Specimen) -> tuple[np.ndarray, np.ndarray]:
    """Exact command->piston-displacement transfer function, all links rigid.

    Parameters
    ----------
    act : Actuator
        Actuator (its latency is *not* included; it is a separate delay).
    spec : Specimen
        Nominal specimen installed on the actuator (control-structure interaction).

    Returns
    -------
    num, den : ndarray
        Polynomial coefficients in descending powers of s, den[0] == 1.
    """
    m = act.piston_mass + spec.total_inertance
    wv = 2 * np.pi * act.valve_freq
    kq = 4 * act.bulk_modulus / act.volume
    # states: xv, vv, pl, x, v ; input r
    A = np.array(
        [
            [0, 1, 0, 0, 0],
            [-wv * wv, -2 * act.valve_zeta * wv, -wv * wv * act.kdp, -wv * wv * act.kp, 0],
            [kq * act.rated_flow, 0, -kq * act.leakage, 0, -kq * act.area],
            [0, 0, 0, 0, 1],
            [0, 0, act.area / m, -spec.stiffness / m, -(spec.damping + act.piston_damping) / m],
        ]
    )
    B = np.array([[0], [wv * wv * act.kp], [0], [0], [0]])
    C = np.array([[0, 0, 0, 1, 0]])
    num, den = signal.ss2tf(A, B, C, np.zeros((1, 1)))
    num = np.atleast_1d(np.squeeze(num))
    # strip numerically-zero leading coefficients of the numerator
    scale = np.max(np.abs(num))
    first = int(np.argmax(np.abs(num) > 1e-9 * scale))
    num = num[first:] / den[0]
    return num, den / den[0]
