"""Reachability: which axes the remaining actuators can still move, and how well.

After actuator failures the effectiveness matrix ``B = R diag(effective)`` loses columns; when
it loses rank (or nearly: a large condition number) some axis can no longer be controlled.
Inverting such a matrix gives huge commands of random sign (a hexarotor after two opposing
motor failures, PX4 #28589); the decision which axes are still achievable comes first. This
module makes it: the thesis's rank condition (3.6) with the matrix's conditioning, reported
per axis by name, and per failure event by time (a structured result, never a gain).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from adaptive_ftc.errors import ConfigurationError

__all__ = ["Reachability", "ReachabilityEvent", "reachability", "reachability_timeline"]


@dataclass(frozen=True, kw_only=True)
class Reachability:
    """What the working actuators can still do.

    Attributes
    ----------
    rank
        Numerical rank of the working effectiveness matrix (singular values at least
        ``sigma_max / max_condition`` count).
    condition
        ``sigma_max / sigma_min`` over the axes' full dimension (``inf`` when rank deficient).
    singular_values
        The singular values of the working matrix (largest first, one per axis).
    axes
        The axis names, in row order.
    reach
        Per axis, the fraction (0..1) of a unit demand on that axis alone that the kept
        directions can produce: 1 reachable, 0 not at all.
    unreachable
        Names of the axes whose ``reach`` is below ``1 - tolerance``.
    working
        The actuators (1-based) counted as working.
    lost_directions
        Unit vectors (in axis space) that the working actuators cannot produce: a lost axis
        alone, or a combination of axes (e.g. pitch with yaw).
    """

    rank: int
    condition: float
    singular_values: tuple[float, ...]
    axes: tuple[str, ...]
    reach: tuple[float, ...]
    unreachable: tuple[str, ...]
    working: tuple[int, ...]
    lost_directions: tuple[tuple[float, ...], ...] = ()

    @property
    def full(self) -> bool:
        """Every axis reachable (full row rank, well conditioned)."""
        return not self.unreachable

    def describe(self) -> str:
        """One line: reachable or which axes are not."""
        cond = "inf" if math.isinf(self.condition) else f"{self.condition:.3g}"
        if self.full:
            return f"all axes reachable (rank {self.rank}, condition {cond})"
        return (
            f"NOT reachable: {', '.join(self.unreachable)} (rank {self.rank} of "
            f"{len(self.axes)}, condition {cond}); working actuators: "
            f"{', '.join(map(str, self.working)) or 'none'}"
        )


def reachability(
    B,
    *,
    failed: Iterable[int] = (),
    axis_names: Sequence[str] | None = None,
    max_condition: float = 1e3,
    tolerance: float = 1e-6,
) -> Reachability:
    """The reachable axes of ``B`` (p x m) with the actuators ``failed`` (1-based: stuck,
    floating or without effectiveness) removed.

    A direction of the working matrix whose singular value is below
    ``sigma_max / max_condition`` counts as lost (the same guard as
    :class:`~adaptive_ftc.allocation.PseudoInverse`); an axis is reachable when its unit
    vector lies in the span of the kept directions.

    Examples
    --------
    >>> R = [[1, 0, 0, 1, 0, 0], [0, 1, 0, 0, 1, 0], [0, 0, 1, 0, 0, 1]]
    >>> reachability(R, failed=(1, 4), axis_names=("roll", "pitch", "yaw")).unreachable
    ('roll',)
    """
    B = np.atleast_2d(np.asarray(B, dtype=float))
    if B.ndim != 2 or not np.all(np.isfinite(B)):
        raise ConfigurationError(f"`B` must be a finite (axes x actuators) matrix; got {B!r}.")
    p, m = B.shape
    failed = tuple(int(j) for j in failed)
    bad = [j for j in failed if not 1 <= j <= m]
    if bad:
        raise ConfigurationError(
            f"`failed` names actuator {bad[0]}, but B has {m} actuators (numbered 1..{m})."
        )
    if axis_names is None:
        axis_names = tuple(f"axis {i + 1}" for i in range(p))
    axis_names = tuple(axis_names)
    if len(axis_names) != p:
        raise ConfigurationError(
            f"`axis_names` needs one name per row of B ({p}); got {len(axis_names)}."
        )
    if not (isinstance(max_condition, (int, float)) and max_condition >= 1.0):
        raise ConfigurationError(f"`max_condition` must be >= 1; got {max_condition!r}.")
    working = tuple(j + 1 for j in range(m) if (j + 1) not in failed and np.any(B[:, j] != 0))
    Bw = B[:, [j - 1 for j in working]] if working else np.zeros((p, 0))
    if Bw.shape[1]:
        U, S, _ = np.linalg.svd(Bw, full_matrices=True)
    else:
        U, S = np.eye(p), np.zeros(0)
    sv = np.zeros(p)
    sv[: min(p, S.size)] = S[:p]
    smax = sv[0] if sv.size else 0.0
    kept = sv >= smax / max_condition if smax > 0 else np.zeros(p, dtype=bool)
    rank = int(np.sum(kept))
    Uk = U[:, :p][:, kept]
    reach = np.linalg.norm(Uk.T, axis=0) if rank else np.zeros(p)  # |P e_i| per axis
    unreachable = tuple(axis_names[i] for i in range(p) if reach[i] < 1.0 - tolerance)
    condition = float(smax / sv[-1]) if sv.size and sv[-1] > 0 else math.inf
    return Reachability(
        rank=rank,
        condition=condition,
        singular_values=tuple(float(s) for s in sv),
        axes=axis_names,
        reach=tuple(float(min(1.0, r)) for r in reach),
        unreachable=unreachable,
        working=working,
        lost_directions=tuple(tuple(float(x) for x in U[:, k]) for k in range(p) if not kept[k]),
    )


@dataclass(frozen=True, kw_only=True)
class ReachabilityEvent:
    """The reachability from ``time`` on (a failure or recovery event, or the start)."""

    time: float
    failed: tuple[int, ...]
    report: Reachability

    def describe(self) -> str:
        lost = ", ".join(map(str, self.failed)) or "none"
        return f"t = {self.time:g} s (lost actuators: {lost}): {self.report.describe()}"


def reachability_timeline(loop, *, max_condition: float = 1e3) -> tuple[ReachabilityEvent, ...]:
    """The reachability of a :class:`~adaptive_ftc.sim.system.ClosedLoop` at its start and
    at every failure event, axes named by the plant's outputs.

    An actuator is lost on an interval where its failed output no longer depends on its
    command (stuck, floating, zero effectiveness), the thesis's effectiveness test of the
    rank condition (3.6) (:meth:`ClosedLoop.compensability`). Only the events where the set
    of lost actuators changes are listed.
    """
    report = loop.compensability()
    names = tuple(loop.plant.output_names)
    events: list[ReachabilityEvent] = []
    last = None
    for iv in report.intervals:
        failed = tuple(j + 1 for j, ok in enumerate(iv.effective) if not ok)
        if failed == last:
            continue
        last = failed
        events.append(
            ReachabilityEvent(
                time=float(iv.start),
                failed=failed,
                report=reachability(
                    loop.R, failed=failed, axis_names=names, max_condition=max_condition
                ),
            )
        )
    return tuple(events)
