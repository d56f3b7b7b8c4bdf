"""Real actuators and sensors: what the thesis idealises away (issue 14).

The thesis's actuators reach any commanded deflection at once, its controller sees the exact
state, and it runs in continuous time. These parts add, per closed loop:

- :class:`Actuators`: position limits, rate limits and first-order lag, per actuator. Each
  actuator then has a state ``a_j`` (its deflection) with

  .. math:: \\dot a_j = \\operatorname{clip}\\Big(\\frac{\\operatorname{clip}(u_j, l_j, h_j)
            - a_j}{\\tau_j}, -r_j, r_j\\Big),

  or, with a natural frequency ``omega_j`` instead of a lag, second-order dynamics
  ``a_j' = clip(v_j, -r_j, r_j)``, ``v_j' = omega_j^2 (clip(u_j, l_j, h_j) - a_j)
  - 2 zeta_j omega_j v_j`` (a velocity state ``v_j`` per actuator),

  and the failure acts on ``a_j`` (a stuck actuator stays where it is stuck, a lossy one
  delivers ``rho a_j``). A rate limit without a lag uses the time constant
  :data:`RATE_ONLY_TAU` (a rate limiter with a linear band ``r tau`` wide). The failure models
  :class:`~adaptive_ftc.faults.models.RateLimited` and
  :class:`~adaptive_ftc.faults.models.Sluggish` change ``r_j`` and ``tau_j`` during their window
  (GUAM's rate-limit and bandwidth failure types).
- :class:`Sensors`: seeded Gaussian measurement noise and a constant bias on each measured
  state. The controller (tracking errors, regressors, design laws) sees ``x + b + n_k``; the
  plant, the failures and the recorded tracking errors use the true state. Noise sample ``k``
  holds on ``[t0 + k T, t0 + (k+1) T)`` with ``T`` the controller's sample time, or ``1/rate``
  for a continuous controller. The same seed gives the same noise.
- a digital controller: ``ClosedLoop(sample_time=T)`` runs the whole controller (control law,
  adaptive laws, the ``s'`` filter) at the instants ``t0 + k T`` on the sampled measurement and
  holds its outputs: the command ``u`` is constant on each sample interval (zero-order hold) and
  every controller state advances by ``T`` times the derivative computed at the sample (forward
  Euler, the usual digital implementation of a continuous law). The plant is still integrated
  by the chosen solver between samples, exactly as a continuous system.

With noise or a digital controller the default ``s'`` is the dirty-derivative filter
(``SolverOptions(sdot="auto")``): the exact ``s'`` needs the true plant derivative, which no
sensor gives.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from adaptive_ftc.errors import ConfigurationError

__all__ = ["RATE_ONLY_TAU", "Actuators", "Sensors"]

#: Time constant (s) of an actuator given a rate limit but no lag.
RATE_ONLY_TAU = 0.005


def _per_actuator(
    value, m: int, name: str, *, allow_inf: bool, minimum: float | None, zero: bool = False
):
    vals = (value,) * m if isinstance(value, (int, float)) else tuple(value)
    if len(vals) != m:
        raise ConfigurationError(
            f"`{name}` of Actuators needs one value per actuator ({m}) or a single number; "
            f"got {len(vals)}."
        )
    out = []
    for v in vals:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v):
            raise ConfigurationError(f"`{name}` of Actuators must be numbers; got {v!r}.")
        if not allow_inf and not math.isfinite(v):
            raise ConfigurationError(f"`{name}` of Actuators must be finite; got {v!r}.")
        if minimum is not None and not v > minimum and not (zero and v == 0):
            raise ConfigurationError(f"`{name}` of Actuators must be > {minimum:g}; got {v!r}.")
        out.append(float(v))
    return tuple(out)


@dataclass(frozen=True, kw_only=True)
class Actuators:
    """Actuator dynamics of every actuator of the plant.

    Parameters
    ----------
    tau
        First-order lag time constant (s), one number or one per actuator; 0 = no lag.
    rate
        Rate limit (actuator units per second), one number or one per actuator; ``inf`` = none.
    lower, upper
        Position limits (actuator units); ``-inf``/``inf`` = none.
    omega, zeta
        Second-order dynamics instead of the lag: natural frequency (rad/s; 0 = none) and
        damping ratio, one number or one per actuator. An actuator has ``tau`` or ``omega``,
        not both.
    initial
        Initial deflections; empty = each actuator starts at its first command (no start-up
        transient).

    Examples
    --------
    >>> Actuators(tau=0.05, rate=1.0).table(2)[:, 0].tolist()
    [0.05, 0.05]
    """

    tau: float | tuple[float, ...] = 0.0
    rate: float | tuple[float, ...] = math.inf
    lower: float | tuple[float, ...] = -math.inf
    upper: float | tuple[float, ...] = math.inf
    omega: float | tuple[float, ...] = 0.0
    zeta: float | tuple[float, ...] = 0.7
    initial: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        for key in ("tau", "rate", "lower", "upper", "omega", "zeta"):
            v = getattr(self, key)
            if not isinstance(v, (int, float)):
                object.__setattr__(self, key, tuple(v))
        object.__setattr__(self, "initial", tuple(self.initial))

    def table(self, m: int) -> np.ndarray:
        """Per actuator ``[tau, rate, lower, upper, omega, zeta]`` (tau with
        :data:`RATE_ONLY_TAU` filled in), after checking every value for ``m`` actuators."""
        tau = _per_actuator(self.tau, m, "tau", allow_inf=False, minimum=0.0, zero=True)
        rate = _per_actuator(self.rate, m, "rate", allow_inf=True, minimum=0.0)
        lo = _per_actuator(self.lower, m, "lower", allow_inf=True, minimum=None)
        hi = _per_actuator(self.upper, m, "upper", allow_inf=True, minimum=None)
        om = _per_actuator(self.omega, m, "omega", allow_inf=False, minimum=0.0, zero=True)
        ze = _per_actuator(self.zeta, m, "zeta", allow_inf=False, minimum=0.0)
        out = np.zeros((m, 6))
        for j in range(m):
            if not lo[j] < hi[j]:
                raise ConfigurationError(
                    f"Actuator {j + 1}: `lower` ({lo[j]}) must be below `upper` ({hi[j]})."
                )
            if tau[j] > 0 and om[j] > 0:
                raise ConfigurationError(
                    f"Actuator {j + 1} has both a lag `tau` and a natural frequency `omega`: "
                    "give one (first- or second-order dynamics)."
                )
            t = tau[j] if tau[j] > 0 or om[j] > 0 or math.isinf(rate[j]) else RATE_ONLY_TAU
            out[j] = (t if om[j] == 0 else 0.0, rate[j], lo[j], hi[j], om[j], ze[j])
        if self.initial:
            init = _per_actuator(self.initial, m, "initial", allow_inf=False, minimum=None)
            del init  # checked here, used by the loop's initial state
        return out


@dataclass(frozen=True, kw_only=True)
class Sensors:
    """Measurement noise and bias on the states the controller sees.

    Parameters
    ----------
    noise
        Standard deviation of white Gaussian noise per state, by state name or alias
        (``{"alpha": 1e-4, "q": 1e-3}``) or as one number per state.
    bias
        Constant measurement bias per state, same forms.
    rate
        Noise samples per second when the controller is continuous (a digital controller
        samples at its own rate). Each sample holds until the next.
    seed
        Seed of the noise (:func:`numpy.random.default_rng`): same seed, same noise.
    """

    noise: Mapping[str, float] | tuple[float, ...] = field(default_factory=dict)
    bias: Mapping[str, float] | tuple[float, ...] = field(default_factory=dict)
    rate: float = 1000.0
    seed: int = 0

    def __post_init__(self) -> None:
        for key in ("noise", "bias"):
            v = getattr(self, key)
            if isinstance(v, Mapping):
                object.__setattr__(self, key, dict(v))
            elif isinstance(v, (list, tuple, np.ndarray)):
                object.__setattr__(self, key, tuple(v))
            else:
                raise ConfigurationError(
                    f"`{key}` of Sensors must be a table by state name (e.g. {{alpha = 1e-4}}) "
                    f"or one number per state; got {v!r}."
                )
        if (
            isinstance(self.rate, bool)
            or not isinstance(self.rate, (int, float))
            or not math.isfinite(self.rate)
            or self.rate <= 0
        ):
            raise ConfigurationError(
                f"`rate` of Sensors must be a positive number; got {self.rate!r}."
            )
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ConfigurationError(
                f"`seed` of Sensors must be an integer >= 0; got {self.seed!r}."
            )

    def __hash__(self) -> int:  # dicts are not hashable; loops are dictionary keys
        return hash((_frozen(self.noise), _frozen(self.bias), self.rate, self.seed))

    def per_state(self, aliases: Mapping[str, int], n: int) -> tuple[np.ndarray, np.ndarray]:
        """``(std, bias)`` per state, resolving names against the plant's ``aliases``."""
        return (
            _resolve(self.noise, aliases, n, "noise", nonnegative=True),
            _resolve(self.bias, aliases, n, "bias", nonnegative=False),
        )

    @property
    def has_noise(self) -> bool:
        vals = self.noise.values() if isinstance(self.noise, dict) else self.noise
        return any(float(v) != 0.0 for v in vals)


def _frozen(v):
    return tuple(sorted(v.items())) if isinstance(v, dict) else tuple(v)


def _resolve(value, aliases: Mapping[str, int], n: int, name: str, *, nonnegative: bool):
    out = np.zeros(n)
    if isinstance(value, dict):
        items = value.items()
    else:
        if len(value) not in (0, n):
            raise ConfigurationError(
                f"`{name}` of Sensors needs one value per state ({n}) or a table by state "
                f"name; got {len(value)} values."
            )
        items = [(i, v) for i, v in enumerate(value)]
    for key, v in items:
        if isinstance(key, str):
            if key not in aliases:
                from adaptive_ftc.errors import did_you_mean

                raise ConfigurationError(
                    f"`{name}` of Sensors names an unknown state '{key}'."
                    f"{did_you_mean(key, list(aliases))} States: {', '.join(aliases)}."
                )
            i = aliases[key]
        else:
            i = key
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ConfigurationError(f"`{name}` of Sensors for '{key}' must be a finite number.")
        if nonnegative and v < 0:
            raise ConfigurationError(
                f"`{name}` of Sensors for '{key}' is a standard deviation: it must be >= 0; "
                f"got {v}."
            )
        out[i] = float(v)
    return out
