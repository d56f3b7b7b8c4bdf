"""Tolerance study: error of every state against a tight reference versus wall time.

For every catalogue scenario (or ``--only NAME``), integrates the closed loop with

- today's compiled fixed-step RK4 at several steps around the scenario's own ``dt``,
- the compiled adaptive integrators of ``adaptive_ftc/sim/templates/adaptive.py`` (``dopri5``,
  ``rodasp``, ``auto``) at several tolerances,

and compares every recorded state with an independent reference: scipy ``solve_ivp`` (DOP853,
or Radau for the stiff wing-rock loops) at ``rtol = 1e-11``, integrated piecewise across the
failure break times with the loop's allocating ``derivative``. The error of a setting is the
largest over states of ``max_t |y_i - y_ref_i| / scale_i`` with ``scale_i = max(max_t
|y_ref_i|, 1e-6)``. Per scenario it prints the fastest setting whose error is below 1e-6 and
its speed-up over RK4 at the scenario's ``dt``.

Wall times are the best of a few runs of the integrator call alone (compiled before timing);
they are ratios measured in the same process, so machine load cancels only in part: run it on
a quiet machine for numbers to quote.

Usage::

    python benchmarks/bench_tolerance.py                  # every scenario (slow: minutes)
    python benchmarks/bench_tolerance.py --quick          # fewer settings
    python benchmarks/bench_tolerance.py --only wingrock-estimation-s1
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from adaptive_ftc import load_scenario
from adaptive_ftc.sim.compose import assemble as compose
from adaptive_ftc.sim.templates import adaptive as template

TARGET = 1e-6
BOUND = 1e8
SCALE_FLOOR = 1e-6
STIFF_REFERENCE = ("wingrock-direct", "wingrock-estimation")
_BOUND: dict[int, object] = {}


def _namespace(loop):
    """Everything the integrators need for ``loop``.

    Returns ``(module, D, W, y0, breaks, f, rk4, names)``: a module holding the adaptive
    integrators with the loop's compiled rhs, the loop's data and work arrays, the initial
    state, the break times, an allocating ``f(t, y, ph)`` for scipy, ``rk4(dt, t_rec, out_Y,
    out_phase[, breaks])`` running the fixed-step RK4 on the same rhs, and the state names.

    Uses the loop's generated module (``adaptive_ftc.sim.compose``), whose integrators are
    the template pasted by the code generator.
    """
    asm = compose(loop)
    gen = asm.module
    if hasattr(gen, "integrate_rodasp"):
        mod = gen
    else:  # a generated module without the adaptive template: bind it to the module's rhs
        if id(gen) not in _BOUND:
            _BOUND[id(gen)] = template.bind(gen.rhs, None, name=f"bench_{id(gen)}")
        mod = _BOUND[id(gen)]
    D = asm.data
    breaks = np.array(asm.breakpoints, dtype=float)

    def rk4(dt, t_rec, out_Y, out_phase, breaks=breaks):
        stop = np.zeros(1, dtype=np.int64)
        stats = np.zeros(5, dtype=np.int64)
        return gen.integrate_rk4(
            asm.y0, breaks, dt, t_rec, D, asm.work(), BOUND, stop, out_Y, out_phase, stats
        )

    names = list(loop.plant.state_names) + list(asm.adaptive_names)
    return mod, D, asm.work(), asm.y0, breaks, asm.derivative, rk4, names


def record_times(t0: float, t1: float, dt: float) -> np.ndarray:
    """The engine's recording grid."""
    n = int(math.floor((t1 - t0) / dt + 1e-9))
    t = t0 + dt * np.arange(n + 1)
    if t1 - t[-1] > 1e-9 * max(1.0, abs(t1)):
        t = np.append(t, t1)
    return t


def reference(f, y0, breaks, t_rec, method):
    """scipy ``solve_ivp`` at rtol 1e-11 piecewise across ``breaks``, on ``t_rec``."""
    Y = np.full((t_rec.size, y0.size), np.nan)
    y = np.array(y0, dtype=float)
    nph = breaks.size - 1
    for ph in range(nph):
        a, b = breaks[ph], breaks[ph + 1]
        tol = 1e-9 * max(1.0, abs(b))
        last = ph == nph - 1
        sel = (t_rec >= a - tol) & ((t_rec <= b + tol) if last else (t_rec < b - tol))
        t_eval = np.clip(t_rec[sel], a, b)
        t_eval = np.append(t_eval, b) if (t_eval.size == 0 or t_eval[-1] < b) else t_eval
        sol = solve_ivp(
            lambda t, v, ph=ph: f(t, v, ph),
            (a, b),
            y,
            method=method,
            t_eval=t_eval,
            rtol=1e-11,
            atol=1e-13,
        )
        if sol.status != 0:
            raise RuntimeError(f"reference failed in phase {ph}: {sol.message}")
        Y[sel] = sol.y.T[: int(sel.sum())]
        y = sol.y[:, -1].copy()
    return Y


def _timed(fn, budget: float = 1.0, reps: int = 3):
    best = math.inf
    out = None
    for _ in range(reps):
        t0 = time.perf_counter()
        out = fn()
        dt = time.perf_counter() - t0
        best = min(best, dt)
        if dt > budget:
            break
    return best, out


def _error(Y, Yref, nrec):
    if nrec < Yref.shape[0]:
        return math.inf, -1, math.inf
    scale = np.maximum(np.abs(Yref).max(axis=0), SCALE_FLOOR)
    absdiff = np.abs(Y - Yref).max(axis=0)
    rel = absdiff / scale
    worst = int(np.argmax(rel))
    return float(rel[worst]), worst, absdiff


def study(name: str, quick: bool):
    sc = load_scenario(name)
    loop = sc.loop
    mod, D, W, y0, breaks, f, rk4, names = _namespace(loop)
    t_rec = record_times(loop.t0, loop.t_final, sc.solver.record_dt)
    method = "Radau" if name.startswith(STIFF_REFERENCE) else "DOP853"
    t0 = time.perf_counter()
    Yref = reference(f, y0, breaks, t_rec, method)
    t_ref = time.perf_counter() - t0
    print(f"\n## {name}  ({y0.size} states, reference {method} rtol 1e-11 in {t_ref:.1f} s)")
    print(
        f"{'solver':<8} {'setting':>12} {'status':>6} {'wall ms':>9} {'steps':>9} "
        f"{'rejected':>8} {'rhs evals':>10} {'max rel err':>11}  worst state"
    )
    rows = []
    dt0 = sc.solver.dt
    factors = (2.0, 1.0, 0.5) if quick else (4.0, 2.0, 1.0, 0.5, 0.25)
    n = y0.size
    # compile (or load) every integrator for this loop's data types before timing
    tiny = np.array([breaks[0], breaks[0] + 1e-6])
    for meth in ("dopri5", "rodasp", "auto"):
        getattr(mod, f"integrate_{meth}")(
            y0,
            tiny,
            tiny,
            D,
            W,
            1e-6,
            1e-9,
            math.inf,
            BOUND,
            np.zeros(1, np.int64),
            np.zeros((2, n)),
            np.zeros(2, np.int64),
            np.zeros(5, np.int64),
        )
    rk4(1e-7, tiny, np.zeros((2, n)), np.zeros(2, np.int64), tiny)
    for fac in factors:
        dt = dt0 * fac
        Y = np.zeros((t_rec.size, n))
        ph = np.zeros(t_rec.size, dtype=np.int64)
        call = lambda dt=dt, Y=Y, ph=ph: rk4(dt, t_rec, Y, ph)  # noqa: E731
        wall, res = _timed(call)
        nrec, status = int(res[0]), int(res[1])
        err, worst, absdiff = _error(Y, Yref, nrec)
        steps = int(round((breaks[-1] - breaks[0]) / dt))
        rows.append(
            ("rk4", f"dt={dt:.3g}", status, wall, steps, 0, 4 * steps, err, worst, absdiff, call)
        )
    rtols = (1e-5, 1e-6, 1e-7) if quick else (1e-4, 1e-5, 1e-6, 3e-7, 1e-7, 1e-8, 1e-9, 1e-10)
    methods = ("dopri5", "rodasp", "auto")
    if n > 60:  # a dense n x n Jacobian per step: RODASP only on small loops
        methods = ("dopri5", "auto")
    for meth in methods:
        fn = getattr(mod, f"integrate_{meth}")
        for rtol in rtols:
            atol = 1e-3 * rtol
            Y = np.zeros((t_rec.size, n))
            ph = np.zeros(t_rec.size, dtype=np.int64)
            stats = np.zeros(5, dtype=np.int64)
            stop = np.zeros(1, dtype=np.int64)

            def run(fn=fn, rtol=rtol, atol=atol, Y=Y, ph=ph, stats=stats, stop=stop):
                return fn(y0, breaks, t_rec, D, W, rtol, atol, math.inf, BOUND, stop, Y, ph, stats)

            wall, res = _timed(run)
            nrec, status = int(res[0]), int(res[1])
            err, worst, absdiff = _error(Y, Yref, nrec)
            rows.append(
                (
                    meth,
                    f"rtol={rtol:.0e}",
                    status,
                    wall,
                    int(stats[0]),
                    int(stats[1]),
                    int(stats[2]),
                    err,
                    worst,
                    absdiff,
                    run,
                )
            )
    for r in rows:
        wname = names[r[8]] if r[8] >= 0 else "-"
        print(
            f"{r[0]:<8} {r[1]:>12} {r[2]:>6} {1e3 * r[3]:>9.1f} {r[4]:>9} {r[5]:>8} "
            f"{r[6]:>10} {r[7]:>11.2e}  {wname}"
        )
    base = next(r for r in rows if r[0] == "rk4" and r[1] == f"dt={dt0:.3g}")
    ok = [r for r in rows if r[2] == 0 and r[7] <= TARGET]
    if ok:
        best = min(ok, key=lambda r: r[3])
        # the machine is shared: time the two again, interleaved, and keep the best of each
        t_best, t_base = math.inf, math.inf
        for _ in range(3):
            t_best = min(t_best, _timed(best[10], reps=1)[0])
            t_base = min(t_base, _timed(base[10], reps=1)[0])
        print(
            f"fastest meeting {TARGET:g}: {best[0]} {best[1]}, {1e3 * t_best:.1f} ms, "
            f"{t_base / t_best:.2f}x faster than rk4 dt={dt0:g} ({1e3 * t_base:.1f} ms, "
            f"error {base[7]:.2e}; interleaved re-timing, best of 3)"
        )
    else:
        print(f"no setting meets {TARGET:g} on every state")
    if "rho" in names:
        i = names.index("rho")
        errs = [f"{r[0]} {r[1]}: {r[9][i]:.1e}" for r in rows if r[2] == 0]
        print("rho absolute error:", ", ".join(errs))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", action="append", help="scenario name (repeatable)")
    ap.add_argument("--quick", action="store_true", help="fewer steps and tolerances")
    args = ap.parse_args(argv)
    catalog = Path(template.__file__).resolve().parents[2] / "scenarios" / "catalog"
    names = args.only or sorted(p.stem for p in catalog.glob("*.toml"))
    for name in names:
        study(name, args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
