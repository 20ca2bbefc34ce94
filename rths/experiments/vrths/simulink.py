"""A block-for-block reimplementation of the benchmark's Simulink model with its sample controller.

This is the *oracle* the project's own RTHS of the benchmark is checked against: it reproduces
``vRTHS_MDOF_SimRT2014a.slx`` + ``controller_model.slx`` as ``F3_simulation.m`` runs them, not
the project's loop.  Blocks (names from the ``.slx`` XML) and their semantics:

* solver ``ode4`` (classical Runge-Kutta), fixed step ``dt_rths = 1/4096`` s; continuous states:
  *Numerical Substructure* (``A_ns``, ``B_ns`` of ``F1_input_file.m``, 6), *Servo-valve dynamics*
  ``a1b0/(s^2 + beta1 s + beta2)`` (2), *Actuator dynamics* ``1/(s + a3)`` (1), *EXPERIMENTAL
  SUBSTRUCTURE* ``1/(m_e s^2 + c_e s + KE)`` (2);
* *Derivative* blocks (the ``a2 s`` CSI feedback and the specimen's velocity/acceleration in
  *FEEDBACK FORCE*) as Simulink computes them: ``(u(t) - u(t_last)) / (t - t_last)``, ``t_last``
  the last major step before ``t`` (0 at ``t = 0``);
* *FEEDBACK FORCE* ``f_int = KE x + CE x' + ME x''`` from those derivatives; *SENSORS* add
  band-limited white noise (``Cov = 6.25e-14`` and ``1.16e-3``, ``Ts = dt_rths``, i.e. standard
  deviations ``sqrt(Cov/Ts)`` = 16 um and 2.18 N, both blocks seeded alike, hence one normal
  sequence scaled twice); *Unit Delay1* holds ``f_e`` one sample before the numerical
  substructure sees it;
* *GROUND ACCELERATION*: record or chirp times ``eq_intensity``, evaluated at the ode4 stage
  times (*From File* interpolates linearly);
* *CONTROLLER*: A/D (saturate +/-3.8, quantise 2^-18) -> Tustin ``G_T`` -> D/A -> ``y_p``;
  ``y_p - x_m`` -> A/D -> Tustin ``G_C`` -> D/A -> command held over the step, both discrete
  state-space blocks from ``c2dm(ss(.), dt_rths, 'tustin')`` (``F2_controller.m``).

Every logged signal (``Num_resp``, ``X_m``, ``Force_act``, ``EQ_input``) is sampled at the major
steps ``t_k = k dt``, ``k = 0 .. floor(tend/dt)``.  MATLAB's random streams cannot be
reproduced; the noise comes from ``numpy.random.default_rng(noise_seed)``.  The kernel is
compiled with numba: a 41 s record takes ~0.2 s instead of ~20 s in Python.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import control
import numpy as np
from numba import njit
from numpy.typing import NDArray

from plants.frame.cases import BenchmarkCase
from plants.frame.ground_motion import DEFAULT_INTENSITY, GroundMotion
from plants.frame.substructure import numerical_matrices
from rths.core.errors import ParameterError, check_positive
from rths.experiments.vrths.draws import NOMINAL, PlantDraw

__all__ = [
    "DISPLACEMENT_NOISE",
    "DISPLACEMENT_NOISE_POWER",
    "FORCE_NOISE",
    "FORCE_NOISE_POWER",
    "SimulinkRun",
    "sample_controller",
    "simulate_benchmark",
]

FloatArray = NDArray[np.float64]

#: Noise power of the LVDT's *Band-Limited White Noise* block (``rms_noise_DT``) [m^2 s].
DISPLACEMENT_NOISE_POWER = 6.25e-14
#: Noise power of the load cell's block (``rms_noise_FT``) [N^2 s].
FORCE_NOISE_POWER = 1.16e-3
#: Standard deviation [m] of the LVDT noise at 4096 Hz, ``sqrt(Cov / Ts)`` = 1.6e-5.
DISPLACEMENT_NOISE = math.sqrt(DISPLACEMENT_NOISE_POWER * 4096.0)
#: Standard deviation [N] of the load-cell noise at 4096 Hz, ``sqrt(Cov / Ts)`` = 2.18.
FORCE_NOISE = math.sqrt(FORCE_NOISE_POWER * 4096.0)

_GAIN, _A1B0, _A2 = 1.0261, 2.1283e13, 4.2297e6  # F1_input_file.m


@dataclass(frozen=True)
class SimulinkRun:
    """What the Simulink model logs (F3/F4 names), sampled at ``t_k = k dt`` from 0.

    Attributes
    ----------
    t
        ``t`` [s], shape ``(n,)``.
    numerical
        ``Num_resp.Data(:, 1:3)``: floor displacements of the numerical substructure [m],
        ``(n, 3)``.
    measured
        ``X_m.Data``: measured specimen displacement [m], ``(n,)``.
    actuator_force
        ``Force_act.Data``: hydraulic force [N], ``(n,)``.
    ground
        ``EQ_input``: ground acceleration [m/s^2], ``(n,)``.
    command
        Controller output held over each step [m], ``(n,)``.
    """

    t: FloatArray
    numerical: FloatArray
    measured: FloatArray
    actuator_force: FloatArray
    ground: FloatArray
    command: FloatArray


def sample_controller(dt: float) -> FloatArray:
    """``[A_T, B_T, C_T, D_T, A_C, B_C, C_C, D_C]`` of the Tustin ``G_T`` and ``G_C`` (F2).

    Parameters
    ----------
    dt : float
        Loop step [s], > 0 (the Tustin sampling period; benchmark: 1/4096 s).
    """
    lead = control.tf([50.83163360273612, 8570.397339444286], [1.0, 8570.397339444286])
    pi = control.tf([2.0, 95.0], [1.0, 0.0])
    out = []
    for g in (lead, pi):
        d = control.c2d(control.ss(g), dt, method="tustin")
        out += [float(d.A[0, 0]), float(d.B[0, 0]), float(d.C[0, 0]), float(d.D[0, 0])]
    return np.array(out)


@njit(cache=True)
def _quantise(v: float, q: float) -> float:
    r = abs(v) / q
    return math.copysign(math.floor(r + 0.5), v) * q


@njit(cache=True)
def _adc(v: float, q: float, sat: float) -> float:
    return _quantise(min(max(v, -sat), sat), q)


@njit(cache=True)
def _dac(v: float, q: float, sat: float) -> float:
    return min(max(_quantise(v, q), -sat), sat)


@njit(cache=True)
def _derivatives(z, u, f_held, d_csi, ag, a_ns, bg_ns, bf_ns, p):  # pragma: no cover - numba
    # p = [a1b0, a3, beta1, beta2, gain, m_e, c_e, k_e]
    dz = np.empty(11)
    for i in range(6):
        s = bg_ns[i] * ag + bf_ns[i] * f_held
        for j in range(6):
            s += a_ns[i, j] * z[j]
        dz[i] = s
    x = z[9]
    dz[6] = z[7]
    dz[7] = -p[3] * z[6] - p[2] * z[7] + (p[4] * u - x)  # servo-valve, input gain*u - x
    dz[8] = -p[1] * z[8] + p[0] * z[6] - d_csi  # actuator dynamics, input q - d(a2 x)/dt
    dz[9] = z[10]
    dz[10] = (z[8] - p[6] * z[10] - p[7] * x) / p[5]  # experimental substructure
    return dz


@njit(cache=True)
def _run(n, h, a_ns, bg_ns, bf_ns, p, a2, ag_half, noise_x, noise_f, ctrl, q, sat, exact):
    """The model over ``n`` major steps (``ag_half``: ground acceleration every ``h/2``)."""
    numerical = np.zeros((n, 3))
    measured = np.zeros(n)
    f_act = np.zeros(n)
    command = np.zeros(n)
    z = np.zeros(11)
    xt = 0.0  # G_T state
    xc = 0.0  # G_C state
    u_last = 0.0  # Derivative (a2 x): input at the last major step
    x_prev = 0.0  # FEEDBACK FORCE derivatives' memories
    v_prev = 0.0
    f_delayed = 0.0  # Unit Delay1 output
    for k in range(n):
        x = z[9]
        numerical[k, 0], numerical[k, 1], numerical[k, 2] = z[0], z[1], z[2]
        measured[k] = x + noise_x[k]
        f_act[k] = z[8]
        if exact:
            d_major = a2 * z[10]
            v, acc = z[10], (z[8] - p[6] * z[10] - p[7] * x) / p[5]
        else:
            d_major = (a2 * x - u_last) / h if k > 0 else 0.0
            v = (x - x_prev) / h if k > 0 else 0.0
            acc = (v - v_prev) / h if k > 0 else 0.0
        f_e = p[7] * x + p[6] * v + p[5] * acc + noise_f[k]
        f_held = f_delayed
        f_delayed = f_e
        x_prev, v_prev, u_last = x, v, a2 * x
        # controller: phase lead on y_n, PI on the tracking error (discrete, D feedthrough)
        r = _adc(z[0], q, sat)
        y_p = _dac(ctrl[2] * xt + ctrl[3] * r, q, sat)
        xt = ctrl[0] * xt + ctrl[1] * r
        e = _adc(y_p - measured[k], q, sat)
        u = _dac(ctrl[6] * xc + ctrl[7] * e, q, sat)
        xc = ctrl[4] * xc + ctrl[5] * e
        command[k] = u
        # ode4 over [t_k, t_k + h]; the Derivative block differences from the major step t_k
        k1 = _derivatives(z, u, f_held, d_major, ag_half[2 * k], a_ns, bg_ns, bf_ns, p)
        z2 = z + 0.5 * h * k1
        d2 = a2 * z2[10] if exact else (a2 * z2[9] - u_last) / (0.5 * h)
        k2 = _derivatives(z2, u, f_held, d2, ag_half[2 * k + 1], a_ns, bg_ns, bf_ns, p)
        z3 = z + 0.5 * h * k2
        d3 = a2 * z3[10] if exact else (a2 * z3[9] - u_last) / (0.5 * h)
        k3 = _derivatives(z3, u, f_held, d3, ag_half[2 * k + 1], a_ns, bg_ns, bf_ns, p)
        z4 = z + h * k3
        d4 = a2 * z4[10] if exact else (a2 * z4[9] - u_last) / h
        k4 = _derivatives(z4, u, f_held, d4, ag_half[2 * k + 2], a_ns, bg_ns, bf_ns, p)
        z = z + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return numerical, measured, f_act, command


def simulate_benchmark(
    case: BenchmarkCase,
    ground: GroundMotion,
    *,
    plant: PlantDraw = NOMINAL,
    dt: float = 1.0 / 4096.0,
    intensity: float = DEFAULT_INTENSITY,
    noise_seed: int | None = 0,
    noise: bool = True,
    derivative: str = "simulink",
    quantization: float = 2.0**-18,
    saturation: float = 3.8,
) -> SimulinkRun:
    """Run the benchmark's Simulink model with its sample controller (module docstring).

    Parameters
    ----------
    case
        Partitioning case (reference frame).
    ground
        Ground motion; the run lasts ``ground.steps(dt)`` steps (``tend``).
    plant
        Specimen stiffness and actuator parameters of the trial (nominal by default).
    dt
        Fixed step [s].
    intensity
        ``eq_intensity`` [-].
    noise_seed
        Seed of the sensor-noise sequence.
    noise
        ``False`` removes both sensor noises.
    derivative
        ``"simulink"``: the *Derivative* blocks' differences (faithful); ``"exact"``: exact
        derivatives (to measure what they change).
    quantization, saturation
        Converter interval and limit [m] (``quantize_int``, ``sat_limit_upper``).
    """
    dt = check_positive(dt, "time step dt")
    if derivative not in ("simulink", "exact"):
        raise ParameterError(f"derivative must be 'simulink' or 'exact'; got {derivative!r}")
    check_positive(quantization, "converter quantization")
    check_positive(saturation, "converter saturation")
    n = ground.steps(dt) + 1
    spec = plant.specimen()
    mn, cn, kn = numerical_matrices(case, spec)
    m_inv = np.linalg.inv(mn)
    a_ns = np.zeros((6, 6))
    a_ns[:3, 3:] = np.eye(3)
    a_ns[3:, :3], a_ns[3:, 3:] = -m_inv @ kn, -m_inv @ cn
    bg_ns = np.concatenate([np.zeros(3), -m_inv @ case.mass @ np.ones(3)])
    bf_ns = np.concatenate([np.zeros(3), -m_inv[:, 0]])
    p = np.array([_A1B0, plant.a3, plant.beta1, plant.beta2, _GAIN,
                  spec.mass, spec.damping, spec.stiffness])  # fmt: skip
    ag_half = ground.acceleration(np.arange(2 * n + 1) * (0.5 * dt), intensity)
    w = np.random.default_rng(noise_seed).standard_normal(n) if noise else np.zeros(n)
    numerical, measured, f_act, command = _run(
        n, dt, a_ns, bg_ns, bf_ns, p, _A2, ag_half,
        w * math.sqrt(DISPLACEMENT_NOISE_POWER / dt), w * math.sqrt(FORCE_NOISE_POWER / dt),
        sample_controller(dt), float(quantization), float(saturation), derivative == "exact",
    )  # fmt: skip
    return SimulinkRun(
        t=np.asarray(np.arange(n) * dt, dtype=np.float64),
        numerical=numerical,
        measured=measured,
        actuator_force=f_act,
        ground=ag_half[: 2 * n : 2].copy(),
        command=command,
    )
