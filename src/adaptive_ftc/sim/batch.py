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
    lanes: bool | str = "auto",
    lane_kernels: str = "libm",
    expected_members: int | None = None,
) -> list[SimResult]:
    """Simulate many closed loops in parallel (e.g. a Monte Carlo campaign).

    The fixed-step path runs in the compiled kernel without the GIL, so threads give real
    parallelism; results come back in input order and are identical to sequential runs.
    Every result is kept (a 120 s run at ``record_dt = 0.01`` holds about 4 MB): for
    thousands of runs, :func:`iter_simulate` streams them instead. ``lanes``,
    ``lane_kernels``, ``expected_members``: as for :func:`iter_simulate` (members in SIMD
    lanes, ``sim/lanes.py``; by default where they pay, with the same results).

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
            expected_members=expected_members,
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
    lanes: bool | str = "auto",
    lane_kernels: str = "libm",
    lean_signals: bool = False,
    expected_members: int | None = None,
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
    :func:`~adaptive_ftc.sim.lanes.ineligible` accepts). ``"auto"`` (default): lanes where
    they pay, every other member one per thread, the same results either way. A structure's
    members run in lanes when its lane module is already compiled (loaded, or in the disk
    cache) or when ``expected_members`` repays compiling it
    (:data:`~adaptive_ftc.sim.lanes.AUTO_COMPILE_MIN`: 500 RK4, 3,000 DOPRI5 or, with
    ``lean_signals``, 10,000 DOPRI5 members; a one-line message on stderr announces the
    compile, 10-15 s of CPU once per machine; never for RK4 members recorded more often than
    every 10 steps), and each lane group holds enough members to beat one at a time
    (:data:`~adaptive_ftc.sim.lanes.AUTO_GROUP_MIN`: 6 to 8 of 8; a smaller group's members
    run one at a time). ``False``: one member per thread. ``True``: every member in lanes
    (any group size, compiling when needed), a :class:`ConfigurationError` naming why for
    a loop that cannot run in lanes. Members join the lane group of their structure in
    input order (a group goes to the threads when full, or when its first member's result is
    next), so members of other structures or ineligible ones in between do not split
    groups; up to ``max(window, 2 * jobs * 8)`` members are in flight. ``expected_members``:
    how many members of one structure the caller will run in all (a campaign: its runs);
    default ``len(loops)`` when ``loops`` has a length, else not known (then only compiled
    lane modules are used). ``lane_kernels``: ``"libm"`` (default: bit-identical to single
    runs) or ``"vector"`` (stage 1b, RK4 only: call-free ``exp``, ``tanh``, ``sin``,
    ``cos`` that vectorise, the rhs pasted into the stages and fused multiply-adds: faster,
    its lane module compiles about 5x longer, about 1e-14 of the signal scale from the
    single runs).

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
    if expected_members is not None and (
        isinstance(expected_members, bool)
        or not isinstance(expected_members, int)
        or expected_members < 0
    ):
        raise ConfigurationError(
            f"`expected_members` must be a non-negative integer or None; got {expected_members!r}."
        )
    if lanes is not False:
        from adaptive_ftc.sim.lanes import _kernels

        kernels = _kernels(lane_kernels)
        if expected_members is None and isinstance(loops, Sized):
            expected_members = len(loops)
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
            expected=expected_members,
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
    loop: ClosedLoop,
    solver: SolverOptions | None,
    reduce: Callable | None,
    lean: bool = False,
    compiled: Any = None,
) -> Any:
    """One run of a batch, reduced in the same thread when asked (``compiled``: the loop's
    :class:`~adaptive_ftc.sim.engine.CompiledLoop` when the lane path built it already)."""
    if compiled is None:
        result = simulate(loop, solver, lean_signals=lean)
    else:
        from adaptive_ftc.sim.engine import finish_run

        result = finish_run(compiled, compiled.integrate(), stacklevel=3, lean=lean)
    return result if reduce is None else reduce(result)


class _Job:
    """Members submitted together: a lane group (one future, results in its members' order)
    or one member (one future per member)."""

    def __init__(self, members: list, lanes: bool, size: int = 1) -> None:
        self.members = members  # (loop, CompiledLoop or None)
        self.lanes = lanes
        self.size = size  # members that fill it
        self.futures: list = []

    def result(self, k: int) -> Any:
        if self.lanes:
            return self.futures[0].result()[k]
        return self.futures[k].result()


def _iter_lanes(loops, solver, jobs, window, progress, reduce, *, strict, kernels, lean, expected):
    """:func:`iter_simulate` with lanes: each eligible member joins the open lane group of its
    structure (submitted to the threads when it holds
    :func:`~adaptive_ftc.sim.lanes.queue_members` members: ``LANE_WIDTH`` for RK4, for
    DOPRI5 a queue of up to two groups' worth whose lanes refill; or when its
    first member is the next result to yield); with ``"auto"`` (``strict`` false) a structure
    whose lane module does not pay (:func:`~adaptive_ftc.sim.lanes.auto_uses_lanes`) and a
    group smaller than :func:`~adaptive_ftc.sim.lanes.auto_group_min` run one member per
    thread job, as every member that cannot run in lanes does. Results in input order."""
    from adaptive_ftc.sim import lanes as lane_engine
    from adaptive_ftc.sim.engine import CompiledLoop, SolverOptions

    solver = solver or SolverOptions()
    # members per lane job: a group of LANE_WIDTH (RK4), a queue that refills its lanes (DOPRI5)
    width = lane_engine.QUEUE_MEMBERS.get(solver.method, lane_engine.LANE_WIDTH)
    # members out (in flight or waiting): the window, as without lanes; enough for a lane
    # group per thread and the next one (2 * jobs * width) once lanes run, unless the
    # caller's own window says otherwise ("auto") -- with lanes=True at least that many
    grow = strict or window is None
    in_flight = max(window or 0, 2 * jobs * width) if strict else (window or 4 * jobs)
    bar = _bar(loops, progress)
    source = iter(loops)
    slots: deque = deque()  # per member not yet yielded, in input order: (job, place in it)
    groups: dict[str, _Job] = {}  # the open lane group of each structure
    verdicts: dict[str, bool] = {}  # "auto": does this structure run in lanes?
    pool = ThreadPoolExecutor(max_workers=jobs)

    def submit(job: _Job) -> None:
        members = job.members
        if job.lanes and not strict:
            method = members[0][1].solver.method
            job.lanes = len(members) >= lane_engine.auto_group_min(method, lean)
        if job.lanes:
            built = [cl for _, cl in members]
            job.futures = [pool.submit(_run_group, built, reduce, kernels, lean, not strict)]
        else:
            job.futures = [
                pool.submit(_run, loop, solver, reduce, lean, cl) for loop, cl in members
            ]

    def take(loop) -> None:
        """Place ``loop``: in the open lane group of its structure, or a job of its own."""
        nonlocal in_flight
        why = lane_engine.ineligible(loop, solver)
        cl = None
        if why is None:
            try:
                cl = CompiledLoop.build(loop, solver)
            except Exception:
                if strict:
                    raise
                why = "its loop cannot be built"  # its own run raises why, in its turn
            else:
                why = lane_engine._ineligible_numbers(cl.asm)
        if why is not None:
            if strict:
                raise ConfigurationError(lane_engine._refusal(loop, why))
            job = _Job([(loop, cl)], lanes=False)
            submit(job)
            slots.append((job, 0))
            return
        assert cl is not None  # built: it is eligible
        key = cl.asm.source
        if not strict and key not in verdicts:
            try:
                verdicts[key] = lane_engine.auto_uses_lanes(cl, expected, kernels, lean)
            except ConfigurationError:  # no lane module for it after all: one at a time
                verdicts[key] = False
            if verdicts[key] and grow:
                in_flight = max(in_flight, 2 * jobs * width)
        if not strict and not verdicts[key]:
            job = _Job([(loop, cl)], lanes=False)
            submit(job)
            slots.append((job, 0))
            return
        if key not in groups:  # a new lane job: a group (RK4) or a queue (DOPRI5)
            groups[key] = _Job([], lanes=True, size=lane_engine.queue_members(cl))
        job = groups[key]
        slots.append((job, len(job.members)))
        job.members.append((loop, cl))
        if len(job.members) == job.size:
            del groups[key]
            submit(job)

    def fill(upto: int) -> bool:
        """Take members until ``upto`` are out (False: the source is dry)."""
        while len(slots) < upto:
            loop = next(source, None)
            if loop is None:
                return False
            take(loop)
        return True

    try:
        fill(in_flight)
        while slots:
            job, k = slots[0]
            # the open group of the next result: members of other structures between its own
            # may keep it from filling within ``in_flight``; take up to as many again
            while grow and not job.futures and len(job.members) < job.size:
                if len(slots) >= 2 * in_flight or not fill(len(slots) + 1):
                    break
            if not job.futures:  # an open group whose first member is next: it goes as it is
                key = job.members[0][1].asm.source
                if groups.get(key) is job:
                    del groups[key]
                submit(job)
            result = job.result(k)
            slots.popleft()
            fill(in_flight)  # the next members start before the caller takes this result
            _tick(bar)
            yield result
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
        if bar is not None:
            bar.close()


def _run_group(
    built: list, reduce: Callable | None, kernels: str, lean: bool = False, fallback: bool = False
) -> list:
    """One lane group (:class:`~adaptive_ftc.sim.engine.CompiledLoop` of one structure, at
    most :func:`~adaptive_ftc.sim.lanes.queue_members`): each member's result (reduced) in
    order.
    ``fallback`` (``"auto"``): a lane group the lane engine refuses (a
    :class:`ConfigurationError`, e.g. its lane form disagreeing with the single run's) warns
    and runs its members one at a time instead."""
    from adaptive_ftc.sim import lanes as lane_engine  # looked up per call: benches count it
    from adaptive_ftc.sim.engine import finish_run

    try:
        # lean: the lanes' own signals pass over the records (stage 3)
        runs = lane_engine.integrate_lanes(built, kernels=kernels, lean=lean)
    except ConfigurationError as exc:
        if not fallback:
            raise
        import warnings

        warnings.warn(
            f"{exc} lanes='auto' runs these members one at a time instead (same results).",
            RuntimeWarning,
            stacklevel=2,
        )
        runs = [cl.integrate() for cl in built]
    out = []
    for cl, run in zip(built, runs, strict=True):
        result = finish_run(cl, run, lean=lean)
        out.append(result if reduce is None else reduce(result))
    return out
