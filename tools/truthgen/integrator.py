"""Exact-in-mode hybrid integrator for the piecewise-affine plant.

Between switching events each mode is linear time-invariant with inputs held
constant over an internal step ``h = Ts / M`` (the DAC is a zero-order hold, so
this is exact for the command); the step map is the matrix exponential of the
augmented generator ``[[F], [0]]`` (``F`` from :meth:`plant.Plant.system`).
Switching events (contact closing/opening, stick/slip, valve saturation) are
located inside a step by a cubic Hermite model of each guard, refined by Newton
iterations on the exact (matrix-exponential) flow, then the step is resumed in
the new mode.  The remainder of the integration error therefore comes only
from the explicit amplitude-damping force (held over a step at its mid-step
prediction) and the guard tolerances (1e-12 m / 1e-4 N).

The recorded channels are the plant's analog anti-alias filter states, sampled
at the output instants t_k = k Ts: exactly what a DAQ with an analog AA filter
does, so no digital decimation is needed.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import expm

from .plant import U_FAD, U_ONE, U_R, Plant

_TRANS = {"contact": 0, "friction": 1, "sat": 2}
_THETA = np.linspace(0.0, 1.0, 17)[1:]
_H = np.stack(
    [
        2 * _THETA**3 - 3 * _THETA**2 + 1,
        _THETA**3 - 2 * _THETA**2 + _THETA,
        -2 * _THETA**3 + 3 * _THETA**2,
        _THETA**3 - _THETA**2,
    ],
    axis=1,
)


KBITS = 24  # an internal step is 2**KBITS ticks: event times resolved to h * 2**-24


class _Mode:
    """Cached per-mode matrices and tick-exact propagators."""

    def __init__(self, plant: Plant, mode: tuple[int, int, int], h: float) -> None:
        sysd = plant.system(mode)
        n = plant.n
        maug = np.zeros((plant.n_aug, plant.n_aug))
        maug[:n] = sysd["F"]
        self.G = sysd["guards"]
        self.GF = self.G[:, :n] @ sysd["F"] if self.G.size else self.G
        self.tols = sysd["tols"]
        self.targets = sysd["targets"]
        self.sysd = sysd
        self.n = n
        # E[k] = exp(maug * h * 2**-k): one small-norm expm, then repeated squaring
        e = [expm(maug * (h * 2.0**-KBITS))]
        for _ in range(KBITS):
            e.append(e[-1] @ e[-1])
        self.E = e[::-1]
        self._psi: dict[int, np.ndarray] = {1 << KBITS: self.E[0][:n]}

    def psi(self, ticks: int) -> np.ndarray:
        """Cached step map (n, n+NU) over ``ticks`` ticks (used for standard steps)."""
        p = self._psi.get(ticks)
        if p is None:
            acc = np.eye(self.E[0].shape[0])
            for k in range(1, KBITS + 1):
                if ticks >> (KBITS - k) & 1:
                    acc = self.E[k] @ acc
            if ticks >> KBITS & 1:
                acc = self.E[0] @ acc
            p = self._psi[ticks] = acc[: self.n]
        return p

    def std(self, ticks: int, dt: float) -> tuple[np.ndarray, np.ndarray | None]:
        """Step map and guard screen for a standard step of ``ticks`` (= ``dt`` s).

        The screen is a linear map of the augmented state giving the cubic
        Hermite model of every guard (minus its tolerance) at 16 instants of the
        step; if its maximum is <= 0 no event can occur in the step.
        """
        key = -ticks
        got = self._psi.get(key)
        if got is None:
            psi = self.psi(ticks)
            chk = None
            if self.G.size:
                n = self.n
                nu = self.G.shape[1] - n
                tail = np.hstack([np.zeros((nu, n)), np.eye(nu)])
                G1 = self.G[:, :n] @ psi + self.G[:, n:] @ tail
                GD1 = self.GF[:, :n] @ psi + self.GF[:, n:] @ tail
                chk = np.vstack(
                    [
                        _H[i, 0] * self.G
                        + _H[i, 1] * dt * self.GF
                        + _H[i, 2] * G1
                        + _H[i, 3] * dt * GD1
                        for i in range(_H.shape[0])
                    ]
                )
                chk[:, n + U_ONE] -= np.tile(self.tols, _H.shape[0])
            got = self._psi[key] = (psi, chk)
        return got

    def prop(self, xa: np.ndarray, ticks: int) -> np.ndarray:
        """State part (n,) after ``ticks`` ticks from augmented ``xa`` (not cached)."""
        if ticks in self._psi:
            return self._psi[ticks] @ xa
        x = xa
        for k in range(1, KBITS + 1):
            if ticks >> (KBITS - k) & 1:
                x = self.E[k] @ x
        if ticks >> KBITS & 1:
            x = self.E[0] @ x
        return x[: self.n]


class Simulator:
    """Integrates one plant; reusable for several records (mode cache is kept).

    Parameters
    ----------
    plant : Plant
        Assembled plant.
    fs : float
        Output (DAQ) sample rate, Hz.
    substeps : int
        Internal steps per output sample M.
    delay : float
        Total command transport delay (controller latency + any extra delay),
        s; resolved to h * 2**-24.
    """

    def __init__(self, plant: Plant, fs: float, substeps: int, delay: float) -> None:
        self.p = plant
        self.fs = fs
        self.M = int(substeps)
        self.h = 1.0 / (fs * self.M)
        ticks = int(round(delay / self.h * (1 << KBITS)))
        self.q = ticks >> KBITS
        self.phi_ticks = ticks - (self.q << KBITS)
        self.delay = ticks * self.h / (1 << KBITS)
        self.modes: dict[tuple[int, int, int], _Mode] = {}
        self.n_state = plant.n
        self.events = 0
        self.cap_hits = 0
        amp = plant.effects.get("amplitude_damping")
        self.amp = (amp["c1"], amp["c2"]) if amp else None
        self.tau_amp = 0.3  # s, time constant of each of the two mean-square low-pass stages
        fr = plant.effects.get("coulomb_friction")
        self.zmax = fr["friction"] / fr["presliding_stiffness"] if fr else 0.0

    def mode(self, m: tuple[int, int, int]) -> _Mode:
        """Cached mode data."""
        md = self.modes.get(m)
        if md is None:
            md = self.modes[m] = _Mode(self.p, m, self.h)
        return md

    # ------------------------------------------------------------------ events
    def _settle(self, xa: np.ndarray, m: tuple[int, int, int]) -> tuple[int, int, int]:
        """Apply transitions whose guard is already crossed (or at zero and rising)."""
        for _ in range(12):
            md = self.mode(m)
            if not md.G.size:
                return m
            g = md.G @ xa
            if (g + md.tols).max() < 0.0:
                return m
            gd = md.GF @ xa
            fire = (g > md.tols) | ((g > -md.tols) & (gd > 0))
            if not fire.any():
                return m
            j = int(np.argmax(np.where(fire, g / md.tols, -np.inf)))
            m = self._switch(xa, m, md.targets[j])
        self.cap_hits += 1
        return m

    def _switch(
        self, xa: np.ndarray, m: tuple[int, int, int], tgt: tuple[str, int]
    ) -> tuple[int, int, int]:
        """New mode after one element transition (projects z onto its bound on slip)."""
        lst = list(m)
        lst[_TRANS[tgt[0]]] = tgt[1]
        if tgt[0] == "friction" and tgt[1] != 0:
            xa[self.p.i_z] = tgt[1] * self.zmax  # slip: presliding spring sits exactly at its bound
        return (lst[0], lst[1], lst[2])

    def _advance(self, xa: np.ndarray, m: tuple[int, int, int], ticks: int) -> tuple[int, int, int]:
        """Propagate ``xa`` (in place) over ``ticks`` with inputs held, handling events."""
        n = self.p.n
        dt_tick = self.h / (1 << KBITS)
        psi, chk = self.mode(m).std(ticks, ticks * dt_tick)
        if chk is None:
            xa[:n] = psi @ xa
            return m
        if (chk @ xa).max() <= 0.0:
            xa[:n] = psi @ xa
            return m
        remaining = ticks
        for _ in range(64):
            md = self.mode(m)
            if not md.G.size:
                xa[:n] = md.psi(remaining) @ xa if remaining == ticks else md.prop(xa, remaining)
                return m
            x1 = md.psi(remaining) @ xa if remaining == ticks else md.prop(xa, remaining)
            g0 = md.G @ xa
            g1 = md.G[:, :n] @ x1 + md.G[:, n:] @ xa[n:]
            hit = g1 > 0
            gd0 = md.GF @ xa
            gd1 = md.GF[:, :n] @ x1 + md.GF[:, n:] @ xa[n:]
            dt = remaining * dt_tick
            if not hit.any():
                near = (gd0 > 0) & (gd1 < 0)  # interior maximum possible
                if not near.any():
                    xa[:n] = x1
                    return m
                cub = _H @ np.vstack([np.minimum(g0, 0), dt * gd0, g1, dt * gd1])
                hit = near & (cub.max(axis=0) > 0)
                if not hit.any():
                    xa[:n] = x1
                    return m
            best, bj, bt, bx = None, -1, 0, None
            for j in np.flatnonzero(hit):
                th = _first_root((min(g0[j], 0.0), dt * gd0[j], g1[j], dt * gd1[j]))
                res = self._refine(md, xa, remaining, int(j), th, bool(g1[j] > 0))
                if res is not None and (best is None or res[0] < bt):
                    best, bj, bt, bx = True, int(j), res[0], res[1]
            if best is None:  # cubic false alarm: no exact crossing in this step
                xa[:n] = x1
                return m
            xa[:n] = bx
            self.events += 1
            m = self._settle(xa, self._switch(xa, m, md.targets[bj]))
            remaining -= bt
            if remaining <= 0:
                return m
        self.cap_hits += 1
        return m

    def _refine(self, md: _Mode, xa: np.ndarray, T: int, j: int, th: float, end_pos: bool):
        """First tick where guard j is > 0 on the exact flow: (ticks, state) or None."""
        gj, gfj = md.G[j], md.GF[j]
        n = self.n_state
        dt_tick = self.h / (1 << KBITS)
        xt = xa.copy()

        def ev(t: int) -> tuple[float, float]:
            xt[:n] = md.prop(xa, t)
            return float(gj @ xt), float(gfj @ xt)

        lo, hi = 0, T
        t = min(max(int(th * T), 1), T)
        if not end_pos:
            g, _ = ev(t)
            if g <= 0:
                return None
            hi = t
        for _ in range(8):
            g, gd = ev(t)
            if g > 0:
                hi = min(hi, t)
            else:
                lo = max(lo, t)
            if hi - lo <= 1:
                break
            tn = t - g / (gd * dt_tick) if gd > 0 else 0.5 * (lo + hi)
            tn = int(round(tn))
            if tn == t:
                tn = t - 1 if g > 0 else t + 1
            t = min(max(tn, lo + 1), hi - 1)
        while hi - lo > 1:
            mid = (lo + hi) // 2
            g, _ = ev(mid)
            if g > 0:
                hi = mid
            else:
                lo = mid
        return hi, md.prop(xa, hi)

    # ------------------------------------------------------------------ run
    def run(self, command: np.ndarray, truth: bool = False) -> dict[str, np.ndarray]:
        """Simulate one record.

        Parameters
        ----------
        command : ndarray
            DAC command per row, m (row k applied over [t_k, t_k+1)).
        truth : bool
            Also return internal signals sampled at t_k (noise-free, unfiltered).

        Returns
        -------
        dict
            ``measured`` (m) and ``force`` (N): AA-filtered, noise-free samples at
            t_k; with ``truth``: ``xP``, ``vP``, ``xI``, ``vI`` (m, m/s),
            ``load``/``fric``/``contact`` (N), ``current`` (-), ``pl`` (Pa),
            ``amp`` (m), ``mode`` (int codes); ``diverged`` flag.
        """
        p, M, n = self.p, self.M, self.p.n
        N = len(command)
        cmd = np.asarray(command, dtype=float).tolist()
        xa = np.zeros(p.n_aug)
        xa[n + U_ONE] = 1.0
        m = p.initial_mode()
        C = p.outputs()
        rec = np.zeros((N, 2))
        kin = p._kinematics()
        names = ["xP", "vP", "xI", "vI", "delta"]
        trows = np.array([kin["xP"], kin["vP"], kin["xI"], kin["vI"], kin["xP"] - kin["xR"]])
        tr = np.zeros((N, len(names) + 6)) if truth else None
        h, q, phi = self.h, self.q, self.phi_ticks
        full = 1 << KBITS
        sat_inputs = p.has_sat
        amp = self.amp
        m1 = m2 = 0.0
        decay = math.exp(-h / self.tau_amp)
        ivI = p.i_v[p.body_of["I"]]
        ixI = p.i_x[p.body_of["I"]]
        A_now = 0.0
        limit = 20.0 * p.act.stroke
        diverged = False
        for k in range(N):
            rec[k] = C @ xa
            if truth:
                sd = self.mode(m).sysd
                tr[k, :5] = trows @ xa
                tr[k, 5] = sd["load"] @ xa
                tr[k, 6] = sd["fric"] @ xa
                tr[k, 7] = sd["contact"] @ xa
                tr[k, 8] = sd["current"] @ xa
                tr[k, 9] = xa[p.i_pl]
                tr[k, 10] = A_now
            if k == N - 1:
                break
            if not (abs(xa[p.i_x[0]]) < limit and math.isfinite(xa[p.i_x[0]])):
                diverged = True
                rec[k:] = np.nan
                break
            for s in range(M):
                if amp is not None:
                    # running amplitude: A = sqrt(2 * LP2(x^2)), exact for x^2 held over the step
                    w = xa[ixI] * xa[ixI]
                    m2 = w + (m2 - w) * decay + (m1 - w) * (h / self.tau_amp) * decay
                    m1 = w + (m1 - w) * decay
                    A_now = math.sqrt(2.0 * max(m2, 0.0))
                    acc = self.mode(m).sysd["acc_I"] @ xa
                    xa[n + U_FAD] = amp[0] / (A_now + amp[1]) * (xa[ivI] + 0.5 * h * acc)
                jj = k * M + s - q
                i = jj // M
                if phi > 0 and jj % M == 0:
                    xa[n + U_R] = cmd[i - 1] if i >= 1 else 0.0
                    if sat_inputs:
                        m = self._settle(xa, m)
                    m = self._advance(xa, m, phi)
                    xa[n + U_R] = cmd[i] if i >= 0 else 0.0
                    if sat_inputs:
                        m = self._settle(xa, m)
                    m = self._advance(xa, m, full - phi)
                else:
                    xa[n + U_R] = cmd[i] if i >= 0 else 0.0
                    if sat_inputs:
                        m = self._settle(xa, m)
                    m = self._advance(xa, m, full)
        out = {"measured": rec[:, 0].copy(), "force": rec[:, 1].copy(), "diverged": diverged}
        if truth:
            for i, nm in enumerate(names + ["load", "fric", "contact", "current", "pl", "amp"]):
                out[nm] = tr[:, i].copy()
        return out


def _first_root(c: tuple[float, float, float, float]) -> float:
    """First theta in (0, 1] where the cubic Hermite model becomes positive."""
    vals = _H @ np.array(c)
    idx = int(np.argmax(vals > 0))
    if vals[idx] <= 0:
        return 1.0
    lo = _THETA[idx - 1] if idx > 0 else 0.0
    hi = _THETA[idx]
    w = np.array(c)
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        hv = np.array(
            [
                2 * mid**3 - 3 * mid**2 + 1,
                mid**3 - 2 * mid**2 + mid,
                -2 * mid**3 + 3 * mid**2,
                mid**3 - mid**2,
            ]
        )
        if hv @ w > 0:
            hi = mid
        else:
            lo = mid
    return hi
