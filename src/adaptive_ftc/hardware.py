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

  An input delay ``Actuators(delay=d)`` (seconds, per actuator or one number; 0 = none) sits
  between the controller's command and the actuator: the actuator (or, for an ideal one, the
  plant) receives ``u(t - d)``; the recorded command ``u_cmd`` is the controller's, undelayed.
  Before the first command the delay line holds it (no start-up transient, like the actuator
  positions). A continuous controller's delay is the Padé approximant of order
  ``delay_order`` (default :data:`PADE_ORDER`) as ``delay_order`` states per actuator
  (:func:`pade_realization`); its phase error at ``omega d`` (radians of delay phase), lead
  in degrees, is

  ======== ======== ======== ======== ======== ======== ========
  order    1 rad    2 rad    3 rad    4 rad    5 rad    2 pi
  ======== ======== ======== ======== ======== ======== ========
  2        0.075    1.97     10.8     30.3     59.6     108
  3        0.001    0.062    0.86     4.7      14.9     40
  4        <1e-3    0.001    0.034    0.36     2.0      9.4
  6        <1e-3    <1e-3    <1e-3    <1e-3    0.007    0.105
  ======== ======== ======== ======== ======== ======== ========

  (the gain is exactly 1: the approximant is all-pass). At a loop's crossover the delay phase
  is the phase margin (``omega_c d = PM`` at the delay margin), below pi/2 rad for every loop
  with a phase margin below 90 degrees: order 4 is exact there to 1e-4 degrees. Its poles
  have ``|p| d`` between 6.0 and 6.8, a fast mode that an explicit fixed-step solver resolves
  only with ``dt < 0.4 d``. A digital controller (``sample_time`` ``T``) delays its held
  command by exactly ``k = d / T`` samples (``k`` states per actuator, a shift register
  moved at each sample); a delay that is not a whole number of samples is refused
  (:class:`~adaptive_ftc.sim.system.ClosedLoop` names the nearest multiples).
- :class:`Sensors`: seeded Gaussian measurement noise and a constant bias on each measured
  state. The controller (tracking errors, regressors, design laws) sees ``x + b + n_k``; the
  plant, the failures and the recorded tracking errors use the true state. The sensor gives
  a reading every ``1/rate`` s, each with its own noise draw (drawn in time order: a shorter
  run's noise is a prefix of a longer run's; the same seed gives the same noise). A
  continuous controller holds reading ``k`` on ``[t0 + k/rate, t0 + (k+1)/rate)``. A digital
  controller (sample time ``T``) reads at its sample ``k`` the latest reading, number
  ``floor(k T rate)`` (``k N`` where ``N = T rate`` is a whole number), with the state at
  the sample instant (the reading's age, under ``1/rate``, is not modelled where ``N`` is not
  a whole number); a sensor no faster than the controller (``rate <= 1/T``) gives one draw
  per sample (reading ``k`` at sample ``k``). A constraint-aware digital law may average the
  ``N`` readings of each period instead (its decimation filter,
  :attr:`~adaptive_ftc.controllers.constraints.ConstraintAware.decimation`).
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
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np

from adaptive_ftc.errors import ConfigurationError

__all__ = ["PADE_ORDER", "RATE_ONLY_TAU", "Actuators", "Sensors", "pade_realization"]

#: Time constant (s) of an actuator given a rate limit but no lag.
RATE_ONLY_TAU = 0.005

#: Default order of the Padé approximant of an input delay (continuous controller).
PADE_ORDER = 4

#: Orders of the Padé approximant :func:`pade_realization` builds.
PADE_ORDERS = range(1, 7)


def pade_realization(order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, np.ndarray]:
    """``(A, B, C, D, x_ss)`` of the ``[order/order]`` Padé approximant of ``exp(-s d)`` in the
    time unit ``d`` (the loop integrates ``x' = (A x + B u) / d``, ``y = C x + D u``), in a
    balanced realization (both Gramians the identity: every state of order ``|u|``);
    ``x_ss = -A^-1 B`` is the state per unit of a constant input (the output is that input).

    Examples
    --------
    >>> A, B, C, D, xss = pade_realization(1)
    >>> round(float(C @ xss + D), 12)
    1.0
    """
    if isinstance(order, bool) or not isinstance(order, int) or order not in PADE_ORDERS:
        raise ConfigurationError(
            f"`delay_order` of Actuators is the Padé order, an integer from "
            f"{PADE_ORDERS.start} to {PADE_ORDERS.stop - 1}; got {order!r}."
        )
    n = order
    c = [
        math.factorial(2 * n - k)
        * math.factorial(n)
        / (math.factorial(2 * n) * math.factorial(k) * math.factorial(n - k))
        for k in range(n + 1)
    ]
    a = [ck / c[n] for ck in c]  # monic denominator: p^n + a_{n-1} p^{n-1} + ... + a_0
    sign = (-1.0) ** n  # the numerator is the denominator at -p: its leading term (-1)^n p^n
    A = np.zeros((n, n))
    A[:-1, 1:] = np.eye(n - 1)
    A[-1, :] = [-a[k] for k in range(n)]
    B = np.zeros((n, 1))
    B[-1, 0] = 1.0
    C = np.array([[((-1.0) ** k - sign) * a[k] for k in range(n)]])
    # balanced realization (Laub's algorithm): both Gramians become the identity
    from scipy.linalg import cholesky, solve_continuous_lyapunov, svd

    wc = solve_continuous_lyapunov(A, -B @ B.T)
    wo = solve_continuous_lyapunov(A.T, -C.T @ C)
    lc = cholesky(wc, lower=True)
    u, sv, _ = svd(lc.T @ wo @ lc)
    T = lc @ u @ np.diag(sv**-0.25)
    Ti = np.linalg.inv(T)
    Ab, Bb, Cb = Ti @ A @ T, (Ti @ B).ravel(), (C @ T).ravel()
    xss = -np.linalg.solve(Ab, Bb)
    return Ab, Bb, Cb, float(sign), xss


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
    delay
        Input delay (s) between the controller's command and the actuator, one number or one
        per actuator; 0 = none (see the module docstring: a Padé approximant for a continuous
        controller, an exact shift of whole samples for a digital one).
    delay_order
        Order of the Padé approximant of the delay (1 to 6; continuous controller only).

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
    delay: float | tuple[float, ...] = 0.0
    delay_order: int = PADE_ORDER

    def __post_init__(self) -> None:
        for key in ("tau", "rate", "lower", "upper", "omega", "zeta", "delay"):
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
        self.delays(m)
        return out

    def delays(self, m: int) -> tuple[float, ...]:
        """The input delay (s) of each of ``m`` actuators, checked (finite, >= 0)."""
        vals = (self.delay,) * m if isinstance(self.delay, (int, float)) else tuple(self.delay)
        if len(vals) != m:
            raise ConfigurationError(
                f"`delay` of Actuators needs one value per actuator ({m}) or a single number; "
                f"got {len(vals)}."
            )
        for j, v in enumerate(vals):
            if (
                isinstance(v, bool)
                or not isinstance(v, (int, float))
                or not math.isfinite(v)
                or v < 0
            ):
                raise ConfigurationError(
                    f"`delay` of Actuators (actuator {j + 1}) is an input delay in seconds: a "
                    f"finite number >= 0 (0 = none); got {v!r}."
                )
        if any(v > 0 for v in vals):
            pade_realization(self.delay_order)  # checks the order
        return tuple(float(v) for v in vals)

    @property
    def has_delay(self) -> bool:
        """Whether any actuator has an input delay."""
        return any(float(v) > 0 for v in np.ravel(self.delay))


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
        Readings per second, each with its own noise draw. A continuous controller holds each
        reading until the next; a digital controller reads the latest reading at each of its
        samples (one draw per sample where the sensor is no faster than the controller), or,
        with a constraint-aware law's decimation filter, the mean of the period's readings
        (see the module docstring).
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
    items: Iterable[tuple[int | str, float]]  # (state index or name, value)
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
