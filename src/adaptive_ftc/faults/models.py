"""Actuator failure models (thesis §1.4, (2.6)-(2.9), (3.4), (4.3); SPEC §2).

Every failure acts on one actuator (numbered from 1, as in the thesis) on ``[onset, recovery)``
and replaces the actuator's output ``u`` by an expression of ``u``, the time ``t`` and the plant
state ``x1..xn``. Abrupt failures switch at ``onset``; with ``ramp > 0`` the failure is incipient
and blends in linearly from the healthy output over ``ramp`` seconds. Each failure declares the
times at which the closed loop is discontinuous (:attr:`Failure.jump_times`), so the engine can
restart integration exactly there.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.expressions import Expression

__all__ = [
    "Affine",
    "Bias",
    "Failure",
    "LossOfEffectiveness",
    "NonAffine",
    "ParameterisedStuck",
    "PositionLimit",
    "RateLimited",
    "Reversal",
    "Sluggish",
    "Stuck",
]

Value = float | str


def _text(value: Value) -> str:
    if isinstance(value, bool):
        raise ConfigurationError(f"Expected a number or an expression string, got {value!r}.")
    if isinstance(value, (int, float)):
        if not math.isfinite(value):
            raise ConfigurationError(f"Failure values must be finite; got {value}.")
        return repr(float(value))
    return str(value)


def _paren(value: Value) -> str:
    return f"({_text(value)})"


@dataclass(frozen=True, kw_only=True)
class Failure(ABC):
    """Base of all failure models.

    Parameters
    ----------
    actuator
        Actuator number, from 1.
    onset
        Failure time in seconds.
    recovery
        Time at which the actuator is healthy again (``None``: never).
    ramp
        Duration of an incipient onset (0: abrupt).
    """

    model: ClassVar[str]

    actuator: int
    onset: float = 0.0
    recovery: float | None = None
    ramp: float = 0.0

    def __post_init__(self) -> None:
        name = type(self).__name__
        if (
            isinstance(self.actuator, bool)
            or not isinstance(self.actuator, int)
            or self.actuator < 1
        ):
            raise ConfigurationError(
                f"`actuator` of {name} must be an actuator number from 1; got {self.actuator!r}."
            )
        if not (
            isinstance(self.onset, (int, float)) and math.isfinite(self.onset) and self.onset >= 0
        ):
            raise ConfigurationError(
                f"`onset` of {name} must be a finite time >= 0 s; got {self.onset!r}."
            )
        if self.recovery is not None and not (
            isinstance(self.recovery, (int, float)) and self.recovery > self.onset
        ):
            raise ConfigurationError(
                f"`recovery` of {name} must be later than its onset ({self.onset} s); "
                f"got {self.recovery!r}."
            )
        if not (
            isinstance(self.ramp, (int, float)) and math.isfinite(self.ramp) and self.ramp >= 0
        ):
            raise ConfigurationError(f"`ramp` of {name} must be >= 0 s; got {self.ramp!r}.")
        if self.recovery is not None and self.ramp > self.recovery - self.onset:
            raise ConfigurationError(
                f"`ramp` of {name} ({self.ramp} s) must fit between onset and recovery."
            )
        self.expression(("t", "u"), strict=False)  # validate the pattern early

    @abstractmethod
    def pattern(self) -> str:
        """The failed output as an expression of ``u``, ``t`` and the states."""

    @property
    def end(self) -> float:
        """End of the active window (``inf`` when the actuator never recovers)."""
        return math.inf if self.recovery is None else float(self.recovery)

    @property
    def jump_times(self) -> tuple[float, ...]:
        """Times where the closed loop is discontinuous (or has a kink) because of this failure."""
        times = [float(self.onset)]
        if self.ramp > 0:
            times.append(float(self.onset + self.ramp))
        if self.recovery is not None:
            times.append(float(self.recovery))
        return tuple(times)

    def active(self, t: float) -> bool:
        """Whether the failure acts at time ``t`` (window ``[onset, recovery)``)."""
        return self.onset <= t < self.end

    def severity(self, scales: Mapping[str, float] | None = None) -> float:
        """How much authority the failure takes from its actuator, in [0, 1] (``nan``: this
        model is not rated, or its value is an expression).

        ``scales`` gives the largest magnitude a field can take (a campaign's distribution of
        it), for models rated relative to it (:class:`Bias`). The default: not rated.
        """
        return math.nan

    def expression(
        self, variables: tuple[str, ...], *, strict: bool = True, context: str = ""
    ) -> Expression:
        """Compile the failed output into an :class:`Expression` over ``variables``.

        With ``strict=False`` unknown state names are tolerated (used before the plant is
        known); the real check happens when the closed loop is assembled.
        """
        text = self.pattern()
        if self.ramp > 0:
            w = f"min((t - {float(self.onset)!r})/{float(self.ramp)!r}, 1.0)"
            text = f"u + {w}*(({text}) - u)"
        ctx = context or f"{type(self).__name__}(actuator={self.actuator})"
        if not strict:
            variables = tuple(sorted(set(variables) | _names_in(text)))
        return Expression(text, tuple(variables), context=ctx)


def _names_in(text: str) -> set[str]:
    import ast

    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError:
        return set()
    from adaptive_ftc.expressions import FUNCTIONS

    names = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
    # only state-like names are tolerated before the plant is known
    return {
        n for n in names if n not in FUNCTIONS and n not in ("pi", "e") and not n.startswith("_")
    }


@dataclass(frozen=True, kw_only=True)
class LossOfEffectiveness(Failure):
    """Partial or total loss of effectiveness ``u^f = rho(t, x) u`` (eqs. (1.1), (2.6)).

    ``effectiveness`` is a number in [0, 1] or an expression (time-varying, e.g.
    ``"exp(-(t - 25))"``).

    Examples
    --------
    >>> LossOfEffectiveness(actuator=2, onset=50.0, effectiveness=0.75).pattern()
    '(0.75)*u'
    """

    model: ClassVar[str] = "loss_of_effectiveness"
    effectiveness: Value = 1.0

    def __post_init__(self) -> None:
        if (
            isinstance(self.effectiveness, (int, float))
            and not isinstance(self.effectiveness, bool)
            and not 0.0 <= self.effectiveness <= 1.0
        ):
            raise ConfigurationError(
                f"`effectiveness` of LossOfEffectiveness must be in [0, 1]; got "
                f"{self.effectiveness}. Use Affine or Reversal for other gains."
            )
        super().__post_init__()

    def pattern(self) -> str:
        return f"{_paren(self.effectiveness)}*u"

    def severity(self, scales: Mapping[str, float] | None = None) -> float:
        """``1 - effectiveness`` (``nan`` when the effectiveness is an expression)."""
        v = self.effectiveness
        return float(min(1.0, max(0.0, 1.0 - v))) if isinstance(v, (int, float)) else math.nan


@dataclass(frozen=True, kw_only=True)
class Stuck(Failure):
    """Total loss of effectiveness: the output is ``u_bar(t, x)`` whatever the command
    (eqs. (2.7), (2.8)). A constant is lock-in-place; ``0`` is a floating surface."""

    model: ClassVar[str] = "stuck"
    value: Value = 0.0

    def pattern(self) -> str:
        return _paren(self.value)

    def severity(self, scales: Mapping[str, float] | None = None) -> float:
        """1: the actuator has no authority left, whatever the values."""
        return 1.0


@dataclass(frozen=True, kw_only=True)
class ParameterisedStuck(Failure):
    """Stuck at ``u_bar(t) = sum_l coefficients[l] * basis[l](t)`` (eqs. (2.8), (2.51))."""

    model: ClassVar[str] = "parameterised_stuck"
    coefficients: tuple[float, ...] = ()
    basis: tuple[str, ...] = ("1",)

    def __post_init__(self) -> None:
        if len(self.coefficients) != len(self.basis) or not self.basis:
            raise ConfigurationError(
                f"ParameterisedStuck needs one coefficient per basis function; got "
                f"{len(self.coefficients)} coefficients for {len(self.basis)} basis functions."
            )
        super().__post_init__()

    def pattern(self) -> str:
        return " + ".join(
            f"{_paren(c)}*{_paren(b)}" for c, b in zip(self.coefficients, self.basis, strict=True)
        )

    def severity(self, scales: Mapping[str, float] | None = None) -> float:
        """1: the actuator has no authority left, whatever the values."""
        return 1.0


@dataclass(frozen=True, kw_only=True)
class Bias(Failure):
    """Additive bias ``u^f = u + u_bar(t, x)`` (eq. (1.2))."""

    model: ClassVar[str] = "bias"
    bias: Value = 0.0

    def pattern(self) -> str:
        return f"u + {_paren(self.bias)}"

    def severity(self, scales: Mapping[str, float] | None = None) -> float:
        """``|bias| / scales["bias"]`` (``nan`` without a scale or for an expression)."""
        if not scales or "bias" not in scales:
            return math.nan
        v = self.bias
        if not isinstance(v, (int, float)):
            return math.nan
        return float(min(1.0, abs(v) / (scales["bias"] or 1.0)))


@dataclass(frozen=True, kw_only=True)
class Affine(Failure):
    """State-dependent affine failure ``u^f = rho(x, t) u + u_bar(x, t)`` (eqs. (1.3), (3.4))."""

    model: ClassVar[str] = "affine"
    effectiveness: Value = 1.0
    bias: Value = 0.0

    def pattern(self) -> str:
        return f"{_paren(self.effectiveness)}*u + {_paren(self.bias)}"

    def severity(self, scales: Mapping[str, float] | None = None) -> float:
        """``1 - effectiveness`` (``nan`` when the effectiveness is an expression)."""
        v = self.effectiveness
        return float(min(1.0, max(0.0, 1.0 - v))) if isinstance(v, (int, float)) else math.nan


@dataclass(frozen=True, kw_only=True)
class NonAffine(Failure):
    """General non-affine failure ``u^f = f(x, u, t)`` (eqs. (1.4), (4.3)).

    Examples
    --------
    >>> NonAffine(actuator=1, onset=40.0, output="0.75*u**3 - 0.2").pattern()
    '(0.75*u**3 - 0.2)'
    """

    model: ClassVar[str] = "nonaffine"
    output: str = "u"

    def pattern(self) -> str:
        return _paren(self.output)


@dataclass(frozen=True, kw_only=True)
class Reversal(Failure):
    """Control reversal ``u^f = -u`` (as in fault simulators such as NASA GUAM)."""

    model: ClassVar[str] = "reversal"

    def pattern(self) -> str:
        return "-u"

    def severity(self, scales: Mapping[str, float] | None = None) -> float:
        """1: the actuator has no authority left, whatever the values."""
        return 1.0


@dataclass(frozen=True, kw_only=True)
class PositionLimit(Failure):
    """Reduced travel: the output saturates in ``[lower, upper]``."""

    model: ClassVar[str] = "position_limit"
    lower: float = -math.inf
    upper: float = math.inf

    def __post_init__(self) -> None:
        if not self.lower < self.upper:
            raise ConfigurationError(
                f"PositionLimit needs lower < upper; got lower={self.lower}, upper={self.upper}."
            )
        super().__post_init__()

    def pattern(self) -> str:
        # an infinite bound is left out (a literal such as 1e300 is refused by the expression
        # language, whose numbers are at most 1e100 in magnitude)
        lo, hi = math.isfinite(self.lower), math.isfinite(self.upper)
        if lo and hi:
            return f"clip(u, {_text(self.lower)}, {_text(self.upper)})"
        if lo:
            return f"max(u, {_text(self.lower)})"
        return f"min(u, {_text(self.upper)})" if hi else "u"


@dataclass(frozen=True, kw_only=True)
class _DynamicsFailure(Failure):
    """A failure of the actuator's dynamics, not of its static output map: the actuator
    delivers its deflection unchanged but moves differently (see :mod:`adaptive_ftc.hardware`).
    A loop with such a failure has actuator states even without declared ``Actuators``."""

    def __post_init__(self) -> None:
        if self.ramp:
            raise ConfigurationError(
                f"{type(self).__name__} changes the actuator's dynamics at its onset; it has no "
                "incipient form: remove `ramp`."
            )
        super().__post_init__()

    def pattern(self) -> str:
        return "u"

    def dynamics(self) -> dict[str, float]:
        """The entries of the actuator table it replaces (``tau``, ``rate``)."""
        raise NotImplementedError


@dataclass(frozen=True, kw_only=True)
class RateLimited(_DynamicsFailure):
    """The actuator cannot move faster than ``rate`` (units/s): a jammed or weakened drive
    (GUAM's rate-limit failure). Without a declared lag it uses
    :data:`adaptive_ftc.hardware.RATE_ONLY_TAU`."""

    model: ClassVar[str] = "rate_limited"
    rate: float = math.inf

    def __post_init__(self) -> None:
        if (
            isinstance(self.rate, bool)
            or not isinstance(self.rate, (int, float))
            or not self.rate > 0
        ):
            raise ConfigurationError(
                f"`rate` of RateLimited must be a positive rate limit; got {self.rate!r}."
            )
        super().__post_init__()

    def dynamics(self) -> dict[str, float]:
        return {"rate": float(self.rate)}


@dataclass(frozen=True, kw_only=True)
class Sluggish(_DynamicsFailure):
    """The actuator follows its command with the first-order lag ``tau`` (s): lost bandwidth
    (GUAM's bandwidth failure). A second-order actuator becomes this first-order one."""

    model: ClassVar[str] = "sluggish"
    tau: float = 0.0

    def __post_init__(self) -> None:
        if (
            isinstance(self.tau, bool)
            or not isinstance(self.tau, (int, float))
            or not (math.isfinite(self.tau) and self.tau > 0)
        ):
            raise ConfigurationError(
                f"`tau` of Sluggish must be a positive time constant in seconds; got {self.tau!r}."
            )
        super().__post_init__()

    def dynamics(self) -> dict[str, float]:
        return {"tau": float(self.tau), "omega": 0.0}


#: Failure models by the name used in scenario files.
FAILURE_MODELS: dict[str, type[Failure]] = {
    cls.model: cls
    for cls in (
        LossOfEffectiveness,
        Stuck,
        ParameterisedStuck,
        Bias,
        Affine,
        NonAffine,
        Reversal,
        PositionLimit,
        RateLimited,
        Sluggish,
    )
}
