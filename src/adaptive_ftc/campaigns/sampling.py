"""Drawing campaign members: member ``i`` only depends on ``(seed, i)``.

Each member has its own random stream ``np.random.default_rng([seed, index])`` (numpy's
``SeedSequence`` entropy pooling), so a member is the same whatever the chunking, the number of
threads or the scheduler, and :func:`draw_member` alone replays it.

Draw order within a member (documented so that a member can be reproduced by hand): number of
failures; which actuators (without replacement, then sorted); per failure in actuator order:
model, onset, ramp, whether it recovers, time to recovery, the model's params then fields in
spec order; then the initial states, the reference amplitude and the gains in spec order;
then the hardware (:mod:`adaptive_ftc.campaigns.hardware`): lag, rate limit, travel, sample
time, noise per state in spec order and the noise seed; last, when the spec's failures can be
annunciated (issue 31): per drawn failure in actuator order whether it is annunciated, then
the member's detection delay; then, when false alarms can be raised, whether one is, which
healthy actuator and when.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from adaptive_ftc.allocation.inloop import Annunciation
from adaptive_ftc.campaigns.checks import _fill
from adaptive_ftc.campaigns.spec import DESIGN_VARIANTS, CampaignSpec, FailureModelSpec
from adaptive_ftc.errors import ConfigurationError, ExpressionError
from adaptive_ftc.faults import Failure
from adaptive_ftc.registry import FAILURE_MODELS
from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["Member", "draw_member", "severity"]


@dataclass(frozen=True)
class Member:
    """One drawn member of a campaign: its failures, its closed loop and its table columns."""

    index: int
    failures: tuple[Failure, ...]
    severities: tuple[float, ...]
    params: tuple[dict[str, Any], ...]
    loop: ClosedLoop | None
    error: str
    columns: dict[str, Any]
    #: the campaign's allocators by kind (designs ``"adaptive+wls"``; ``None``: fixed)
    allocators: tuple[tuple[str, Any], ...] = ()

    def design_loop(self, design: str) -> ClosedLoop:
        """The member's closed loop for one of the compared designs (``design+kind``: the
        design with that allocator)."""
        if self.loop is None:
            raise ConfigurationError(f"Member {self.index} is invalid: {self.error}")
        name, _, kind = design.partition("+")
        loop = DESIGN_VARIANTS[name](self.loop)
        if kind:
            loop = dataclasses.replace(loop, allocator=dict(self.allocators)[kind])
        return loop


def severity(spec: FailureModelSpec, drawn: dict[str, Any], failure: Failure) -> float:
    """Severity of a drawn failure in [0, 1] (``nan``: not rated).

    The model's own rating (:meth:`Failure.severity <adaptive_ftc.faults.Failure.severity>`:
    ``1 - effectiveness`` for loss of effectiveness and affine failures, ``|bias| / largest
    |bias|`` for biases, 1 for stuck, parameterised stuck and reversal), with the largest
    magnitude of each drawn field as its scale; the spec may name any drawn value instead
    (``severity = "a"``: ``|a| / largest |a|``).
    """
    dists = dict(spec.fields) | dict(spec.params)
    if spec.severity is not None:
        v = drawn.get(spec.severity)
        if isinstance(v, (int, float)):
            return float(min(1.0, abs(v) / (dists[spec.severity].scale() or 1.0)))
        return math.nan
    return failure.severity({k: d.scale() for k, d in spec.fields})


def _draw_failure(
    spec: CampaignSpec, rng: np.random.Generator, actuator: int
) -> tuple[Failure, float, dict[str, Any]]:
    weights = np.array([m.weight for m in spec.models], dtype=float)
    mspec = spec.models[int(rng.choice(len(spec.models), p=weights / weights.sum()))]
    onset = float(spec.onset.draw(rng))
    ramp = float(spec.ramp.draw(rng))
    recovers = bool(rng.uniform() < spec.recovery_probability)
    to_recovery = float(spec.duration.draw(rng))
    recovery = onset + to_recovery if recovers else None
    if recovery is not None:
        ramp = min(ramp, to_recovery)
    params = {k: d.draw(rng) for k, d in mspec.params}
    fields = {k: d.draw(rng) for k, d in mspec.fields}
    kwargs = {k: _fill(v, params) for k, v in fields.items()}
    failure = FAILURE_MODELS[mspec.model](
        actuator=actuator, onset=onset, recovery=recovery, ramp=ramp, **kwargs
    )
    drawn = {**params, **fields}
    return failure, severity(mspec, drawn, failure), drawn


def draw_member(spec: CampaignSpec, index: int) -> Member:
    """Draw member ``index`` of a campaign (deterministic in ``(spec.seed, index)``).

    A draw that the closed loop refuses (e.g. failures overlapping a kept base failure) gives a
    member with ``loop = None`` and the reason in ``error``; it is recorded, never raised.

    Examples
    --------
    >>> from adaptive_ftc.campaigns import load_campaign
    >>> spec = load_campaign("hypersonic-loe")
    >>> draw_member(spec, 3).columns == draw_member(spec, 3).columns
    True
    """
    rng = np.random.default_rng([spec.seed, index])
    base = spec.loop
    plant = base.plant
    failures: list[Failure] = []
    sevs: list[float] = []
    drawn: list[dict[str, Any]] = []
    error = ""
    reported: set[int] = set()  # actuators whose drawn failure is annunciated
    try:
        k = int(spec.count.draw(rng))
        acts = sorted(int(a) for a in rng.choice(spec.actuators, size=k, replace=False))
        for a in acts:
            f, s, d = _draw_failure(spec, rng, a)
            failures.append(f)
            sevs.append(s)
            drawn.append(d)
        x0 = list(base.initial_state)
        cols: dict[str, Any] = {}
        for i, dist in spec.initial_state:
            x0[i] = float(dist.draw(rng))
            cols[f"x0_{plant.state_names[i]}"] = x0[i]
        reference = base.reference
        if spec.reference_amplitude is not None:
            amp = float(spec.reference_amplitude.draw(rng))
            cols["reference_amplitude"] = amp
            reference = tuple(f"({amp!r})*({r})" for r in reference)
        gains = {}
        for key, dist in spec.gains:
            gains[key] = dist.draw(rng)
            cols[f"gain_{key}"] = float(gains[key])
        ctrl = dataclasses.replace(base.controller, **gains) if gains else base.controller
        kept = tuple(base.failures.failures) if spec.keep_base else ()
        hw_loop = base
        if spec.hardware is not None:
            hw_loop, hw_cols = spec.hardware.draw(rng, base)
            cols.update(hw_cols)
        announced = _draw_annunciations(spec, rng, failures)
        alarm = _draw_false_alarm(spec, rng, failures)
        reported = {a.actuator for a in announced}
        if spec.allocation_columns:
            cols["annunciated"] = len(announced)
            cols["detection_delay"] = announced[0].delay if announced else math.nan
            cols["false_alarm"] = alarm[0].actuator if alarm else 0
            cols["false_alarm_time"] = alarm[0].onset if alarm else math.nan
        announced += alarm
        loop = dataclasses.replace(
            hw_loop,
            controller=ctrl,
            reference=reference,
            initial_state=tuple(x0),
            failures=kept + tuple(failures),
            name=f"{spec.name}[{index}]",
            # the base's annunciations belong to its own failures (issue 31)
            annunciations=(base.annunciations if spec.keep_base else ()) + announced,
        )
    except (ConfigurationError, ExpressionError, ValueError) as exc:
        loop, error = None, str(exc)
        cols = {}
    if loop is not None:
        report = loop.compensability()
        names = plant.output_names
        bad = [ln for ln in report.describe(names).splitlines() if "NOT" in ln]
        cols["compensable"] = bool(report.ok)
        cols["compensability"] = "; ".join(bad)
    else:
        cols["compensable"] = False
        cols["compensability"] = ""
    if spec.allocation_columns:
        cols["reachable"], cols["reachability"] = _reachability_verdict(loop)
    head: dict[str, Any] = {
        "index": int(index),
        "seed": int(spec.seed),
        "n_failures": len(failures),
        "models": "+".join(sorted({type(f).model for f in failures})),
        "severity": float(max(sevs)) if sevs and not all(map(math.isnan, sevs)) else math.nan,
    }
    for j in range(spec.max_failures):
        fj = failures[j] if j < len(failures) else None
        head[f"f{j + 1}_actuator"] = fj.actuator if fj else 0
        head[f"f{j + 1}_model"] = type(fj).model if fj else ""
        head[f"f{j + 1}_onset"] = float(fj.onset) if fj else math.nan
        rec = fj.recovery if fj is not None else None
        head[f"f{j + 1}_recovery"] = float(rec) if rec is not None else math.nan
        head[f"f{j + 1}_ramp"] = float(fj.ramp) if fj else math.nan
        head[f"f{j + 1}_severity"] = sevs[j] if fj else math.nan
        head[f"f{j + 1}_params"] = json.dumps(drawn[j], sort_keys=True) if fj else "{}"
        if spec.allocation_columns:
            head[f"f{j + 1}_annunciated"] = bool(fj is not None and fj.actuator in reported)
    return Member(
        index=int(index),
        failures=tuple(failures),
        severities=tuple(sevs),
        params=tuple(drawn),
        loop=loop,
        error=error,
        columns={**head, **cols},
        allocators=spec.allocators,
    )


def _draw_annunciations(
    spec: CampaignSpec, rng: np.random.Generator, failures: list[Failure]
) -> tuple[Annunciation, ...]:
    """Which drawn failures a detector reports (each with probability ``spec.annunciated``, in
    actuator order) and the detector's delay (one per member), drawn after everything else so
    a campaign without annunciations draws what it always drew."""
    if spec.annunciated is None or spec.detection_delay is None:
        return ()
    known = [f for f in failures if rng.uniform() < spec.annunciated]
    delay = float(spec.detection_delay.draw(rng))
    return tuple(
        Annunciation(actuator=f.actuator, onset=f.onset, recovery=f.recovery, delay=delay)
        for f in known
    )


def _draw_false_alarm(
    spec: CampaignSpec, rng: np.random.Generator, failures: list[Failure]
) -> tuple[Annunciation, ...]:
    """A false alarm (with probability ``spec.false_alarm``): one healthy candidate actuator,
    drawn uniformly, reported failed from a drawn time to the end of the run (after the
    annunciations, so a campaign without false alarms draws what it always drew)."""
    if spec.false_alarm is None or spec.false_alarm_time is None:
        return ()
    raised = bool(rng.uniform() < spec.false_alarm)
    healthy = [a for a in spec.actuators if a not in {f.actuator for f in failures}]
    which = int(rng.choice(healthy)) if healthy else 0
    when = float(spec.false_alarm_time.draw(rng))
    if not (raised and healthy):
        return ()
    return (Annunciation(actuator=which, onset=when),)


def _reachability_verdict(loop: ClosedLoop | None) -> tuple[bool, str]:
    """Whether every axis stays reachable over the run, and else which axis is lost when
    (:func:`~adaptive_ftc.allocation.reachability_timeline`), e.g. ``"phi from 61.1 s
    (actuators 1, 4 lost)"``."""
    if loop is None:
        return False, ""
    from adaptive_ftc.allocation import reachability_timeline

    lost = [
        f"{', '.join(e.report.unreachable)} from {e.time:g} s (actuators "
        f"{', '.join(map(str, e.failed))} lost)"
        for e in reachability_timeline(loop)
        if not e.report.full
    ]
    return not lost, "; ".join(lost)
