"""Thesis law vs constraint-aware law on the hardware cases of issue 25 (docs/hardware.md).

Runs a scenario's design under each hardware case twice (the thesis law, and the same design
with ``constraint_aware=ConstraintAware.from_loop(case)``: one configuration per case, derived
from the declared hardware by the rules of :mod:`adaptive_ftc.controllers.constraints`) and
prints, per run, over the final window (the scenario's tracking claim's window): RMS
tracking error, fast command content (RMS of the command minus its zero-phase 1 Hz
low-pass, the whole record filtered then the window cut, recorded at 1 ms; largest over the
actuators), peak |command|, the fraction of the window an actuator spends at its rate
limit, and the verdict against the targets of issue 25.

Each case also runs the oracle (:func:`adaptive_ftc.baselines.oracle`: feedback linearisation
that knows the failure) on the same hardware, with the constraint-aware law's command filter,
smoothing and measurement filters; issue 25's error target is
``max(thesis threshold, 2 x the oracle's error)`` (``--no-oracle``: the thesis threshold).
The oracle's error counts only where the oracle is a **yardstick**
(:func:`oracle_yardstick`): its own run completes, its command is acceptable (the same fast
content, peak and rate-limit targets as the laws') and its error is at most
``ORACLE_LOST_FACTOR`` (10) thesis thresholds. Otherwise the case is reported
``INFEASIBLE-BY-ORACLE`` (with why: diverged, lost, or a command that is not acceptable) and
the laws are judged by the thesis threshold alone: an oracle that loses the task, or tracks
only by chattering, says nothing about what an acceptable controller can achieve there, and
2x its error would pass a law that does nothing (wingrock-direct-s1 behind a 50 ms lag: the
thesis law's 0.44 rad, the open-loop limit cycle, against an oracle lost at 0.46 rad).

    PYTHONPATH=src python scripts/hardware_cases.py hypersonic-direct-s1 [--duration 120]
"""

from __future__ import annotations

import argparse
import math
import time
import warnings
from dataclasses import dataclass, replace

import numpy as np
from scipy.signal import butter, sosfiltfilt

from adaptive_ftc.baselines import baseline_solver, oracle
from adaptive_ftc.controllers.constraints import ConstraintAware
from adaptive_ftc.errors import DivergenceWarning
from adaptive_ftc.hardware import Actuators, Sensors
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim.engine import DEFAULT_FILTER_TAU, simulate

REC_DT = 1e-3  # record fast enough not to alias the chatter being judged

#: an oracle whose final-window error exceeds this many thesis thresholds has lost the task
#: too (an order of magnitude off the thesis's accuracy): it is no yardstick
ORACLE_LOST_FACTOR = 10.0

#: the oracle row's verdict when the oracle is no yardstick for the case
INFEASIBLE = "INFEASIBLE-BY-ORACLE"


@dataclass(frozen=True)
class Case:
    name: str
    lag: float = 0.0
    rate: float = math.inf
    travel: float = math.inf
    hz: float = math.inf
    noise: float = 0.0  # on the position state; 10x on the velocity state


#: the cases of issue 25 item (a) (hypersonic §2.3 and §4.4)
HYPERSONIC_CASES = (
    Case("rate 10 rad/s", rate=10.0),
    Case("rate 2 rad/s", rate=2.0),
    Case("rate 0.5 rad/s", rate=0.5),
    Case("digital 200 Hz", hz=200.0),
    Case("digital 100 Hz", hz=100.0),
    Case("digital 50 Hz", hz=50.0),
    Case("digital 20 Hz", hz=20.0),
    Case("lag 20 ms", lag=0.02),
    Case("lag 50 ms", lag=0.05),
    Case("lag 100 ms", lag=0.1),
    Case("noise 1e-3", noise=1e-3),
    Case("lag 20 ms + 200 Hz + noise 1e-3", lag=0.02, hz=200.0, noise=1e-3),
    Case(
        "lag 50 ms + rate 2 + travel 0.5 + 50 Hz + noise 1e-4",
        lag=0.05,
        rate=2.0,
        travel=0.5,
        hz=50.0,
        noise=1e-4,
    ),
)


def cases_from_ideal(sc, ideal_result) -> tuple[Case, ...]:
    """Issue 25 item (c): lag 50 ms, 50 Hz, a rate limit at half the ideal run's peak command
    rate, noise at 1 % of the reference amplitude (on the output positions; 10x on their
    rates)."""
    r = ideal_result
    rate = float(np.max(np.abs(np.diff(r.u_cmd, axis=0)) / np.diff(r.time)[:, None]))
    amp = reference_amplitude(r)
    return (
        Case("lag 50 ms", lag=0.05),
        Case("digital 50 Hz", hz=50.0),
        Case(f"rate {rate / 2:.3g} (half the ideal peak)", rate=rate / 2),
        Case(f"noise {0.01 * amp:.2g} (1 % of the reference)", noise=0.01 * amp),
    )


def reference_amplitude(r) -> float:
    """Half the reference's largest peak to peak; for a regulation task (a constant
    reference, e.g. the wing rock's zero roll) the initial deviation the law regulates,
    ``max |e(t0)|`` (the wing rock: 1 deg, so "1 % of the reference amplitude" is 1.75e-4
    rad on the roll, 1.75e-3 rad/s on its rate; docs/hardware.md, "Wing rock §2.4")."""
    amp = float(np.max(np.ptp(r.yd, axis=0)) / 2.0)
    if amp > 0:
        return amp
    return float(np.max(np.abs(r.e[0])))


def final_window(t_end: float, width: float, events, settle: float = 0.5) -> tuple:
    """The judged window: the last ``width`` seconds, starting ``settle`` after the last
    failure event (onset or recovery) inside them (the wing rock's aileron recovers at 8 s,
    in its 8-10 s window: the window is 8.5-10 s; the recovery claims' settling time)."""
    t0 = t_end - width
    inside = [float(t) for t in events if t0 <= float(t) < t_end]
    if inside:
        t0 = min(max(inside) + settle, t_end)
    return t0, t_end


def case_loop(sc, case: Case, duration: float | None = None, noise_seed: int = 0):
    """The scenario's loop and solver under ``case``'s hardware (thesis law); ``noise_seed``:
    the seed of the sensors' noise draws (``Sensors(seed=...)``)."""
    loop, solver = sc.loop, replace(sc.solver, record_dt=REC_DT)
    if duration is not None:
        loop = replace(loop, t_final=loop.t0 + duration)
    if case.lag > 0 or math.isfinite(case.rate) or math.isfinite(case.travel):
        loop = replace(
            loop,
            actuators=Actuators(
                tau=case.lag, rate=case.rate, lower=-case.travel, upper=case.travel
            ),
        )
    fixed = False
    if case.noise > 0:
        plant = loop.plant
        noise = [0.0] * plant.n_states
        for i in plant.position_index:
            noise[i] = case.noise
        for i in plant.velocity_index:
            noise[i] = 10.0 * case.noise
        loop = replace(loop, sensors=Sensors(noise=tuple(noise), rate=1000.0, seed=noise_seed))
        fixed = True
    dt = 1e-3
    if math.isfinite(case.hz):
        ts = 1.0 / case.hz
        dt = ts / math.ceil(ts / 1e-3 - 1e-9)
        loop = replace(loop, sample_time=ts)
        tau = solver.filter_tau if solver.filter_tau is not None else DEFAULT_FILTER_TAU
        solver = replace(solver, filter_tau=max(tau, ts))
        fixed = True
    if fixed:
        solver = replace(solver, method="rk4", dt=dt)
    return loop, solver


def constraint_aware(loop, solver=None):
    """The same design with the constraint-aware option derived from the loop's hardware (and
    the time constant of the solver's ``s'`` filter, where it filters ``s'``: the designer
    knows its own derivative filter)."""
    over = {}
    if solver is not None and solver.sdot_for(loop) == "filtered":
        over["derivative_lag"] = solver.filter_tau_for(loop)
    ca = ConstraintAware.from_loop(loop, **over)
    return replace(loop, controller=replace(loop.controller, constraint_aware=ca))


def metrics(r, loop, window=(100.0, 120.0)):
    """Final-window metrics of one run (see the module docstring)."""
    t0, t1 = window
    done = r.status == "completed" and r.time[-1] >= loop.t_final - 1e-9
    out = {"status": r.status, "t_end": float(r.time[-1]) if r.time.size else 0.0}
    u = np.asarray(r.u_cmd, dtype=float)
    out["peak_u"] = float(np.nanmax(np.abs(u))) if u.size else math.nan
    if not done:
        out.update(err=math.nan, fast=math.nan, at_rate=math.nan, pp=math.nan)
        return out
    sel = (r.time >= t0) & (r.time <= t1)
    out["err"] = float(np.max(r.rms_error(t0, t1)))
    fs = 1.0 / float(np.median(np.diff(r.time)))
    sos = butter(2, 1.0, fs=fs, output="sos")
    fast, pp = 0.0, 0.0
    for j in range(u.shape[1]):
        hi = u[:, j] - sosfiltfilt(sos, u[:, j])
        fast = max(fast, float(np.sqrt(np.mean(hi[sel] ** 2))))
        pp = max(pp, float(np.ptp(u[sel, j])))
    out["fast"], out["pp"] = fast, pp
    at_rate = 0.0
    acts = loop.actuators
    if acts is not None and acts.rate is not None:
        rates = np.broadcast_to(np.asarray(acts.rate, dtype=float), (u.shape[1],))
        names = [f"position of {a}" for a in loop.plant.actuator_names]
        for j, name in enumerate(names):
            if not math.isfinite(rates[j]) or name not in r.adaptive_names:
                continue
            a = r.adaptive_state(name)
            da = np.gradient(a, r.time)
            at_rate = max(at_rate, float(np.mean(np.abs(da[sel]) >= 0.98 * rates[j])))
    out["at_rate"] = at_rate
    return out


def verdict(m, thr, fast_max, travel, peak_max):
    """'ok' or the list of failed targets."""
    if m["status"] != "completed" or not math.isfinite(m["err"]):
        return f"DIVERGED at {m['t_end']:.2f} s"
    bad = []
    if not m["err"] <= thr:
        bad.append("error")
    if not m["fast"] <= fast_max:
        bad.append("fast")
    lim = travel if math.isfinite(travel) else peak_max
    if not m["peak_u"] <= lim * (1 + 1e-9):
        bad.append("peak")
    if not m["at_rate"] <= 0.05:
        bad.append("rate")
    return "ok" if not bad else "FAIL " + ",".join(bad)


def oracle_yardstick(m, thr, fast_max, travel, peak_max) -> tuple[float, str]:
    """The case's error target from the oracle's metrics ``m`` and the oracle row's verdict.

    ``max(thr, 2 x the oracle's error)`` with the verdict ``"yardstick"`` only where the
    oracle's run is acceptable by the laws' own targets (completed; fast content, peak and
    time at a rate limit within them), its error at most ``ORACLE_LOST_FACTOR`` x ``thr``.
    Otherwise ``thr`` alone, and ``"INFEASIBLE-BY-ORACLE (why)"``: the oracle diverged, lost
    the task (error more than 10 thresholds) or tracks only with an unacceptable command."""
    v = verdict(m, ORACLE_LOST_FACTOR * thr, fast_max, travel, peak_max)
    if v == "ok":
        return max(thr, 2.0 * m["err"]), "yardstick"
    if v.startswith("DIVERGED"):
        why = v.lower()
    else:
        words = {
            "error": f"lost: error {m['err'] / thr:.3g}x the threshold",
            "fast": "its command chatters",
            "peak": "its command leaves the peak bound",
            "rate": "at a rate limit",
        }
        why = ", ".join(words[p] for p in v.removeprefix("FAIL ").split(","))
    return thr, f"{INFEASIBLE} ({why})"


def run_cases(
    scenario: str,
    cases=HYPERSONIC_CASES,
    duration=None,
    laws=("thesis", "aware"),
    with_oracle: bool = True,
    only: str | None = None,
    noise_seed: int = 0,
):
    """Rows of the table (dicts), the ideal run first; per case the oracle's row (with
    ``with_oracle``), then one row per law; ``noise_seed``: the noisy cases' sensor seed."""
    sc = load_scenario(scenario)
    claim = next(c for c in sc.claims if c.get("kind") == "tracking")
    thr = float(claim["threshold"])
    span = duration or (sc.loop.t_final - sc.loop.t0)
    width = float(claim.get("window", 20.0))  # the thesis claim's final window
    full = (sc.loop.t0 + span - width, sc.loop.t0 + span)
    loop, solver = case_loop(sc, Case("ideal"), duration)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        ideal_run = simulate(loop, solver)
    window = final_window(full[1], width, ideal_run.failure_times)
    # the fast-content threshold: 3 % of the ideal command's peak to peak over the whole
    # final window (the step a failure event in it demands included)
    ideal = metrics(ideal_run, loop, full)
    ideal.update({k: v for k, v in metrics(ideal_run, loop, window).items() if k != "pp"})
    if cases is None:
        cases = cases_from_ideal(sc, ideal_run)
        if only is not None:
            cases = tuple(c for c in cases if only in c.name)
    fast_max = 0.03 * ideal["pp"]
    peak_max = 10.0 * ideal["peak_u"]
    rows = [{"case": "ideal", "law": "thesis", **ideal, "verdict": "-"}]
    for case in cases:
        case_thr = thr
        if with_oracle:
            loop, solver = case_loop(sc, case, duration, noise_seed)
            loop = oracle(constraint_aware(loop, solver))
            t = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", DivergenceWarning)
                r = simulate(loop, baseline_solver("oracle", solver))
            m = metrics(r, loop, window)
            m["cpu"] = time.perf_counter() - t
            case_thr, note = oracle_yardstick(m, thr, fast_max, case.travel, peak_max)
            rows.append({"case": case.name, "law": "oracle", **m, "verdict": note})
            print(_line(rows[-1]), flush=True)
        for law in laws:
            loop, solver = case_loop(sc, case, duration, noise_seed)
            if law == "aware":
                loop = constraint_aware(loop, solver)
            t = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", DivergenceWarning)
                r = simulate(loop, solver)
            m = metrics(r, loop, window)
            m["cpu"] = time.perf_counter() - t
            v = verdict(m, case_thr, fast_max, case.travel, peak_max)
            rows.append({"case": case.name, "law": law, **m, "target": case_thr, "verdict": v})
            print(_line(rows[-1]), flush=True)
    return rows, {"threshold": thr, "fast_max": fast_max, "peak_max": peak_max, **ideal}


def _line(row) -> str:
    return (
        f"| {row['case']} | {row['law']} | {row['err']:.2e} | {row['fast']:.2e} | "
        f"{row['peak_u']:.3g} | {row.get('at_rate', math.nan):.3f} | {row['verdict']} |"
    )


def plot_cases(rows, ideal, title: str = ""):
    """The success region of each law: per case, the final-window error over the error target
    the law was held to (``target``) against the fast content over its target, log axes; the
    acceptable box (both <= 1) shaded. Filled: acceptable ("ok"); hollow: a target missed
    (peak and rate included). Points are numbered by case; the list on the right names the
    cases and the laws that diverged there (no point: no final window)."""
    import matplotlib.patches as mpatches

    from adaptive_ftc.plots import figure_style, new_figure, wrap_title

    style = {
        "thesis": ("#c0392b", "s", "thesis law"),
        "aware": ("#1f6fb4", "o", "constraint-aware"),
    }
    judged = [r for r in rows if r["case"] != "ideal" and r["law"] != "oracle"]
    cases = list(dict.fromkeys(r["case"] for r in judged))
    fast_max = ideal["fast_max"]
    points, diverged = [], {c: [] for c in cases}
    for r in judged:
        if not math.isfinite(r["err"]):
            name = style.get(r["law"], ("", "", r["law"]))[2]
            diverged[r["case"]].append(f"{name} diverges at {r['t_end']:.3g} s")
            continue
        x = max(r["fast"] / fast_max, 1e-6)
        y = max(r["err"] / r.get("target", ideal["threshold"]), 1e-6)
        points.append((r["law"], cases.index(r["case"]) + 1, x, y, r["verdict"] == "ok"))
    xs = [p[2] for p in points] or [1.0]
    ys = [p[3] for p in points] or [1.0]
    lo_x, hi_x = min(min(xs) / 3, 0.1), max(max(xs) * 3, 10.0)
    lo_y, hi_y = min(min(ys) / 3, 0.1), max(max(ys) * 3, 10.0)
    with figure_style():
        fig = new_figure(9.5, 5.2)
        ax = fig.add_subplot(1, 1, 1)
        ax.add_patch(
            mpatches.Rectangle((lo_x, lo_y), 1 - lo_x, 1 - lo_y, color="#2e8b57", alpha=0.12, lw=0)
        )
        labelled = set()
        for law, k, x, y, ok in points:
            color, marker, label = style.get(law, ("#555555", "^", law))
            ax.scatter(
                [x],
                [y],
                s=36,
                marker=marker,
                facecolors=color if ok else "none",
                edgecolors=color,
                label=None if law in labelled else label,
                zorder=3,
            )
            labelled.add(law)
            ax.annotate(
                str(k), (x, y), fontsize=7, xytext=(4, 3), textcoords="offset points", color=color
            )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(lo_x, hi_x)
        ax.set_ylim(lo_y, hi_y)
        ax.axhline(1.0, color="#2e8b57", lw=0.8)
        ax.axvline(1.0, color="#2e8b57", lw=0.8)
        ax.set_xlabel(f"fast command content / target ({fast_max:.2g}, 3 % of the ideal p-p)")
        ax.set_ylabel("final-window RMS error / error target")
        if labelled:
            ax.legend(loc="upper left", fontsize=8, title="filled: acceptable", title_fontsize=8)
        lines = []
        for i, c in enumerate(cases):
            lines.append(f"{i + 1}  {c}")
            lines += [f"     {d}" for d in diverged[c]]
        ax.text(
            1.02, 1.0, "\n".join(lines), transform=ax.transAxes, va="top", ha="left", fontsize=7
        )
        if title:
            fig.suptitle(wrap_title(title, 9.5))
    return fig


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenario", nargs="?", default="hypersonic-direct-s1")
    ap.add_argument("--duration", type=float, default=None)
    ap.add_argument("--only", default=None, help="substring of the case names to run")
    ap.add_argument("--laws", default="thesis,aware")
    ap.add_argument("--no-oracle", action="store_true", help="do not run the oracle")
    ap.add_argument(
        "--noise-seed",
        type=int,
        default=0,
        help="the seed of the noisy cases' sensor draws (Sensors(seed=...); default 0)",
    )
    ap.add_argument(
        "--ideal-cases",
        action="store_true",
        help="the cases of issue 25 (c), sized from the ideal run, instead of the hypersonic set",
    )
    ap.add_argument(
        "--figure",
        default=None,
        help="also draw the success region of each law to this file (.png or .pdf)",
    )
    args = ap.parse_args(argv)
    cases = [c for c in HYPERSONIC_CASES if args.only is None or args.only in c.name]
    if args.ideal_cases:
        cases = None
    print("| case | law | error (rad) | fast (rad) | peak |u| | at rate | verdict |")
    print("|---|---|---|---|---|---|---|")
    rows, ideal = run_cases(
        args.scenario,
        cases,
        args.duration,
        tuple(args.laws.split(",")),
        with_oracle=not args.no_oracle,
        only=args.only,
        noise_seed=args.noise_seed,
    )
    print(
        f"ideal: error {ideal['err']:.2e}, command p-p {ideal['pp']:.3g}, "
        f"peak {ideal['peak_u']:.3g}; "
        f"targets: error <= max({ideal['threshold']:.2e}, 2x oracle; the oracle counts only "
        f"where it is acceptable with an error <= {ORACLE_LOST_FACTOR:g}x the threshold, "
        f"else {INFEASIBLE} and the threshold alone), "
        f"fast <= {ideal['fast_max']:.2e}, "
        f"peak <= travel or {ideal['peak_max']:.3g}, at rate <= 5 %"
    )
    if args.figure:
        from adaptive_ftc.plots import figure_style

        fig = plot_cases(rows, ideal, f"{args.scenario}: thesis law and constraint-aware law")
        with figure_style():
            fig.savefig(args.figure)
        print(f"wrote {args.figure}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
