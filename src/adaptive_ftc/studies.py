"""Robustness studies the thesis did not make (issue 14).

The thesis's designs assume ideal actuators, exact measurements and a continuous-time
controller. :func:`robustness_sweep` runs one scenario many times, each time with one of these
assumptions relaxed by a *knob*, and tabulates how the tracking degrades; :func:`break_points`
finds where each design breaks.

Knobs (the value's unit in brackets; every other setting is the scenario's own):

``noise`` [output units, e.g. rad]
    Seeded Gaussian measurement noise (:class:`~adaptive_ftc.hardware.Sensors`, 1000 samples
    per second, each held until the next) with standard deviation ``value`` on the first state
    and ``value * 10**i`` on state ``i`` (for the hypersonic plant: ``value`` on ``alpha``,
    ``10 value`` on ``q``; pass ``noise_shape`` to change this). ``s'`` comes from the
    dirty-derivative filter (``SolverOptions(sdot="auto")``, ``filter_tau`` 0.01 s).
``controller_rate`` [Hz]
    Sample-and-hold digital controller at ``value`` Hz (``ClosedLoop(sample_time=1/value)``);
    the filter time constant is ``max(filter_tau, 1/value)`` (a sampled filter needs
    ``sample_time < 2 filter_tau``; at ``filter_tau = sample_time`` it is the backward
    difference, the plainest digital derivative).
``lag`` [s]
    First-order lag of every actuator, time constant ``value``
    (:class:`~adaptive_ftc.hardware.Actuators`).
``rate_limit`` [actuator units per second]
    Rate limit ``value`` on every actuator with no other lag. The rate limiter then has the
    time constant :data:`~adaptive_ftc.hardware.RATE_ONLY_TAU` (5 ms) in its linear band, so a
    rate limit that never binds gives the ``lag`` = 5 ms run: read this knob's break point
    together with the lag knob's.

Noise and digital runs integrate with RK4 at ``dt <= 1 ms`` dividing the sample period (the
noise and the held command jump every sample; an adaptive step would only shrink to meet
them: the RMS errors agree with dopri5 within 2 %); lag and rate-limit runs use the scenario's
own solver. A ``noise`` value of 0 (or ``controller_rate`` ``inf``, ``lag`` 0, ``rate_limit``
``inf``) is the scenario's ideal run, unchanged.

**Break point.** A run is *broken* when it diverged (or was stopped) before the end, or its RMS
tracking error over the last ``window`` seconds exceeds ``threshold``. The default threshold is
that of the scenario's own ``tracking`` claim (in the catalogue: 1 % of the reference amplitude,
``pi/36 * 0.01 = 8.7e-4`` rad for the hypersonic scenarios), i.e. the accuracy the thesis
claims. The break point of a knob is the mildest value, in order of increasing severity (noise
and lag growing, controller rate and rate limit falling), from which every harsher value
tested is broken too. The table also reports the ratio to the ideal error and the peak command
``|u|``: a design can keep its error small while its adaptive law winds the command up to
hundreds of radians behind a rate limit (no anti-windup in the thesis's laws), which the
``windup`` column flags (peak command more than 10 times the ideal run's).

**Time-delay margin.** :func:`delay_margin` finds, by bisection on an injected input delay
(:class:`~adaptive_ftc.hardware.Actuators` ``delay``), the largest delay at which a loop stays
acceptable (no divergence, final-window RMS error within the tracking threshold, fast command
content within 3 % of the undelayed run's command peak to peak); :func:`delay_margin_study`
tabulates it per scenario for the thesis law and the constraint-aware law
(``aftc study delay-margin``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd

from adaptive_ftc.errors import ConfigurationError, did_you_mean
from adaptive_ftc.hardware import Actuators, Sensors
from adaptive_ftc.scenarios.loader import Scenario, load_scenario
from adaptive_ftc.sim.batch import simulate_many
from adaptive_ftc.sim.engine import DEFAULT_FILTER_TAU, SolverOptions
from adaptive_ftc.sim.result import SimResult
from adaptive_ftc.sim.system import ClosedLoop

__all__ = [
    "ACTIVITY_FRACTION",
    "DEFAULT_VALUES",
    "DELAY_SCENARIOS",
    "DelayMargin",
    "DelayRun",
    "KNOBS",
    "QUICK_VALUES",
    "STUDY_SCENARIOS",
    "break_points",
    "delay_margin",
    "delay_margin_study",
    "robustness_study",
    "robustness_sweep",
]

#: Knob name -> (unit, True when a larger value is harsher).
KNOBS: dict[str, tuple[str, bool]] = {
    "noise": ("rad", True),
    "controller_rate": ("Hz", False),
    "lag": ("s", True),
    "rate_limit": ("rad/s", False),
}

#: Values swept by ``aftc study robustness``.
DEFAULT_VALUES: dict[str, tuple[float, ...]] = {
    "noise": (1e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2),
    "controller_rate": (5000.0, 2000.0, 1000.0, 500.0, 200.0, 100.0, 50.0),
    "lag": (1e-4, 3e-4, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2),
    "rate_limit": (200.0, 100.0, 50.0, 20.0, 10.0, 5.0, 2.0),
}

#: Values swept by ``aftc study robustness --quick``.
QUICK_VALUES: dict[str, tuple[float, ...]] = {
    "noise": (1e-5, 1e-4, 1e-3),
    "controller_rate": (1000.0, 200.0, 100.0),
    "lag": (0.005, 0.05, 0.2),
    "rate_limit": (50.0, 10.0, 2.0),
}

#: The designs of the study: §2.3 (direct) and §4.4 (sign estimation), hypersonic plant.
STUDY_SCENARIOS: tuple[str, ...] = ("hypersonic-direct-s1", "hypersonic-sign-s1-rho0pos")

_NOISE_RATE = 1000.0
_MAX_DT = 1e-3
_WINDUP = 10.0
_COLUMNS = [
    "scenario",
    "knob",
    "value",
    "unit",
    "seed",
    "status",
    "rms_error",
    "ideal_rms_error",
    "ratio_to_ideal",
    "threshold",
    "broken",
    "peak_u_cmd",
    "peak_u_applied",
    "windup",
    "diverged_at",
    "fast_rms",
    "tv_per_s",
    "rate_limited_fraction",
    "activity_record_ok",
]


def _check_knob(knob: str) -> None:
    if knob not in KNOBS:
        raise ConfigurationError(
            f"Unknown robustness knob {knob!r}.{did_you_mean(knob, list(KNOBS))} "
            f"Knobs: {', '.join(KNOBS)}."
        )


def _is_ideal(knob: str, value: float) -> bool:
    return value == 0.0 if KNOBS[knob][1] else math.isinf(value)


def _noise_table(loop: ClosedLoop, value: float, shape: Mapping[str, float] | None):
    names = loop.plant.state_names
    if shape is None:
        if loop.plant.n_outputs != 1:
            raise ConfigurationError(
                f"The noise knob's default shape (value * 10**i on state i) is for one-output "
                f"plants; plant '{loop.plant.name}' has {loop.plant.n_outputs} outputs. Pass "
                f"noise_shape={{state name: multiplier}} (states: {', '.join(names)})."
            )
        shape = {name: 10.0**i for i, name in enumerate(names)}
    return {name: value * float(k) for name, k in shape.items()}


def _variant(
    loop: ClosedLoop,
    solver: SolverOptions,
    knob: str,
    value: float,
    seed: int,
    noise_shape: Mapping[str, float] | None,
) -> tuple[ClosedLoop, SolverOptions]:
    """The loop and solver of one run of the sweep."""
    if _is_ideal(knob, value):
        return loop, solver
    if knob == "noise":
        sensors = Sensors(
            noise=_noise_table(loop, value, noise_shape), rate=_NOISE_RATE, seed=int(seed)
        )
        rk4 = replace(solver, method="rk4", dt=_MAX_DT)
        return replace(loop, sensors=sensors), rk4
    if knob == "controller_rate":
        ts = 1.0 / value
        dt = ts / math.ceil(ts / _MAX_DT - 1e-9)
        tau = max(solver.filter_tau or DEFAULT_FILTER_TAU, ts)
        rk4 = replace(solver, method="rk4", dt=dt, filter_tau=tau)
        return replace(loop, sample_time=ts), rk4
    if knob == "lag":
        return replace(loop, actuators=Actuators(tau=value)), solver
    return replace(loop, actuators=Actuators(rate=value)), solver


def _check_values(knob: str, values: Iterable[float]) -> list[float]:
    out = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v):
            raise ConfigurationError(f"Values of knob {knob!r} must be numbers; got {v!r}.")
        if v < 0 or (v == 0 and not KNOBS[knob][1]):
            raise ConfigurationError(
                f"Values of knob {knob!r} must be {'>= 0' if KNOBS[knob][1] else '> 0'} "
                f"({KNOBS[knob][0]}); got {v!r}."
            )
        out.append(float(v))
    if not out:
        raise ConfigurationError(f"Knob {knob!r} needs at least one value to sweep.")
    return out


def _shortened(loop, duration, window):
    """``loop`` ending ``duration`` s after its start (unchanged when None), after checking
    that the judged final ``window`` fits in the run."""
    if duration is not None:
        if not duration > 0:
            raise ConfigurationError(f"`duration` must be > 0 s; got {duration!r}.")
        loop = replace(loop, t_final=loop.t0 + float(duration))
    span = loop.t_final - loop.t0
    if not 0 < window <= span:
        raise ConfigurationError(
            f"`window` must be in (0, {span:g}] s (the run's length); got {window!r}."
        )
    return loop


def _default_threshold(sc: Scenario) -> float:
    for claim in sc.claims:
        if claim.get("kind") == "tracking" and "threshold" in claim:
            return float(claim["threshold"])
    raise ConfigurationError(
        f"Scenario '{sc.name}' has no `tracking` claim to take the break threshold from: pass "
        "threshold= (an RMS tracking error, in the output's unit)."
    )


def _metrics(r: SimResult, window: float, t_final: float) -> tuple[float, float, float, float]:
    """(rms error over the last window, peak |u_cmd|, peak |u_applied|, divergence time)."""
    done = r.status == "completed" and r.time.size and r.time[-1] >= t_final - 1e-9
    rms = float(np.max(r.rms_error(t_final - window, t_final))) if done else math.nan
    peak_cmd = float(np.nanmax(np.abs(r.u_cmd))) if r.u_cmd.size else math.nan
    peak_app = float(np.nanmax(np.abs(r.u_applied))) if r.u_applied.size else math.nan
    diverged_at = math.nan if done else float(r.time[-1] if r.time.size else 0.0)
    return rms, peak_cmd, peak_app, diverged_at


def _activity(r: SimResult, window: float, t_final: float) -> dict[str, Any]:
    """The worst actuator's fast command content (above 1 Hz), total variation per second
    and fraction at a rate limit over the last window (NaN for a run that did not reach its
    end), and whether the record is fine enough to judge them
    (:mod:`adaptive_ftc.sim.activity`)."""
    done = r.status == "completed" and r.time.size and r.time[-1] >= t_final - 1e-9
    out: dict[str, Any] = {
        "fast_rms": math.nan,
        "tv_per_s": math.nan,
        "rate_limited_fraction": math.nan,
        "activity_record_ok": False,
    }
    if not done:
        return out
    acts = list(r.activity(t_final - window, t_final).values())
    for key in ("fast_rms", "tv_per_s", "rate_limited_fraction"):
        vals = [getattr(a, key) for a in acts if not math.isnan(getattr(a, key))]
        out[key] = max(vals) if vals else math.nan
    out["activity_record_ok"] = bool(acts and acts[0].record_ok)
    return out


def robustness_sweep(
    scenario: str | Scenario,
    knob: str,
    values: Sequence[float],
    *,
    seeds: Sequence[int] = (0,),
    window: float = 20.0,
    threshold: float | None = None,
    duration: float | None = None,
    noise_shape: Mapping[str, float] | None = None,
    jobs: int | None = None,
    progress: bool = False,
    record_dt: float | None = None,
) -> pd.DataFrame:
    """Run ``scenario`` once per knob value (and per seed for ``noise``) and tabulate the result.

    Parameters
    ----------
    scenario
        A catalogue name, a scenario file, or a :class:`Scenario`.
    knob
        ``"noise"``, ``"controller_rate"``, ``"lag"`` or ``"rate_limit"`` (see the module
        docstring for what each changes and its unit).
    values
        Knob values; 0 noise / lag (``inf`` rate) is the ideal run, unchanged.
    seeds
        Noise seeds (one row per value and seed); the other knobs are deterministic and run
        once, with seed ``-1``.
    window
        The RMS tracking error is taken over the last ``window`` seconds (the thesis claims'
        window).
    threshold
        RMS error above which a completed run counts as broken; default: the threshold of the
        scenario's ``tracking`` claim (1 % of the reference amplitude in the catalogue).
    duration
        Shorten every run to this many seconds (default: the scenario's duration).
    noise_shape
        Multiplier of ``value`` per state name for the ``noise`` knob.
    jobs, progress
        Threads and progress bar of :func:`~adaptive_ftc.sim.batch.simulate_many`.
    record_dt
        Record spacing of every run (default: the scenario's). The activity columns need
        records of 1 ms or finer (``activity_record_ok``; the aliasing rule of
        :mod:`adaptive_ftc.sim.activity`); a 120 s run then keeps about 40 MB of records.

    Returns
    -------
    pandas.DataFrame
        One row per run, in the order of ``values`` then ``seeds``, with columns ``scenario,
        knob, value, unit, seed, status, rms_error, ideal_rms_error, ratio_to_ideal,
        threshold, broken, peak_u_cmd, peak_u_applied, windup, diverged_at, fast_rms, tv_per_s,
        rate_limited_fraction, activity_record_ok`` (``rms_error`` is the largest over the
        outputs, NaN for a run that did not reach its end; ``diverged_at`` the time of the
        last good sample, NaN for a completed run; the activity columns: the worst
        actuator's command over the last ``window`` seconds, see
        :meth:`~adaptive_ftc.sim.result.SimResult.activity`). The same arguments give the same
        table.

    Examples
    --------
    >>> df = robustness_sweep("hypersonic-direct-s1", "lag", [0.0, 0.05])
    >>> df[["value", "status", "broken"]].values.tolist()
    [[0.0, 'completed', False], [0.05, 'completed', False]]
    """
    _check_knob(knob)
    vals = _check_values(knob, values)
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    seeds = [int(s) for s in seeds] if knob == "noise" else [-1]
    if knob == "noise" and not seeds:
        raise ConfigurationError("`seeds` of a noise sweep needs at least one seed.")
    loop, solver = sc.loop, sc.solver
    if record_dt is not None:
        solver = replace(solver, record_dt=record_dt)
    loop = _shortened(loop, duration, window)
    thr = _default_threshold(sc) if threshold is None else float(threshold)
    runs = [(v, s) for v in vals for s in seeds]
    pairs = [_variant(loop, solver, knob, v, max(s, 0), noise_shape) for v, s in runs]
    results = _simulate_grouped([(loop, solver), *pairs], jobs=jobs, progress=progress)
    ideal = _metrics(results[0], window, loop.t_final)
    rows = []
    for (v, s), r in zip(runs, results[1:], strict=True):
        rms, peak_cmd, peak_app, div = _metrics(r, window, loop.t_final)
        broken = not (rms <= thr)  # NaN (diverged) is broken
        rows.append(
            {
                "scenario": sc.name,
                "knob": knob,
                "value": v,
                "unit": KNOBS[knob][0],
                "seed": s,
                "status": r.status,
                "rms_error": rms,
                "ideal_rms_error": ideal[0],
                "ratio_to_ideal": rms / ideal[0] if ideal[0] > 0 else math.nan,
                "threshold": thr,
                "broken": bool(broken),
                "peak_u_cmd": peak_cmd,
                "peak_u_applied": peak_app,
                "windup": bool(peak_cmd > _WINDUP * ideal[1]),
                "diverged_at": div,
                **_activity(r, window, loop.t_final),
            }
        )
    return pd.DataFrame(rows, columns=_COLUMNS)


def _simulate_grouped(pairs, *, jobs, progress) -> list[SimResult]:
    """simulate_many over (loop, solver) pairs that may use different solvers."""
    import warnings

    from adaptive_ftc.errors import DivergenceWarning

    out: list[SimResult | None] = [None] * len(pairs)
    groups: dict[SolverOptions, list[int]] = {}
    for i, (_, solver) in enumerate(pairs):
        groups.setdefault(solver, []).append(i)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)  # a diverged run is a data point
        for solver, idx in groups.items():
            res = simulate_many([pairs[i][0] for i in idx], solver, jobs=jobs, progress=progress)
            for i, r in zip(idx, res, strict=True):
                out[i] = r
    return out  # type: ignore[return-value]


def break_points(table: pd.DataFrame) -> pd.DataFrame:
    """The break point of every (scenario, knob) of a sweep table.

    A value counts as broken when any of its seeds is broken. Values are ordered by severity
    (noise and lag growing, controller rate and rate limit falling); the break point is the
    mildest value from which every harsher value tested is broken (NaN when the harshest
    value still holds). ``last_ok`` is the harshest value that holds with every milder one.

    Returns
    -------
    pandas.DataFrame
        Columns ``scenario, knob, unit, break_point, last_ok, how`` (``how``: "diverged" when
        the break-point run did not reach its end, else "error > threshold").

    Examples
    --------
    >>> t = pd.DataFrame({"scenario": "s", "knob": "lag", "value": [0.01, 0.1, 0.05],
    ...                   "unit": "s", "broken": [False, True, False], "status": "completed"})
    >>> break_points(t)[["break_point", "last_ok"]].values.tolist()
    [[0.1, 0.05]]
    """
    missing = {"scenario", "knob", "value", "broken", "status"} - set(table.columns)
    if missing:
        raise ConfigurationError(
            f"break_points() needs a robustness_sweep table; columns missing: "
            f"{', '.join(sorted(missing))}."
        )
    rows = []
    for (scen, knob), grp in table.groupby(["scenario", "knob"], sort=False):
        _check_knob(knob)
        harsher_up = KNOBS[knob][1]
        per = grp.groupby("value", sort=True).agg(
            broken=("broken", "any"), diverged=("status", lambda s: (s != "completed").any())
        )
        per = per.sort_index(ascending=harsher_up)  # mildest first
        values = list(per.index)
        broken = list(per["broken"])
        bp = last_ok = math.nan
        how = ""
        k = len(values)
        while k > 0 and broken[k - 1]:
            k -= 1
        if k < len(values):
            bp = float(values[k])
            how = "diverged" if per["diverged"].iloc[k] else "error > threshold"
        if k > 0:
            last_ok = float(values[k - 1])
        unit = grp["unit"].iloc[0] if "unit" in grp else KNOBS[knob][0]
        rows.append(
            {
                "scenario": scen,
                "knob": knob,
                "unit": unit,
                "break_point": bp,
                "last_ok": last_ok,
                "how": how,
            }
        )
    return pd.DataFrame(rows, columns=["scenario", "knob", "unit", "break_point", "last_ok", "how"])


def robustness_study(
    scenarios: Sequence[str] = STUDY_SCENARIOS,
    *,
    quick: bool = False,
    values: Mapping[str, Sequence[float]] | None = None,
    seeds: Sequence[int] = (0, 1, 2),
    jobs: int | None = None,
    progress: bool = False,
) -> pd.DataFrame:
    """Every knob of :data:`KNOBS` on every scenario (the ``aftc study robustness`` table).

    ``quick`` sweeps :data:`QUICK_VALUES` with one seed instead of :data:`DEFAULT_VALUES`.
    """
    chosen = dict(QUICK_VALUES if quick else DEFAULT_VALUES)
    for knob, vals in (values or {}).items():
        _check_knob(knob)
        chosen[knob] = tuple(vals)
    from adaptive_ftc._feedback import EtaBar

    seeds = seeds[:1] if quick else seeds
    sweeps = [(s, k) for s in scenarios for k in chosen]
    # the ETA weighs a sweep by its runs (values x seeds)
    cost = {k: float(len(chosen[k]) * len(seeds)) for k in chosen}
    tables = []
    with EtaBar(
        len(sweeps),
        cost=sum(cost[k] for _, k in sweeps),
        disable=not progress,
        desc="robustness sweeps",
        unit="sweep",
    ) as bar:
        for name, knob in sweeps:
            bar.note(f"{name} {knob}")
            tables.append(robustness_sweep(name, knob, chosen[knob], seeds=seeds, jobs=jobs))
            bar.tick(cost[knob])
    return pd.concat(tables, ignore_index=True)


# ---------------------------------------------------------------------------- delay margin

#: The scenarios of ``aftc study delay-margin``.
DELAY_SCENARIOS: tuple[str, ...] = (
    "hypersonic-direct-s1",
    "hypersonic-sign-s1-rho0pos",
    "hypersonic-nussbaum-s1-pos",
    "wingrock-estimation-s1",
    "manipulator-mimo-s1",
    "spacecraft-mimo-s1",
)

#: Fast command content (above ``f_c``) allowed in an acceptable run, as a fraction of the
#: undelayed run's command peak to peak in the same window, per actuator (issue 25).
ACTIVITY_FRACTION = 0.03

_DELAY_COLUMNS = [
    "scenario",
    "design",
    "law",
    "margin",
    "lower",
    "upper",
    "unit",
    "resolution",
    "runs",
    "how",
    "ideal_rms_error",
    "threshold",
    "window",
    "duration",
]


@dataclass(frozen=True)
class DelayRun:
    """One run of a :func:`delay_margin` search."""

    #: injected input delay (s)
    delay: float
    #: whether the run is acceptable (see :func:`delay_margin`)
    acceptable: bool
    #: why not: "diverged", "error > threshold", "fast command content" ("" when acceptable)
    reason: str
    #: RMS tracking error over the final window (worst output; NaN when diverged)
    rms_error: float
    #: largest ratio over the actuators of the fast command content to its allowance
    activity_ratio: float


@dataclass(frozen=True)
class DelayMargin:
    """What :func:`delay_margin` found: the margin lies in ``[lower, upper]`` (s)."""

    #: scenario (or loop) name, design and law ("thesis", "constraint-aware (...)", "scenario")
    scenario: str
    design: str
    law: str
    #: the largest acceptable delay tested below the first unacceptable one (s); 0 when even
    #: the smallest tried delay is not acceptable, NaN when the undelayed run is not
    margin: float
    #: bracket: ``lower`` acceptable, ``upper`` not (``inf``: none found below ``max_delay``)
    lower: float
    upper: float
    #: every run, in the order made (the undelayed run first)
    runs: tuple[DelayRun, ...]
    #: why the ``upper`` run is not acceptable
    how: str
    ideal_rms_error: float
    threshold: float
    window: float
    duration: float
    resolution: float

    def row(self) -> dict[str, Any]:
        """The study table's row."""
        return {
            "scenario": self.scenario,
            "design": self.design,
            "law": self.law,
            "margin": self.margin,
            "lower": self.lower,
            "upper": self.upper,
            "unit": "s",
            "resolution": self.resolution,
            "runs": len(self.runs),
            "how": self.how,
            "ideal_rms_error": self.ideal_rms_error,
            "threshold": self.threshold,
            "window": self.window,
            "duration": self.duration,
        }


def _tracking_window(sc: Scenario, default: float) -> float:
    for claim in sc.claims:
        if claim.get("kind") == "tracking" and "window" in claim:
            return float(claim["window"])
    return default


def _judge(
    r: SimResult,
    delay: float,
    t_final: float,
    window: float,
    threshold: float,
    allowance: np.ndarray | None,
    f_c: float,
    fraction: float = ACTIVITY_FRACTION,
) -> DelayRun:
    done = r.status == "completed" and r.time.size and r.time[-1] >= t_final - 1e-9
    if not done:
        return DelayRun(delay, False, "diverged", math.nan, math.nan)
    rms = float(np.max(r.rms_error(t_final - window, t_final)))
    acts = list(r.activity(t_final - window, t_final, f_c=f_c).values())
    fast = np.array([a.fast_rms for a in acts])
    if allowance is None:  # the undelayed run: its own allowance
        allowance = fraction * np.array([a.peak_to_peak for a in acts])
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = float(np.nanmax(np.where(allowance > 0, fast / allowance, 0.0), initial=0.0))
    if not rms <= threshold:
        return DelayRun(delay, False, "error > threshold", rms, ratio)
    if not ratio <= 1.0:
        return DelayRun(delay, False, "fast command content", rms, ratio)
    return DelayRun(delay, True, "", rms, ratio)


def delay_margin(
    scenario: str | Scenario | ClosedLoop,
    *,
    constraint_aware: Any = "scenario",
    solver: SolverOptions | None = None,
    threshold: float | None = None,
    window: float | None = None,
    duration: float | None = None,
    resolution: float = 0.05,
    min_delay: float = 1e-6,
    max_delay: float = 2.0,
    start: float = 1e-3,
    max_runs: int = 20,
    order: int | None = None,
    f_c: float = 1.0,
    activity_fraction: float | None = ACTIVITY_FRACTION,
) -> DelayMargin:
    """Time-delay margin of a loop: the largest injected input delay for which it stays
    acceptable, by bisection (issue 25, item 4; the robustness figure of adaptive control).

    The delay is :class:`~adaptive_ftc.hardware.Actuators` ``delay`` on every actuator, added
    to the loop's own actuators: a Padé approximant (order ``order``, default 4, phase exact
    to 1e-4 degrees at ``omega d <= pi/2``) for a continuous controller, a shift of whole
    samples for a digital one (then the delays tried are whole samples and the resolution
    one sample). A run is **acceptable** when

    - it reaches its end (no divergence),
    - its RMS tracking error over the final ``window`` is at most ``threshold`` (default:
      the scenario's ``tracking`` claim: its threshold and window), and
    - every actuator's fast command content (RMS above ``f_c`` Hz over that window,
      :meth:`~adaptive_ftc.sim.result.SimResult.activity`) is at most
      ``activity_fraction`` (default :data:`ACTIVITY_FRACTION`, 3 %) of the undelayed run's
      command peak to peak there (the activity threshold of issue 25); ``None`` leaves the
      activity out (a regulation loop whose ideal command is constant in the window).

    Runs are recorded at ``min(record_dt, 1 ms)`` (the activity's aliasing rule). The search
    starts at ``start`` s, doubles (or halves) until the verdict changes, then bisects the
    bracket ``[lower, upper]`` until ``upper - lower <= resolution * upper`` (relative
    resolution; 5 % by default) or ``max_runs`` runs are made. ``margin`` is ``lower``: an
    acceptable delay with every tested larger delay up to ``upper`` unacceptable. The verdict
    need not be monotonic in the delay (a limit cycle can come and go); the bisection finds
    one boundary, the first from below along the doubling. A continuous loop's fixed-step
    solver is replaced by ``dopri5`` (the Padé states' fast mode, ``|p| ~ 6.8/d``, would make
    a fixed step unstable for small delays).

    Parameters
    ----------
    scenario
        A catalogue name, scenario file, :class:`Scenario`, or a :class:`ClosedLoop` (then
        ``threshold`` and ``window`` are needed, and ``solver`` defaults to
        :class:`SolverOptions`).
    constraint_aware
        ``"scenario"``: the design as the scenario declares it; ``None``: the thesis law
        (``constraint_aware`` removed); a
        :class:`~adaptive_ftc.controllers.constraints.ConstraintAware`: that designer's model.
    duration
        Shorten the run to this many seconds.
    min_delay, max_delay
        Below ``min_delay`` the margin is reported as 0; above ``max_delay`` as
        ``max_delay`` with ``upper = inf``.

    Examples
    --------
    >>> dm = delay_margin("hypersonic-direct-s1", duration=30.0, window=10.0, resolution=0.3)
    >>> 0.0 < dm.margin < 0.01 and dm.lower < dm.upper
    True
    """
    from adaptive_ftc.hardware import PADE_ORDER

    if isinstance(scenario, ClosedLoop):
        loop, name = scenario, scenario.name or "loop"
        solver = solver or SolverOptions()
        if threshold is None or window is None:
            raise ConfigurationError(
                "delay_margin() of a ClosedLoop needs `threshold` (an RMS tracking error) and "
                "`window` (s): a scenario gives them from its tracking claim."
            )
    else:
        sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
        loop, name = sc.loop, sc.name
        solver = solver or sc.solver
        threshold = _default_threshold(sc) if threshold is None else threshold
        window = _tracking_window(sc, 20.0) if window is None else window
    loop = _shortened(loop, duration, window)
    if not 0 < resolution < 1:
        raise ConfigurationError(
            f"`resolution` is relative (upper - lower <= resolution * upper): in (0, 1); "
            f"got {resolution!r}."
        )
    if not 0 < min_delay <= start <= max_delay or not math.isfinite(max_delay):
        raise ConfigurationError(
            "Need 0 < min_delay <= start <= max_delay < inf (s); got "
            f"{min_delay!r}, {start!r}, {max_delay!r}."
        )
    if isinstance(max_runs, bool) or not isinstance(max_runs, int) or max_runs < 3:
        raise ConfigurationError(f"`max_runs` must be an integer >= 3; got {max_runs!r}.")
    ctrl = loop.controller
    if constraint_aware is None:
        ctrl, law = replace(ctrl, constraint_aware=None), "thesis"
    elif isinstance(constraint_aware, str):
        if constraint_aware != "scenario":
            raise ConfigurationError(
                f"`constraint_aware` must be 'scenario', None (the thesis law) or a "
                f"ConstraintAware; got {constraint_aware!r}."
            )
        law = "scenario" if ctrl.constraint_aware is None else "constraint-aware (scenario)"
    else:
        ctrl, law = replace(ctrl, constraint_aware=constraint_aware), "constraint-aware"
    loop = replace(loop, controller=ctrl)
    from adaptive_ftc.sim.activity import max_record_dt

    ts = loop.sample_time
    rec = min(solver.record_dt or math.inf, max_record_dt(f_c, ts))
    solver = replace(solver, record_dt=rec)
    if ts == 0 and solver.method in ("rk4", "euler"):
        solver = replace(solver, method="dopri5")
    base_acts = loop.actuators or Actuators()
    kw = {"delay_order": PADE_ORDER if order is None else order}

    def run(d: float) -> tuple[SimResult, float]:
        import warnings

        from adaptive_ftc.errors import DivergenceWarning

        if ts > 0:
            d = round(d / ts) * ts
        acts = replace(base_acts, delay=d, **kw)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DivergenceWarning)
            from adaptive_ftc.sim.engine import simulate

            return simulate(replace(loop, actuators=acts), solver), d

    t1 = loop.t_final
    frac = math.inf if activity_fraction is None else float(activity_fraction)
    ideal, _ = run(0.0)
    first = _judge(ideal, 0.0, t1, window, threshold, None, f_c, frac)
    acts0 = list(ideal.activity(t1 - window, t1, f_c=f_c).values()) if first.acceptable else []
    allowance = frac * np.array([a.peak_to_peak for a in acts0])
    runs = [first]
    res = max(resolution, 0.0)

    def result(lower: float, upper: float, margin: float, how: str) -> DelayMargin:
        return DelayMargin(
            scenario=name,
            design=loop.controller.design,
            law=law,
            margin=margin,
            lower=lower,
            upper=upper,
            runs=tuple(runs),
            how=how,
            ideal_rms_error=first.rms_error,
            threshold=float(threshold),
            window=float(window),
            duration=float(loop.t_final - loop.t0),
            resolution=ts if ts > 0 else res,
        )

    if not first.acceptable:
        return result(math.nan, 0.0, math.nan, "undelayed run: " + first.reason)
    verdict: dict[float, DelayRun] = {}

    def test(d: float) -> DelayRun:
        r, d = run(d)
        v = _judge(r, d, t1, window, threshold, allowance, f_c)
        runs.append(v)
        verdict[d] = v
        return v

    if ts > 0:  # whole samples: integer bisection
        lo_k, hi_k, k = 0, None, max(1, round(start / ts))
        while len(runs) < max_runs and hi_k is None and k * ts <= max_delay:
            if test(k * ts).acceptable:
                lo_k, k = k, 2 * k
            else:
                hi_k = k
        while hi_k is not None and hi_k - lo_k > 1 and len(runs) < max_runs:
            mid = (lo_k + hi_k) // 2
            if test(mid * ts).acceptable:
                lo_k = mid
            else:
                hi_k = mid
        lo, hi = lo_k * ts, (math.inf if hi_k is None else hi_k * ts)
    else:
        lo, hi, d = 0.0, math.inf, start
        if test(d).acceptable:
            lo = d
            while len(runs) < max_runs and d < max_delay:
                d = min(2 * d, max_delay)
                if test(d).acceptable:
                    lo = d
                else:
                    hi = d
                    break
        else:
            hi = d
            while len(runs) < max_runs and d / 2 >= min_delay:
                d /= 2
                if test(d).acceptable:
                    lo = d
                    break
                hi = d
        while math.isfinite(hi) and lo > 0 and hi - lo > res * hi and len(runs) < max_runs:
            mid = 0.5 * (lo + hi)
            if test(mid).acceptable:
                lo = mid
            else:
                hi = mid
    how = verdict[hi].reason if hi in verdict else ""
    return result(lo, hi, lo, how)


def delay_margin_study(
    scenarios: Sequence[str] = DELAY_SCENARIOS,
    *,
    quick: bool = False,
    laws: Mapping[str, Any] | None = None,
    progress: bool = False,
    **kwargs,
) -> pd.DataFrame:
    """:func:`delay_margin` of every scenario under every law (the ``aftc study delay-margin``
    table, one row per scenario and law).

    ``laws`` maps a label to a ``constraint_aware`` argument of :func:`delay_margin`; default:
    ``thesis`` (None), ``constraint-aware (ideal model)`` (the model derived from ideal
    hardware: :meth:`ConstraintAware.from_hardware` with nothing declared, which is the
    thesis law by construction) and ``constraint-aware (lag 20 ms)``
    (``ConstraintAware.from_hardware(actuators=Actuators(tau=0.02))``). ``quick``: the thesis
    law only, a third of each scenario's horizon (final window a quarter of that), 20 %
    resolution.
    """
    from adaptive_ftc._feedback import EtaBar
    from adaptive_ftc.controllers.constraints import ConstraintAware

    if laws is None:
        laws = {"thesis": None}
        if not quick:
            laws["constraint-aware (ideal model)"] = "ideal"
            laws["constraint-aware (lag 20 ms)"] = "lag 20 ms"
    rows = []
    jobs = [(s, lab, law) for s in scenarios for lab, law in laws.items()]
    # the ETA weighs a margin by its scenario's duration (each bisection step is one run)
    weight = {s: _span(s) for s in scenarios}
    bar = EtaBar(
        len(jobs),
        cost=sum(weight[s] for s, _, _ in jobs),
        disable=not progress,
        desc="delay margins",
        unit="law",
    )
    for name, label, law in jobs:
        bar.note(f"{name} {label}")
        sc = load_scenario(name)
        if law == "ideal":
            law = ConstraintAware.from_hardware(plant=sc.loop.plant, lam=sc.loop.controller.lam)
        elif law == "lag 20 ms":
            law = ConstraintAware.from_hardware(
                actuators=Actuators(tau=0.02), plant=sc.loop.plant, lam=sc.loop.controller.lam
            )
        kw = dict(kwargs)
        if quick:
            span = sc.loop.t_final - sc.loop.t0
            kw.setdefault("duration", span / 3)
            kw.setdefault("window", min(_tracking_window(sc, 20.0), span / 12))
            kw.setdefault("resolution", 0.2)
        dm = delay_margin(sc, constraint_aware=law, **kw)
        rows.append({**dm.row(), "law": label})
        bar.tick(weight[name])
    bar.close()
    return pd.DataFrame(rows, columns=_DELAY_COLUMNS)


def _span(name: str) -> float:
    """The duration of a scenario (s), or 1 for one that does not load (the study reports
    it)."""
    try:
        sc = load_scenario(name)
    except Exception:  # noqa: BLE001 - an estimate; the study itself raises the error
        return 1.0
    return max(float(sc.loop.t_final) - float(sc.loop.t0), 1e-9)
