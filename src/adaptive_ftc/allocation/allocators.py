"""Control allocators: how a virtual control ``v`` (the moment or force the design asks for,
one entry per axis) becomes actuator commands ``u`` with ``B u = v``.

``B`` (p x m) is the effectiveness matrix: for the thesis's plants the actuation matrix ``R``
of (3.14) (or the row of gains ``b_j`` of (2.10)) times the actuators' effectiveness. Every
allocator is a frozen dataclass with one method::

    allocate(v, B, limits=None, weights=None, previous=None) -> u

- :class:`FixedAllocation`: the thesis's fixed coefficients (``u = R^T u0``), chosen for the
  healthy plant and blind to failures and limits (the default everywhere).
- :class:`PseudoInverse`: weighted minimum-norm ``B^+ v`` with a conditioning guard.
- :class:`WeightedLeastSquares`: Härkegård's active-set WLS with position limits, bounded
  iterations and warm start.
- :class:`AdaptiveAllocation`: an online estimate of each actuator's effectiveness (projected
  onto its bounds) that the allocation inverts (Tohidi, Yildiz & Kolmanovsky 2020).

The numerical work is done by :mod:`adaptive_ftc.allocation.kernels`, which a generated closed
loop calls from compiled code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from adaptive_ftc.allocation import kernels
from adaptive_ftc.errors import ConfigurationError, did_you_mean

__all__ = [
    "ALLOCATORS",
    "AdaptiveAllocation",
    "Allocator",
    "FixedAllocation",
    "PseudoInverse",
    "WeightedLeastSquares",
    "allocator_from_spec",
]


def _matrix(B, name: str = "B") -> np.ndarray:
    B = np.asarray(B, dtype=float)
    if B.ndim == 1:
        B = B[None, :]
    if B.ndim != 2 or B.size == 0 or not np.all(np.isfinite(B)):
        raise ConfigurationError(
            f"`{name}` must be a finite (axes x actuators) matrix; got shape {B.shape}."
        )
    return B


def _vector(value, n: int, name: str, default: float) -> np.ndarray:
    if value is None:
        return np.full(n, default)
    arr = np.broadcast_to(np.asarray(value, dtype=float), (n,)).copy()
    if not np.all(np.isfinite(arr) | np.isinf(arr)) or np.any(np.isnan(arr)):
        raise ConfigurationError(f"`{name}` must hold numbers; got {value!r}.")
    return arr


def _limits(limits, m: int) -> tuple[np.ndarray, np.ndarray]:
    if limits is None:
        return np.full(m, -np.inf), np.full(m, np.inf)
    try:
        lo, hi = limits
    except (TypeError, ValueError):
        raise ConfigurationError(
            f"`limits` must be a pair (lower, upper), each a number or {m} numbers; got {limits!r}."
        ) from None
    lo = _vector(lo, m, "limits (lower)", -np.inf)
    hi = _vector(hi, m, "limits (upper)", np.inf)
    if np.any(lo > hi):
        j = int(np.argmax(lo > hi))
        raise ConfigurationError(
            f"`limits` of actuator {j + 1}: lower {lo[j]:g} is above upper {hi[j]:g}; swap them."
        )
    return lo, hi


def _weights(weights, m: int) -> np.ndarray:
    w = _vector(weights, m, "weights", 1.0)
    if np.any(~np.isfinite(w)) or np.any(w <= 0):
        raise ConfigurationError(f"`weights` must be positive finite numbers; got {weights!r}.")
    return w


def _check_v(v, p: int) -> np.ndarray:
    v = np.atleast_1d(np.asarray(v, dtype=float))
    if v.shape != (p,):
        raise ConfigurationError(
            f"`v` must have one entry per row of B ({p} axes); got shape {v.shape}."
        )
    return v


class Allocator:
    """Interface of an allocator (frozen dataclasses implement it; not subclassed further)."""

    kind: ClassVar[str] = ""

    def allocate(self, v, B, limits=None, weights=None, previous=None) -> np.ndarray:
        """Actuator commands ``u`` (m) for the virtual control ``v`` (p) through ``B``
        (p x m), within ``limits = (lower, upper)``, with per-actuator ``weights`` (a larger
        weight: used less), warm-started from ``previous`` where the method uses one."""
        raise NotImplementedError


@dataclass(frozen=True, kw_only=True)
class FixedAllocation(Allocator):
    """The thesis's fixed coefficients: ``u = C v`` with ``C = R^T (R R^T)^-1`` computed once
    from the healthy actuation matrix ``nominal`` (eq. (3.14); for one output the gains
    ``b_j`` of (2.10): ``u_j = b_j u0``).

    It ignores the ``B`` it is given (it does not know about failures) and the limits (the
    actuators saturate physically). With ``v = R R^T u0`` it returns exactly the thesis's
    ``R^T u0``.

    Examples
    --------
    >>> FixedAllocation(nominal=[[1, 0, 1, 0], [0, 1, 0, 1]]).allocate([2.0, 4.0], None)
    array([1., 2., 1., 2.])
    """

    kind: ClassVar[str] = "fixed"
    nominal: tuple = ()

    def __post_init__(self) -> None:
        R = _matrix(self.nominal, "nominal")
        if np.linalg.matrix_rank(R) < R.shape[0]:
            raise ConfigurationError(
                f"`nominal` of FixedAllocation must have full row rank ({R.shape[0]}); "
                f"got rank {np.linalg.matrix_rank(R)}: an axis no actuator moves."
            )
        object.__setattr__(self, "nominal", tuple(tuple(map(float, r)) for r in R))

    @property
    def distribution(self) -> np.ndarray:
        """The fixed distribution matrix ``C`` (m x p)."""
        R = np.asarray(self.nominal)
        return R.T @ np.linalg.inv(R @ R.T)

    def allocate(self, v, B=None, limits=None, weights=None, previous=None) -> np.ndarray:
        C = self.distribution
        return C @ _check_v(v, C.shape[1])


@dataclass(frozen=True, kw_only=True)
class PseudoInverse(Allocator):
    """Weighted minimum-norm allocation ``u = W^-1 B^T (B W^-1 B^T)^+ v``, then clipped to
    the limits.

    The conditioning guard: a direction of ``W^-1/2 B`` whose singular value is below
    ``sigma_max / max_condition`` is not inverted (it gets no command), so a nearly singular
    ``B`` (two opposing rotors lost) cannot produce huge gains of random sign; such an axis is
    reported by :func:`~adaptive_ftc.allocation.reachable.reachability`.

    Examples
    --------
    >>> PseudoInverse().allocate([2.0], [[1.0, 1.0]])
    array([1., 1.])
    """

    kind: ClassVar[str] = "pinv"
    max_condition: float = 1e3

    def __post_init__(self) -> None:
        c = self.max_condition
        if isinstance(c, bool) or not isinstance(c, (int, float)) or not (1.0 <= c < math.inf):
            raise ConfigurationError(
                f"`max_condition` of PseudoInverse must be a finite number >= 1; got {c!r}."
            )

    def allocate(self, v, B, limits=None, weights=None, previous=None) -> np.ndarray:
        B = _matrix(B)
        p, m = B.shape
        v = _check_v(v, p)
        w = _weights(weights, m)
        u = np.zeros(m)
        work = np.zeros(kernels.pinv_work_size(p, m))
        kernels.pinv_allocate(B.ravel(), v, w, p, m, float(self.max_condition), u, work)
        lo, hi = _limits(limits, m)
        return np.clip(u, lo, hi)


@dataclass(frozen=True, kw_only=True)
class WeightedLeastSquares(Allocator):
    """Härkegård's weighted least-squares allocator (active set, bounded iterations, warm
    start): ``min ||W (u - preferred)||^2 + gamma ||B u - v||^2`` within the limits.

    ``gamma`` weighs the allocation error against the control effort (large: meet ``v``
    first, the effort only decides among the exact solutions). ``previous`` warm-starts the
    working set (the actuators at a bound stay there first); ``max_iterations`` bounds the
    work per call (a real-time budget): when reached, the last feasible iterate is returned.

    Examples
    --------
    >>> WeightedLeastSquares().allocate([3.0], [[1.0, 1.0]], limits=(-1.0, 1.0)).round(6)
    array([1., 1.])
    """

    kind: ClassVar[str] = "wls"
    gamma: float = 1e6
    max_iterations: int = 100
    preferred: float = 0.0

    def __post_init__(self) -> None:
        g = self.gamma
        if isinstance(g, bool) or not isinstance(g, (int, float)) or not (0 < g < math.inf):
            raise ConfigurationError(
                f"`gamma` of WeightedLeastSquares must be a positive number; got {g!r}."
            )
        n = self.max_iterations
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise ConfigurationError(
                f"`max_iterations` of WeightedLeastSquares must be a whole number >= 1; got {n!r}."
            )
        if not math.isfinite(float(self.preferred)):
            raise ConfigurationError("`preferred` of WeightedLeastSquares must be finite.")

    def allocate(self, v, B, limits=None, weights=None, previous=None) -> np.ndarray:
        return self.solve(v, B, limits, weights, previous)[0]

    def solve(self, v, B, limits=None, weights=None, previous=None) -> tuple[np.ndarray, int]:
        """:meth:`allocate` and the number of iterations used (-1: the limit was reached)."""
        B = _matrix(B)
        p, m = B.shape
        v = _check_v(v, p)
        lo, hi = _limits(limits, m)
        wu = _weights(weights, m)
        u = np.zeros(m) if previous is None else _vector(previous, m, "previous", 0.0)
        ud = np.clip(np.full(m, float(self.preferred)), lo, hi)
        work = np.zeros(kernels.wls_work_size(p, m))
        iters = kernels.wls_allocate(
            B.ravel(), v, lo, hi, wu, ud, float(self.gamma), p, m, self.max_iterations, u, work
        )
        return u, int(iters)


@dataclass(frozen=True, kw_only=True)
class AdaptiveAllocation(Allocator):
    """Adaptive allocation: an online estimate ``rho_hat`` of each actuator's effectiveness
    (``B = R diag(rho)``), projected element-wise onto ``[lower, upper]``, and the allocation
    through the estimated ``B`` (by ``inner``: weighted least squares with the limits, or the
    guarded pseudo-inverse).

    ``measured`` says what the estimate learns from: ``"actuator"`` (default), each actuator's
    delivered output ``u^f_j`` (wheel torque from wheel speed), so every estimate is
    identifiable on its own; ``"axis"``, only the achieved virtual control ``R u^f``, where two
    actuators of one axis that get equal commands stay indistinguishable (only their sum is
    learnt). The estimate follows :meth:`rate` (a gradient law on the prediction error, with
    projection: Tohidi, Yildiz & Kolmanovsky, Automatica 2020, eq. of
    the adaptive allocation with element-wise projection); :meth:`allocate` takes the
    *estimated* ``B`` (``R diag(rho_hat)``, see :meth:`estimated`). In a closed loop the
    estimate is a state integrated with the plant. The floor ``lower`` (default 0.1) keeps
    every actuator in use: an estimate at 0 would get no command, hence no excitation, and
    could never recover.

    Examples
    --------
    >>> a = AdaptiveAllocation(gain=10.0)
    >>> a.rate([[1.0, 1.0]], [1.0, 1.0], [1.0, 1.0], achieved=[1.5]).round(3)
    array([-5., -5.])
    """

    kind: ClassVar[str] = "adaptive"
    gain: float = 1.0
    lower: float = 0.1
    upper: float = 1.0
    inner: str = "wls"
    measured: str = "actuator"
    max_condition: float = 1e3
    gamma: float = 1e6
    max_iterations: int = 100

    def __post_init__(self) -> None:
        for name in ("gain", "lower", "upper"):
            val = getattr(self, name)
            if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val):
                raise ConfigurationError(
                    f"`{name}` of AdaptiveAllocation must be a finite number; got {val!r}."
                )
        if self.gain <= 0:
            raise ConfigurationError(
                f"`gain` of AdaptiveAllocation must be positive; got {self.gain!r}."
            )
        if not self.lower < self.upper:
            raise ConfigurationError(
                f"`lower` ({self.lower!r}) of AdaptiveAllocation must be below `upper` "
                f"({self.upper!r})."
            )
        if self.inner not in ("wls", "pinv"):
            raise ConfigurationError(
                f"Unknown `inner` allocator '{self.inner}' of AdaptiveAllocation."
                f"{did_you_mean(self.inner, ('wls', 'pinv'))} Use 'wls' or 'pinv'."
            )
        if self.measured not in ("actuator", "axis"):
            raise ConfigurationError(
                f"Unknown `measured` '{self.measured}' of AdaptiveAllocation."
                f"{did_you_mean(self.measured, ('actuator', 'axis'))} Use 'actuator' (each "
                "actuator's delivered output is measured) or 'axis' (only the achieved "
                "virtual control R u^f)."
            )
        self._inner_allocator()  # validates max_condition, gamma, max_iterations

    def _inner_allocator(self) -> Allocator:
        if self.inner == "pinv":
            return PseudoInverse(max_condition=self.max_condition)
        return WeightedLeastSquares(gamma=self.gamma, max_iterations=self.max_iterations)

    @staticmethod
    def estimated(R, rho) -> np.ndarray:
        """The estimated effectiveness matrix ``R diag(rho_hat)``."""
        R = _matrix(R, "R")
        return R * np.asarray(rho, dtype=float)[None, :]

    def allocate(self, v, B, limits=None, weights=None, previous=None) -> np.ndarray:
        return self._inner_allocator().allocate(v, B, limits, weights, previous)

    def rate(self, R, rho, u, achieved) -> np.ndarray:
        """``d rho_hat / dt`` given the nominal ``R``, the estimate ``rho``, the commands ``u``
        and the achieved virtual control (projection onto ``[lower, upper]`` included)."""
        R = _matrix(R, "R")
        p, m = R.shape
        out = np.zeros(m)
        kernels.adaptive_effectiveness_rate(
            R.ravel(),
            np.asarray(rho, dtype=float),
            np.asarray(u, dtype=float),
            _check_v(achieved, p),
            np.full(m, float(self.gain)),
            np.full(m, float(self.lower)),
            np.full(m, float(self.upper)),
            p,
            m,
            out,
        )
        return out

    def step(self, R, rho, u, achieved, dt: float) -> np.ndarray:
        """One explicit Euler step of the estimate, projected onto ``[lower, upper]`` (the
        discrete-time form of :meth:`rate`)."""
        rho = np.asarray(rho, dtype=float)
        new = rho + float(dt) * self.rate(R, rho, u, achieved)
        return np.clip(new, self.lower, self.upper)


#: the allocators by the name a scenario file uses (``[allocation] kind = ...``)
ALLOCATORS: dict[str, type] = {
    "fixed": FixedAllocation,
    "pinv": PseudoInverse,
    "wls": WeightedLeastSquares,
    "adaptive": AdaptiveAllocation,
}


def allocator_from_spec(kind: str, **options) -> Allocator:
    """The allocator named ``kind`` with ``options`` (a scenario's ``[allocation]`` table)."""
    if kind not in ALLOCATORS:
        raise ConfigurationError(
            f"Unknown allocation kind '{kind}'.{did_you_mean(kind, ALLOCATORS)} "
            f"Use one of: {', '.join(ALLOCATORS)}."
        )
    cls = ALLOCATORS[kind]
    try:
        return cls(**options)
    except TypeError as exc:
        import dataclasses

        allowed = [f.name for f in dataclasses.fields(cls)]
        raise ConfigurationError(
            f"Bad option for allocation kind '{kind}': {exc}. Allowed: {', '.join(allowed)}."
        ) from None
