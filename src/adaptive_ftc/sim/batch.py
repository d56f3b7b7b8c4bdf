"""Many runs at once: threads over the compiled kernel (it releases the GIL)."""

from __future__ import annotations

import os
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence, Sized
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim.engine import SolverOptions, simulate
from adaptive_ftc.sim.result import SimResult
from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["iter_simulate", "simulate_many"]


def _jobs(jobs: int | None) -> int:
    """Threads to use: ``jobs``, or every core for ``None`` (or 0)."""
    if isinstance(jobs, bool) or not (jobs is None or isinstance(jobs, int)) or (jobs or 0) < 0:
        raise ConfigurationError(f"`jobs` must be a positive integer or None; got {jobs!r}.")
    return jobs or os.cpu_count() or 1


def simulate_many(
    loops: Sequence[ClosedLoop],
    solver: SolverOptions | None = None,
    *,
    jobs: int | None = None,
    progress: bool = False,
    lanes: bool | str = False,
    lane_kernels: str = "libm",
) -> list[SimResult]:
    """Simulate many closed loops in parallel (e.g. a Monte Carlo campaign).

    The fixed-step path runs in the compiled kernel without the GIL, so threads give real
    parallelism; results come back in input order and are identical to sequential runs.
    Every result is kept (a 120 s run at ``record_dt = 0.01`` holds about 4 MB): for
    thousands of runs, :func:`iter_simulate` streams them instead. ``lanes``: as for
    :func:`iter_simulate` (members in SIMD lanes, ``sim/lanes.py``).

    Examples
    --------
    >>> from dataclasses import replace
    >>> from adaptive_ftc import load_scenario
    >>> sc = load_scenario("hypersonic-direct-s1")
    >>> loops = [replace(sc.loop, initial_state=(a, 0.0)) for a in (0.0, 0.03)]
    >>> [r.status for r in simulate_many(loops, sc.solver, jobs=2)]
    ['completed', 'completed']
    """
    # every run submitted at once: iter_simulate with a window as long as the list
    window = max(1, len(loops))
    return list(
        iter_simulate(
            loops,
            solver,
            jobs=jobs,
            window=window,
            progress=progress,
            lanes=lanes,
            lane_kernels=lane_kernels,
        )
    )


def iter_simulate(
    loops: Iterable[ClosedLoop],
    solver: SolverOptions | None = None,
    *,
    jobs: int | None = None,
    window: int | None = None,
    progress: bool = False,
    reduce: Callable[[SimResult], Any] | None = None,
    lanes: bool | str = False,
    lane_kernels: str = "libm",
    lean_signals: bool = False,
) -> Iterator[Any]:
    """Simulate closed loops in parallel and yield their results one by one, in input order.

    Like :func:`simulate_many`, but at most ``window`` runs (default ``4 * jobs``) are in
    flight or waiting to be taken, so memory stays bounded however many loops there are, and
    the threads keep running while the caller processes each result (no pause between
    batches, as calling :func:`simulate_many` on chunks has). ``loops`` may be any iterable,
    a generator included (loops are drawn as the window frees up). Leaving the loop early
    cancels the runs not started and waits for the running ones.

    ``reduce``: a function of one result, called in the thread that simulated it (right after
    the run, while the other threads run theirs); its value is yielded instead of the result,
    which is dropped there (a campaign reduces each run to its metrics row this way, without
    the trajectories passing through one thread). An exception it raises is raised here.
    ``lean_signals``: as in :func:`simulate` (only the signals the metrics read; a campaign's
    ``reduce`` reads nothing else); with lanes, a lane group computes them itself.

    ``lanes``: run members in SIMD lanes (:mod:`adaptive_ftc.sim.lanes`: ``LANE_WIDTH`` = 8
    members of one structure per compiled call, each member's result equal to its own
    :func:`simulate` bit for bit; fixed-step RK4 or DOPRI5 and the loops
    :func:`~adaptive_ftc.sim.lanes.ineligible` accepts). ``False`` (default): one member per
    thread. ``"auto"``: consecutive eligible members of one structure in lanes, every other
    member one at a time. ``True``:
    as ``"auto"``, but a :class:`ConfigurationError` naming why for a loop that cannot run in
    lanes. With lanes the threads take groups of up to 8 consecutive members, and up to
    ``max(window, 2 * jobs * 8)`` members are in flight. The lane module of a structure
    compiles once (10-30 s; cached on disk like the loop modules). ``lane_kernels``:
    ``"libm"`` (default: bit-identical to single runs) or ``"vector"`` (stage 1b, RK4 only:
    call-free ``exp``, ``tanh``, ``sin``, ``cos`` that vectorise, the rhs pasted into the
    stages and fused multiply-adds: faster, its lane module compiles about 5x longer, about
    1e-14 of the signal scale from the single runs).

    Examples
    --------
    >>> from dataclasses import replace
    >>> from adaptive_ftc import load_scenario
    >>> sc = load_scenario("hypersonic-direct-s1")
    >>> loops = (replace(sc.loop, initial_state=(a, 0.0), t_final=5.0) for a in (0.0, 0.03))
    >>> [round(float(r.states[-1, 0]), 4) for r in iter_simulate(loops, sc.solver, jobs=2)]
    [0.0734, 0.0734]
    """
    jobs = _jobs(jobs)
    if not (isinstance(lanes, bool) or lanes == "auto"):
        raise ConfigurationError(f"`lanes` must be True, False or 'auto'; got {lanes!r}.")
    if window is not None and (
        isinstance(window, bool) or not isinstance(window, int) or window < 1
    ):
        raise ConfigurationError(f"`window` must be a positive integer; got {window!r}.")
    if lanes is not False:
        from adaptive_ftc.sim.lanes import _kernels

        kernels = _kernels(lane_kernels)
        yield from _iter_lanes(
            loops,
            solver,
            jobs,
            window,
            progress,
            reduce,
            strict=lanes is True,
            kernels=kernels,
            lean=lean_signals,
        )
        return
    window = 4 * jobs if window is None else window
    bar = _bar(loops, progress)
    source = iter(loops)
    pending: deque = deque()
    pool = ThreadPoolExecutor(max_workers=jobs)
    try:
        for loop in source:
            pending.append(pool.submit(_run, loop, solver, reduce, lean_signals))
            if len(pending) >= window:
                break
        while pending:
            result = pending.popleft().result()
            following = next(source, None)
            if following is not None:  # the next run starts before the caller takes this result
                pending.append(pool.submit(_run, following, solver, reduce, lean_signals))
            _tick(bar)
            yield result
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
        if bar is not None:
            bar.close()


def _bar(loops: Iterable, progress: bool) -> Any:
    """The progress bar of a batch: an EtaBar for a known number of runs (of one solver: the
    ETA counts them as equals), a tqdm bar without total or ETA for an open stream, or None."""
    if not progress:
        return None
    if isinstance(loops, Sized):
        from adaptive_ftc._feedback import EtaBar

        return EtaBar(len(loops), desc="simulations", unit="run")
    from tqdm.auto import tqdm  # imported on use: it costs 40 ms at import time

    return tqdm(total=None, desc="simulations")


def _tick(bar: Any) -> None:
    """One run more on the bar (an EtaBar ticks, a tqdm bar updates; None: no bar)."""
    if hasattr(bar, "tick"):
        bar.tick()
    elif bar is not None:
        bar.update()


def _run(
    loop: ClosedLoop, solver: SolverOptions | None, reduce: Callable | None, lean: bool = False
) -> Any:
    """One run of a batch, reduced in the same thread when asked."""
    result = simulate(loop, solver, lean_signals=lean)
    return result if reduce is None else reduce(result)


def _iter_lanes(loops, solver, jobs, window, progress, reduce, *, strict, kernels, lean=False):
    """:func:`iter_simulate` with lanes: chunks of up to ``LANE_WIDTH`` consecutive members per
    thread job (:func:`_run_chunk`), results yielded per member in input order."""
    from adaptive_ftc.sim.lanes import LANE_WIDTH, _refusal, ineligible

    width = LANE_WIDTH
    in_flight = max(window or 0, 2 * jobs * width)
    bar = _bar(loops, progress)
    source = iter(loops)

    def chunk() -> list:
        out = []
        for loop in source:
            if strict:
                why = ineligible(loop, solver)
                if why is not None:
                    raise ConfigurationError(_refusal(loop, why))
            out.append(loop)
            if len(out) == width:
                break
        return out

    pending: deque = deque()
    members = 0  # submitted and not yet yielded
    pool = ThreadPoolExecutor(max_workers=jobs)

    def fill() -> None:
        """Submit chunks until ``in_flight`` members are out or the source is dry."""
        nonlocal members
        while members < in_flight:
            part = chunk()
            if not part:
                return
            pending.append(pool.submit(_run_chunk, part, solver, reduce, strict, kernels, lean))
            members += len(part)

    try:
        fill()
        while pending:
            results = pending.popleft().result()
            members -= len(results)
            fill()  # the next chunks start before the caller takes these results
            for result in results:
                _tick(bar)
                yield result
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
        if bar is not None:
            bar.close()


def _run_chunk(
    loops: list, solver, reduce: Callable | None, strict: bool, kernels: str, lean: bool = False
) -> list:
    """Consecutive members: those of one eligible structure in a lane group (two or more, or
    any with ``strict``), the others one at a time; results (reduced) in input order."""
    from adaptive_ftc.sim.engine import SolverOptions, finish_run
    from adaptive_ftc.sim.lanes import _refusal, integrate_lanes, lane_groups

    solver = solver or SolverOptions()
    groups, built = lane_groups(loops, solver)
    out: list[Any] = [None] * len(loops)
    for kind, idx in groups:
        if kind == "lanes" and (len(idx) > 1 or strict):
            # lean: the lanes' own signals pass over the records (stage 3)
            runs = integrate_lanes([built[k] for k in idx], kernels=kernels, lean=lean)
            for k, run in zip(idx, runs, strict=True):
                result = finish_run(built[k], run, lean=lean)  # type: ignore[arg-type]
                out[k] = result if reduce is None else reduce(result)
            continue
        for k in idx:
            if strict and k not in built:
                from adaptive_ftc.sim.lanes import ineligible_reason

                why = ineligible_reason(loops[k], solver) or "no lane group"
                raise ConfigurationError(_refusal(loops[k], why))
            out[k] = _run(loops[k], solver, reduce, lean)
    return out
