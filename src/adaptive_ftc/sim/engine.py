"""Simulation engine: integrates a closed loop's compiled module with the method of its
:class:`SolverOptions` (fixed-step RK4, adaptive DOPRI5, RODASP, Rodas5P or automatic
stiffness switching, all compiled; or a ``scipy.integrate.solve_ivp`` method), restarting
exactly at every failure time, and returns a :class:`~adaptive_ftc.sim.result.SimResult`."""

from __future__ import annotations

import functools
import math
import threading
import time
import warnings
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from adaptive_ftc.errors import ConfigurationError, DivergenceWarning
from adaptive_ftc.sim import solvers
from adaptive_ftc.sim.compile_errors import clear_compile_errors
from adaptive_ftc.sim.compose import Assembled, assemble
from adaptive_ftc.sim.result import SimResult, lean_signal_block, signal_block
from adaptive_ftc.sim.status import RunStatus, SimulationInterrupted, StatusReason, describe
from adaptive_ftc.sim.system import ClosedLoop

__all__ = [
    "CompiledLoop",
    "Integration",
    "SolverOptions",
    "finish_run",
    "integrate_only",
    "simulate",
]

# the names of the registry (sim/solvers.py), by kind
_SCIPY_METHODS = solvers.names("scipy")
#: Compiled adaptive-step methods (``sim/templates/adaptive.py``; evidence in docs/solvers.md).
_ADAPTIVE_METHODS = solvers.names("adaptive")
_METHODS = solvers.names()
#: Time constant (s) of a continuous controller's s' filter (``SolverOptions.filter_tau``).
DEFAULT_FILTER_TAU = 0.01


@dataclass(frozen=True, kw_only=True)
class SolverOptions:
    """How to integrate a closed loop.

    Parameters
    ----------
    method
        ``"rk4"``: compiled fixed-step RK4 (default; step ``dt``).
        ``"dopri5"``: compiled Dormand-Prince 5(4), for non-stiff loops.
        ``"rodasp"``: compiled Rosenbrock RODASP 4(3), L-stable, for stiff loops.
        ``"rodas5p"``: compiled Rosenbrock Rodas5P 5(4) with a 4th-order dense output, for
        stiff loops at tight tolerances (wing rock).
        ``"auto"``: DOPRI5 switching to RODASP while the loop is stiff.
        ``"accurate"``: ``"auto"`` (kept for old scenario files); with the default tolerances.
        Any :func:`scipy.integrate.solve_ivp` method name runs scipy (slow; a cross-check).
        Every path restarts exactly at each failure time.
    dt
        Step of the fixed-step path (seconds); steps also land on every failure time.
    rtol, atol, max_step
        Tolerances (error control on every state: ``|err_i| <= atol_i + rtol |y_i|``) and the
        largest step of the adaptive-step paths. ``atol`` is one number for every state or a
        sequence with one number per state of the loop, in its state order (plant states,
        adaptive states, extra states such as filters); a list is stored as a tuple.
    record_dt
        Spacing of the recorded samples.
    sdot
        ``"exact"``: ``s'`` from the plant derivative inside the right-hand side (SPEC §1);
        ``"filtered"``: a first-order dirty-derivative filter of ``s`` with time constant
        ``filter_tau`` (what a real system could measure); ``"auto"`` (default): ``"filtered"``
        when the loop has measurement noise or a digital controller, else ``"exact"``.
    filter_tau
        Time constant (s) of the ``s'`` filter; ``None`` (default): 0.01 s, or twice the
        sample time of a digital controller slower than 50 Hz (:meth:`filter_tau_for`), so
        that the sampled filter is stable (it needs ``sample_time < 2 filter_tau``).
    divergence_bound
        A run stops (keeping its partial result) when any state leaves ``|y| < bound`` or
        becomes non-finite.
    """

    method: str = "rk4"
    dt: float = 1e-3
    rtol: float = 1e-8
    atol: float | tuple[float, ...] = 1e-10
    max_step: float = math.inf
    record_dt: float = 0.01
    sdot: str = "auto"
    filter_tau: float | None = None
    divergence_bound: float = 1e8

    def __post_init__(self) -> None:
        solvers.method(self.method)  # a clear error naming the registered methods
        if isinstance(self.atol, (list, tuple, np.ndarray)):
            atol = tuple(self.atol)
            if not atol:
                raise ConfigurationError(
                    "`atol` of SolverOptions must be a positive number or one positive number "
                    "per state; got an empty sequence."
                )
            for i, v in enumerate(atol):
                if isinstance(v, bool) or not isinstance(v, (int, float, np.floating)):
                    raise ConfigurationError(
                        f"`atol[{i}]` of SolverOptions must be a positive number; got {v!r}."
                    )
                if not (v > 0 and math.isfinite(v)):
                    raise ConfigurationError(
                        f"`atol[{i}]` of SolverOptions must be positive and finite; got {v!r}."
                    )
            object.__setattr__(self, "atol", tuple(float(v) for v in atol))
        elif isinstance(self.atol, np.floating):
            object.__setattr__(self, "atol", float(self.atol))
        for key in (
            "dt",
            "rtol",
            *(() if isinstance(self.atol, tuple) else ("atol",)),
            "max_step",
            "record_dt",
            *(() if self.filter_tau is None else ("filter_tau",)),
            "divergence_bound",
        ):
            v = getattr(self, key)
            if (
                isinstance(v, bool)
                or not isinstance(v, (int, float))
                or not v > 0
                or (math.isnan(v))
            ):
                raise ConfigurationError(f"`{key}` of SolverOptions must be positive; got {v!r}.")
        if self.sdot not in ("auto", "exact", "filtered"):
            raise ConfigurationError(
                f"`sdot` of SolverOptions must be 'auto', 'exact' or 'filtered'; got {self.sdot!r}."
            )

    def sdot_for(self, loop: ClosedLoop) -> str:
        """The ``s'`` this setting uses on ``loop`` (``"auto"`` resolved)."""
        if self.sdot != "auto":
            return self.sdot
        return "filtered" if loop.measured_with_noise else "exact"

    def filter_tau_for(self, loop: ClosedLoop) -> float:
        """The ``s'`` filter's time constant on ``loop``: ``filter_tau`` when given, else the
        design's own (``AdaptiveController.derivative_filter_tau``: the constraint-aware MIMO
        law's backward difference, ``sample_time``), else ``max(0.01, 2 sample_time)`` (0.01 s
        for a continuous controller)."""
        if self.filter_tau is not None:
            return float(self.filter_tau)
        own = getattr(loop.controller, "derivative_filter_tau", None)
        tau = own(loop) if own is not None else None
        if tau is not None:
            return float(tau)
        return max(DEFAULT_FILTER_TAU, 2.0 * float(loop.sample_time))

    @property
    def compiled_method(self) -> str | None:
        """The compiled integrator this setting runs (``None`` for a scipy method)."""
        return solvers.method(self.method).compiled

    def atol_for(self, n: int, names=None) -> np.ndarray:
        """The absolute tolerance of each of the ``n`` states (``names``: their names, for the
        error message)."""
        if not isinstance(self.atol, tuple):
            return np.full(n, float(self.atol))
        if len(self.atol) != n:
            listed = f" ({', '.join(names)})" if names is not None else ""
            raise ConfigurationError(
                f"`atol` of SolverOptions has {len(self.atol)} entries but the loop has {n} "
                f"states{listed}; give one number, or one per state in that order."
            )
        return np.array(self.atol, dtype=float)

    @property
    def scipy_method(self) -> str:
        """The solve_ivp method of the scipy path."""
        return self.method


def _record_times(t0: float, t1: float, dt: float) -> np.ndarray:
    """The record grid ``t0 + dt * k`` (and ``t1`` when the last record falls short of it): a
    copy of the grid of these three numbers (:func:`_grid`, found once), over a block of the
    pool of :mod:`~adaptive_ftc.sim.blocks` when big (a campaign's members share their grid:
    no fresh pages, no arithmetic, per member)."""
    from adaptive_ftc.sim import blocks
    from adaptive_ftc.sim.result import TIME_POOL_BYTES

    grid = _grid(*(np.float64(v).tobytes() for v in (t0, t1, dt)))  # keyed by the bits
    t = blocks.empty(grid.shape, min_bytes=TIME_POOL_BYTES)
    t[...] = grid
    return t


@functools.lru_cache(maxsize=8)
def _grid(t0_bits: bytes, t1_bits: bytes, dt_bits: bytes) -> np.ndarray:
    """:func:`_record_times`' grid of the floats with these bits (read-only, never handed out)."""
    t0, t1, dt = (float(np.frombuffer(b, dtype=np.float64)[0]) for b in (t0_bits, t1_bits, dt_bits))
    n = int(math.floor((t1 - t0) / dt + 1e-9))
    t = t0 + dt * np.arange(n + 1)
    if t1 - t[-1] > 1e-9 * max(1.0, abs(t1)):
        t = np.append(t, t1)
    t.setflags(write=False)
    return t


def _user_times(loop: ClosedLoop, t_eval) -> np.ndarray:
    """``t_eval`` checked: a strictly increasing 1-D grid of finite times inside the run."""
    t = np.asarray(t_eval, dtype=float)
    if t.ndim != 1 or t.size == 0:
        raise ConfigurationError(
            f"t_eval must be a non-empty 1-D sequence of times (s); got shape {t.shape}."
        )
    if not np.all(np.isfinite(t)):
        raise ConfigurationError("t_eval has non-finite times; give finite times in seconds.")
    if t.size > 1 and not np.all(np.diff(t) > 0):
        i = int(np.argmax(np.diff(t) <= 0))
        raise ConfigurationError(
            f"t_eval must be strictly increasing; t_eval[{i + 1}] = {t[i + 1]:g} follows "
            f"{t[i]:g}. Sort it and drop repeated times (np.unique)."
        )
    t0, t1 = float(loop.t0), float(loop.t_final)
    tol = 1e-9 * max(1.0, abs(t1))
    if t[0] < t0 - tol or t[-1] > t1 + tol:
        raise ConfigurationError(
            f"t_eval spans {t[0]:g} s to {t[-1]:g} s, outside the run's {t0:g} s to {t1:g} s; "
            "keep it inside, or change the loop's t_final."
        )
    return np.clip(t, t0, t1)


def simulate(
    loop: ClosedLoop,
    solver: SolverOptions | None = None,
    *,
    t_eval=None,
    lean_signals: bool = False,
) -> SimResult:
    """Simulate a closed loop.

    Integration restarts exactly at every failure onset/recovery (each interval of fixed
    failure pattern is integrated on its own), so the jumps are never stepped across.

    Parameters
    ----------
    loop
        The closed loop to run.
    solver
        Integration settings; defaults to compiled RK4 with ``dt = 1e-3``.
    t_eval
        Times (s) to record, strictly increasing, inside ``[loop.t0, loop.t_final]`` (like
        scipy's ``t_eval`` and python-control's ``T``); default: every ``solver.record_dt``.
        The integration itself (its steps) does not depend on it: between steps the state is
        interpolated (cubic Hermite for RK4, the method's dense output for the adaptive ones).
    lean_signals
        Compute only the signals that :meth:`SimResult.metrics`, :meth:`SimResult.recovery`
        and :meth:`SimResult.activity` read (tracking errors ``e``, commands ``u_cmd``,
        applied commands ``u_applied``; states and times as always): every other signal
        (``y``, ``yd``, ``s``, ``u0``, ``gain``, ``control_gain``, ...) is a read-only ``nan``
        array that takes no memory. Those numbers are the same as without it; a campaign asks
        for it (its row reads nothing else), a result for users should not.

    Returns
    -------
    SimResult
        Recorded states and signals. ``result.status`` says how the run ended (a
        :class:`~adaptive_ftc.RunStatus`) and ``result.reason`` why (a
        :class:`~adaptive_ftc.StatusReason`); a run that stopped early holds everything up to
        the last good sample and a :class:`DivergenceWarning` with ``result.message`` is issued.
        ``meta`` holds the integrator's statistics: ``steps`` (accepted), ``rejected_steps``
        (absent where the method does not report them: scipy's Radau, BDF and LSODA),
        ``rhs_evaluations`` (every call of the loop's right-hand side, those of finite-difference
        Jacobians included), ``jacobian_evaluations`` and ``lu_decompositions``.

    Raises
    ------
    SimulationInterrupted
        On Ctrl-C (a :class:`KeyboardInterrupt`); its ``.result`` holds the partial result.

    Examples
    --------
    >>> from adaptive_ftc.scenarios import load_scenario
    >>> sc = load_scenario("hypersonic-direct-s1")
    >>> result = simulate(sc.loop, sc.solver)
    >>> result.status
    'completed'
    """
    compiled = CompiledLoop.build(loop, solver or SolverOptions(), t_eval=t_eval)
    return finish_run(compiled, compiled.integrate(), stacklevel=3, lean=lean_signals)


def finish_run(
    compiled: CompiledLoop, run: Integration, *, stacklevel: int = 2, lean: bool = False
) -> SimResult:
    """The :class:`SimResult` of ``run`` (an integration of ``compiled``, by
    :meth:`CompiledLoop.integrate` or the lane engine, ``sim/lanes.py``): signals, envelope
    cut, status, meta counts; warns or raises as :func:`simulate` does. ``lean``: only the
    signals the metrics read (:func:`simulate`'s ``lean_signals``)."""
    loop = compiled.loop
    T, Y, phases, signals, status, reason = compiled.recorded(run, lean=lean)
    message = describe(status, reason, _run_label(loop))
    result = SimResult.from_run(
        loop,
        compiled.asm,
        T,
        Y,
        phases,
        signals=signals,
        solver=compiled.solver,
        message=message,
        wall_time=run.wall,
        status=status,
        reason=reason,
        lean=lean,
    )
    result.meta.update(_counts(run.stats))
    if status is RunStatus.INTERRUPTED:
        raise SimulationInterrupted(result, message)
    if message:
        warnings.warn(message, DivergenceWarning, stacklevel=stacklevel)
    return result


def _counts(stats: np.ndarray) -> dict[str, int]:
    """The integrator's statistics for ``SimResult.meta`` (``rejected_steps`` absent where the
    method does not count them: -1)."""
    counts = {"steps": int(stats[0])}
    if stats[1] >= 0:  # -1: not known (scipy's implicit methods do not count them)
        counts["rejected_steps"] = int(stats[1])
    counts["rhs_evaluations"] = int(stats[2])
    counts["jacobian_evaluations"] = int(stats[3])
    counts["lu_decompositions"] = int(stats[4])
    return counts


def integrate_only(loop: ClosedLoop, solver: SolverOptions | None = None):
    """Integrate ``loop`` and return ``(times, states, phases)`` without the recorded signals.

    The cheapest way to get a trajectory (used by benchmarks and campaigns that only need the
    states); :func:`simulate` adds the signals and the labelled :class:`SimResult`.
    """
    compiled = CompiledLoop.build(loop, solver or SolverOptions())
    run = compiled.integrate()
    nrec, _ = _envelope_cut(loop, run.Y, compiled.t_rec, run.nrec)
    return compiled.t_rec[:nrec], run.Y[:nrec], run.phases[:nrec]


class Integration(NamedTuple):
    """What one integration of a :class:`CompiledLoop` left: the record rows (``Y``,
    ``phases``; the first ``nrec`` are records), how it ended, its wall time and the
    integrator's counts ``[accepted, rejected (-1: unknown), rhs, Jacobians, LUs]``."""

    Y: np.ndarray
    phases: np.ndarray
    nrec: int
    status: RunStatus
    reason: StatusReason | None
    wall: float
    stats: np.ndarray
    #: the lean signals' block and the first record outside the plant's envelope (-1: none),
    #: when the integrator computed them already (the lane engine's signals pass, stage 3);
    #: :meth:`CompiledLoop.recorded` then uses them for a lean result instead of its own pass
    lean_signals: tuple[np.ndarray, int] | None = None


@dataclass(frozen=True)
class CompiledLoop:
    """A closed loop compiled for one solver setting: it owns the loop's compiled structure and
    numbers (``asm``), the record times and the tolerances, and integrates it.

    One run reads: :meth:`build` (size check, compile or cache load, record grid), then
    :meth:`integrate` (the compiled integrator of the solver's method, or scipy), then
    :meth:`recorded` (the signals' pass, cut at the plant's envelope).
    """

    loop: ClosedLoop
    solver: SolverOptions
    asm: Assembled
    t_rec: np.ndarray
    atol: np.ndarray

    @classmethod
    def build(cls, loop: ClosedLoop, solver: SolverOptions, *, t_eval=None) -> CompiledLoop:
        """Check the run's size, compile (or load) ``loop``'s structure, set the record times."""
        if not isinstance(loop, ClosedLoop):
            raise ConfigurationError(f"simulate() needs a ClosedLoop; got {type(loop).__name__}.")
        from adaptive_ftc.sim.budget import check_run_size

        check_run_size(loop, solver)  # refuse runs that could not finish or fit in memory
        asm = assemble(loop, sdot=solver.sdot_for(loop), filter_tau=solver.filter_tau_for(loop))
        if t_eval is None:
            t_rec = _record_times(loop.t0, loop.t_final, solver.record_dt)
        else:
            t_rec = _user_times(loop, t_eval)
        n = asm.y0.size
        names = None
        if isinstance(solver.atol, tuple):
            names = [_state_label(loop, asm, i) for i in range(n)]
        return cls(loop, solver, asm, t_rec, solver.atol_for(n, names))

    def integrate(self) -> Integration:
        """Integrate from ``loop.t0`` to ``loop.t_final``, restarting at every break."""
        stats = np.zeros(5, dtype=np.int64)
        start = time.perf_counter()
        if self.solver.compiled_method is not None:
            Y, phases, nrec, outcome = self._run_compiled(stats)
        else:
            bps = np.array(self.asm.breakpoints)
            Y, phases, nrec, outcome = _integrate_scipy(
                self.asm, bps, self.t_rec, self.solver, self.loop, self.atol, stats
            )
        wall = time.perf_counter() - start
        return Integration(Y, phases, nrec, outcome[0], outcome[1], wall, stats)

    def recorded(self, run: Integration, *, lean: bool = False):
        """The records of ``run`` with their signals, cut at the first one outside the plant's
        envelope: ``(T, Y, phases, signals, status, reason)``; ``lean``: only the signals the
        metrics read (``simulate``'s ``lean_signals``)."""
        nrec = run.nrec
        T, Y, phases = self.t_rec[:nrec], run.Y[:nrec], run.phases[:nrec]
        signals: np.ndarray
        if lean and run.lean_signals is not None:
            signals = run.lean_signals[0]
        else:
            signals = (lean_signal_block if lean else signal_block)(self.loop, nrec)
        status, reason = run.status, run.reason
        if nrec:
            # the signals' pass over the records also finds the first one outside the envelope
            if lean and run.lean_signals is not None:  # computed in lanes (sim/lanes.py)
                first = run.lean_signals[1]
            else:
                first = self.asm.signals(T, Y, phases, signals, lean=lean)
            cut, env_reason = _envelope_cut(self.loop, Y, T, nrec, first=first)
            if env_reason is not None:
                status, reason = RunStatus.DIVERGED, env_reason
            T, Y, phases, signals = T[:cut], Y[:cut], phases[:cut], signals[:cut]
        return T, Y, phases, signals, status, reason

    def _run_compiled(self, stats: np.ndarray):
        """The compiled integrator's run: ``(Y, phases, nrec, (status, reason))``."""
        asm, solver, t_rec = self.asm, self.solver, self.t_rec
        method = solver.compiled_method
        assert method is not None  # only compiled methods reach here (scipy's take the other path)
        # rows past the last record are never read: not zeroed (4 MB a 120 s run); a block of
        # an earlier run's records, already mapped, when one is free (sim/blocks.py)
        from adaptive_ftc.sim import blocks
        from adaptive_ftc.sim.result import TIME_POOL_BYTES

        Y = blocks.empty((t_rec.size, asm.y0.size))
        phases = blocks.empty((t_rec.size,), np.int64, min_bytes=TIME_POOL_BYTES)
        args = (asm.data, asm.work())
        bound = float(solver.divergence_bound)
        outputs = (Y, phases, stats)
        integrator = asm.integrator(method)
        bps = np.array(asm.breakpoints)
        if method == "rk4":
            scratch = tuple(np.empty((8, asm.y0.size)))  # 8 separate rows

            def run(stop):
                return integrator(
                    asm.y0, bps, float(solver.dt), t_rec, *args, bound, stop, *outputs, *scratch
                )
        else:
            tol = (float(solver.rtol), self.atol, float(min(solver.max_step, 1e300)))

            def run(stop):
                return integrator(asm.y0, bps, t_rec, *args, *tol, bound, stop, *outputs)

        nrec, code, t_stop, bad = _compiled_call(self.loop, run)
        nrec = int(nrec)
        if code == 0:
            return Y, phases, nrec, (RunStatus.COMPLETED, None)
        # codes 1 and 2 leave the state at the stop in the row after the last record
        kept = int(code) in (1, 2) and nrec < t_rec.size
        status, reason = _stop(
            self.loop, asm, solver, t_rec, Y, nrec, int(code), float(t_stop), int(bad),
            Y[nrec].copy() if kept else None,
        )  # fmt: skip
        if status is RunStatus.STEP_UNDERFLOW and method != "rk4":
            from adaptive_ftc.sim.templates.adaptive import MAX_STEPS

            if int(stats[0]) + int(stats[1]) >= MAX_STEPS:  # the count, not the size
                reason = replace(reason, step_limit=MAX_STEPS)
        return Y, phases, nrec, (status, reason)


def _stop(loop, asm, solver, t_rec, Y, nrec, code, t_stop, bad, y_stop):
    """The (status, reason) of a run that stopped with ``code`` (see :mod:`.diagnose`)."""
    from adaptive_ftc.sim.diagnose import stop_outcome

    return stop_outcome(
        loop,
        asm,
        solver,
        code=code,
        t_stop=t_stop,
        bad=bad,
        y_stop=y_stop,
        t_prev=float(t_rec[nrec - 1]) if nrec else float(loop.t0),
        y_prev=Y[nrec - 1].copy() if nrec else None,
    )


def _check_envelope(
    loop: ClosedLoop,
    Y: np.ndarray,
    t_rec: np.ndarray,
    nrec: int,
    message: str,
    *,
    first: int | None = None,
):
    """Cut the run at the first recorded sample outside the plant's physical envelope
    (``first``: that sample's row when the compiled signals found it, -1 when none is);
    returns the number of rows kept and the message (``message`` when none is outside)."""
    row, reason = _envelope_cut(loop, Y, t_rec, nrec, first=first)
    if reason is None:
        return nrec, message
    return row, describe(RunStatus.DIVERGED, reason, _run_label(loop))


def _envelope_cut(
    loop: ClosedLoop,
    Y: np.ndarray,
    t_rec: np.ndarray,
    nrec: int,
    *,
    first: int | None = None,
) -> tuple[int, StatusReason | None]:
    """The first recorded row outside the plant's envelope and its reason (``nrec, None``:
    none is)."""
    env = tuple(getattr(loop.plant, "envelope", ()) or ())
    if not env or nrec == 0 or first == -1:
        return nrec, None
    bound = np.asarray(env, dtype=float)
    start = 0 if first is None else first
    out = np.abs(Y[start:nrec, : bound.size]) > bound
    if not out.any():
        return nrec, None
    k = int(np.argmax(out.any(axis=1)))
    i = int(np.argmax(out[k]))
    row = start + k
    return row, StatusReason(
        time=float(t_rec[row]),
        signal=loop.plant.state_names[i],
        value=float(Y[row, i]),
        bound=float(bound[i]),
        envelope=True,
    )


def _compiled_call(loop: ClosedLoop, run):
    """Run the compiled loop, turning compiler and bounds errors of user parts into clear
    errors that name the plant."""
    with clear_compile_errors(loop):
        return _interruptible(run)


def _interruptible(run):
    """Run compiled ``run(stop)``; Ctrl-C in the main thread sets ``stop`` and waits for it.

    The compiled loop releases the GIL and polls ``stop`` every step, so an interrupt returns
    within a step with the partial result instead of being ignored until the run ends.
    """
    stop = np.zeros(1, dtype=np.int64)
    if threading.current_thread() is not threading.main_thread():
        return run(stop)
    box: dict[str, object] = {}
    done = threading.Event()

    def target():
        try:
            box["value"] = run(stop)
        except BaseException as exc:  # re-raised in the calling thread
            box["error"] = exc
        finally:
            done.set()

    worker = threading.Thread(target=target, name="adaptive-ftc-integrate", daemon=True)
    worker.start()
    # wait on an Event, not Thread.join: an interrupted join can leave the thread's state
    # inconsistent (join then returns while the thread still runs)
    try:
        while not done.wait(0.05):
            pass
    except KeyboardInterrupt:
        stop[0] = 1  # the compiled loop sees it at its next step
        while not done.wait(0.05):
            pass
    if "error" in box:
        raise box["error"]  # type: ignore[misc]
    return box["value"]


def _state_label(loop: ClosedLoop, asm: Assembled, index: int) -> str:
    names = list(loop.plant.state_names) + list(asm.adaptive_names) + list(asm.extra_names)
    return names[index] if 0 <= index < len(names) else f"state {index}"


def _run_label(loop: ClosedLoop) -> str:
    return f"'{loop.name}'" if loop.name else "(unnamed loop)"


def _counting_method(name: str, counts: np.ndarray):
    """scipy's ``name`` solver class, counting its accepted steps into ``counts[0]`` and, for
    the explicit Runge-Kutta methods (whose every attempt costs ``n_stages`` evaluations),
    its rejected steps into ``counts[1]``."""
    from scipy.integrate._ivp.ivp import METHODS

    base = METHODS[name]
    stages = getattr(base, "n_stages", None)
    stages = stages if isinstance(stages, int) else None

    class Counting(base):  # type: ignore[misc,valid-type]
        def _step_impl(self):
            before = self.nfev
            ok, message = super()._step_impl()
            counts[0] += int(ok)
            if stages:
                counts[1] += (self.nfev - before) // stages - int(ok)
            return ok, message

    Counting.__name__ = Counting.__qualname__ = f"Counting{name}"
    return Counting


def _integrate_scipy(
    asm: Assembled,
    bps: np.ndarray,
    t_rec: np.ndarray,
    solver: SolverOptions,
    loop: ClosedLoop,
    atol: np.ndarray,
    stats: np.ndarray,
):
    """The scipy path: :func:`scipy.integrate.solve_ivp` over each interval of fixed failure
    pattern; ``stats`` receives the counts of the compiled path's ``stats`` (steps, rejected
    steps or -1 when the method does not tell, right-hand side calls, Jacobians, LU
    decompositions)."""
    from scipy.integrate import solve_ivp

    bound = solver.divergence_bound
    W = asm.work()
    Y = np.zeros((t_rec.size, asm.y0.size))
    phases = np.zeros(t_rec.size, dtype=np.int64)
    y = asm.y0.copy()
    r = 0
    nph = bps.size - 1
    counts = np.zeros(3, dtype=np.int64)  # accepted steps, rejected steps, rhs calls
    method = _counting_method(solver.scipy_method, counts)
    rejections_known = getattr(method, "n_stages", None) is not None

    def blowup(t, y):
        return bound - np.max(np.abs(y))

    blowup.terminal = True  # type: ignore[attr-defined]  # scipy's event protocol
    for ph in range(nph):
        a, b = float(bps[ph]), float(bps[ph + 1])
        asm.module.jump(a, y, ph, asm.data, W)  # e.g. a digital controller's sample
        last = ph == nph - 1
        tol = 1e-9 * max(1.0, abs(b))
        sel = (t_rec >= a - tol) & ((t_rec <= b + tol) if last else (t_rec < b - tol))
        t_want = np.clip(t_rec[sel], a, b)
        # always evaluate at b too, so the next interval starts from the exact end state
        t_eval = np.append(t_want, b) if (t_want.size == 0 or t_want[-1] < b) else t_want

        def fun(t, y, ph=ph):
            # the compiled rhs takes C-contiguous float64 vectors only; scipy's
            # finite-difference Jacobians (Radau, BDF) pass columns of a matrix
            y = np.ascontiguousarray(y, dtype=np.float64)
            dy = np.zeros(y.size)
            asm.module.rhs(float(t), y, ph, asm.data, W, dy)
            counts[2] += 1
            return dy

        with np.errstate(all="ignore"):
            sol = solve_ivp(
                fun,
                (a, b),
                y,
                method=method,
                t_eval=t_eval,
                rtol=solver.rtol,
                atol=atol if isinstance(solver.atol, tuple) else solver.atol,
                max_step=solver.max_step,
                events=blowup,
            )
        stats[3] += sol.njev
        stats[4] += sol.nlu
        stats[0], stats[1], stats[2] = counts[0], counts[1] if rejections_known else -1, counts[2]
        ys = sol.y[:, : min(sol.t.size, t_want.size)]
        good = np.all(np.abs(ys) < bound, axis=0)
        ngood = int(np.argmin(good)) if not good.all() else ys.shape[1]
        Y[r : r + ngood] = ys[:, :ngood].T
        phases[r : r + ngood] = ph
        r += ngood
        if sol.status != 0 or ngood < ys.shape[1]:
            outcome = _scipy_stop(loop, asm, solver, t_rec, Y, r, sol, ys, ngood, a, y)
            return Y, phases, r, outcome
        y = sol.y[:, -1].copy()
    return Y, phases, r, (RunStatus.COMPLETED, None)


def _scipy_stop(loop, asm, solver, t_rec, Y, r, sol, ys, ngood, a, y):
    """The (status, reason) of a scipy interval that stopped early (``sol``): a state over the
    bound (the event, or a recorded sample ``ys[:, ngood]``) or the solver's own failure."""
    bound = solver.divergence_bound
    if sol.t_events and len(sol.t_events[0]):
        t_bad, yb = float(sol.t_events[0][0]), sol.y_events[0][0]
    elif ngood < ys.shape[1]:
        t_bad, yb = float(sol.t[ngood]), ys[:, ngood]
    else:
        t_bad, yb = (
            float(sol.t[-1]) if sol.t.size else a,
            (sol.y[:, -1] if sol.t.size else y),
        )
    off = ~(np.abs(yb) < bound)
    bad = int(np.argmax(off)) if off.any() else 0
    # a state over the bound (the event, a recorded sample) or the solver's failure
    code = 1 if off.any() else 2
    status, reason = _stop(
        loop, asm, solver, t_rec, Y, r, code, t_bad, bad, np.array(yb, dtype=float)
    )
    if sol.status == -1:
        reason = replace(reason, detail=str(sol.message))
    return status, reason
