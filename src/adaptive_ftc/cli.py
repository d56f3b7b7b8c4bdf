"""The ``aftc`` command-line tool: list, validate and run scenarios; reproduce the thesis."""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from dataclasses import replace
from pathlib import Path

from adaptive_ftc._version import __version__
from adaptive_ftc.errors import (
    ConfigurationError,
    DivergenceWarning,
    ExpressionError,
    ScenarioError,
)

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="aftc",
        description="Adaptive actuator-failure compensation: run the thesis scenarios and your "
        "own scenario files.",
    )
    p.add_argument("--version", action="version", version=f"adaptive-ftc {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list the thesis scenarios with their figures")
    v = sub.add_parser("validate", help="check a scenario file (and its compensability)")
    v.add_argument("scenario", help="scenario name or path to a .toml file")
    r = sub.add_parser("run", help="run one scenario; write data and figures")
    r.add_argument("scenario", help="scenario name or path to a .toml file")
    r.add_argument("--out", default="out", help="output folder (default: ./out)")
    r.add_argument("--method", choices=["rk4", "accurate"], help="override the solver")
    r.add_argument("--dt", type=float, help="override the fixed step")
    r.add_argument(
        "--no-baselines",
        action="store_true",
        help="skip the frozen-adaptation and failure-free comparison runs",
    )
    r.add_argument("--csv", action="store_true", help="also write CSV tables")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    rep = sub.add_parser("reproduce", help="reproduce every figure of the thesis with a report")
    rep.add_argument("--out", default="reproduction", help="output folder")
    rep.add_argument("--quick", action="store_true", help="shortened runs (for CI)")
    rep.add_argument("--jobs", type=int, default=None, help="parallel processes")
    rep.add_argument("--quiet", action="store_true", help="no progress bar")
    from adaptive_ftc.campaigns import cli as campaign_cli

    campaign_cli.add_parser(sub)
    return p


def _cmd_list() -> int:
    from adaptive_ftc.scenarios.loader import list_scenarios, load_scenario

    rows = []
    for name in list_scenarios():
        sc = load_scenario(name)
        rows.append((name, f"§{sc.section}" if sc.section else "", ", ".join(sc.figures), sc.title))
    w0 = max([len(r[0]) for r in rows] + [8])
    w2 = max([len(r[2]) for r in rows] + [7])
    print(f"{'scenario':<{w0}}  {'thesis':<7}  {'figures':<{w2}}  title")
    for name, sec, figs, title in rows:
        print(f"{name:<{w0}}  {sec:<7}  {figs:<{w2}}  {title}")
    return 0


def _cmd_validate(target: str) -> int:
    from adaptive_ftc.scenarios.loader import load_scenario

    sc = load_scenario(target)
    loop = sc.loop
    print(
        f"{sc.name}: OK ({loop.plant.name} plant, '{loop.controller.design}' design, "
        f"{loop.t_final:g} s, {len(loop.failures.failures)} failure(s))"
    )
    for line in loop.describe_failures():
        print(f"  failure {line}")
    report = loop.compensability()
    print("compensability (rank condition (3.6), one effective actuator per output):")
    for line in report.describe(loop.plant.output_names).splitlines():
        print(f"  {line}")
    if not report.ok:
        print(
            f"{sc.name}: WARNING - some intervals are not compensable; the thesis's "
            "guarantees do not hold there."
        )
        return 1
    return 0


def _cmd_run(args: argparse.Namespace) -> int:
    from tqdm.auto import tqdm

    from adaptive_ftc.scenarios.loader import load_scenario
    from adaptive_ftc.sim.engine import simulate

    sc = load_scenario(args.scenario)  # validate everything before touching the output folder
    from adaptive_ftc import plots

    solver = sc.solver
    if args.method:
        solver = replace(solver, method=args.method)
    if args.dt:
        solver = replace(solver, dt=args.dt)
    out = Path(args.out)
    (out / "data").mkdir(parents=True, exist_ok=True)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    variants = {"adaptive": sc.loop}
    if not args.no_baselines:
        variants["frozen"] = sc.loop.frozen()
        variants["failure_free"] = sc.loop.without_failures()
    results = {}
    with warnings.catch_warnings():
        # divergence is reported below from each result's status (a frozen baseline is
        # expected to diverge under some failures)
        warnings.simplefilter("ignore", DivergenceWarning)
        for key, loop in tqdm(
            variants.items(), desc=sc.name, disable=args.quiet, total=len(variants)
        ):
            results[key] = simulate(loop, solver)
    if results["adaptive"].message:
        print(f"warning: {results['adaptive'].message}", file=sys.stderr)
    summary = {}
    for key, res in results.items():
        stem = sc.name if key == "adaptive" else f"{sc.name}_{key}"
        res.meta["scenario"] = sc.name
        res.to_netcdf(out / "data" / f"{stem}.nc")
        if args.csv:
            res.to_csv(out / "data" / f"{stem}.csv")
        summary[key] = res.metrics()
    main = results["adaptive"]
    baselines = {k.replace("_", " "): v for k, v in results.items() if k != "adaptive"}
    specs = list(sc.figure_specs) or plots.default_figure_specs(main)
    figures = []
    for i, spec in enumerate(specs):
        path = out / "figures" / f"fig_{spec.get('number', i + 1)}.png"
        figures.append(str(plots.save_figure(main, spec, path, baselines=baselines or None)))
    (out / "metrics.json").write_text(
        json.dumps(
            {"scenario": sc.name, "runs": summary, "recovery": main.recovery(), "figures": figures},
            indent=2,
            default=float,
        )
    )
    m = summary["adaptive"]
    print(
        f"{sc.name}: {main.status}; RMS error {m['rms_error']:.3g}, last "
        f"{m['final_window_s']:.3g} s {m['rms_error_final']:.3g}; peak command "
        f"{m['peak_command']:.3g}"
    )
    for key in ("frozen", "failure_free"):
        if key in summary:
            b = summary[key]
            print(
                f"  {key.replace('_', '-')}: {results[key].status}; last-window RMS error "
                f"{b['rms_error_final']:.3g}"
                + (
                    f" (stopped at t = {b['t_end']:.4g} s)"
                    if results[key].status != "completed"
                    else ""
                )
            )
    print(f"wrote {len(figures)} figure(s) and {len(results)} dataset(s) to {out}")
    return 0 if main.status == "completed" else 3


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from adaptive_ftc.reproduce import run_reproduction

    summary = run_reproduction(args.out, quick=args.quick, jobs=args.jobs, progress=not args.quiet)
    print(
        f"reproduced {summary['n_scenarios']} scenarios in {summary['wall_time_s']:.1f} s: "
        f"{summary['n_pass']}/{summary['n_claims']} thesis claims PASS; report: "
        f"{summary['report']}"
    )
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``aftc``; returns the exit status."""
    args = _parser().parse_args(argv)
    try:
        if args.command == "list":
            return _cmd_list()
        if args.command == "validate":
            return _cmd_validate(args.scenario)
        if args.command == "run":
            return _cmd_run(args)
        if args.command == "campaign":
            from adaptive_ftc.campaigns import cli as campaign_cli

            return campaign_cli.main(args)
        return _cmd_reproduce(args)
    except (ScenarioError, ConfigurationError, ExpressionError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # pragma: no cover
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
