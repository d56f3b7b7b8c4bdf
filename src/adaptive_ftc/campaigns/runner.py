"""Running a campaign: chunks of members through :func:`iter_simulate`, one Parquet part per
finished chunk, resumable, memory flat in the number of runs (each trajectory is reduced to
its metrics row and dropped)."""

from __future__ import annotations

import functools
import itertools
import math
import signal
import time
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from adaptive_ftc.campaigns import store
from adaptive_ftc.campaigns.sampling import Member, draw_member
from adaptive_ftc.campaigns.spec import CampaignSpec, load_campaign
from adaptive_ftc.errors import ConfigurationError, DivergenceWarning
from adaptive_ftc.sim.batch import iter_simulate
from adaptive_ftc.sim.result import SimResult, _monotone

#: Status of a row whose design could not be built on the member (the fixed-gain baseline
#: whose failure-free tuning run diverged under the drawn hardware): a failed run of that
#: design, the reason in ``message``; the page counts it with the runs that stopped early.
UNBUILT = "not_built"

if TYPE_CHECKING:
    from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["CampaignRun", "outcome", "run_campaign", "run_chunk"]


@dataclass(frozen=True)
class CampaignRun:
    """What :func:`run_campaign` did: the folder, the runs done now and before, timing."""

    out: Path
    results: Path | None
    runs_total: int
    runs_done_now: int
    runs_resumed: int
    complete: bool
    wall_time_s: float
    summary: dict[str, Any]


def recovery_times(result: SimResult, tolerance: float) -> list[float]:
    """Per failure event: time until ``max |e|`` stays within ``tolerance`` up to the next event
    (``inf``: not recovered before the next event or the end)."""
    times = list(result.failure_times)
    if not times or result.time.size == 0:
        return []
    ends = times[1:] + [float(result.time[-1])]
    if _monotone(result.time):  # segments are spans of rows: one compiled scan each
        from adaptive_ftc.sim.reduce import last_above, row_span

        out = []
        for t, nxt in zip(times, ends, strict=True):
            i0, i1 = row_span(result.time, t, nxt)
            if i1 <= i0:
                continue
            last = last_above(result.e, i0, i1, tolerance)
            if last < 0:
                out.append(0.0)
            elif last == i1 - i0 - 1:
                out.append(math.inf)
            else:
                out.append(float(result.time[i0 + last + 1] - t))
        return out
    err = np.max(np.abs(result.e), axis=1)
    out = []
    for t, nxt in zip(times, ends, strict=True):
        seg = (result.time >= t - 1e-9) & (result.time <= nxt + 1e-9)
        idx = np.flatnonzero(seg)
        if idx.size == 0:
            continue
        bad = np.flatnonzero(err[idx] > tolerance)
        if bad.size == 0:
            out.append(0.0)
        elif bad[-1] == idx.size - 1:
            out.append(math.inf)
        else:
            out.append(float(result.time[idx[bad[-1] + 1]] - t))
    return out


#: Control-activity columns of an outcome row (:meth:`SimResult.metrics`).
ACTIVITY_COLUMNS = (
    "fast_rms_max",
    "tv_per_s_max",
    "peak_rate_max",
    "rate_limited_fraction_max",
    "peak_command_travel_ratio_max",
    "activity_record_ok",
)


def outcome(
    result: SimResult, spec: CampaignSpec, *, thresholds: tuple[float, float] | None = None
) -> dict[str, Any]:
    """The outcome columns of one run: status, divergence time/signal, metrics, success.

    ``success``: ``tracking_ok`` (completed, final-window RMS error within the threshold) and,
    when the spec judges it (:mod:`adaptive_ftc.campaigns.activity`), ``activity_ok``.
    ``thresholds``: the activity thresholds (``spec.activity.thresholds(spec)``) when the
    caller has them (a chunk asks once, not once per run)."""
    row: dict[str, Any] = {"status": str(result.status), "message": result.message}
    m = result.metrics(final_window=spec.final_window, fast=True) if result.time.size else {}
    for key in ("rms_error", "max_error", "rms_error_final", "max_error_final"):
        row[key] = float(m.get(key, math.nan))
    for key in ("peak_command", "peak_applied", "t_end"):
        row[key] = float(m.get(key, math.nan))
    # control activity over the final window, worst actuator (sim/activity.py; judged only
    # when activity_record_ok: records fine enough not to alias the chatter)
    for key in ACTIVITY_COLUMNS:
        value = m.get(key, math.nan)
        row[key] = bool(value) if key == "activity_record_ok" else float(value)
    row["peak_command_final"] = float(m.get("peak_command_max", math.nan))
    reason = result.reason  # where and what stopped the run, never parsed from the message
    if reason is not None and result.status != "completed":
        row["divergence_time"] = float(reason.time) if reason.time is not None else math.nan
        row["divergence_signal"] = reason.signal or reason.expression
    else:
        row["divergence_time"] = math.nan
        row["divergence_signal"] = ""
    rec = recovery_times(result, spec.recovery_tolerance)
    row["worst_recovery_time"] = max(rec) if rec else 0.0
    rms_after = [r["rms_after"] for r in result.recovery(fast=True)] if result.time.size else []
    rms_after = [v for v in rms_after if not math.isnan(v)]
    row["worst_recovery_rms"] = max(rms_after) if rms_after else math.nan
    row["tracking_ok"] = bool(
        result.status == "completed" and row["rms_error_final"] <= spec.success_rms
    )
    if spec.activity is None:
        row["activity_ok"], row["activity_why"] = True, ""
    elif result.status != "completed":
        row["activity_ok"], row["activity_why"] = False, "the run did not complete"
    else:
        row["activity_ok"], row["activity_why"] = spec.activity.judge(
            row, spec, thresholds=thresholds
        )
    row["success"] = row["tracking_ok"] and row["activity_ok"]
    return row


def run_chunk(
    spec: CampaignSpec, chunk: int, jobs: int | None = 1, *, lanes: bool | str = "auto"
) -> list[dict[str, Any]]:
    """Simulate one chunk (every design of members ``chunk*size ..``); rows in (index, design)
    order. Only metrics rows are kept, never the trajectories: each run's outcome is computed
    in the thread that simulated it (:func:`iter_simulate` with ``reduce``), while the other
    threads run the next ones. ``lanes``: as for :func:`iter_simulate` (``"auto"``: members
    in SIMD lanes where they pay, the campaign's runs counted as the members each structure
    will have; the same rows either way)."""
    lo = chunk * spec.chunk_size
    hi = min(spec.runs, lo + spec.chunk_size)
    members: list[Member] = []
    slots: list[int | None] = []  # each run's place among the simulated runs (None: invalid)
    unbuilt: dict[int, str] = {}  # run k's design could not be built: why (a failed run)
    n_loops = 0

    def loops() -> Iterator[ClosedLoop]:
        # drawn as the threads take them (iter_simulate pulls from here between results), so
        # that drawing a member overlaps the runs already going
        nonlocal n_loops
        for i in range(lo, hi):
            mem = draw_member(spec, i)
            members.append(mem)
            for d in spec.designs:
                if mem.loop is None:
                    slots.append(None)
                    continue
                try:
                    loop = mem.design_loop(d)
                except ConfigurationError as exc:
                    # a design that cannot be built on this member (the fixed-gain baseline
                    # whose failure-free tuning run diverged under the drawn hardware) is a
                    # failed run of that design, recorded with the reason, never a crash of
                    # the campaign
                    unbuilt[len(slots)] = str(exc)
                    slots.append(None)
                    continue
                slots.append(n_loops)
                n_loops += 1
                yield loop

    thresholds = spec.activity.thresholds(spec) if spec.activity is not None else None
    reduce = functools.partial(outcome, spec=spec, thresholds=thresholds)
    with warnings.catch_warnings():  # a diverged run is a recorded outcome, not a warning
        warnings.simplefilter("ignore", DivergenceWarning)
        # each run's row is computed by the thread that simulated it (iter_simulate's reduce)
        # the row reads the errors, commands and applied commands only (lean_signals: the
        # other signals, the plant's control gain among them, are not computed)
        outcomes = list(
            iter_simulate(
                loops(),
                spec.solver,
                jobs=jobs,
                reduce=reduce,
                lean_signals=True,
                lanes=lanes,
                expected_members=spec.runs,  # one loop per design: runs of each structure
            )
        )
    rows = []
    k = 0
    for mem in members:
        for d in spec.designs:
            row = dict(mem.columns)
            row["design"] = d
            if spec.allocation_columns:
                row["allocator"] = spec.allocator_kind(d)
            slot = slots[k]
            k += 1
            if k - 1 in unbuilt:
                row.update(
                    status=UNBUILT,
                    message=unbuilt[k - 1],
                    success=False,
                    tracking_ok=False,
                    activity_ok=False,
                )
            elif slot is None:
                row.update(status="invalid", message=mem.error, success=False)
            else:
                row.update(outcomes[slot])
            rows.append(row)
    return rows


class _Stop(KeyboardInterrupt):
    """Raised by the SIGTERM handler so a terminated campaign stops like Ctrl-C."""


def run_campaign(
    spec: CampaignSpec | str | Path,
    out: str | Path,
    *,
    jobs: int | None = None,
    scheduler: Any = None,
    progress: bool = True,
    max_chunks: int | None = None,
    summary: bool = True,
    lanes: bool | str = "auto",
) -> CampaignRun:
    """Run (or resume) a campaign into the folder ``out``.

    Finished chunks already in ``out`` are kept and skipped. Each finished chunk is written at
    once as ``parts/part-NNNNN.parquet``; when every chunk is done, ``results.parquet`` and the
    summary (``summary.html``, ``summary.json``, ``figures/``) are written.

    Parameters
    ----------
    spec
        A :class:`CampaignSpec`, an example name or a spec file.
    out
        Results folder (created; an existing folder must hold the same campaign).
    jobs
        Threads per chunk for the local run (default: all cores).
    scheduler
        Address of a Dask scheduler (``"tcp://host:8786"``), or a ``distributed.Client`` /
        ``LocalCluster``: chunks run on the cluster, the results are written here.
    progress
        Show a progress bar with an ETA.
    max_chunks
        Stop after this many new chunks (the rest is left for a later resume).
    summary
        Write the summary when the campaign is complete.
    lanes
        Members in SIMD lanes (:func:`~adaptive_ftc.sim.batch.iter_simulate`'s ``lanes``):
        ``"auto"`` (default) where they pay (the lane module of the members' structure is
        compiled already, or the campaign's runs repay compiling it), ``False`` never,
        ``True`` always. The table is the same bit for bit; on a Dask cluster each worker
        decides for itself (its own disk cache).

    Examples
    --------
    >>> run = run_campaign("hypersonic-loe", "campaign-out")  # doctest: +SKIP
    >>> run.summary["success_rate"]["adaptive"]  # doctest: +SKIP
    0.93
    """
    from adaptive_ftc._feedback import EtaBar

    if not isinstance(spec, CampaignSpec):
        spec = load_campaign(spec)
    if spec.activity is not None:  # the ideal run's references, before any chunk runs
        spec.activity.thresholds(spec)
    out = store.prepare_folder(spec, out)
    done = store.finished_chunks(spec, out)
    pending: Iterator[int] = (c for c in range(spec.n_chunks) if c not in done)  # lazy: many
    if max_chunks is not None:
        pending = itertools.islice(pending, max(0, int(max_chunks)))
    n_runs = spec.runs * len(spec.designs)

    def runs_in(c: int) -> int:
        return (min(spec.runs, (c + 1) * spec.chunk_size) - c * spec.chunk_size) * len(spec.designs)

    resumed = sum(runs_in(c) for c in done)
    start = time.perf_counter()
    # the ETA counts the runs of this session only (a resumed campaign's earlier runs are not
    # part of the measured rate); with max_chunks, only the chunks this call runs
    todo = n_runs - resumed
    if max_chunks is not None:
        todo = sum(
            runs_in(c)
            for c in itertools.islice(
                (c for c in range(spec.n_chunks) if c not in done), max(0, int(max_chunks))
            )
        )
    bar = EtaBar(
        n_runs,
        cost=float(todo),
        initial=resumed,
        disable=not progress,
        desc=spec.name,
        unit="run",
    )
    old = signal.getsignal(signal.SIGTERM)
    handler_set = False
    try:
        try:
            signal.signal(signal.SIGTERM, _raise_stop)
            handler_set = True
        except ValueError:  # not in the main thread: keep the default handler
            pass
        if scheduler is not None:
            from adaptive_ftc.campaigns.dask import run_chunks_dask

            chunk_runner = functools.partial(run_chunk, lanes=lanes)
            source = run_chunks_dask(spec, list(pending), scheduler, chunk_runner)
        else:
            source = ((c, run_chunk(spec, c, jobs, lanes=lanes)) for c in pending)
        now = 0
        for c, rows in source:
            store.write_part(store.to_table(rows, spec), out, c)
            now += len(rows)
            bar.tick(len(rows), n=len(rows))
    finally:
        bar.close()
        if handler_set:
            signal.signal(signal.SIGTERM, old)
    wall = time.perf_counter() - start
    complete = len(store.finished_chunks(spec, out)) == spec.n_chunks
    results = None
    info: dict[str, Any] = {}
    if complete:
        results = store.write_results(spec, out)
        if summary:
            from adaptive_ftc.campaigns.summary import write_summary

            info = write_summary(spec, out)
    return CampaignRun(
        out=out,
        results=results,
        runs_total=n_runs,
        runs_done_now=now,
        runs_resumed=resumed,
        complete=complete,
        wall_time_s=wall,
        summary=info,
    )


def _raise_stop(signum, frame) -> None:  # pragma: no cover - exercised through the CLI
    raise _Stop()
