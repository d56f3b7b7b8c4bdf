"""The allocation layer inside a generated closed loop, and annunciated failures.

With the thesis's fixed allocation (``ClosedLoop.allocator = None``, the default) the loop's
text is the one it always was: ``u = R^T u0`` (3.14). With another allocator the generated
right-hand side forms

- the virtual control ``v = R R^T u0``: what the fixed allocation asks of the healthy
  actuators (so every allocator gives the thesis's commands while all actuators are healthy
  and within their limits);
- the effectiveness matrix the allocator believes, ``B = R diag(e)``, with ``e_j = 0`` for an
  actuator whose failure has been *annunciated* (a detector removed it, from its onset plus
  the detection delay until its recovery) and, for the adaptive allocator, ``e_j`` times the
  effectiveness estimate ``rho_hat_j`` (a state integrated with the plant);
- the commands ``u`` from the allocator's kernel (:mod:`adaptive_ftc.allocation.kernels`).

A *silent* failure (not annunciated) is known only to the plant: the allocator keeps using the
actuator. The adaptive allocator's estimate learns it from what the actuators deliver: each
actuator's output ``u^f_j`` (``measured = "actuator"``, e.g. a reaction wheel's torque from its
speed) or only the achieved virtual control ``R u^f`` (``measured = "axis"``). Its model
``rho u`` has no bias, so a stuck actuator reads as an effectiveness at a bound.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from adaptive_ftc.allocation import kernels
from adaptive_ftc.allocation.allocators import (
    AdaptiveAllocation,
    FixedAllocation,
    PseudoInverse,
    WeightedLeastSquares,
)
from adaptive_ftc.errors import ConfigurationError

__all__ = ["Annunciation", "check_allocator", "emit_allocation", "known_table"]


@dataclass(frozen=True, kw_only=True)
class Annunciation:
    """A failure of ``actuator`` (1-based) that a detector reports to the allocator: known from
    ``onset + delay`` until ``recovery`` (``None``: the end of the run).

    Examples
    --------
    >>> Annunciation(actuator=2, onset=50.0, delay=0.5).known_from
    50.5
    """

    actuator: int
    onset: float
    recovery: float | None = None
    delay: float = 0.0

    def __post_init__(self) -> None:
        if isinstance(self.actuator, bool) or not isinstance(self.actuator, int):
            raise ConfigurationError(
                f"`actuator` of Annunciation must be a whole number; got {self.actuator!r}."
            )
        if self.actuator < 1:
            raise ConfigurationError(
                f"`actuator` of Annunciation is numbered from 1; got {self.actuator}."
            )
        for name in ("onset", "delay"):
            val = getattr(self, name)
            if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val):
                raise ConfigurationError(
                    f"`{name}` of Annunciation must be a finite number; got {val!r}."
                )
        if self.delay < 0:
            raise ConfigurationError(
                f"`detection_delay` must be >= 0 s (the detector reports after the onset); "
                f"got {self.delay!r}."
            )
        if self.recovery is not None and not self.recovery > self.onset:
            raise ConfigurationError(
                f"`recovery` of Annunciation ({self.recovery!r}) must come after its onset "
                f"({self.onset!r})."
            )

    @property
    def known_from(self) -> float:
        """When the allocator learns of the failure."""
        return float(self.onset + self.delay)

    @property
    def known_until(self) -> float:
        """When the allocator takes the actuator back (its recovery; ``inf``: never)."""
        return math.inf if self.recovery is None else float(self.recovery)

    def times(self) -> tuple[float, ...]:
        """The times at which the allocator's knowledge changes."""
        out = [self.known_from]
        if self.recovery is not None and self.recovery > self.known_from:
            out.append(float(self.recovery))
        return tuple(out)


def check_allocator(allocator, R: np.ndarray, m: int, annunciations) -> tuple:
    """Validate a loop's allocator and annunciations; returns ``(allocator, annunciations)``
    normalised (the fixed allocation of the loop's own ``R`` is ``None``: the thesis's code)."""
    if isinstance(allocator, FixedAllocation):
        if np.asarray(allocator.nominal).shape != R.shape or not np.array_equal(
            np.asarray(allocator.nominal), R
        ):
            raise ConfigurationError(
                "A FixedAllocation in a loop must use the loop's own `allocation` R; leave "
                "`allocator` unset (None) for the thesis's u = R^T u0."
            )
        allocator = None
    if allocator is not None and not isinstance(
        allocator, (PseudoInverse, WeightedLeastSquares, AdaptiveAllocation)
    ):
        raise ConfigurationError(
            "`allocator` must be None (the thesis's fixed allocation) or an allocator of "
            f"adaptive_ftc.allocation (PseudoInverse, WeightedLeastSquares, "
            f"AdaptiveAllocation); got {allocator!r}."
        )
    anns = tuple(annunciations)
    for a in anns:
        if not isinstance(a, Annunciation):
            raise ConfigurationError(f"`annunciations` must hold Annunciation objects; got {a!r}.")
        if a.actuator > m:
            raise ConfigurationError(
                f"An annunciation names actuator {a.actuator}, but the plant has {m} actuators."
            )
    return allocator, anns


def known_table(annunciations, bps, m: int, R=None) -> np.ndarray:
    """Per (interval, actuator): 1 where the allocator has removed the actuator (its failure
    annunciated, at the interval's midpoint), else 0.

    With the actuation matrix ``R``, the reachability check decides first: where removing the
    annunciated actuators would leave a direction that no kept actuator reaches (a rank loss
    of ``R diag(kept)``), every annunciated actuator acting along that direction stays in the
    allocation, as if silent (one of them may be only partly failed, and the allocator does
    not know which: a pseudo-inverse would otherwise command nothing there).
    """
    edges = np.asarray(bps, dtype=float)
    mids = 0.5 * (edges[:-1] + edges[1:])
    out = np.zeros((mids.size, m))
    order = sorted(annunciations, key=lambda a: a.known_from)
    for a in order:
        out[(a.known_from <= mids) & (mids < a.known_until), a.actuator - 1] = 1.0
    if R is None:
        return out
    R = np.atleast_2d(np.asarray(R, dtype=float))
    full = np.linalg.matrix_rank(R)
    for k in range(mids.size):
        kept = R * (1.0 - out[k])[None, :]
        if not out[k].any() or np.linalg.matrix_rank(kept) == full:
            continue
        # the directions the kept actuators lost (left null space of kept within R's range)
        U, S, _ = np.linalg.svd(kept)
        tol = max(R.shape) * np.finfo(float).eps * max(1.0, np.max(np.abs(R)))
        rank = int(np.sum(S > tol))
        lost = U[:, rank:full] if full <= U.shape[1] else U[:, rank:]
        for j in range(m):  # every removed actuator that acts along a lost direction returns
            if out[k, j] and np.linalg.norm(lost.T @ R[:, j]) > tol:
                out[k, j] = 0.0
    return out


def breakpoints(annunciations, times: tuple[float, ...], t0: float, t1: float) -> tuple:
    """``times`` with the annunciations' detection and recovery times in ``(t0, t1)`` added."""
    extra = {t for a in annunciations for t in a.times() if t0 < t < t1}
    if not extra:
        return times
    return tuple(sorted(set(times) | extra))


def emit_allocation(g, loop, *, rho_at: int, has_act: bool):
    """The generated text of a loop's allocator (not the fixed one).

    Returns ``(prelude, adapt, settings, states, work_size)``: the lines of the right-hand side
    that fill the work buffer ``u`` before the actuators read it, the lines of the adaptive
    allocator's estimate (after the design's adaptive laws), its numbers (the ``ALLOC`` block
    of ``D.c``: first the place of the table of :func:`known_table`, written per run), the
    initial values of its states (from ``rho_at`` on in ``Y``) and the size of its work buffer.
    """
    alloc = loop.allocator
    p, m = g.p, g.m
    adaptive = isinstance(alloc, AdaptiveAllocation)
    inner: Any = alloc._inner_allocator() if isinstance(alloc, AdaptiveAllocation) else alloc
    n_b, n_w = p * m, max(kernels.pinv_work_size(p, m), kernels.wls_work_size(p, m))
    # the work buffer: B, v, lower, upper, weights, preferred, achieved v, kernel work
    at_v, at_lo = n_b, n_b + p
    at_hi, at_w, at_ud = at_lo + m, at_lo + 2 * m, at_lo + 3 * m
    at_ach, at_k = at_lo + 4 * m, at_lo + 4 * m + p
    size = at_k + n_w
    lim_lo, lim_hi = -math.inf, math.inf
    # ALLOC + 0: the known table's place; 1, 2: limits; 3: max_condition; 4: gamma;
    # 5: max_iterations; 6: preferred; 7, 8, 9: the estimate's gain, lower, upper
    settings: list[float] = [0.0, lim_lo, lim_hi]
    if isinstance(inner, WeightedLeastSquares):
        settings += [0.0, float(inner.gamma), float(inner.max_iterations), float(inner.preferred)]
    else:
        settings += [float(inner.max_condition), 0.0, 0.0, 0.0]
    if isinstance(alloc, AdaptiveAllocation):
        settings += [float(alloc.gain), float(alloc.lower), float(alloc.upper)]
    kernel = kernels.wls_allocate if inner.kind == "wls" else kernels.pinv_allocate
    ka = g.use("alloc_kernel", kernel)
    rho = f"Y[{rho_at} + j]" if adaptive else "1.0"
    lines = [
        f"    # control allocation '{alloc.kind}' (adaptive_ftc.allocation): v = R R^T u0, the",
        "    # healthy demand of u = R^T u0 (3.14); B = R diag(e), e_j = 0 once actuator j's",
        "    # failure is annunciated" + (", else its effectiveness estimate" if adaptive else ""),
        "    alw = W[ALW:ALW + N_ALW]",
        "    known = int(c[ALLOC]) + ph * M",
        f"    for i in range({p}):",
        "        acc = 0.0",
        f"        for j in range({m}):",
        "            rj = 0.0",
        f"            for k in range({p}):",
        f"                rj += c[RMAT + k * {m} + j] * u0[k]",
        f"            acc += c[RMAT + i * {m} + j] * rj",
        f"        alw[{at_v} + i] = acc",
        f"    for j in range({m}):",
        f"        e = (1.0 - c[known + j]) * {rho}",
        f"        for i in range({p}):",
        f"            alw[i * {m} + j] = c[RMAT + i * {m} + j] * e",
        f"        alw[{at_lo} + j] = c[ALLOC + 1]",
        f"        alw[{at_hi} + j] = c[ALLOC + 2]",
        *(
            [
                f"        alw[{at_lo} + j] = max(alw[{at_lo} + j], act(ph, j, 2, D))",
                f"        alw[{at_hi} + j] = min(alw[{at_hi} + j], act(ph, j, 3, D))",
            ]
            if has_act
            else []
        ),
        f"        alw[{at_w} + j] = 1.0",
        f"        alw[{at_ud} + j] = min(max(c[ALLOC + 6], alw[{at_lo} + j]), alw[{at_hi} + j])",
    ]
    B, v = f"alw[0:{n_b}]", f"alw[{at_v}:{at_v + p}]"
    lo, hi = f"alw[{at_lo}:{at_lo + m}]", f"alw[{at_hi}:{at_hi + m}]"
    w, ud, work = f"alw[{at_w}:{at_w + m}]", f"alw[{at_ud}:{at_ud + m}]", f"alw[{at_k}:{size}]"
    if inner.kind == "wls":
        lines += [
            "    # Haerkegard's WLS with limits, warm-started from the last command in u",
            f"    {ka}({B}, {v}, {lo}, {hi}, {w}, {ud}, c[ALLOC + 4], {p}, {m},",
            f"        int(c[ALLOC + 5]), u, {work})",
        ]
    else:
        lines += [
            "    # guarded pseudo-inverse, then the limits",
            f"    {ka}({B}, {v}, {w}, {p}, {m}, c[ALLOC + 3], u, {work})",
            f"    for j in range({m}):",
            f"        u[j] = min(max(u[j], alw[{at_lo} + j]), alw[{at_hi} + j])",
        ]
    adapt: list[str] = []
    states: list[float] = []
    if isinstance(alloc, AdaptiveAllocation):
        states = [1.0] * m
        g.adaptive_names += [f"rho_hat_{a}" for a in loop.plant.actuator_names]
        adapt = [
            "    # effectiveness estimates, projected onto [lower, upper]: gradient law on what",
            "    # the actuators deliver (u^f)"
            if alloc.measured == "actuator"
            else "    # the actuators achieve together (v = R u^f)",
            "    alw = W[ALW:ALW + N_ALW]",
            f"    for j in range({m}):",
            f"        alw[{at_w} + j] = c[ALLOC + 7]",
            f"        alw[{at_lo} + j] = c[ALLOC + 8]",
            f"        alw[{at_hi} + j] = c[ALLOC + 9]",
        ]
        rho_v, drho = f"Y[{rho_at}:{rho_at + m}]", f"dY[{rho_at}:{rho_at + m}]"
        if alloc.measured == "actuator":
            kr = g.use("alloc_rate", kernels.actuator_effectiveness_rate)
            adapt.append(f"    {kr}({rho_v}, u, uf, {w}, {lo}, {hi}, {m}, {drho})")
        else:
            kr = g.use("alloc_rate", kernels.adaptive_effectiveness_rate)
            adapt += [
                f"    for i in range({p}):",
                "        acc = 0.0",
                f"        for j in range({m}):",
                f"            acc += c[RMAT + i * {m} + j] * uf[j]",
                f"        alw[{at_ach} + i] = acc",
                f"    {kr}(c[RMAT:RMAT + {p * m}], {rho_v}, u, alw[{at_ach}:{at_ach + p}], "
                f"{w}, {lo}, {hi}, {p}, {m}, {drho})",
            ]
    return lines, adapt, tuple(settings), states, size
