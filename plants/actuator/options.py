"""Options of the actuator kinds (the ``[actuator]`` table): ``transfer_function`` and
``servo_hydraulic``.  Both take a pure ``delay`` [s] and a ``velocity_limit`` [m/s] (flow limit),
which the :class:`plants.actuator.base.Actuator` base class applies."""

from __future__ import annotations

from dataclasses import dataclass, fields

from plants.actuator.linear import check_transfer_function
from plants.actuator.parameters import (
    BENCHMARK,
    HEAVY_INERTIAL_LOAD,
    MTS_IDENTIFIED,
    BenchmarkParameters,
)
from rths.core.errors import (
    ParameterError,
    check_in_range,
    check_positive,
    format_choices,
)

__all__ = ["MAX_DELAY", "ServoHydraulicOptions", "TransferFunctionOptions"]

_SERVO_PRESETS = {"benchmark": BENCHMARK, "heavy_inertial_load": HEAVY_INERTIAL_LOAD}
_TF_PRESETS = {"mts_identified": MTS_IDENTIFIED}


#: Longest actuator transport delay [s]: no servo-hydraulic actuator lags by more (the MTS and
#: benchmark actuators: a few to 30 ms).
MAX_DELAY = 1.0


def _check_common(delay: float, velocity_limit: float | None) -> None:
    check_in_range(delay, "actuator delay [s]", 0.0, MAX_DELAY)
    if velocity_limit is not None:
        check_positive(velocity_limit, "actuator velocity_limit")


@dataclass(frozen=True)
class TransferFunctionOptions:
    """A command→displacement transfer function identified with the specimen attached.

    Parameters
    ----------
    num, den
        Coefficients in descending powers of s (proper, stable); or a ``preset``.
    nominal_num, nominal_den
        A different model for the compensator (an identification error); default: the same.
    delay
        Pure delay [s] on the command path, >= 0.
    velocity_limit
        Flow (rate) limit [m/s] of the displacement, > 0; none by default.
    """

    num: tuple[float, ...] | None = None
    den: tuple[float, ...] | None = None
    nominal_num: tuple[float, ...] | None = None
    nominal_den: tuple[float, ...] | None = None
    delay: float = 0.0
    velocity_limit: float | None = None

    def __post_init__(self) -> None:
        if self.num is None or self.den is None:
            raise ParameterError("num/den: give both num and den, or a preset")
        if (self.nominal_num is None) != (self.nominal_den is None):
            raise ParameterError("nominal_num/nominal_den: give both, or neither")
        _check_common(self.delay, self.velocity_limit)
        check_transfer_function(self.num, self.den, "actuator transfer function num/den")
        if self.nominal_num is not None and self.nominal_den is not None:
            check_transfer_function(
                self.nominal_num, self.nominal_den, "nominal transfer function nominal_num/den"
            )

    @staticmethod
    def presets() -> tuple[str, ...]:
        """Identified transfer functions shipped with the project."""
        return tuple(_TF_PRESETS)

    @classmethod
    def from_preset(cls, name: str, **overrides: object) -> TransferFunctionOptions:
        """The preset's ``num``/``den`` with other keys given (``num``/``den`` override it)."""
        if name not in _TF_PRESETS:
            raise ParameterError(
                f"unknown transfer_function preset {name!r}; choose one of "
                f"{format_choices(sorted(_TF_PRESETS))}"
            )
        tf = _TF_PRESETS[name]
        values: dict[str, object] = {"num": tuple(tf.num), "den": tuple(tf.den)} | overrides
        return cls(**values)  # type: ignore[arg-type]

    @property
    def nominal(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """The compensator's ``(num, den)``."""
        if self.nominal_num is not None and self.nominal_den is not None:
            return self.nominal_num, self.nominal_den
        assert self.num is not None and self.den is not None  # __post_init__
        return self.num, self.den


@dataclass(frozen=True)
class ServoHydraulicOptions(BenchmarkParameters):
    """The vRTHS benchmark servo-hydraulic actuator with control--structure interaction: every
    field of :class:`plants.actuator.parameters.BenchmarkParameters` (documented there), plus the
    keys below.

    The loop (design.md section 5; Silva et al. 2020 -- not in the seed papers, which use a
    physical MTS 204.63 actuator) is, with ``e = gain*command - x - pressure_feedback*F_a`` [m],
    the servo-valve flow ``q = a1_beta0 / (s^2 + beta1 s + beta2) e`` [N/s], the hydraulics
    ``(s + a3) F_a = q - a2 xdot`` [N/s] and the mechanics
    ``(piston_mass + m_r) xddot + (piston_damping + c_r) xdot = F_a - F_rest`` [N], ``m_r`` and
    ``c_r`` being the specimen's rigid part.

    Parameters
    ----------
    substeps
        Internal sub-steps per loop step (default: sub-steps <= 1/16384 s).
    delay
        Pure delay [s] on the command path, >= 0.
    velocity_limit
        Flow (rate) limit [m/s] of the displacement, > 0; none by default.
    """

    substeps: int | None = None
    delay: float = 0.0
    velocity_limit: float | None = None

    def __post_init__(self) -> None:
        BenchmarkParameters.__post_init__(self)
        if self.substeps is not None and self.substeps < 1:
            raise ParameterError(f"substeps must be >= 1; got {self.substeps!r}")
        _check_common(self.delay, self.velocity_limit)

    @staticmethod
    def presets() -> tuple[str, ...]:
        """``benchmark`` (light specimens) and ``heavy_inertial_load`` (inerters of ~1.6 t)."""
        return tuple(_SERVO_PRESETS)

    @classmethod
    def from_preset(cls, name: str, **overrides: object) -> ServoHydraulicOptions:
        """The preset's hydraulics with some fields replaced."""
        if name not in _SERVO_PRESETS:
            raise ParameterError(
                f"unknown servo_hydraulic preset {name!r}; choose one of "
                f"{format_choices(sorted(_SERVO_PRESETS))}"
            )
        base = _SERVO_PRESETS[name]
        values = {f.name: getattr(base, f.name) for f in fields(BenchmarkParameters)}
        return cls(**(values | overrides))

    @property
    def hydraulics(self) -> BenchmarkParameters:
        """The :class:`BenchmarkParameters` part."""
        return BenchmarkParameters(
            **{f.name: getattr(self, f.name) for f in fields(BenchmarkParameters)}
        )
