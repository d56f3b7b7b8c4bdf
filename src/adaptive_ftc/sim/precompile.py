"""A cold run's compiles on both cores: the shared integrators in a second process, the loops'
structures in this one.

A first run after install compiles, one after another, things that do not depend on each
other (``python benchmarks/bench_compile_events.py``): the integrator every loop shares
(``integrate_dopri5`` and its helpers, 4.5-5.5 s of CPU) and the record pass ``signals``
(0.6-1.0 s), which call a loop's right-hand side only through an address in its data
(sim/fptr.py); each structure's ``rhs``, ``jump`` and plant ``control_gain`` (1-2 s a
structure; ``aftc run hypersonic-direct-s1`` has two: the scenario's, which its frozen,
failure-free and fixed-gain runs share, and the exact inverse of the nominal-inverse and
oracle baselines); the activity low-pass ``filtfilt`` (0.5 s) and its design (scipy.signal's
import, 0.8-0.9 s, once per install). numba writes every compiled function to its disk cache,
and a process that finds it there loads it in milliseconds. So :func:`overlapped` forks a
child that compiles the integrators and ``filtfilt`` for the argument types the runs will pass
(:func:`shared_signatures`, :func:`compile_lowpass`) and exits, while this process compiles
the structures and ``signals`` and designs the low-pass: about as much CPU each. Then it waits
for the child, and the runs load what the child compiled from the cache.

Nothing the runs compute changes: the child compiles the same functions for the same types
that the first run would have compiled (tests/test_precompile.py checks that the runs then
compile none of them, and that the results are those of a serial first run, bit for bit).
Only where ``fork`` is the process start (Linux), more than one CPU is usable and no other
thread runs; elsewhere, or when the child fails, the runs compile what is missing themselves,
as before.
"""

from __future__ import annotations

import os
import sys
import threading
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover - annotations only
    from adaptive_ftc.sim.engine import SolverOptions
    from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["SharedCompile", "compile_shared", "compile_structures", "overlapped"]


def shared_signatures(loop: ClosedLoop, solver: SolverOptions) -> list[tuple[str, tuple]]:
    """``(name, argument types)`` of the shared module's functions (``integrate_<method>``,
    ``signals``) as :func:`~adaptive_ftc.sim.engine.simulate` calls them on ``loop`` with
    ``solver``: the types of the arguments ``CompiledLoop._run_compiled`` and
    ``Assembled.signals`` pass, built here from the loop's generated numbers without
    compiling its structure."""
    import numba
    import numpy as np

    from adaptive_ftc.sim.compose import generate
    from adaptive_ftc.sim.layout import Header

    _, data, g, layout = generate(loop, sdot=solver.sdot_for(loop))
    n = int(layout["loop_layout"].n_states)
    m = int(data.i[Header.M])
    vec = np.zeros(n)
    ints = np.zeros(1, dtype=np.int64)
    rows = np.zeros((2, n))
    out: list[tuple[str, tuple]] = []
    method = solver.compiled_method
    if method is not None:
        head = (vec, np.zeros(2), *((float(solver.dt),) if method == "rk4" else ()), vec)
        common = (data, np.zeros(4))  # the loop's numbers, a work array
        if method == "rk4":
            args: tuple = (*head, *common, 1.0, ints, rows, ints, ints, *tuple(np.empty((8, n))))
        else:  # rtol, atol per state, max_step, divergence bound, stop flag, outputs
            args = (*head, *common, 1.0, vec, 1.0, 1.0, ints, rows, ints, ints)
        out.append((f"integrate_{method}", tuple(numba.typeof(a) for a in args)))
    scratch = (vec, np.zeros(m), np.zeros(g.nx), np.zeros(g.nx))
    sig = (vec, rows, ints, data, np.zeros(4), rows, *scratch, 0)
    out.append(("signals", tuple(numba.typeof(a) for a in sig)))
    return out


def compile_shared(
    jobs: Iterable[tuple[ClosedLoop, SolverOptions]], names: Sequence[str] | None = None
) -> int:
    """Compile (or load from the disk cache) in this process the shared functions that
    ``simulate(loop, solver)`` calls for each ``(loop, solver)`` of ``jobs`` (``names``: only
    those, e.g. ``("signals",)``); returns how many were compiled (not found in the cache)."""
    from adaptive_ftc.sim.compose import integrators

    module = integrators()
    wanted: dict[tuple[str, tuple], None] = {}
    for loop, solver in jobs:
        try:
            signatures = shared_signatures(loop, solver)
        except Exception:  # noqa: BLE001 - the run itself reports a loop that cannot be built
            continue
        for name, sig in signatures:
            if names is None or name in names:
                wanted.setdefault((name, sig), None)
    compiled = 0
    for name, sig in wanted:
        disp = getattr(module, name)
        before = sum(disp.stats.cache_misses.values())
        try:
            disp.compile(sig)
        except Exception:  # noqa: BLE001 - the run compiles it again and reports the error
            continue  # with the loop's name (sim/compile_errors.py)
        compiled += sum(disp.stats.cache_misses.values()) - before
    return compiled


def compile_structures(jobs: Iterable[tuple[ClosedLoop, SolverOptions]]) -> None:
    """Compile (or load) each loop's structure (``rhs``, ``jump``, the plant's
    ``control_gain``, its failure patterns) as ``simulate`` would, and design the activity
    metrics' low-pass for the records of each solver (scipy, once per install)."""
    from adaptive_ftc.sim.activity import _ORDER, DEFAULT_F_C
    from adaptive_ftc.sim.compose import assemble
    from adaptive_ftc.sim.zerophase import lowpass_design

    record_dts = set()
    for loop, solver in jobs:
        try:
            assemble(loop, sdot=solver.sdot_for(loop), filter_tau=solver.filter_tau_for(loop))
        except Exception:  # noqa: BLE001 - the run itself reports a loop that cannot be built
            continue
        record_dts.add(float(solver.record_dt))
    for dt in sorted(record_dts):
        if DEFAULT_F_C < 0.5 / dt:  # else the metrics filter nothing (activity._lowpass)
            lowpass_design(_ORDER, DEFAULT_F_C, 1.0 / dt)


def compile_lowpass() -> int:
    """Compile (or load) the activity metrics' zero-phase filter for the types
    :func:`~adaptive_ftc.sim.zerophase.sosfiltfilt_odd` passes (a design's read-only
    sections and initial conditions, the padded record); returns 1 when it compiled."""
    import numba
    import numpy as np

    from adaptive_ftc.sim.zerophase import _kernel

    fixed = np.zeros((2, 6)), np.zeros((2, 2))
    for a in fixed:
        a.setflags(write=False)  # as lowpass_design returns them
    disp = _kernel()
    before = sum(disp.stats.cache_misses.values())
    # the record's columns as the metrics pass them (a strided view: layout "A"; the kernel
    # pads them itself) and the pad length
    u = np.zeros((4, 4))[:, ::2]
    disp.compile(tuple(numba.typeof(a) for a in (*fixed, u, 1)))
    return sum(disp.stats.cache_misses.values()) - before


class SharedCompile:
    """A forked child that runs :func:`compile_shared` and exits (see the module's text).

    ``start(jobs)`` (``None`` where unavailable), then ``wait()``; ``close()`` in a
    ``finally`` ends a child that is still running (Ctrl-C in the parent).
    """

    def __init__(self, process: Any) -> None:
        self._process = process

    @staticmethod
    def available() -> bool:
        """Whether :meth:`start` can fork a child here: Linux, more than one usable CPU, no
        other thread running (a fork copies none, nor their locks), jit enabled."""
        from numba.core.config import DISABLE_JIT  # type: ignore[attr-defined]  # set at import

        from adaptive_ftc._figure_process import _usable_cpus

        return (
            not DISABLE_JIT
            and sys.platform.startswith("linux")
            and _usable_cpus() > 1
            and threading.active_count() == 1
        )

    @classmethod
    def start(cls, jobs: Sequence[tuple[ClosedLoop, SolverOptions]]) -> SharedCompile | None:
        """Fork the child now; ``None`` when this process should compile everything itself
        (no fork here, one usable CPU, another thread running, or jit disabled)."""
        import multiprocessing

        from adaptive_ftc.sim.compose import integrators

        if not cls.available():
            return None
        from adaptive_ftc.sim.zerophase import _kernel

        # the modules' files are written here, once, before the child reads them: numba's
        # cache entries are keyed by their time stamps
        integrators()
        _kernel()
        from numba.core.registry import cpu_target

        # numba's typing and lowering registries, filled on the first compile (0.3-0.4 s of
        # CPU): filled here once, not in both processes
        cpu_target.typing_context.refresh()
        cpu_target.target_context.refresh()
        for stream in (sys.stdout, sys.stderr):  # or the child writes its copy again at exit
            stream.flush()
        try:
            ctx = multiprocessing.get_context("fork")
            process = ctx.Process(
                target=_serve, args=(list(jobs),), daemon=True, name="aftc-compile"
            )
            process.start()
        except (OSError, ValueError):  # no fork here (or no resources): compile in this process
            return None
        return cls(process)

    def wait(self) -> bool:
        """Wait for the child; ``True`` when it compiled everything (else the runs compile
        what it left)."""
        self._process.join()
        return self._process.exitcode == 0

    def close(self) -> None:
        """End the child if it still runs, and reap it."""
        from adaptive_ftc._figure_process import end_child

        end_child(self._process)


def _serve(jobs: list) -> None:  # pragma: no cover - runs in the forked child
    from adaptive_ftc._figure_process import child_signals

    child_signals()
    try:
        from adaptive_ftc.sim.solvers import compiled_entries

        # the integrators (4.5-5.5 s of CPU for DOPRI5) and the low-pass filter (0.5 s); the
        # parent compiles the structures (1-2 s each) and signals (0.6 s) and designs the
        # low-pass (scipy.signal's import, 0.5-0.9 s): about as long
        compile_shared(jobs, names=compiled_entries())
        compile_lowpass()
    except BaseException:  # noqa: BLE001 - the parent's runs compile it and report the error
        os._exit(1)
    os._exit(0)  # nothing of the parent's to flush or finalise


def overlapped(jobs: Sequence[tuple[ClosedLoop, SolverOptions]]) -> bool:
    """Compile what ``simulate(loop, solver)`` needs for every ``(loop, solver)`` of
    ``jobs``, on two cores where possible: the shared integrators in a forked child, the
    structures here. ``True`` when a child was used; either way the runs afterwards compile
    nothing that was compiled here (the child's work is loaded from the disk cache)."""
    jobs = list(jobs)
    child = SharedCompile.start(jobs)
    try:
        compile_structures(jobs)
        # signals here (it calls the structures' code by address: none of it compiles again);
        # everything when there is no child
        compile_shared(jobs, names=None if child is None else ("signals",))
        if child is None:
            compile_lowpass()
        if child is not None:
            child.wait()
    finally:
        if child is not None:
            child.close()
    return child is not None
