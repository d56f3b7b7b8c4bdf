"""Allocation study (issue 31): success vs number of failed actuators and detection delay, per
allocator.

Each *draw* fails ``n`` distinct actuators of a catalogue scenario (its own failures are
replaced), each either stuck at a random value or at a random loss of effectiveness, from a
random onset. Every allocator sees the same draws (a paired comparison), each failure either
silent (known only to the plant) or annunciated after a detection delay. A run *succeeds*
when it completes and the RMS tracking error over the last ``window`` seconds (the worst
output) is at most ``threshold`` (default: the scenario's own ``tracking`` claim). The fixed
allocation ignores annunciations: its silent run stands for every detection setting.

``scripts/allocation_study.py`` runs the shipped study and writes ``docs/figures/allocation*``;
the numbers are discussed in ``docs/allocation.md``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np
import pandas as pd

from adaptive_ftc.allocation.allocators import (
    AdaptiveAllocation,
    Allocator,
    PseudoInverse,
    WeightedLeastSquares,
)
from adaptive_ftc.allocation.inloop import Annunciation
from adaptive_ftc.allocation.reachable import reachability_timeline
from adaptive_ftc.errors import ConfigurationError

__all__ = [
    "DEFAULT_ALLOCATORS",
    "allocation_study",
    "draw_failures",
    "plot_allocation_study",
    "summarize",
]

#: the allocators compared by default (``None``: the thesis's fixed ``u = R^T u0``)
DEFAULT_ALLOCATORS: dict[str, Allocator | None] = {
    "fixed": None,
    "pinv": PseudoInverse(),
    "wls": WeightedLeastSquares(),
    "adaptive": AdaptiveAllocation(gain=5.0),
}


def draw_failures(
    n_actuators: int,
    n_failed: int,
    rng: np.random.Generator,
    *,
    onset: tuple[float, float],
    stuck: float,
    effectiveness: tuple[float, float] = (0.1, 0.5),
    p_stuck: float = 0.5,
) -> tuple:
    """``n_failed`` failures of distinct actuators: stuck at a value uniform in
    ``[-stuck, stuck]`` (probability ``p_stuck``) or a loss of effectiveness uniform in
    ``effectiveness``, from an onset uniform in ``onset``."""
    from adaptive_ftc.faults import LossOfEffectiveness, Stuck

    if not 0 <= n_failed <= n_actuators:
        raise ConfigurationError(
            f"`n_failed` must be between 0 and the {n_actuators} actuators; got {n_failed}."
        )
    acts = rng.choice(n_actuators, size=n_failed, replace=False) + 1
    out: list = []
    for j in sorted(int(a) for a in acts):
        t = float(np.round(rng.uniform(*onset), 3))
        if rng.uniform() < p_stuck:
            out.append(
                Stuck(actuator=j, onset=t, value=float(np.round(rng.uniform(-1, 1) * stuck, 3)))
            )
        else:
            level = float(np.round(rng.uniform(*effectiveness), 3))
            out.append(LossOfEffectiveness(actuator=j, onset=t, effectiveness=level))
    return tuple(out)


def _detections(delays: Sequence[float | None]) -> list[tuple[str, float | None]]:
    return [("silent", None) if d is None else (f"annunciated +{d:g} s", float(d)) for d in delays]


def allocation_study(
    scenario: str,
    *,
    failed: Sequence[int] = (1, 2),
    draws: int = 4,
    delays: Sequence[float | None] = (None, 0.0, 2.0),
    allocators: Mapping[str, Allocator | None] | None = None,
    duration: float | None = None,
    onset: tuple[float, float] | None = None,
    stuck: float = 5.0,
    window: float | None = None,
    threshold: float | None = None,
    seed: int = 0,
) -> pd.DataFrame:
    """One row per (failed count, draw, detection, allocator) run of ``scenario``.

    Parameters
    ----------
    scenario
        Catalogue name or path (its own failures are replaced by the draws).
    failed
        The numbers of failed actuators to draw.
    draws
        Draws per number of failed actuators (the same for every allocator and detection).
    delays
        Detection settings: ``None`` silent, a number: annunciated after that delay (s).
    allocators
        Name -> allocator (``None``: fixed); default :data:`DEFAULT_ALLOCATORS`.
    duration, onset
        Run length (default: the scenario's) and the window of onsets (default: the first
        half of the run, after a tenth of it).
    stuck
        Largest magnitude of a stuck value (actuator units).
    window, threshold
        Success: RMS tracking error of the worst output over the last ``window`` s at most
        ``threshold`` (default: the scenario's ``tracking`` claim; else 20 % of the run and
        5 % of the largest reference amplitude is not guessed: give it).
    seed
        Seed of the draws.

    Returns
    -------
    pandas.DataFrame
        Columns ``scenario, n_failed, draw, detection, allocator, failures, reachable,
        status, rms, peak_u, success``.
    """
    from adaptive_ftc.scenarios.loader import load_scenario
    from adaptive_ftc.sim.engine import simulate

    sc = load_scenario(scenario)
    claim = next((c for c in sc.claims if c.get("kind") == "tracking"), {})
    window = float(window if window is not None else claim.get("window", 0.0))
    threshold = threshold if threshold is not None else claim.get("threshold")
    if threshold is None or not window > 0:
        raise ConfigurationError(
            f"Scenario '{sc.name}' has no tracking claim to take the success criterion from: "
            "give `window` and `threshold`."
        )
    t_final = float(duration if duration is not None else sc.loop.t_final)
    if onset is None:
        onset = (0.1 * t_final, 0.5 * t_final)
    allocators = dict(DEFAULT_ALLOCATORS if allocators is None else allocators)
    base = replace(sc.loop, t_final=t_final, failures=())
    m = base.plant.n_actuators
    rng = np.random.default_rng(seed)
    rows: list[dict] = []
    for n in failed:
        for d in range(draws):
            fails = draw_failures(m, n, rng, onset=onset, stuck=stuck)
            loop = replace(base, failures=fails)
            reachable = all(e.report.full for e in reachability_timeline(loop))
            text = "; ".join(f"{type(f).__name__}({f.actuator}, t={f.onset:g})" for f in fails)
            for label, delay in _detections(delays):
                anns = (
                    ()
                    if delay is None
                    else tuple(
                        Annunciation(actuator=f.actuator, onset=f.onset, delay=delay) for f in fails
                    )
                )
                for name, alloc in allocators.items():
                    if alloc is None and delay is not None:  # fixed: ignores annunciations
                        prev = next(
                            r
                            for r in rows
                            if r["allocator"] == name
                            and r["n_failed"] == n
                            and r["draw"] == d
                            and r["detection"] == "silent"
                        )
                        rows.append({**prev, "detection": label})
                        continue
                    run = simulate(replace(loop, allocator=alloc, annunciations=anns), sc.solver)
                    done = run.status.name == "COMPLETED" and run.time[-1] >= t_final - 1e-9
                    rms = (
                        float(np.max(run.rms_error(t_final - window, t_final))) if done else np.inf
                    )
                    rows.append(
                        {
                            "scenario": sc.name,
                            "n_failed": n,
                            "draw": d,
                            "detection": label,
                            "allocator": name,
                            "failures": text,
                            "reachable": reachable,
                            "status": run.status.name.lower(),
                            "rms": rms,
                            "peak_u": float(np.max(np.abs(run.u_cmd))),
                            "success": bool(done and rms <= threshold),
                        }
                    )
    return pd.DataFrame(rows)


def summarize(table: pd.DataFrame) -> pd.DataFrame:
    """Success rate, median RMS error and runs per (scenario, failed count, detection,
    allocator)."""
    keys = ["scenario", "n_failed", "detection", "allocator"]
    g = table.groupby(keys, sort=False)
    return g.agg(
        success_rate=("success", "mean"),
        median_rms=("rms", "median"),
        runs=("success", "size"),
    ).reset_index()


def plot_allocation_study(table: pd.DataFrame):
    """Success rate vs failed actuators, one panel per (scenario, detection), one line per
    allocator (a matplotlib Figure)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    summary = summarize(table)
    scenarios = list(dict.fromkeys(summary["scenario"]))
    detections = list(dict.fromkeys(summary["detection"]))
    fig, axes = plt.subplots(
        len(scenarios),
        len(detections),
        figsize=(3.2 * len(detections), 2.6 * len(scenarios)),
        squeeze=False,
        sharey=True,
    )
    for r, scn in enumerate(scenarios):
        for c, det in enumerate(detections):
            ax = axes[r][c]
            part = summary[(summary["scenario"] == scn) & (summary["detection"] == det)]
            names = list(dict.fromkeys(part["allocator"]))
            for k, (name, rows) in enumerate(part.groupby("allocator", sort=False)):
                shift = 0.05 * (k - (len(names) - 1) / 2)  # equal rates stay visible
                ax.plot(rows["n_failed"] + shift, rows["success_rate"], marker="o", label=name)
            ax.set_title(f"{scn}\n{det}", fontsize=8)
            ax.set_xticks(sorted(set(part["n_failed"])))
            ax.set_ylim(-0.05, 1.05)
            if r == len(scenarios) - 1:
                ax.set_xlabel("failed actuators")
            if c == 0:
                ax.set_ylabel("success rate")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    return fig
