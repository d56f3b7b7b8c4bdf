"""One-command reproduction of the thesis's simulations (``aftc reproduce``).

For every catalogue scenario (or the ones named) three runs are made, in parallel over processes:

``adaptive``
    the scenario as the thesis ran it (adaptation on, failures on);
``frozen``
    adaptation frozen at the initial parameters (what the failures do without adaptation);
``failure_free``
    adaptation on, no failures (the nominal behaviour);
``fixed-gain``, ``nominal-inverse``, ``oracle``
    the fair baselines of :mod:`adaptive_ftc.baselines` (with the failures), for every scenario
    with a ``baseline_ratio`` claim (every adaptive scenario with ``baselines=True``; not in
    quick mode unless asked, see ``fair_baselines``): the claim is held against the best of
    fixed-gain, nominal inverse and frozen; the oracle, which knows the true failure, is shown
    but never compared with;
``thesis_law``
    for every scenario whose controller declares ``constraint_aware`` (the scenario's design is
    then the constraint-aware law): the thesis law beside it, the option removed
    (``dataclasses.replace(controller, constraint_aware=None)``), same hardware, failures and
    solver. The scenario's claims are judged on it too
    (:func:`adaptive_ftc.claims.evaluate_thesis_law_claims`): what it does not meet is a named
    FINDING, never PASS and never a FAIL of the exit code; ``claims.csv`` says in its ``run``
    column which run a verdict judges, and the tracking figures overlay it.

Variants that would repeat the adaptive run are skipped: ``frozen`` when the scenario has no
adaptation (open-loop runs), ``failure_free`` when it has no failures.

Everything is written into ``out_dir``::

    figures/fig_<number>.png    every [[figure]] table (+ .pdf/.svg beside it, see ``formats``);
                                with ``baselines=True`` the frozen/failure-free runs are overlaid
    data/<scenario>[_frozen|_failure_free|_fixed-gain|_nominal-inverse|_oracle|_thesis_law].nc
    metrics.csv                 one row per run (+ baseline/adaptive error ratios per scenario)
    claims.csv                  one row per [[claims]] table and judged run (``run``: adaptive,
                                or thesis_law for the companion): verdict, measured number, unit
    report.html                 the report (links the figure files; keep it beside figures/)

A figure number used by several scenarios (e.g. the ``+``/``-`` variants of one thesis figure) is
written ``fig_<number>_<scenario>.png``; a scenario without [[figure]] tables gets the default
figures of :func:`adaptive_ftc.plots.default_figure_specs`, written
``fig_<scenario>_<kind>.png``.

Quick mode (``quick=True``, for CI) shortens every run to
``min(T, max(T/4, t_first + T/10))`` where ``T`` is the scenario's duration and ``t_first`` its
first failure event, so at least the first failure happens inside the shortened run (failures
later than that are simply not reached). Claims are evaluated against the full duration ``T``:
a claim whose window the shortened run does not reach is ``NOT EVALUATED`` (not a FAIL).

Claims-only mode (``claims_only=True``, ``data=False``, ``figure_limit=0``: what ``aftc
reproduce --quick`` runs) makes the runs the claims need and nothing else, at full length: the
adaptive run of every scenario, and for a scenario with a ``baseline_ratio`` claim the
baselines it is held against (frozen, fixed-gain, nominal inverse). Its verdicts are those of
a full reproduction; what it leaves out (the failure-free runs, the oracle, the thesis law's
companion runs and their verdicts, data files, figures) is listed in the report and the
summary's ``left_out``. The runs themselves are a few seconds of the catalogue's cost: a warm
full reproduction spends its time writing the 1 ms records and drawing the figures.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import csv
import dataclasses
import functools
import math
import multiprocessing
import os
import time
import traceback
import warnings
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from adaptive_ftc.baselines import BASELINES, FAIR_BASELINES, baseline_loop, baseline_solver
from adaptive_ftc.claims import (
    FAIL,
    FINDING,
    NOT_EVALUATED,
    NOT_REPRODUCED,
    ORACLES,
    PASS,
    ClaimError,
    ClaimResult,
    evaluate_claims,
    evaluate_thesis_law_claims,
)
from adaptive_ftc.report import FigureEntry, ScenarioEntry, write_report
from adaptive_ftc.scenarios.loader import Scenario, list_scenarios, load_scenario
from adaptive_ftc.sim.result import SimResult

__all__ = ["VARIANTS", "quick_duration", "run_reproduction"]

#: Run variants per scenario, in report order.
VARIANTS: tuple[str, ...] = (
    "adaptive",
    "frozen",
    "failure_free",
    "fixed-gain",
    "nominal-inverse",
    "oracle",
    "thesis_law",
)
#: The variants that are :mod:`adaptive_ftc.baselines` designs (besides ``frozen``).
_DESIGN_BASELINES = tuple(b for b in BASELINES if b != "frozen")

_BASELINE_LABELS = {
    "frozen": "frozen adaptation",
    "failure_free": "failure-free",
    "fixed-gain": "fixed-gain",
    "nominal-inverse": "nominal inverse",
    "oracle": "oracle (knows the failure)",
    "thesis_law": "thesis law (constraint-aware off)",
}


def thesis_law_loop(loop):
    """``loop`` with the thesis law in place of its constraint-aware design (the option
    removed: ``dataclasses.replace(loop.controller, constraint_aware=None)``)."""
    return dataclasses.replace(
        loop, controller=dataclasses.replace(loop.controller, constraint_aware=None)
    )


def _is_constraint_aware(sc: Scenario) -> bool:
    return getattr(sc.loop.controller, "constraint_aware", None) is not None


# ---------------------------------------------------------------------------- scenario set-up
def quick_duration(sc: Scenario) -> float:
    """Shortened duration of quick mode: ``min(T, max(T/4, t_first + T/10))``."""
    t0, T = float(sc.loop.t0), float(sc.loop.t_final)
    span = T - t0
    events = sorted(t for f in _failures_of(sc) for t in getattr(f, "jump_times", ()) if t0 < t < T)
    first = events[0] if events else t0
    return min(T, max(t0 + span / 4, first + span / 10))


def _failures_of(sc: Scenario) -> tuple:
    failures = sc.loop.failures
    return tuple(getattr(failures, "failures", failures))


#: Scenarios loaded by this process during one reproduction (a worker runs several variants of
#: a scenario: each loaded and validated once); emptied when a reproduction starts
_LOADED: dict[tuple[str, bool], Scenario] = {}


def _prepare(name: str, quick: bool) -> Scenario:
    sc = _LOADED.get((name, quick))
    if sc is None:
        sc = load_scenario(name)
        if quick:
            loop = dataclasses.replace(sc.loop, t_final=quick_duration(sc))
            sc = dataclasses.replace(sc, loop=loop)
        _LOADED[(name, quick)] = sc
    return sc


def _compile_order(scenarios: Sequence[Scenario], tasks: list[tuple[str, str]]):
    """``tasks`` reordered so that the workers never compile the same code at once.

    Runs that share a compiled loop (a scenario's adaptive, frozen, failure-free and fixed-gain
    variants; scenarios that differ only in numbers or failures; the exact-inverse baselines of
    one plant) would, back to back, be compiled by both workers at once on a cold cache. So:
    first one run of every integration method (each compiles that shared integrator; the
    costliest first), then the first run of every other loop, then the second ones...: by the
    time a loop or a method runs again, one worker has compiled it and the other loads it from
    the disk cache. Measured on a cold ``aftc reproduce``: the variants back to back took 4m08s
    (7m36s CPU), round robin over scenarios 2m16s (4m09s CPU), first runs first 1m59s (3m35s
    CPU). A log of numba's compile events over a cold run then still showed the Rosenbrock
    integrator, one ``rhs`` and one control gain compiled twice; with the loops keyed by the
    text of the loop each variant actually runs (not its scenario's), the methods' first runs
    apart, plants in turn and second runs in first-run order, each compiles once. The loop
    texts are generated again here (about 1 ms a loop, before the workers start).
    """
    import hashlib

    from adaptive_ftc.baselines import baseline_solver, nominal_inverse
    from adaptive_ftc.sim.compose import generate

    by_name = {sc.name: sc for sc in scenarios}
    memo: dict[tuple[str, bool | None], str] = {}

    def key(name: str, variant: str) -> tuple[str, str]:
        sc = by_name[name]
        # one loop for both (oracle: a number); None: a loop of its own
        exact: bool | None = variant in ("nominal-inverse", "oracle")
        solver = baseline_solver(variant, sc.solver) if variant in _DESIGN_BASELINES else sc.solver
        if variant == "thesis_law":
            exact = None  # its own loop (the option removed)
        if (name, exact) not in memo:
            try:
                loop = sc.loop
                if exact:
                    loop = nominal_inverse(sc.loop)
                elif exact is None:
                    loop = thesis_law_loop(sc.loop)
                text = generate(loop, sdot=solver.sdot_for(loop))[0]
            except Exception:  # noqa: BLE001 - the run itself will report it
                text = f"{name}:{exact}"
            memo[(name, exact)] = hashlib.sha256(text.encode()).hexdigest()
        return memo[(name, exact)], solver.method

    keys = [key(*task) for task in tasks]
    plants = [by_name[name].loop.plant.name for name, _ in tasks]
    # the shared integrators' compile cost, largest first (measured on a cold run: auto 4.7 s,
    # Rodas5P 3.5 s, DOPRI5 1.2 s and its helpers, RK4 0.8 s)
    from adaptive_ftc.sim.solvers import METHODS

    cost = {m.name: m.compile_cost for m in METHODS}
    first_of_method: dict[str, int] = {}
    for i, (_, method) in enumerate(keys):
        first_of_method.setdefault(method, i)
    openers = sorted(first_of_method.values(), key=lambda i: (-cost.get(keys[i][1], 0), i))
    opening = set(openers)
    seen: Counter = Counter(keys[i][0] for i in openers)
    # then the first run of every other loop, one plant after another (the plant's control
    # gain is a module of its own: two new loops of one plant back to back would compile it
    # twice), then the second runs of every loop...
    firsts: dict[str, list[int]] = {}
    later: list[tuple[int, int]] = []  # (runs of its loop before it, task index)
    for i in range(len(tasks)):
        if i in opening:
            continue
        text = keys[i][0]
        if seen[text] == 0:
            firsts.setdefault(plants[i], []).append(i)
        else:
            later.append((seen[text], i))
        seen[text] += 1
    queues = list(firsts.values())
    round_robin = [
        q[n] for n in range(max(map(len, queues), default=0)) for q in queues if n < len(q)
    ]
    # second runs in the order their loops were first run: the first of them is not the loop
    # the other worker may still be compiling
    where: dict[str, int] = {}
    for n, i in enumerate(openers + round_robin):
        where.setdefault(keys[i][0], n)
    later.sort(key=lambda item: (item[0], where.get(keys[item[1]][0], 0), item[1]))
    order = openers + round_robin + [i for _, i in later]
    return [tasks[i] for i in order]


def _default_count(sc: Scenario) -> int:
    """How many default figures (:func:`adaptive_ftc.plots.default_figure_specs`) a scenario
    without [[figure]] tables gets, from its loop (before it runs)."""
    loop = sc.loop
    names = tuple(getattr(loop.plant, "state_names", ()))
    n = 3 + any(str(n).startswith("eta") for n in names)
    return n + (loop.controller.design in ("nussbaum", "sign"))


def _task_loops(by_name: dict[str, Scenario], tasks: list[tuple[str, str]]):
    """``(loop, sdot)`` of every structure the tasks compile (the variants of a scenario share
    its loop's structure; the exact-inverse baselines have one of their own)."""
    from adaptive_ftc.baselines import nominal_inverse

    for name, variant in tasks:
        sc = by_name[name]
        solver = baseline_solver(variant, sc.solver) if variant in _DESIGN_BASELINES else sc.solver
        try:
            loop = nominal_inverse(sc.loop) if variant in ("nominal-inverse", "oracle") else sc.loop
        except Exception:  # noqa: BLE001 - the run itself reports it
            continue
        yield loop, solver.sdot_for(loop)


def _has_baseline_claim(sc: Scenario) -> bool:
    return any(c.get("baseline_ratio") is not None for c in sc.claims)


def _variants(sc: Scenario, all_baselines: bool = False) -> list[str]:
    out = ["adaptive"]
    if sc.loop.adapt:
        out.append("frozen")
    if _failures_of(sc):
        out.append("failure_free")
    if sc.loop.adapt and (_has_baseline_claim(sc) or (all_baselines and _failures_of(sc))):
        out += list(_DESIGN_BASELINES)
    if _is_constraint_aware(sc):
        out.append("thesis_law")
    return out


def _claim_variants(sc: Scenario, fair: bool) -> list[str]:
    """The runs a scenario's claims are judged on (claims-only mode): the adaptive run, and
    for a ``baseline_ratio`` claim the baselines it is held against (the oracle is never)."""
    out = ["adaptive"]
    if sc.loop.adapt and _has_baseline_claim(sc):
        out.append("frozen")
        if fair:
            out += [v for v in _DESIGN_BASELINES if v not in ORACLES]
    return out


def _run_cost(sc: Scenario, data: bool) -> float:
    """Expected CPU seconds of one run of ``sc`` (and of writing its data file), the weight of
    its task in the progress bar's ETA (:func:`adaptive_ftc._feedback.run_cost`)."""
    from adaptive_ftc._feedback import run_cost
    from adaptive_ftc.sim.layout import RecordLayout

    try:
        loop = sc.loop
        records = (float(loop.t_final) - float(loop.t0)) / float(sc.solver.record_dt) + 1
        recorded = RecordLayout(p=loop.plant.n_outputs, m=loop.plant.n_actuators)
        values = records * (len(loop.initial_state) + recorded.width)
    except Exception:  # noqa: BLE001 - an estimate: the run itself reports a broken loop
        values = 1e6
    return run_cost(values, write=data)


def _data_path(out_dir: Path, name: str, variant: str) -> Path:
    suffix = "" if variant == "adaptive" else f"_{variant}"
    return out_dir / "data" / f"{name}{suffix}.nc"


# ---------------------------------------------------------------------------- worker tasks
def _simulate_task(
    name: str,
    variant: str,
    quick: bool,
    out_dir: str,
    float32: bool = False,
    decimate: int = 1,
    data: bool = True,
) -> dict[str, Any]:
    """Run one variant in a worker process, write its netCDF (float64, every sample unless
    ``float32`` / ``decimate`` say otherwise; none without ``data``), return the result."""
    start = time.perf_counter()
    try:
        sc = _prepare(name, quick)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # divergence is recorded in the result's status
            if variant in _DESIGN_BASELINES:
                from adaptive_ftc.errors import ConfigurationError
                from adaptive_ftc.sim.engine import simulate

                try:
                    loop = baseline_loop(sc.loop, variant, sc.solver)
                except ConfigurationError as exc:  # e.g. a fixed-gain tuning run diverged:
                    # no such baseline exists; reported, not counted as an error
                    return {"result": None, "error": str(exc), "wall": 0.0, "skipped": True}
                result = sc.stamp(simulate(loop, baseline_solver(variant, sc.solver)))
            elif variant == "thesis_law":
                from adaptive_ftc.sim.engine import simulate

                result = sc.stamp(simulate(thesis_law_loop(sc.loop), sc.solver))
            else:
                result = sc.run(adapt=variant != "frozen", failures=variant != "failure_free")
        result.meta["variant"] = variant
        if data:
            result.to_netcdf(
                _data_path(Path(out_dir), name, variant),
                float32=float32,
                decimate=decimate,
            )
        return {"result": result, "error": "", "wall": time.perf_counter() - start}
    except Exception:  # noqa: BLE001 - reported in the report and metrics, the others go on
        return {"result": None, "error": traceback.format_exc(limit=3), "wall": 0.0}


def _figure_task(
    result: SimResult,
    spec: dict[str, Any],
    path: str,
    baselines: dict[str, SimResult],
    formats: Sequence[str] = ("png",),
    dpi: int | None = None,
    zoom_result: SimResult | None = None,
) -> str:
    """Render one figure in a worker process; returns an error text or ``""``."""
    from adaptive_ftc.plots import save_figure

    try:
        base = baselines if spec.get("kind") == "tracking" and baselines else None
        save_figure(
            result, spec, path, baselines=base, formats=formats, dpi=dpi, zoom_result=zoom_result
        )
        return ""
    except Exception as exc:  # noqa: BLE001 - a broken figure must not stop the reproduction
        return f"{type(exc).__name__}: {exc}"


# ---------------------------------------------------------------------------- figures plan
def _figure_plan(scenarios: Sequence[Scenario]) -> dict[str, list[tuple[dict[str, Any], str]]]:
    """Per scenario: (figure spec, file name), with unique file names across scenarios."""
    counts = Counter(str(f.get("number")) for sc in scenarios for f in sc.figure_specs)
    plan: dict[str, list[tuple[dict[str, Any], str]]] = {}
    for sc in scenarios:
        items = []
        for spec in sc.figure_specs:
            number = str(spec.get("number"))
            fname = f"fig_{number}.png" if counts[number] == 1 else f"fig_{number}_{sc.name}.png"
            items.append((dict(spec), fname))
        plan[sc.name] = items
    return plan


def _default_specs(sc: Scenario, result: SimResult) -> list[tuple[dict[str, Any], str]]:
    from adaptive_ftc.plots import default_figure_specs

    figs = ", ".join(sc.figures)
    items = []
    for spec in default_figure_specs(result, title=sc.title or sc.name):
        spec = dict(spec)
        spec["caption"] = spec["caption"] + (f" (cf. thesis Fig. {figs})" if figs else "")
        items.append((spec, f"fig_{sc.name}_{spec['kind']}.png"))
    return items


# ---------------------------------------------------------------------------- metrics
def _metrics_row(name: str, variant: str, result: SimResult | None, err: str, wall: float):
    row: dict[str, Any] = {"scenario": name, "variant": variant}
    if result is None:
        row.update(status="error", message=err.strip().splitlines()[-1] if err else "")
        return row
    m = result.metrics()
    row.update(
        status=result.status,
        message=result.message,
        t_end=m.get("t_end", math.nan),
        rms_error=m.get("rms_error", math.nan),
        max_error=m.get("max_error", math.nan),
        final_window_s=m.get("final_window_s", math.nan),
        rms_error_final=m.get("rms_error_final", math.nan),
        max_error_final=m.get("max_error_final", math.nan),
        peak_command=m.get("peak_command", math.nan),
        peak_applied=m.get("peak_applied", math.nan),
        wall_time_s=wall,
    )
    # control activity over the final window (worst actuator; sim/activity.py)
    row.update({k: m.get(k, math.nan) for k in _ACTIVITY_METRICS})
    return row


def _error_ratio(adaptive: SimResult | None, frozen: SimResult | None) -> float:
    """RMS error of a baseline run (e.g. frozen) over that of the adaptive run, in the adaptive
    run's final window (10 % of the duration); ``inf`` when the baseline diverged, ``nan`` if
    unknown."""
    if adaptive is None or frozen is None or adaptive.status != "completed":
        return math.nan
    t_end = float(adaptive.meta.get("t_final", adaptive.time[-1]))
    start = t_end - 0.1 * (t_end - float(adaptive.time[0]))
    if frozen.status != "completed" or not frozen.window(start, t_end).any():
        return math.inf
    a = float(max(adaptive.rms_error(start, t_end)))
    f = float(max(frozen.rms_error(start, t_end)))
    return f / a if a > 0 else math.inf


#: Control-activity columns of metrics.csv (the final window's worst actuator, see
#: :meth:`adaptive_ftc.sim.result.SimResult.metrics`).
_ACTIVITY_METRICS = (
    "fast_rms_max",
    "tv_per_s_max",
    "peak_rate_max",
    "rate_limited_fraction_max",
    "travel_limited_fraction_max",
    "peak_command_travel_ratio_max",
    "peak_to_peak_max",
    "activity_record_dt",
    "activity_record_ok",
)

_METRIC_FIELDS = [
    "scenario",
    "variant",
    "status",
    "message",
    "t_end",
    "rms_error",
    "max_error",
    "final_window_s",
    "rms_error_final",
    "max_error_final",
    "peak_command",
    "peak_applied",
    *_ACTIVITY_METRICS,
    "wall_time_s",
    "error_ratio_frozen_over_adaptive",
    "error_ratio_best_fair_baseline_over_adaptive",
    "best_fair_baseline",
    "error_ratio_oracle_over_adaptive",
]


#: Columns of claims.csv: ``run`` says which run a verdict judges (``adaptive``: the scenario's
#: design; ``thesis_law``: the thesis law beside a constraint-aware design).
CLAIM_FIELDS = [
    "scenario",
    "section",
    "run",
    "kind",
    "verdict",
    "measured",
    "threshold",
    "unit",
    "text",
    "detail",
    "finding",
]


def _claim_row(sc: Scenario, c: ClaimResult, run: str) -> dict[str, Any]:
    return {
        "scenario": sc.name,
        "section": sc.section,
        "run": run,
        "kind": c.kind,
        "verdict": c.verdict,
        "measured": c.measured,
        "threshold": c.threshold,
        "unit": c.unit,
        "text": " ".join(c.text.split()),
        "detail": c.detail,
        "finding": c.finding,
    }


def _write_csv(path: Path, fields: Sequence[str], rows: Sequence[dict[str, Any]]) -> Path:
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(fields), extrasaction="ignore")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: row.get(k, "") for k in fields})
    return path


# ---------------------------------------------------------------------------- main entry
def _worker_init() -> None:
    """Worker processes end with their parent: Linux delivers SIGTERM to a worker when the
    parent dies (even by SIGKILL); Ctrl-C is handled by the parent, which stops the workers."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # SIGTERM ends a worker: forked while the parent's handler (_workers_end_with_parent) is
    # installed, it would otherwise raise KeyboardInterrupt, which the pool records as the
    # task's error and goes on with the next task (Ctrl-C then took 12 s to return, or hung)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not Linux: the parent's handler below still applies
        pass
    # The libraries every task uses, imported once here and then frozen out of the cyclic
    # garbage collector: its full collections no longer walk their hundreds of thousands of
    # long-lived objects (numba's and matplotlib's), while what the tasks create is collected
    # as usual. Measured: 3.5 s of 26 s CPU of a warm `aftc reproduce` were collections; with
    # both settings it takes 22-25 s CPU, 13.1-14.2 s wall instead of 26-27 s, 15.3-16.3 s.
    import gc

    import adaptive_ftc.plots  # noqa: F401 - matplotlib (Agg figures)
    import adaptive_ftc.sim.engine  # noqa: F401
    import adaptive_ftc.sim.result  # noqa: F401

    try:
        import netCDF4  # noqa: F401 - the data files
        import numba  # noqa: F401 - the compiled loops
        import xarray  # noqa: F401
    except ImportError:  # pragma: no cover - a task then reports the missing library
        pass
    gc.collect()
    gc.freeze()
    # and young collections less often (matplotlib allocates many small objects per figure):
    # these processes only live for one reproduction
    gc.set_threshold(10_000, 20, 20)


@contextlib.contextmanager
def _workers_end_with_parent():
    """On SIGTERM/SIGINT stop this process's worker processes, then raise KeyboardInterrupt."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(signum, frame):
        for child in multiprocessing.active_children():
            child.terminate()
        raise KeyboardInterrupt

    old = {sig: signal.signal(sig, stop) for sig in (signal.SIGTERM, signal.SIGINT)}
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


def _staged(fn):
    """Write everything into a staging folder inside ``out_dir`` and move it into place only
    when the reproduction has finished (each file with an atomic rename): a failed or
    interrupted reproduction leaves the earlier complete results untouched."""

    @functools.wraps(fn)
    def wrapper(out_dir: str | Path, *args: Any, **kwargs: Any) -> dict[str, Any]:
        from adaptive_ftc._atomic import (
            check_output_dir,
            commit_staged,
            discard_staged,
            staging_dir,
        )

        final = check_output_dir(out_dir)
        stage = staging_dir(final)
        try:
            with _workers_end_with_parent():
                summary = fn(stage, *args, **kwargs)
        except BaseException:
            for child in multiprocessing.active_children():
                child.terminate()
            discard_staged(stage)
            raise
        commit_staged(stage, final)
        summary["report"] = final / Path(summary["report"]).relative_to(stage)
        summary["out_dir"] = final
        return summary

    return wrapper


def _left_out(
    scenarios: Sequence[Scenario], claims_only: bool, data: bool, figure_limit: int | None
) -> tuple[list[str], int]:
    """What a reproduction did not do, one sentence each (report and summary), and how many
    verdicts on the thesis law's companion runs that leaves out."""
    out: list[str] = []
    n_thesis = 0
    if claims_only:
        aware = [sc for sc in scenarios if _is_constraint_aware(sc) and sc.claims]
        n_thesis = sum(len(sc.claims) for sc in aware)
        if aware:
            out.append(
                f"the thesis law's companion runs beside the {len(aware)} constraint-aware "
                f"design(s), and their {n_thesis} verdicts (a full reproduction judges every "
                "claim of these scenarios on the thesis law too: "
                + ", ".join(f"{sc.name} ({len(sc.claims)})" for sc in aware)
                + ")"
            )
        out.append(
            "the failure-free runs, the oracle baseline, and the frozen-adaptation runs of "
            "scenarios without a baseline_ratio claim (no verdict uses them; the report's "
            "error ratios against them are blank)"
        )
    if not data:
        out.append(
            "the data files (data/*.nc): not written; metrics.csv and the verdicts are "
            "computed from the runs in memory"
        )
    if figure_limit == 0:
        out.append("the figures: none drawn")
    elif figure_limit is not None:
        out.append(f"the figures after the first {figure_limit} of each scenario")
    return out, n_thesis


def _data_note(float32: bool, decimate: int) -> str:
    """What the data files of a reproduction hold, for the report."""
    if not float32 and decimate == 1:
        return (
            "Data files (data/*.nc): double precision, every recorded sample: metrics "
            "recomputed from them equal metrics.csv."
        )
    kept = "every recorded sample" if decimate == 1 else f"one recorded sample in {decimate}"
    prec = "single precision (about 7 digits)" if float32 else "double precision"
    return (
        f"Data files (data/*.nc): {prec}, {kept} (--float32/--decimate, recorded in each "
        "file's 'precision' and 'decimation' attributes): metrics recomputed from them can "
        "differ from metrics.csv, which is computed from the full runs."
    )


def _short_status(result) -> str:
    """The status of a run with where and what stopped it (report tables)."""
    from adaptive_ftc.sim.status import short

    return short(result.status, result.reason)


@_staged
def run_reproduction(
    out_dir: str | Path,
    *,
    quick: bool = False,
    jobs: int | None = None,
    progress: bool = True,
    names: Sequence[str] | None = None,
    baselines: bool = False,
    formats: Sequence[str] = ("png", "pdf"),
    dpi: int | None = None,
    fair_baselines: bool | None = None,
    float32: bool = False,
    decimate: int = 1,
    figure_limit: int | None = None,
    claims_only: bool = False,
    data: bool = True,
) -> dict[str, Any]:
    """Run the catalogue, write figures, data, metrics, claims and the HTML report.

    Parameters
    ----------
    out_dir
        Output folder (created).
    quick
        Shorten every run (see the module docstring) for a fast smoke test.
    jobs
        Worker processes (default ``os.cpu_count()``); ``1`` runs everything in this process.
    progress
        Show a tqdm progress bar.
    names
        Scenario names (default: the whole catalogue).
    baselines
        Overlay the baseline and failure-free runs on the tracking figures (they are run
        anyway, for the metrics and the claims), and run the fixed-gain, nominal-inverse and
        oracle baselines for every adaptive scenario with failures, not only for those with a
        ``baseline_ratio`` claim.
    formats
        File formats of every figure (``png``, ``pdf``, ``svg``); the report shows the PNG and
        links the others.
    dpi
        Resolution of the PNG files (default :data:`adaptive_ftc.plots.DPI`).
    fair_baselines
        Run the fixed-gain, nominal-inverse and oracle baselines. Default: yes, except in
        quick mode, whose shortened runs never reach a ``baseline_ratio`` claim's final window
        (those claims are NOT EVALUATED there) unless ``baselines=True``. ``False`` holds
        ``baseline_ratio`` claims against the frozen run alone, as before issue 14 (faster).
    float32, decimate
        Store the data files in single precision / keep every ``decimate``-th sample (the
        last always). Default: double precision, every sample, so that every metric
        recomputed from a file equals ``metrics.csv``. The choice is recorded in each file's
        ``precision``, ``decimation`` and ``history`` attributes and stated in the report.
    figure_limit
        Draw only the first ``figure_limit`` figures of each scenario (``0``: none, as
        ``aftc reproduce --quick``); default: all.
    claims_only
        Make only the runs the claims are judged on (see the module docstring; ``aftc
        reproduce --quick``): no failure-free runs, no oracle, no thesis-law companions (their
        verdicts are left out, and listed as such in the report and in ``left_out``).
    data
        Write the data files (``data/*.nc``); ``False``: none (the claims and metrics are
        computed from the runs in memory), stated in the report.

    Returns
    -------
    dict
        ``n_scenarios``, ``n_runs``, ``n_claims``, ``n_pass``, ``n_fail``,
        ``n_not_evaluated``, ``n_not_reproduced``, ``n_finding`` (claims marked ``finding``
        that the data show: never PASS, not counted as FAIL), ``n_thesis_law_finding`` (claims
        the thesis law's companion run of a constraint-aware scenario does not meet: apart
        from all the others), ``n_thesis_law_left_out`` (verdicts on the thesis law's
        companion runs that ``claims_only`` did not make), ``left_out`` (what was not done, one
        sentence each: empty for a full reproduction), ``n_errors``, ``wall_time_s``,
        ``report``
        (path of report.html) and ``out_dir``.

    Examples
    --------
    >>> s = run_reproduction("out", quick=True, names=["hypersonic-direct-s1"])  # doctest: +SKIP
    >>> s["report"]                                                               # doctest: +SKIP
    PosixPath('out/report.html')
    """
    from adaptive_ftc._feedback import EtaBar, figure_cost

    t_start = time.perf_counter()
    if isinstance(decimate, bool) or not isinstance(decimate, int) or decimate < 1:
        from adaptive_ftc.errors import ConfigurationError

        raise ConfigurationError(
            f"`decimate` must be a whole number >= 1 (keep every k-th sample of the data "
            f"files); got {decimate!r}."
        )
    float32 = bool(float32)
    out = Path(out_dir)
    if figure_limit != 0:
        (out / "figures").mkdir(parents=True, exist_ok=True)
    if data:
        (out / "data").mkdir(parents=True, exist_ok=True)
    out.mkdir(parents=True, exist_ok=True)
    scenario_names = list(names) if names is not None else list_scenarios()
    _LOADED.clear()  # files may have changed since an earlier reproduction in this process
    # loaded (and validated) here, before the workers fork: they inherit them
    scenarios = [_prepare(n, quick) for n in scenario_names]  # validates every name first
    durations = {n: float(_prepare(n, False).loop.t_final) for n in scenario_names}
    from adaptive_ftc.plots import check_formats

    formats = check_formats(formats)
    plan = _figure_plan(scenarios)
    jobs = max(1, int(jobs or os.cpu_count() or 1))

    results: dict[tuple[str, str], dict[str, Any]] = {}
    fig_errors: dict[tuple[str, str], str] = {}
    figures: dict[str, list[FigureEntry]] = {sc.name: [] for sc in scenarios}

    if fair_baselines is None:
        fair_baselines = baselines or not quick

    def variants(sc: Scenario) -> list[str]:
        if claims_only:
            return _claim_variants(sc, fair_baselines)
        out = _variants(sc, all_baselines=baselines)
        return out if fair_baselines else [v for v in out if v not in _DESIGN_BASELINES]

    sim_tasks = _compile_order(scenarios, [(sc.name, v) for sc in scenarios for v in variants(sc)])
    by_name = {sc.name: sc for sc in scenarios}

    executor: cf.Executor
    if jobs == 1:
        executor = _InlineExecutor()
    else:
        ctx = multiprocessing.get_context("fork" if os.name == "posix" else None)
        executor = cf.ProcessPoolExecutor(
            max_workers=jobs, mp_context=ctx, initializer=_worker_init
        )
    # the bar's total is fixed up front: every run and every figure it will draw (a scenario
    # without [[figure]] tables: its default figures, counted from its loop); corrected only
    # if a run fails and draws fewer
    expected = {sc.name: len(plan[sc.name]) or _default_count(sc) for sc in scenarios}
    if figure_limit is not None:
        expected = {k: min(figure_limit, v) for k, v in expected.items()}
    if progress:
        from adaptive_ftc._feedback import compile_line, compile_plan

        n_new, seconds = compile_plan(_task_loops(by_name, sim_tasks))
        if n_new:
            import sys

            print(compile_line(n_new, seconds, jobs), file=sys.stderr, flush=True)
    # the ETA weighs each task by its expected cost (a 1 ms record of a 120 s run costs a
    # hundred times a 10 ms one; a figure about half a second)
    run_cost = {sc.name: _run_cost(sc, data) for sc in scenarios}
    fig_cost = figure_cost(len(formats))
    bar = EtaBar(
        len(sim_tasks) + sum(expected.values()),
        cost=sum(run_cost[n] for n, _ in sim_tasks) + fig_cost * sum(expected.values()),
        disable=not progress,
        desc="reproduce",
        unit="task",
    )
    with executor:
        pending: dict[cf.Future, tuple] = {
            executor.submit(_simulate_task, n, v, quick, str(out), float32, decimate, data): (
                "sim",
                n,
                v,
            )
            for n, v in sim_tasks
        }
        while pending:
            done, _ = cf.wait(pending, return_when=cf.FIRST_COMPLETED)
            for fut in done:
                tag = pending.pop(fut)
                bar.tick(run_cost[tag[1]] if tag[0] == "sim" else fig_cost)
                if tag[0] == "sim":
                    _, name, variant = tag
                    results[(name, variant)] = fut.result()
                    needed = [(name, v) for v in variants(by_name[name])]
                    if all(k in results for k in needed):
                        new = _submit_figures(
                            executor,
                            by_name[name],
                            plan,
                            results,
                            out,
                            baselines,
                            formats,
                            dpi,
                            limit=figure_limit,
                        )
                        for f, ftag, entry in new:
                            pending[f] = ftag
                            figures[name].append(entry)
                        if len(new) != expected[name]:  # a failed run draws none
                            extra = len(new) - expected[name]
                            bar.grow(extra, extra * fig_cost)
                else:
                    _, name, fname = tag
                    fig_errors[(name, fname)] = fut.result()
    bar.close()

    # claims, metrics, report
    metric_rows, claim_rows, entries = [], [], []
    n_pass = n_fail = n_errors = n_not_evaluated = n_not_reproduced = n_finding = 0
    n_thesis_finding = 0
    for sc in scenarios:
        adaptive = results[(sc.name, "adaptive")]["result"]
        frozen = results.get((sc.name, "frozen"), {}).get("result")
        ratio = _error_ratio(adaptive, frozen) if (sc.name, "frozen") in results else math.nan
        base_runs = {
            v: results[(sc.name, v)]["result"] for v in BASELINES if (sc.name, v) in results
        }
        base_ratios = {v: _error_ratio(adaptive, b) for v, b in base_runs.items()}
        fair = {v: q for v, q in base_ratios.items() if v in FAIR_BASELINES and not math.isnan(q)}
        best = min(fair, key=fair.__getitem__) if fair else ""
        for v in variants(sc):
            rec = results[(sc.name, v)]
            row = _metrics_row(sc.name, v, rec["result"], rec["error"], rec["wall"])
            if v == "adaptive":
                row["error_ratio_frozen_over_adaptive"] = ratio
                row["error_ratio_best_fair_baseline_over_adaptive"] = fair[best] if best else ""
                row["best_fair_baseline"] = best
                row["error_ratio_oracle_over_adaptive"] = base_ratios.get("oracle", "")
            metric_rows.append(row)
            n_errors += rec["result"] is None and not rec.get("skipped")
        verdicts: list[ClaimResult] = []
        thesis_verdicts: list[ClaimResult] = []
        claim_error = ""
        thesis = results.get((sc.name, "thesis_law"), {}).get("result")
        if adaptive is not None:
            try:
                verdicts = evaluate_claims(
                    sc.claims, adaptive, baselines=base_runs, duration=durations[sc.name]
                )
                if thesis is not None:
                    thesis_verdicts = evaluate_thesis_law_claims(
                        sc.claims, thesis, baselines=base_runs, duration=durations[sc.name]
                    )
            except ClaimError as exc:
                claim_error = f"{sc.name}: {exc}"
        elif sc.claims:
            claim_error = (
                "the adaptive run raised an error: "
                + results[(sc.name, "adaptive")]["error"].strip().splitlines()[-1]
            )
            verdicts = [
                ClaimResult(
                    kind=str(c.get("kind", "")),
                    text=str(c.get("text", "")),
                    passed=False,
                    measured=math.nan,
                    threshold=math.nan,
                    detail="not evaluated: the run raised an error",
                    status=FAIL,
                )
                for c in sc.claims
            ]
        for c in verdicts:
            n_pass += c.status == PASS
            n_fail += c.status == FAIL
            n_not_evaluated += c.status == NOT_EVALUATED
            n_not_reproduced += c.status == NOT_REPRODUCED
            n_finding += c.status == FINDING
            claim_rows.append(_claim_row(sc, c, "adaptive"))
        for c in thesis_verdicts:
            # the thesis law's companion: only PASS, FINDING or NOT EVALUATED, counted apart
            # from the scenario's own verdicts
            n_thesis_finding += c.status == FINDING
            claim_rows.append(_claim_row(sc, c, "thesis_law"))
        for entry in figures[sc.name]:
            err = fig_errors.get((sc.name, entry.path.name), "")
            if err:
                entry.error = err
        statuses = {
            v: (
                _short_status(results[(sc.name, v)]["result"])
                if results[(sc.name, v)]["result"] is not None
                else ("not run: " if results[(sc.name, v)].get("skipped") else "error: ")
                + results[(sc.name, v)]["error"].strip().splitlines()[-1]
            )
            for v in variants(sc)
        }
        entries.append(
            ScenarioEntry(
                name=sc.name,
                title=sc.title,
                section=sc.section,
                thesis_figures=tuple(sc.figures),
                description=sc.description.strip(),
                notes=sc.notes.strip(),
                failures=tuple(adaptive.failures) if adaptive is not None else (),
                duration=float(sc.loop.t_final),
                figures=figures[sc.name],
                claims=verdicts,
                claim_error=claim_error,
                error_ratio=ratio,
                statuses=statuses,
                baseline_ratios=base_ratios,
                thesis_law_claims=thesis_verdicts,
            )
        )
    _write_csv(out / "metrics.csv", _METRIC_FIELDS, metric_rows)
    _write_csv(out / "claims.csv", CLAIM_FIELDS, claim_rows)
    left_out, n_thesis_left_out = _left_out(scenarios, claims_only, data, figure_limit)
    wall = time.perf_counter() - t_start
    report = write_report(
        out / "report.html",
        entries,
        quick=quick,
        wall_time_s=wall,
        jobs=jobs,
        data_note=_data_note(float32, decimate) if data else "",
        left_out=left_out,
    )
    return {
        "n_scenarios": len(scenarios),
        "n_runs": len(sim_tasks),
        "n_claims": n_pass + n_fail + n_not_evaluated + n_not_reproduced + n_finding,
        "n_pass": n_pass,
        "n_fail": n_fail,
        "n_not_evaluated": n_not_evaluated,
        "n_not_reproduced": n_not_reproduced,
        "n_finding": n_finding,
        "n_thesis_law_finding": n_thesis_finding,
        "n_thesis_law_left_out": n_thesis_left_out,
        "left_out": left_out,
        "n_errors": n_errors,
        "data_precision": "float32" if float32 else "float64",
        "data_decimation": decimate,
        "wall_time_s": time.perf_counter() - t_start,
        "report": report,
        "out_dir": out,
    }


def _submit_figures(
    executor, sc, plan, results, out, overlay=False, formats=("png",), dpi=None, limit=None
):
    """Submit the figure tasks of a scenario whose runs are all done (``limit``: only the first
    ``limit`` figures, quick mode)."""
    from adaptive_ftc.plots import dense_zoom, figure_input

    adaptive = results[(sc.name, "adaptive")]["result"]
    if adaptive is None or adaptive.time.size == 0:
        return []
    items = (plan[sc.name] or _default_specs(sc, adaptive))[:limit]
    baselines = {
        _BASELINE_LABELS[v]: results[(sc.name, v)]["result"]
        for v in ("frozen", "failure_free", *_DESIGN_BASELINES, "thesis_law")
        if (overlay or v == "thesis_law")  # the thesis law's companion: always overlaid
        and (sc.name, v) in results
        and results[(sc.name, v)]["result"] is not None
    }
    new = []
    for spec, fname in items:
        path = out / "figures" / fname
        zoom = dense_zoom(sc, adaptive, spec)
        # the worker is sent what the figure draws (figure_input: the thinned copies, the
        # baselines only to the tracking figures that overlay them), not 45 MB per 1 ms run
        kind = str(spec.get("kind", ""))
        drawn = figure_input(adaptive, kind)
        drawn_bases = (
            {k: figure_input(v, kind) for k, v in baselines.items()} if kind == "tracking" else {}
        )
        fut = executor.submit(
            _figure_task, drawn, spec, str(path), drawn_bases, tuple(formats), dpi, zoom
        )
        entry = FigureEntry(
            number=str(spec.get("number", "")),
            caption=str(spec.get("caption", "")),
            kind=str(spec.get("kind", "")),
            path=path,
            extra=tuple(path.with_suffix(f".{f}") for f in formats if f != "png"),
        )
        new.append((fut, ("fig", sc.name, fname), entry))
    return new


class _InlineExecutor(cf.Executor):
    """Runs tasks at submission in this process (``jobs=1``; easier to debug and profile)."""

    def submit(self, fn, /, *args, **kwargs):  # type: ignore[override]
        fut: cf.Future = cf.Future()
        try:
            fut.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # noqa: BLE001 - handed to the caller through the future
            fut.set_exception(exc)
        return fut
