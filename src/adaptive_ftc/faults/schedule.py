"""Per-actuator failure timelines and the compensability check (thesis (3.6), (3.9), (4.6))."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.faults.models import Failure

__all__ = ["CompensabilityReport", "FailureSchedule", "Interval", "check_compensability"]


@dataclass(frozen=True)
class FailureSchedule:
    """A validated set of failures for a plant with ``n_actuators`` actuators.

    Several failures may follow each other on one actuator, but their windows
    ``[onset, recovery)`` must not overlap.

    Examples
    --------
    >>> from adaptive_ftc.faults import Stuck, LossOfEffectiveness
    >>> s = FailureSchedule((Stuck(actuator=2, onset=40.0, value=0.1),
    ...                      LossOfEffectiveness(actuator=1, onset=80.0, effectiveness=0.75)), 2)
    >>> s.breakpoints(0.0, 120.0)
    (0.0, 40.0, 80.0, 120.0)
    """

    failures: tuple[Failure, ...]
    n_actuators: int

    def __post_init__(self) -> None:
        object.__setattr__(self, "failures", tuple(self.failures))
        for f in self.failures:
            if not isinstance(f, Failure):
                raise ConfigurationError(f"Expected Failure objects in the schedule; got {f!r}.")
            if f.actuator > self.n_actuators:
                raise ConfigurationError(
                    f"{type(f).__name__} names actuator {f.actuator}, but the plant has only "
                    f"{self.n_actuators} actuators (numbered 1..{self.n_actuators})."
                )
        by_act: dict[int, list[Failure]] = {}
        for f in self.failures:
            by_act.setdefault(f.actuator, []).append(f)
        for act, fs in by_act.items():
            fs = sorted(fs, key=lambda f: f.onset)
            for a, b in zip(fs, fs[1:], strict=False):
                if b.onset < a.end:
                    raise ConfigurationError(
                        f"Failures on actuator {act} overlap: {type(a).__name__} from "
                        f"{a.onset} s to {a.end} s and {type(b).__name__} from {b.onset} s. "
                        "Give the first one a `recovery` time no later than the second onset."
                    )

    def breakpoints(self, t0: float, t_final: float) -> tuple[float, ...]:
        """Sorted times splitting ``[t0, t_final]`` into intervals of fixed failure pattern."""
        times = {float(t0), float(t_final)}
        for f in self.failures:
            times.update(t for t in f.jump_times if t0 < t < t_final)
        return tuple(sorted(times))

    def active(self, t: float) -> list[Failure | None]:
        """The failure acting on each actuator at time ``t`` (``None``: healthy)."""
        out: list[Failure | None] = [None] * self.n_actuators
        for f in self.failures:
            if f.active(t):
                out[f.actuator - 1] = f
        return out


@dataclass(frozen=True)
class Interval:
    """One interval of fixed failure pattern in a compensability report."""

    start: float
    end: float
    effective: tuple[bool, ...]
    lost_groups: tuple[int, ...]
    reversed_groups: tuple[int, ...] = ()

    @property
    def ok(self) -> bool:
        """True when every output keeps at least one effective actuator (rank condition) and,
        for a known-sign design, its control direction (sign conditions (2.16)/(4.6))."""
        return not self.lost_groups and not self.reversed_groups


@dataclass(frozen=True)
class CompensabilityReport:
    """Result of :func:`check_compensability`: one :class:`Interval` per failure pattern."""

    intervals: tuple[Interval, ...]
    #: Outputs whose control gain is not positive with *healthy* actuators, for a known-sign
    #: design (sign conditions (2.16)/(4.6) already fail before any failure).
    healthy_reversed: tuple[int, ...] = ()
    #: The healthy control gain of each output (``sum_j g_ij R_ij``), for a known-sign design.
    healthy_gains: tuple[float, ...] = ()

    @property
    def ok(self) -> bool:
        """True when the rank condition (and, for a known-sign design, the sign conditions)
        holds on every interval and for the healthy plant."""
        return not self.healthy_reversed and all(i.ok for i in self.intervals)

    @property
    def dead_actuators(self) -> tuple[int, ...]:
        """Actuators (0-based) that are not effective on any interval of the run (e.g. stuck
        or at zero effectiveness from the start to the end): they never contribute."""
        if not self.intervals:
            return ()
        m = len(self.intervals[0].effective)
        return tuple(j for j in range(m) if not any(iv.effective[j] for iv in self.intervals))

    def describe(self, output_names: Sequence[str] | None = None) -> str:
        """Human-readable summary naming each interval and output group that fails."""
        lines = []
        for g in self.healthy_reversed:
            name = output_names[g] if output_names else f"output {g + 1}"
            gain = self.healthy_gains[g] if g < len(self.healthy_gains) else float("nan")
            lines.append(
                f"healthy plant: NOT compensable by this known-sign design - the control gain "
                f"of {name} with healthy actuators is {gain:.4g}, not positive (sign conditions "
                "(2.16)/(4.6)); flip the signs of its allocation row (docs/sign-convention.md) "
                "or use the 'nussbaum' or 'sign' design"
            )
        for iv in self.intervals:
            end = "end" if math.isinf(iv.end) else f"{iv.end:g} s"

            def named(groups: tuple[int, ...]) -> str:
                return ", ".join(
                    output_names[g] if output_names else f"output {g + 1}" for g in groups
                )

            if iv.ok:
                lines.append(f"[{iv.start:g} s, {end}): compensable")
            elif iv.lost_groups:
                lines.append(
                    f"[{iv.start:g} s, {end}): NOT compensable - no effective actuator "
                    f"left for {named(iv.lost_groups)}"
                )
            if iv.reversed_groups:
                lines.append(
                    f"[{iv.start:g} s, {end}): NOT compensable by this known-sign design - the "
                    f"control direction of {named(iv.reversed_groups)} is reversed or lost "
                    "(sign conditions (2.16)/(4.6)); use the 'nussbaum' or 'sign' design"
                )
        return "\n".join(lines)


def _slope(f: Failure | None, variables: tuple[str, ...], samples: dict) -> np.ndarray:
    """``d u^f / d u`` of an actuator at the sample points (1 for a healthy one)."""
    n = len(samples["t"])
    if f is None:
        return np.ones(n)
    d = f.expression(variables).derivative("u")
    if d.is_constant:
        return np.full(n, float(d.node[1]))
    values = d(**{k: v for k, v in samples.items() if k in d.used})
    return np.broadcast_to(np.asarray(values, dtype=float), (n,)).copy()


def check_compensability(
    schedule: FailureSchedule,
    allocation: np.ndarray,
    t_final: float,
    *,
    state_names: Iterable[str] = (),
    t0: float = 0.0,
    known_sign: bool = False,
    gains: Sequence[float] | np.ndarray | None = None,
) -> CompensabilityReport:
    """Check the rank condition ``rank(rho(x, t) R^T) = p`` (3.6) on every interval.

    An actuator counts as effective on an interval when its failed output still depends on its
    command (``d u^f / d u`` not identically zero, probed at sample points), so a stuck, floating
    or fully ineffective actuator counts as lost. For grouped actuators (each output driven by
    its own group, (3.9)) the condition reads: at least one effective actuator per group.

    Parameters
    ----------
    schedule
        The failure timeline.
    allocation
        The actuation matrix ``R`` (p x m) of ``u = R^T u0``.
    t_final
        End of the run.
    state_names
        Names the failure expressions may use for states (``x1..xn`` and aliases).
    known_sign
        The design assumes a known control direction (``direct``, ``estimation``, ``mimo``):
        then also check the sign conditions (2.16)/(4.6): along its allocation row, each
        output's control gain ``sum_j g_ij R_ij du^f_j/du_j`` must be positive with healthy
        actuators (:attr:`CompensabilityReport.healthy_reversed`) and at every sample point
        of every interval (a reversal that flips it is reported, even when the rank condition
        holds).
    gains
        Plant gains weighting the directional gain: one per actuator ``g_j`` (shared by every
        output) or a ``(outputs, actuators)`` matrix ``g_ij`` (``Plant.input_gains``); default
        all 1.
    """
    R = np.atleast_2d(np.asarray(allocation, dtype=float))
    if R.shape[1] != schedule.n_actuators:
        raise ConfigurationError(
            f"The allocation has {R.shape[1]} columns but the schedule has "
            f"{schedule.n_actuators} actuators."
        )
    m = schedule.n_actuators
    G = np.ones(m) if gains is None else np.asarray(gains, dtype=float)
    if G.shape == (m,):
        G = np.broadcast_to(G, R.shape)
    if G.shape != R.shape or not np.all(np.isfinite(G)):
        raise ConfigurationError(
            f"`gains` must be {m} finite numbers (one per actuator) or a {R.shape[0]}x{m} "
            f"matrix (one per output and actuator); got {gains!r}."
        )
    healthy = np.sum(G * R, axis=1)  # each output's control gain with healthy actuators
    healthy_reversed = (
        tuple(i for i in range(R.shape[0]) if not healthy[i] > 1e-12) if known_sign else ()
    )
    variables = ("t", "u", *state_names)
    rng = np.random.default_rng(0)
    bps = schedule.breakpoints(t0, t_final)
    intervals = []
    for a, b in zip(bps, bps[1:], strict=False):
        mid = 0.5 * (a + b)
        samples = {name: rng.uniform(-1, 1, 16) for name in variables}
        samples["t"] = rng.uniform(a, b, 16)
        slopes = [_slope(f, variables, samples) for f in schedule.active(mid)]
        eff = tuple(bool(np.any(np.abs(d) > 1e-12)) for d in slopes)
        reversed_groups: list[int] = []
        if known_sign:
            D = np.stack(slopes, axis=0)  # (m, samples)
            directional = (G * R) @ D  # (p, samples)
            for i in range(R.shape[0]):
                if i not in healthy_reversed and np.any(directional[i] <= 1e-12):
                    reversed_groups.append(i)
        lost = []
        Reff = R * np.asarray(eff, dtype=float)[None, :]
        if np.linalg.matrix_rank(Reff) < R.shape[0]:
            for i in range(R.shape[0]):
                if not np.any(Reff[i] != 0):
                    lost.append(i)
            if not lost:  # rank deficient without an empty row: report every output
                lost = list(range(R.shape[0]))
        reversed_groups = [i for i in reversed_groups if i not in lost]
        intervals.append(Interval(a, b, eff, tuple(lost), tuple(reversed_groups)))
    return CompensabilityReport(
        tuple(intervals),
        healthy_reversed=healthy_reversed,
        healthy_gains=tuple(float(v) for v in healthy) if known_sign else (),
    )
