"""Calibration of the uncontrolled primary structure (PS) on the numbers S1 reports for it
(private; re-exported by :mod:`plants.tmdi.structure`).

S1 identifies its HDRB coefficients (S1 §4.2, Eq.14) on the TMDI-equipped structure at PGA
0.10 g only, and gives no model of the PS alone.  For the uncontrolled tests it reports three
numbers (:data:`S1_UNCONTROLLED`):

* the absolute peak PS displacement ``u_I``: 5 mm at 0.05 g and 38 mm at 0.15 g (S1 §3.1,
  Fig.4a-c; the down sweep, whose peak is the higher, S1 Fig.5);
* the PS resonance ``f0 = 2.25 Hz`` at 0.10 g (S1 Fig.12/14 captions);

and the qualitative softening of S1 Fig.4/5 (down-sweep peaks higher and at lower frequency than
up-sweep peaks, more so at larger PGA), which is kept for validation, not fitted.

Model.  The PS of S1 Eq.12 without TMDI, ``m_I ü + c(A) u̇ + s F_E(u) = -m_I ü_G``, with the S1
§4.2 spring ``F_E`` scaled by ``s`` and the damping law ``c(A) = c_ref (A/A_ref)^(-n)`` of
:class:`plants.tmdi.hdrb.AmplitudeDamping` (held constant outside the reported 5-38 mm).  Unknowns
``(c_ref, n, s)``, or ``(c_ref, n)`` with ``s = 1``.

Prediction.  Harmonic balance with the describing-function stiffness ``k(A)``
(:meth:`plants.tmdi.hdrb.HDRB.equivalent_stiffness`): a harmonic response of amplitude ``A`` at
``ω`` satisfies ``A²[(k(A) - mω²)² + (c(A)ω)²] = (m a_g)²``.  Its crest -- the largest amplitude of
the branch that grows from rest, which a down sweep climbs to before it drops (S1 Fig.5) -- is the
first root of ``A c(A) sqrt(4 m k(A) - c(A)²) = 2 m² a_g``, at ``ω² = k/m - c²/(2m²)``
(:func:`harmonic_balance_crest`).  The crest amplitude is compared with the reported peak and the
crest frequency at 0.10 g with ``f0``.  Harmonic balance misses the time-domain crest of the
emulated sweep (online amplitude estimate, ``max |u|`` rather than the first harmonic, the
describing function) by up to 1.6 % at 38 mm, so the fit is corrected to the time domain:
:func:`stepped_sine_crest` runs the PS through a fine (5 mHz) down sweep around the crest, and
the harmonic-balance targets are rescaled by the time-domain/harmonic-balance ratio at the
current parameters until the time-domain crests settle (output space mapping; 4-5 iterations).

Fit.  Weighted least squares (:func:`scipy.optimize.least_squares`, trust-region reflective with
bounds ``0 <= n <= 1``, ``0.5 <= s <= 1.5``) on residuals scaled by the reading uncertainty of
each number: half a millimetre for peaks printed to the millimetre, half the 0.05 Hz frequency
step for ``f0``.  With ``s`` free, three numbers fix three unknowns: ``c_ref = 623.0 N s/m`` at
``A_ref = 10 mm``, ``n = 0.3596``, ``s = 0.8319`` with time-domain residuals below 0.003 of the
reading uncertainties (5.000 mm, 38.00 mm, 2.2500 Hz).  With ``s = 1`` the best harmonic-balance
fit leaves 6.5 mm (+3.1), 38.4 mm (+0.8) and 2.45 Hz (+8.0 reading uncertainties): the
uncontrolled tests need a bearing 17 % softer than S1's identification with the TMDI.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final

import numpy as np
import scipy.optimize
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import brentq

from plants.tmdi.hdrb import AMPLITUDE_RANGE, HDRB, S1_PRIMARY, AmplitudeDamping
from plants.tmdi.integration import kernel as kern
from plants.tmdi.integration import layout
from plants.tmdi.parameters import TMDIParameters
from rths.core.errors import NumericalError, ParameterError, check_positive

__all__ = [
    "S1_UNCONTROLLED",
    "PSCalibration",
    "UncontrolledObservations",
    "calibrate_uncontrolled_ps",
    "harmonic_balance_crest",
    "stepped_sine_crest",
]

_GRAVITY: Final[float] = 9.80665  # m/s², the unit of S1's PGA
_CYCLES: Final[int] = 20  # cycles per step (S1 §2.3)
#: final cycles of a step whose peak is its amplitude (the S1 sweep's default)
_STEADY: Final[int] = 5
#: The output correction stops when the emulated crests move by less than this many reading
#: uncertainties between iterations (2 %: 10 µm on a peak, 0.5 mHz on f0), a few times the
#: jitter of the parabola-refined crest frequency of the 5 mHz grid.
SETTLED: Final[float] = 0.02


@dataclass(frozen=True, slots=True)
class UncontrolledObservations:
    """What S1 reports about the uncontrolled PS tests, with reading uncertainties.

    Attributes
    ----------
    mass
        ``m_I`` [kg] (S1 §2.2).
    peaks
        ``((PGA [g], peak u_I [m]), ...)`` (S1 §3.1).
    peak_uncertainty
        Reading uncertainty of the peaks [m].
    resonance
        ``(PGA [g], f0 [Hz])`` (S1 Fig.12 caption).
    resonance_uncertainty
        Reading uncertainty of ``f0`` [Hz].
    """

    mass: float
    peaks: tuple[tuple[float, float], ...]
    peak_uncertainty: float
    resonance: tuple[float, float]
    resonance_uncertainty: float


#: S1's uncontrolled-PS numbers: 5 mm at 0.05 g, 38 mm at 0.15 g (S1 §3.1, printed to 1 mm:
#: ±0.5 mm); f0 = 2.25 Hz at 0.10 g (S1 Fig.12, on the 0.05 Hz grid of S1 §2.3: ±0.025 Hz).
S1_UNCONTROLLED: Final[UncontrolledObservations] = UncontrolledObservations(
    mass=125.0,
    peaks=((0.05, 0.005), (0.15, 0.038)),
    peak_uncertainty=0.0005,
    resonance=(0.10, 2.25),
    resonance_uncertainty=0.025,
)


def harmonic_balance_crest(isolator: HDRB, mass: float, pga: float) -> tuple[float, float]:
    """Crest of the harmonic-balance response of the PS alone (module docstring).

    Parameters
    ----------
    isolator
        The bearing (its damping law, if any, gives ``c(A)``).
    mass
        ``m_I`` [kg].
    pga
        Ground acceleration amplitude [g].

    Returns
    -------
    amplitude, frequency
        Crest amplitude [m] and its frequency [Hz].

    Raises
    ------
    NumericalError
        If the branch has no crest below 1 m or the bearing's monotonic limit.
    """
    m = check_positive(mass, "mass")
    a_g = check_positive(pga, "PGA") * _GRAVITY

    def gap(a: ArrayLike) -> NDArray[np.float64]:
        c = np.asarray(isolator.damping_coefficient(a))
        k = np.asarray(isolator.equivalent_stiffness(a))
        return a * c * np.sqrt(np.maximum(4.0 * m * k - c * c, 0.0)) - 2.0 * m * m * a_g

    top = min(isolator.monotonic_limit(), 1.0)
    grid = np.geomspace(1e-6, top, 400)
    values = gap(grid)
    crossings = np.flatnonzero((values[:-1] < 0.0) & (values[1:] >= 0.0))
    if crossings.size == 0:
        raise NumericalError(
            f"no harmonic-balance crest below {top!r} m at PGA {pga!r} g: the response runs away"
        )
    i = int(crossings[0])
    amplitude = brentq(lambda a: float(gap(a)), grid[i], grid[i + 1], xtol=1e-13, rtol=1e-12)
    c = float(isolator.damping_coefficient(amplitude))
    k = float(isolator.equivalent_stiffness(amplitude))
    return amplitude, math.sqrt(k / m - c * c / (2.0 * m * m)) / (2.0 * math.pi)


def stepped_sine_crest(
    isolator: HDRB,
    mass: float,
    pga: float,
    band: tuple[float, float],
    step: float = 0.005,
    dt: float = 1e-3,
) -> tuple[float, float]:
    """Crest of the PS response to a fine down sweep, integrated in time (module docstring).

    ``ü_G = PGA g sin(2π f_k τ)`` for 20 whole cycles per step (S1 §2.3; a perfect table) from
    ``band[1]`` down to ``band[0]`` in steps of ``step``; the PS
    (:class:`plants.tmdi.structure.TMDIStructure` kernel, online damping law) starts from rest.
    Each step's amplitude is ``max |u_I|`` over its last 5 cycles (S1's "peak",
    :mod:`rths.experiments.s1_shake_table.frf`); the crest is refined by the parabola through the
    largest step and its two neighbours.

    Parameters
    ----------
    isolator, mass, pga
        As :func:`harmonic_balance_crest`.
    band
        ``(f_lo, f_hi)`` [Hz], ``0 < f_lo < f_hi``: the sweep range.
    step
        Frequency step [Hz].
    dt
        Integration and sampling step [s].

    Returns
    -------
    amplitude, frequency
        Crest amplitude [m] and frequency [Hz].

    Raises
    ------
    NumericalError
        If the integration fails or the largest step is at an end of the band.
    """
    a_g = check_positive(pga, "PGA") * _GRAVITY
    step = check_positive(step, "frequency step")
    dt = check_positive(dt, "time step dt")
    lo, hi = (check_positive(f, "sweep band") for f in band)
    if hi - lo < 2.0 * step:
        raise ParameterError(
            f"sweep band must span at least two steps of {step!r} Hz; got {band!r}"
        )
    freqs = hi - step * np.arange(math.floor((hi - lo) / step + 1e-9) + 1)
    bounds = np.concatenate([[0.0], np.cumsum(_CYCLES / freqs)])
    t = np.arange(math.ceil(bounds[-1] / dt - 1e-9) + 1) * dt
    k = np.clip(np.searchsorted(bounds, t, side="right") - 1, 0, freqs.size - 1)
    ag = np.where(t < bounds[-1], a_g * np.sin(2.0 * np.pi * freqs[k] * (t - bounds[k])), 0.0)
    params = layout.pack_parameters(TMDIParameters(mass, isolator))
    out, failures = kern.simulate(ag, dt, 1, params, np.zeros(layout.N_STATE))
    if failures or not np.all(np.isfinite(out)):
        raise NumericalError(f"PS time integration failed at PGA {pga!r} g")
    u = np.abs(out[:, layout.O_U_I])
    peaks = np.array(
        [
            np.max(u[math.ceil((b - _STEADY / f) / dt - 1e-9) : math.ceil(b / dt - 1e-9)])
            for f, b in zip(freqs, bounds[1:])
        ]
    )
    i = int(np.argmax(peaks))
    if i in (0, freqs.size - 1):
        raise NumericalError(
            f"the largest response of the sweep is at its edge, {freqs[i]!r} Hz: widen the band "
            f"{band!r}"
        )
    y0, y1, y2 = peaks[i - 1], peaks[i], peaks[i + 1]  # at f_i + step, f_i, f_i - step
    curvature = y0 - 2.0 * y1 + y2
    shift = 0.0 if curvature >= 0.0 else 0.5 * (y0 - y2) / curvature  # in steps toward f_i - step
    shift = float(np.clip(shift, -1.0, 1.0))
    return float(y1 - 0.25 * (y0 - y2) * shift), float(freqs[i] - shift * step)


@dataclass(frozen=True, slots=True)
class PSCalibration:
    """Result of :func:`calibrate_uncontrolled_ps`.

    Attributes
    ----------
    isolator
        The calibrated primary bearing.
    reference_damping
        ``c_ref = c(A_ref)`` [N s/m].
    exponent
        ``n`` [-].
    stiffness_scale
        ``s`` [-] (1 when not fitted).
    peaks
        Predicted peak amplitudes [m] at the observed PGAs, in the order of the observations:
        :func:`stepped_sine_crest` (or :func:`harmonic_balance_crest` without time domain).
    resonance
        Predicted ``f0`` [Hz] at the PGA of the observed one (same method).
    residuals
        ``(prediction - observation) / uncertainty`` [-]: the peaks, then ``f0``.
    harmonic_balance
        The harmonic-balance crests ``((A [m], f [Hz]), ...)`` at the peak PGAs, then at the
        ``f0`` PGA, for the calibrated bearing.
    iterations
        Output-correction iterations used (0 without time domain).
    """

    isolator: HDRB
    reference_damping: float
    exponent: float
    stiffness_scale: float
    peaks: tuple[float, ...]
    resonance: float
    residuals: tuple[float, ...]
    harmonic_balance: tuple[tuple[float, float], ...]
    iterations: int


def calibrate_uncontrolled_ps(
    observations: UncontrolledObservations = S1_UNCONTROLLED,
    base: HDRB = S1_PRIMARY,
    reference_amplitude: float = 0.010,
    fit_stiffness: bool = True,
    time_domain: bool = True,
    max_iterations: int = 6,
) -> PSCalibration:
    """Fit the damping law (and a spring scale) of the PS bearing to S1's uncontrolled tests.

    The harmonic-balance crests are fitted by weighted least squares (module docstring).  With
    ``time_domain`` the fit is then corrected to the time-domain emulation (output space
    mapping): the targets of the harmonic-balance fit become the observations times the ratio
    harmonic balance / :func:`stepped_sine_crest` at the current parameters (for ``f0`` the
    difference), and the fit is repeated until the parameters settle (relative change below
    1e-6), so the *emulated* crests meet the observations.

    Parameters
    ----------
    observations
        The reported numbers (default :data:`S1_UNCONTROLLED`).
    base
        Bearing whose springs are kept (scaled by ``s``): S1 §4.2 by default.
    reference_amplitude
        ``A_ref`` [m] of the law (where ``c_ref`` applies; a choice of units, not a fit).
    fit_stiffness
        Fit ``s`` too (three unknowns, three numbers) or keep ``s = 1``.
    time_domain
        Correct the fit to the time-domain crests (a few seconds) or stop at harmonic balance.
    max_iterations
        Most output-correction iterations (>= 1).

    Returns
    -------
    PSCalibration
        The bearing, the parameters, predictions and scaled residuals.

    Raises
    ------
    NumericalError
        If a least-squares fit fails or the correction does not settle.
    """
    obs = observations
    a_ref = check_positive(reference_amplitude, "reference amplitude A_ref")
    if not obs.peaks:
        raise ParameterError("the calibration needs at least one observed peak; got none")
    if (
        isinstance(max_iterations, bool)
        or not isinstance(max_iterations, int)
        or max_iterations < 1
    ):
        raise ParameterError(f"max_iterations must be a positive integer; got {max_iterations!r}")
    pgas = [pga for pga, _ in obs.peaks] + [obs.resonance[0]]
    observed = np.array([u for _, u in obs.peaks] + [obs.resonance[1]])
    scale = np.array([obs.peak_uncertainty] * len(obs.peaks) + [obs.resonance_uncertainty])
    n_peaks = len(obs.peaks)

    def bearing(x: NDArray[np.float64]) -> HDRB:
        law = AmplitudeDamping(float(x[1]), a_ref, AMPLITUDE_RANGE)
        return (
            base.with_damping(float(math.exp(x[0])))
            .with_damping_law(law)
            .with_stiffness_scale(float(x[2]) if fit_stiffness else 1.0)
        )

    def harmonic(iso: HDRB) -> list[tuple[float, float]]:
        return [harmonic_balance_crest(iso, obs.mass, pga) for pga in pgas]

    def measured(crests: list[tuple[float, float]]) -> NDArray[np.float64]:
        return np.array([a for a, _ in crests[:n_peaks]] + [crests[-1][1]])

    def fit(target: NDArray[np.float64], x0: NDArray[np.float64]) -> NDArray[np.float64]:
        def residuals(x: NDArray[np.float64]) -> NDArray[np.float64]:
            try:
                return (measured(harmonic(bearing(x))) - target) / scale
            except NumericalError:  # a run-away trial point: push back hard but finitely
                return np.full(target.size, 1e3)

        lower = [-np.inf, 0.0] + ([0.5] if fit_stiffness else [])
        upper = [np.inf, 1.0] + ([1.5] if fit_stiffness else [])
        sol = scipy.optimize.least_squares(
            residuals, x0, bounds=(lower, upper), xtol=1e-14, ftol=1e-14, gtol=1e-14
        )
        if not sol.success:
            raise NumericalError(f"PS calibration did not converge: {sol.message}")
        return np.asarray(sol.x)

    def simulated(iso: HDRB, crests: list[tuple[float, float]]) -> NDArray[np.float64]:
        td = [
            stepped_sine_crest(iso, obs.mass, pga, (0.95 * f, 1.05 * f))
            for pga, (_, f) in zip(pgas, crests)
        ]
        return measured(td)

    x = fit(
        observed, np.array([math.log(max(base.c, 1.0)), 0.3] + ([1.0] if fit_stiffness else []))
    )
    iterations = 0
    crests = harmonic(bearing(x))
    predicted = measured(crests)
    if time_domain:
        previous = None
        for iterations in range(1, max_iterations + 1):
            predicted = simulated(bearing(x), crests)
            if previous is not None and np.max(np.abs(predicted - previous) / scale) <= SETTLED:
                break
            previous = predicted
            target = observed * measured(crests) / predicted
            target[-1] = observed[-1] + measured(crests)[-1] - predicted[-1]
            x = fit(target, x)
            crests = harmonic(bearing(x))
        else:
            raise NumericalError(f"PS calibration did not settle in {max_iterations} iterations")
    iso = bearing(x)
    return PSCalibration(
        isolator=iso,
        reference_damping=iso.c,
        exponent=float(x[1]),
        stiffness_scale=float(x[2]) if fit_stiffness else 1.0,
        peaks=tuple(float(p) for p in predicted[:n_peaks]),
        resonance=float(predicted[-1]),
        residuals=tuple(float(r) for r in (predicted - observed) / scale),
        harmonic_balance=tuple((float(a), float(f)) for a, f in crests),
        iterations=iterations,
    )
