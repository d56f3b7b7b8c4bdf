"""Peers on one loop (issue 29): the same members of the §2.3 hypersonic loop through each
engine that is available, per core.

Run: ``python benchmarks/bench_peers.py [--n 200] [--t-final 120] [--check 20] [--seed 0]``
or ``--small`` (CI: 3 members of 8 s, no timing targets; checks that every engine runs and
agrees).

Engines, each on ONE thread so that its wall time is its per-core time:

* ``batch``: this project's member-per-thread batch (:func:`iter_simulate`, ``jobs=1``);
* ``lanes``: this project's lane engine (``iter_simulate(..., lanes=True)``, ``sim/lanes.py``:
  8 members per compiled call in SIMD lanes; RK4 (stage 1 of issue 29) and DOPRI5 (stage 2:
  each lane its own step size and error control), same thread; with DOPRI5 it also prints the
  lanes' occupancy: the share of the lane slots (8 per pass of a group) that were a member's
  step attempt, counted by the engine (lane refill: a lane whose member ends takes the next
  one of its queue), beside what groups of 8 without refill would give (each group runs
  until its slowest member); ``lanes-vec`` (RK4): the same with
  ``lane_kernels="vector"`` (stage 1b/1c: call-free exp, tanh, sin, cos, the rhs pasted into
  the RK4 stages, fused multiply-adds; about 1e-14 from the single
  runs instead of bit-identical);
* ``C``: the hand-written C loop (``benchmarks/c/hypersonic_loop.c``, RK4 only, 1 pthread);
  skipped with a message when no C compiler is found;
* ``scipy``: :func:`scipy.integrate.solve_ivp` (``RK45``) on the same compiled right-hand side
  (the engine's ``method="RK45"`` path; Dopri5 only: scipy has no fixed-step RK4; timed on
  the first ``--check`` members only, as it is some 20x slower);
* ``JAX RK4`` and ``diffrax`` (Dopri5): the same loop written in JAX (``_jaxloop.py``),
  members vmapped in chunks of ``--chunk`` (default 100), only when ``jax`` and ``diffrax``
  are importable (``pip install "adaptive-ftc[bench]"``; never installed in CI). JAX RK4 runs
  this project's step grid (agreement to rounding); diffrax's Dopri5 its own step control
  (agreement to the tolerance).

Times are CPU seconds (this process's threads for the Python engines, the child process for
C, start-up and input parsing included), so a loaded machine inflates them less than wall
times.

Methods: RK4 with dt = 1e-3 and Dopri5 with rtol = 1e-6, atol = 1e-9 (record_dt 0.01).
Printed per engine and method: per-core seconds per member, that time relative to the C loop
(RK4), to the batch and to the JAX peer, and the max difference of each member's final state
(relative above 1) from the single run of the same member: for ``batch`` and ``lanes`` its own
:func:`simulate` (must be 0: the batch runs the single-run code, the lanes reproduce it bit for
bit, RK4 and DOPRI5), for the other engines
this project's single run of the same method (the agreement between engines). ``--check K``
compares the first K members (single runs cost as much as the batch).
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _cref import CReferenceError, build, failure_records, rk4_scenario, run_batch  # noqa: E402
from bench_batch import draw_failures  # noqa: E402

from adaptive_ftc import SolverOptions, iter_simulate, simulate  # noqa: E402
from adaptive_ftc.sim.lanes import QUEUE_MEMBERS, lane_occupancy  # noqa: E402

METHODS = {
    "RK4 dt 1e-3": SolverOptions(method="rk4", dt=1e-3, record_dt=0.01),
    "Dopri5 1e-6/1e-9": SolverOptions(method="dopri5", rtol=1e-6, atol=1e-9, record_dt=0.01),
}
SCIPY = SolverOptions(method="RK45", rtol=1e-6, atol=1e-9, record_dt=0.01)


def final_row(r) -> np.ndarray:
    """[status, samples, final closed-loop state] of one result (the C batch's row)."""
    state = np.concatenate([r.states[-1], r.adaptive[-1]]) if r.time.size else np.full(27, np.nan)
    return np.concatenate([[0.0 if r.status == "completed" else 1.0, r.time.size], state])


def max_diff(a: np.ndarray, b: np.ndarray) -> float:
    """Max |a - b| over final states, relative where |b| > 1 (as bench_batch.py)."""
    scale = np.maximum(1.0, np.abs(b[:, 2:]))
    return float(np.nanmax(np.abs(a[:, 2:] - b[:, 2:]) / scale))


def python_batch(
    loops, solver, lanes: bool = False, kernels: str = "libm", attempts: list | None = None
) -> tuple[float, np.ndarray]:
    """Per-core seconds of the batch (or the lane engine) on one thread, and its rows
    (``attempts``: receives each member's step attempts, accepted and rejected)."""
    t = time.process_time()
    runs = iter_simulate(loops, solver, jobs=1, lanes=lanes, lane_kernels=kernels)
    rows = []
    for r in runs:
        rows.append(final_row(r))
        if attempts is not None:
            attempts.append(r.meta["steps"] + r.meta.get("rejected_steps", 0))
    return time.process_time() - t, np.array(rows)


def occupancy(attempts: list, width: int = 8) -> float:
    """The share of a lane engine's step attempts that were its members' own WITHOUT refill:
    consecutive groups of ``width`` run until their slowest member (the others idle), the
    last group padded to ``width``."""
    groups = [attempts[i : i + width] for i in range(0, len(attempts), width)]
    return sum(attempts) / sum(width * max(g) for g in groups)


def singles(loops, solver) -> np.ndarray:
    return np.array([final_row(simulate(loop, solver)) for loop in loops])


def jax_engines(base, drawn, t_final: float, chunk: int) -> tuple[str, dict[str, tuple]]:
    """Per-core seconds per member and final-state rows of the JAX peers (``_jaxloop.py``):
    ``"JAX RK4"`` (vmapped ``lax.fori_loop``, this project's step grid) and ``"diffrax"``
    (vmapped ``diffrax.Dopri5``), with a note; ``(note, {})`` when jax or diffrax is not
    importable.
    Members run in vmapped chunks of ``chunk`` (the last one padded with copies of the first
    member, whose time is not counted); compile time excluded (a first call on the same shapes)."""
    try:
        import _jaxloop as J
    except ImportError:
        return "skipped (jax and diffrax are not importable; pip install jax diffrax)", {}
    rk4, dp = METHODS["RK4 dt 1e-3"], METHODS["Dopri5 1e-6/1e-9"]
    x0 = base.initial_state
    members = [J.member_arrays(x0, failure_records(f), t_final, rk4.dt) for f in drawn]
    n = len(members)
    chunk = max(1, min(chunk, n))
    padded = members + [members[0]] * (-n % chunk)
    batches = [J.stack(padded[i : i + chunk]) for i in range(0, len(padded), chunk)]
    n_total = int(max(m["steps"].sum() for m in members))  # one compile for every chunk
    out = {}
    for name, run in (
        ("JAX RK4", lambda b: J.rk4(b, n_total)),
        ("diffrax", lambda b: J.dopri5(b, t_final, dp.rtol, float(dp.atol))),
    ):
        np.asarray(run(batches[0]))  # compile
        t = time.process_time()
        ys = np.concatenate([np.asarray(run(b)) for b in batches])[:n]
        per = (time.process_time() - t) / n
        rows = np.column_stack([np.zeros(n), np.zeros(n), ys])
        out[name] = (per, rows)
    return f"run (vmapped chunks of {chunk} members, CPU time of all XLA threads)", out


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--n", type=int, default=200, help="members (default 200)")
    ap.add_argument("--t-final", type=float, default=120.0, help="seconds per run (default 120)")
    ap.add_argument("--check", type=int, default=20, help="members compared with single runs")
    ap.add_argument("--seed", type=int, default=0, help="seed of the failure draws")
    ap.add_argument("--chunk", type=int, default=100, help="members per vmapped JAX call")
    ap.add_argument("--small", action="store_true", help="CI: 3 members of 8 s, no targets")
    args = ap.parse_args()
    if args.small:
        args.n, args.t_final, args.check = 3, 8.0, 3
    if args.n < 1 or args.check < 0 or not args.t_final > 6.0:
        print(
            "error: --n must be >= 1, --check >= 0, --t-final > 6 (failures start after 5 s)",
            file=sys.stderr,
        )
        return 2
    base = rk4_scenario().loop
    base = replace(base, t_final=args.t_final)
    rng = np.random.default_rng(args.seed)
    drawn = [draw_failures(rng, args.t_final) for _ in range(args.n)]
    loops = [replace(base, failures=f) for f in drawn]
    k = min(args.check, args.n)
    warnings.simplefilter("ignore")  # diverged members (if any) are compared, not reported
    print(
        f"hypersonic-direct-s1 loop, {args.n} members of {args.t_final:g} s (seed {args.seed}), "
        f"one thread per engine; differences over the first {k} members"
    )
    c_per = None
    try:
        exe = build()
        runs = [(base.initial_state, failure_records(f)) for f in drawn]
        sol = METHODS["RK4 dt 1e-3"]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        _, c_rows = run_batch(
            exe, runs, threads=1, t_final=args.t_final, dt=sol.dt, record_dt=sol.record_dt
        )
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        t_c = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        c_per = t_c / args.n
    except CReferenceError as exc:
        print(f"  C: skipped ({exc})")
    jax_note, jax_rows = jax_engines(base, drawn, args.t_final, args.chunk)
    print(f"  JAX peers: {jax_note}")
    failed = False
    for label, solver in METHODS.items():
        iter_simulate(loops[:1], solver, jobs=1).__next__()  # compile or load the cached loop
        t_b, b_rows = python_batch(loops, solver)
        ref = singles(loops[:k], solver)
        lines = [("batch", t_b / args.n, max_diff(b_rows[:k], ref))]
        # the lane engine: RK4 with both kernels (stage 1, 1b), DOPRI5 with libm's (stage 2)
        kinds = (("lanes", "libm"), ("lanes-vec", "vector")) if label.startswith("RK4") else ()
        for name, kernels in kinds or (("lanes", "libm"),):
            warm = iter_simulate(loops[:2], solver, jobs=1, lanes=True, lane_kernels=kernels)
            list(warm)  # compile or load the lane module
            attempts: list[int] = []
            before = lane_occupancy()
            t_l, l_rows = python_batch(loops, solver, True, kernels, attempts)
            after = lane_occupancy()
            lines.append((name, t_l / args.n, max_diff(l_rows[:k], ref)))
            if label.startswith("Dopri5"):
                used = after.attempts - before.attempts
                slots = after.slots - before.slots
                print(
                    f"  {label}: lane occupancy {used / max(slots, 1):.1%} with refill "
                    f"(queues of up to {QUEUE_MEMBERS['dopri5']}; counted: the members' step "
                    f"attempts / the lane slots), {occupancy(attempts):.1%} in groups of 8 "
                    "without"
                )
        if label.startswith("RK4") and c_per is not None:
            lines.append(("C", c_per, max_diff(c_rows[:k], ref)))
        peer = "JAX RK4" if label.startswith("RK4") else "diffrax"
        if peer in jax_rows:
            per, rows = jax_rows[peer]
            lines.append((peer, per, max_diff(rows[:k], ref)))
        if label.startswith("Dopri5"):
            t_s, s_rows = python_batch(loops[: max(k, 1)], SCIPY)
            lines.append(("scipy RK45", t_s / max(k, 1), max_diff(s_rows[:k], ref)))
        print(f"  {label}:")
        jax_per = jax_rows[peer][0] if peer in jax_rows else None
        for name, per, diff in lines:
            rel = f"{per / c_per:6.2f}x C (RK4)" if c_per else "  (no C)"
            rel += f"  {per / lines[0][1]:6.2f}x batch"
            rel += f"  {per / jax_per:6.2f}x {peer}" if jax_per else ""
            cost = f"{per * 1e3:9.2f} ms per member per core"
            print(f"    {name:10s} {cost}  {rel}  max diff {diff:.1e}")
        for name, _, diff in lines:
            if (name in ("batch", "lanes") and diff != 0.0) or (
                name == "lanes-vec" and not diff <= 1e-10
            ):
                print(f"    FAILED: a {name} member differs from its single run ({diff:.1e})")
                failed = True
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
