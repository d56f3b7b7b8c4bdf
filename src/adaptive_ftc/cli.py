"""The ``aftc`` command-line tool: list, validate and run scenarios; reproduce the thesis.

Exit status (also in ``aftc --help`` and the README):

====  ===========================================================================
0     success
1     internal error (a bug: please report it with the command line)
2     invalid input: scenario file, command-line argument, output folder
3     the run stopped early: diverged, nonfinite, step_underflow or singular (``aftc run``;
      the message says why, see docs/statuses.md)
4     claims failed (``aftc run``: the scenario's ``[[claims]]``; ``aftc reproduce``: the
      thesis claims), or some runs raised errors (``aftc reproduce``); a claim marked as an
      expected ``finding`` that the data show is reported as FINDING, not as a failure
5     not compensable: the failures break the rank (3.6) or sign (2.16)/(4.6)
      conditions of the design (``aftc validate``)
130   interrupted (Ctrl-C or SIGTERM); earlier complete results are kept
====  ===========================================================================

Every file is written to a staging folder inside ``--out`` and moved into place only when the
command has finished, each with an atomic rename, so a failed or interrupted command leaves
the earlier complete results untouched.
"""

from __future__ import annotations

import argparse
import json
import math
import signal
import sys
import warnings
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path

from adaptive_ftc._version import __version__
from adaptive_ftc.errors import (
    ConfigurationError,
    DivergenceWarning,
    ExpressionError,
    ScenarioError,
)

__all__ = [
    "EXIT_CLAIMS_FAILED",
    "EXIT_DIVERGED",
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_INVALID",
    "EXIT_NOT_COMPENSABLE",
    "EXIT_OK",
    "main",
]

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_INVALID = 2
EXIT_DIVERGED = 3
EXIT_CLAIMS_FAILED = 4
EXIT_NOT_COMPENSABLE = 5
EXIT_INTERRUPTED = 130

_EPILOG = """exit status:
  0    success
  1    internal error (a bug: please report it with the command line)
  2    invalid input (scenario file, argument, output folder)
  3    the run stopped early: diverged, nonfinite, step_underflow, singular (run)
  4    claims failed (run, reproduce) or runs raised errors (reproduce); FINDING is not a
       failure
  5    not compensable: rank (3.6) or sign (2.16)/(4.6) conditions fail (validate)
  130  interrupted (Ctrl-C, SIGTERM); earlier complete results are kept
"""


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, got {text!r}")
    return value


def _count(low: int, high: int):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"expected {low}..{high}, got {value}")
        return value

    return parse


class _HelpFormatter(argparse.HelpFormatter):
    """Wraps a one-paragraph text (a description) to the terminal; keeps a text of several
    lines (the exit-status table of an epilog) line by line."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        if "\n" in text.strip():
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)


def _solver_methods() -> tuple[str, ...]:
    """Every method name :class:`~adaptive_ftc.SolverOptions` accepts."""
    from adaptive_ftc.sim import solvers

    return solvers.names()


class _Deferred(Sequence):
    """A sequence of choices read on first use (``load``): building the parser, ``aftc --help``
    and an error in another argument then import nothing heavy (the registry imports the
    engine and numpy); argparse reads the choices only to check a value or to print the
    ``%(choices)s`` of a help text."""

    def __init__(self, load: Callable[[], Sequence[str]]) -> None:
        self._load = load
        self._items: tuple[str, ...] | None = None

    def _get(self) -> tuple[str, ...]:
        if self._items is None:
            self._items = tuple(self._load())
        return self._items

    def __getitem__(self, index):
        return self._get()[index]

    def __len__(self) -> int:
        return len(self._get())

    def __contains__(self, value) -> bool:
        return value in self._get()

    def __iter__(self):
        return iter(self._get())


def _add_figure_options(parser: argparse.ArgumentParser, default: str) -> None:
    parser.add_argument(
        "--formats",
        default=None,
        help=f"figure formats, comma-separated (png, pdf, svg; default {default})",
    )
    parser.add_argument("--dpi", type=_count(30, 1200), default=None, help="PNG resolution")


def _formats(text: str) -> tuple[str, ...]:
    formats = tuple(f.strip().lower() for f in text.split(",") if f.strip())
    bad = [f for f in formats if f not in ("png", "pdf", "svg")]
    if bad or not formats:
        raise ConfigurationError(
            f"--formats: unknown figure format(s) {', '.join(bad) or '(none)'}; use png, pdf, svg."
        )
    return formats


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="aftc",
        description="Adaptive actuator-failure compensation: run the thesis scenarios and your "
        "own scenario files.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--version", action="version", version=f"adaptive-ftc {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    raw = _HelpFormatter  # keeps the exit-status epilog's lines, wraps the descriptions
    ls = sub.add_parser(
        "list",
        help="list the thesis scenarios with their figures",
        description="List the catalogue scenarios: name, thesis section, figures and title "
        "(fits 100 columns; --long: every figure, the full title, plant, design, duration).",
        epilog=_EPILOG,
        formatter_class=raw,
    )
    ls.add_argument("--long", action="store_true", help="full titles and details")
    v = sub.add_parser(
        "validate",
        help="check a scenario file (and its compensability)",
        description="Load a scenario (catalogue name or .toml file), report every problem of "
        "the file at once, and check that its failures leave the design compensable: the rank "
        "condition (3.6) and, for designs that assume it, the known sign (2.16)/(4.6).",
        epilog=_EPILOG,
        formatter_class=raw,
    )
    v.add_argument("scenario", help="scenario name or path to a .toml file")
    r = sub.add_parser(
        "run",
        help="run one scenario; write data and figures",
        description="Run one scenario (catalogue name or .toml file) with its baselines "
        "(frozen adaptation, failure-free, and the fair fixed-gain, nominal-inverse and oracle "
        "designs), write data/*.nc, figures/, metrics.json and, when the file has "
        "[[claims]], claims.csv; exit by the claims as 'aftc reproduce' does.",
        epilog=_EPILOG,
        formatter_class=raw,
    )
    r.add_argument("scenario", help="scenario name or path to a .toml file")
    r.add_argument("--out", default="out", help="output folder (default: ./out)")
    r.add_argument(
        "--method",
        choices=_Deferred(_solver_methods),
        metavar="METHOD",
        help="override the solver: %(choices)s (docs/solvers.md)",
    )
    r.add_argument(
        "--dt",
        type=_positive_float,
        help="override the step of the fixed-step rk4 method (s); an error with an "
        "adaptive-step method, whose step is set by its tolerances",
    )
    r.add_argument(
        "--t-final",
        type=_positive_float,
        metavar="SECONDS",
        help="end the run at this time instead of the scenario's t_final (e.g. a quick check)",
    )
    r.add_argument(
        "--no-baselines",
        action="store_true",
        help="skip the frozen-adaptation, failure-free and baseline comparison runs (a "
        "constraint-aware scenario still runs the thesis law beside it: its claims name what "
        "it fails)",
    )
    r.add_argument("--csv", action="store_true", help="also write CSV tables")
    r.add_argument(
        "--no-figures",
        action="store_true",
        help="write no figures (the data files, metrics.json and claims.csv only; faster: "
        "matplotlib is not loaded)",
    )
    r.add_argument("--float32", action="store_true", help="store the data in single precision")
    r.add_argument(
        "--decimate",
        type=_count(1, 1_000_000),
        default=1,
        help="keep every K-th recorded sample in the data files (default 1: all)",
    )
    _add_figure_options(r, "png")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    rep = sub.add_parser(
        "reproduce",
        help="reproduce every figure of the thesis with a report",
        description="Run the thesis scenarios (all, or the NAMEs given) with their baselines, "
        "write figures/, data/, metrics.csv, claims.csv and report.html, and judge every "
        "[[claims]] table of the catalogue.",
        epilog=_EPILOG,
        formatter_class=raw,
    )
    rep.add_argument(
        "names",
        nargs="*",
        metavar="NAME",
        help="scenarios to reproduce (default: the whole catalogue; see 'aftc list')",
    )
    rep.add_argument("--out", default="reproduction", help="output folder")
    rep.add_argument(
        "--quick",
        action="store_true",
        help="judge the claims fast: only the runs the claims are judged on, at full length "
        "(so the verdicts are a full reproduction's), no data files, no figures, no thesis-law "
        "companion runs; the report and the summary list what it left out",
    )
    rep.add_argument("--jobs", type=_count(1, 1024), default=None, help="parallel processes")
    rep.add_argument("--quiet", action="store_true", help="no progress bar")
    rep.add_argument(
        "--baselines",
        action="store_true",
        help="overlay the frozen-adaptation and failure-free runs on the figures",
    )
    rep.add_argument(
        "--no-fair-baselines",
        action="store_true",
        help="skip the fixed-gain, nominal-inverse and oracle runs (faster; baseline_ratio "
        "claims are then held against the frozen run alone, an unfair comparison)",
    )
    _add_figure_options(rep, "png,pdf; --quick draws none")
    s = sub.add_parser(
        "schema",
        help="print the JSON Schema of scenario files (for editors)",
        description="Print (or write with --out) the JSON Schema of scenario .toml files, for "
        "editors that complete and check TOML against a schema.",
        epilog=_EPILOG,
        formatter_class=raw,
    )
    rep.add_argument(
        "--float32",
        action="store_true",
        help="store the data files in single precision (default: double, so that metrics "
        "recomputed from them equal metrics.csv; the choice is recorded in the files and report)",
    )
    rep.add_argument(
        "--decimate",
        type=_count(1, 1_000_000),
        default=1,
        help="keep every K-th recorded sample in the data files (default 1: all)",
    )
    s.add_argument("--out", help="write it to this file instead of printing it")
    try:
        from adaptive_ftc.campaigns import cli as campaign_cli
    except ImportError:  # pragma: no cover - campaigns not installed
        pass
    else:
        campaign_cli.add_parser(sub, formatter_class=raw)
    from adaptive_ftc import study_cli

    st = study_cli.add_parser(sub)
    st.epilog, st.formatter_class = _EPILOG, raw  # the same exit status as every command
    from adaptive_ftc.export import cli as export_cli

    export_cli.add_parser(sub, epilog=_EPILOG, formatter_class=raw)
    return p


#: Width of ``aftc list`` (without ``--long``): a terminal of 100 columns
LIST_WIDTH = 100


def _figure_ranges(figures) -> str:
    """``3.9, 3.10, 3.11`` -> ``3.9-3.11``: three or more consecutive figures of one chapter
    as a range (two stay a pair: ``2.1, 2.2``)."""
    parts: list[list[str]] = []
    for f in figures:
        chap, _, num = str(f).partition(".")
        if parts and num.isdigit():
            last = parts[-1][-1]
            lchap, _, lnum = last.partition(".")
            if lchap == chap and lnum.isdigit() and int(lnum) + 1 == int(num):
                parts[-1].append(str(f))
                continue
        parts.append([str(f)])
    return ", ".join(", ".join(p) if len(p) < 3 else f"{p[0]}-{p[-1]}" for p in parts)


def _cmd_list(long: bool = False) -> int:
    from adaptive_ftc.scenarios.loader import list_scenarios, load_scenario

    scenarios = [load_scenario(name) for name in list_scenarios()]
    if long:
        for sc in scenarios:
            loop = sc.loop
            print(f"{sc.name}  (§{sc.section})" if sc.section else sc.name)
            print(f"  {sc.title}")
            if sc.figures:
                print(f"  thesis figures: {', '.join(sc.figures)}")
            print(
                f"  {loop.plant.name} plant, '{loop.controller.design}' design, "
                f"{loop.t_final:g} s, {len(loop.failures.failures)} failure(s), "
                f"solver {sc.solver.method}"
            )
        return EXIT_OK
    rows = [
        (sc.name, f"§{sc.section}" if sc.section else "", _figure_ranges(sc.figures), sc.title)
        for sc in scenarios
    ]
    w0 = max([len(r[0]) for r in rows] + [8])
    w1 = max([len(r[1]) for r in rows] + [6])
    w2 = max([len(r[2]) for r in rows] + [7])
    room = max(10, LIST_WIDTH - (w0 + w1 + w2 + 6))
    print(f"{'scenario':<{w0}}  {'thesis':<{w1}}  {'figures':<{w2}}  title")
    for name, sec, figs, title in rows:
        title = title if len(title) <= room else title[: room - 3].rstrip() + "..."
        print(f"{name:<{w0}}  {sec:<{w1}}  {figs:<{w2}}  {title}")
    print("(full titles and details: aftc list --long)")
    return EXIT_OK


def _cmd_validate(target: str) -> int:
    from adaptive_ftc.scenarios.loader import load_scenario
    from adaptive_ftc.sim.budget import estimate_run_size

    sc = load_scenario(target)
    loop = sc.loop
    size = estimate_run_size(loop, sc.solver)
    print(
        f"{sc.name}: OK ({loop.plant.name} plant, '{loop.controller.design}' design, "
        f"{loop.t_final:g} s, {len(loop.failures.failures)} failure(s); {size.describe()})"
    )
    for line in loop.describe_failures():
        print(f"  failure {line}")
    design = loop.controller.design
    known_sign = loop.known_sign
    report = loop.compensability(design=True)
    conditions = "rank condition (3.6), one effective actuator per output"
    if known_sign:
        conditions += f"; sign conditions (2.16)/(4.6): '{design}' assumes a known direction"
    print(f"compensability ({conditions}):")
    for line in report.describe(loop.plant.output_names).splitlines():
        print(f"  {line}")
    if loop.describe_failures():  # issue 31: which axes the working actuators still reach
        from adaptive_ftc.allocation import reachability_timeline

        print("reachability (allocation matrix R without the lost actuators, per event):")
        for event in reachability_timeline(loop):
            print(f"  {event.describe()}")
    for j in report.dead_actuators:  # a warning: the others may still compensate
        print(
            f"warning: actuator {j + 1} ({loop.plant.actuator_names[j]}) is never effective "
            f"from {loop.t0:g} s to {loop.t_final:g} s (its failures leave no dependence on "
            "its command): it never contributes. Remove its failure or give it a later onset "
            "if that is not intended."
        )
    if not report.ok:
        print(
            f"{sc.name}: NOT COMPENSABLE - some intervals break the conditions above; the "
            "thesis's guarantees do not hold there."
        )
        return EXIT_NOT_COMPENSABLE
    return EXIT_OK


def _n_values(result) -> int:
    """How many numbers a run recorded (the size of its data file, for the ETA)."""
    import numpy as np

    return sum(int(v.size) for v in vars(result).values() if isinstance(v, np.ndarray) and v.ndim)


def _cmd_run(args: argparse.Namespace) -> int:
    from adaptive_ftc._atomic import check_output_dir
    from adaptive_ftc.scenarios.loader import load_scenario
    from adaptive_ftc.sim.budget import check_run_size

    sc = load_scenario(args.scenario)  # validate everything before touching the output folder
    if args.t_final is not None:  # ClosedLoop checks it (after t0)
        if args.t_final < sc.loop.t_final and sc.claims:
            # the claims hold for the whole run (final windows, recovery after each failure)
            print(
                f"note: --t-final {args.t_final:g} s shortens the run ({sc.name} lasts "
                f"{sc.loop.t_final:g} s): its {len(sc.claims)} claim(s) are not judged.",
                file=sys.stderr,
            )
            sc = replace(sc, claims=())
        sc = replace(sc, loop=replace(sc.loop, t_final=args.t_final))
    solver = sc.solver
    if args.method:
        solver = replace(solver, method=args.method)
    if args.dt:
        if solver.compiled_method != "rk4":
            raise ConfigurationError(
                f"--dt {args.dt:g}: '{sc.name}' runs the adaptive-step method "
                f"'{solver.method}', whose step is chosen by its tolerances (rtol "
                f"{solver.rtol:g}), so a fixed step would be ignored. Add --method rk4 to run "
                "fixed steps of --dt, or set max_step in the scenario's [solver] table to "
                "bound the adaptive step."
            )
        solver = replace(solver, dt=args.dt)
    formats = _formats(args.formats or "png")
    check_run_size(sc.loop, solver)
    out = check_output_dir(args.out)
    figure_process = None
    if not args.no_figures:
        from adaptive_ftc._figure_process import FigureProcess

        # forked before any thread starts: its matplotlib loads while the loops run here
        figure_process = FigureProcess.start()
    try:
        return _run_and_write(args, sc, solver, out, formats, figure_process)
    finally:
        if figure_process is not None:
            figure_process.close()


def _compile_first(args, sc, solver, fair: bool) -> None:
    """What a first run compiles, before the runs: the line that says so (unless
    ``--quiet``), then the compiles themselves on two cores where possible (the shared
    integrators in a second process, the structures here: sim/precompile.py)."""
    from adaptive_ftc._feedback import compile_line, compile_plan, shared_compiled

    loops = [sc.loop]
    if not args.no_baselines:
        loops += [sc.loop.frozen(), sc.loop.without_failures()]
    if fair:
        from adaptive_ftc.baselines import nominal_inverse, oracle

        for make in (nominal_inverse, oracle):  # fixed-gain: the scenario's structure
            try:
                loops.append(make(sc.loop))
            except ConfigurationError:
                pass  # no such baseline: reported below
    if getattr(sc.loop.controller, "constraint_aware", None) is not None:
        from adaptive_ftc.reproduce import thesis_law_loop

        loops.append(thesis_law_loop(sc.loop))  # the thesis law's companion run
    n_new, seconds = compile_plan((loop, solver.sdot_for(loop)) for loop in loops)
    if not n_new and shared_compiled():
        return
    from adaptive_ftc.sim.precompile import SharedCompile, overlapped

    if n_new and not args.quiet:
        jobs = 2 if SharedCompile.available() else 1
        print(compile_line(n_new, seconds, jobs), file=sys.stderr, flush=True)

    overlapped([(loop, solver) for loop in loops])


def _run_and_write(args, sc, solver, out: Path, formats: tuple[str, ...], figure_process) -> int:
    """The runs of ``aftc run`` and their files (figures drawn by ``figure_process`` when it
    is not ``None``, beside the data files)."""
    from adaptive_ftc import plots
    from adaptive_ftc._atomic import commit_staged, discard_staged, inside, safe_stem, staging_dir
    from adaptive_ftc._feedback import EtaBar, figure_cost, write_cost
    from adaptive_ftc.sim.engine import simulate

    fair = (
        not args.no_baselines
        and sc.loop.adapt
        and sc.loop.controller.design not in ("nominal-inverse", "oracle")
    )
    # before the fixed-gain baseline's tuning run compiles the loop: what the runs compile
    _compile_first(args, sc, solver, fair)
    variants = {"adaptive": sc.loop}
    if not args.no_baselines:
        variants["frozen"] = sc.loop.frozen()
        variants["failure_free"] = sc.loop.without_failures()
        if fair:
            from adaptive_ftc.baselines import baseline_loop

            for name in ("fixed-gain", "nominal-inverse", "oracle"):  # the fair baselines
                try:
                    variants[name.replace("-", "_")] = baseline_loop(sc.loop, name, solver)
                except ConfigurationError as exc:  # e.g. no healthy run to tune on
                    print(f"note: no {name} baseline: {exc}", file=sys.stderr)
    if getattr(sc.loop.controller, "constraint_aware", None) is not None:
        from adaptive_ftc.reproduce import thesis_law_loop

        # the thesis law beside the constraint-aware design, judged on the same claims (also
        # with --no-baselines: the scenario's claims name what it fails)
        variants["thesis_law"] = thesis_law_loop(sc.loop)
    stage = staging_dir(out)
    try:
        results = {}
        with warnings.catch_warnings():
            # divergence is reported below from each result's status (a frozen baseline is
            # expected to diverge under some failures)
            warnings.simplefilter("ignore", DivergenceWarning)
            # the runs the figures show first: the figures are drawn beside the others
            drawn = [k for k in variants if k in ("adaptive", *_OVERLAID)]
            rest = [k for k in variants if k not in drawn]
            # the runs are alike (one scenario, one duration): the ETA counts them as equals
            with EtaBar(len(variants), desc=sc.name, disable=args.quiet, unit="run") as bar:
                for key in drawn:
                    # Ctrl-C inside the compiled loop raises SimulationInterrupted (exit 130)
                    results[key] = sc.stamp(simulate(variants[key], solver))
                    bar.tick()
                main = results["adaptive"]
                specs = (
                    list(sc.figure_specs) or plots.default_figure_specs(main)
                    if main.time.size and not args.no_figures
                    else []
                )
                baselines = {
                    k.replace("_", " "): v
                    for k, v in results.items()
                    # a run with no samples: none
                    if k in _OVERLAID and v.time.size
                }
                names = [f"fig_{spec.get('number', i + 1)}.png" for i, spec in enumerate(specs)]
                jobs = [
                    # the direction figures' zoom window is re-run densely here (it simulates)
                    {
                        "spec": spec,
                        "path": stage / "figures" / name,
                        "zoom": plots.dense_zoom(sc, main, spec, solver),
                    }
                    for spec, name in zip(specs, names, strict=True)
                ]
                if figure_process is not None and jobs:  # drawn there from now on
                    if not figure_process.draw(
                        main, jobs, baselines=baselines or None, formats=formats, dpi=args.dpi
                    ):
                        figure_process = None  # they cannot be sent: drawn here, below
                for key in rest:
                    results[key] = sc.stamp(simulate(variants[key], solver))
                    bar.tick()
        results = {k: results[k] for k in variants}  # in the variants' order: files, summary
        if main.time.size == 0:  # reported, not plotted: there is nothing to draw or store
            discard_staged(stage)
            print(
                f"aftc run: {sc.name}: {main.status} before the first sample: {main.message} "
                f"Nothing was written to {out}.",
                file=sys.stderr,
            )
            return EXIT_DIVERGED
        if main.message:
            print(f"warning: {main.message}", file=sys.stderr)
        summary = {}
        base_stem = safe_stem(sc.name)  # the name is a label; the file stem is derived
        # what is being written, file by file (a figure takes a second or two); the ETA
        # weighs a data file by its size
        sizes = {k: _n_values(r) for k, r in results.items()}
        writing = EtaBar(
            len(results) + len(specs),
            cost=sum(write_cost(n) for n in sizes.values())
            + len(specs) * figure_cost(len(formats)),
            desc="writing",
            disable=args.quiet,
            unit="file",
        )
        for key, res in results.items():
            # the variant's name as 'aftc reproduce' spells it: data/<name>_fixed-gain.nc
            stem = base_stem if key == "adaptive" else f"{base_stem}_{_FILE_SUFFIX[key]}"
            writing.note(f"data/{stem}.nc")
            res.meta["variant"] = key
            res.to_netcdf(
                inside(stage, stage / "data" / f"{stem}.nc"),
                float32=args.float32,
                decimate=args.decimate,
            )
            if args.csv:
                res.to_csv(inside(stage, stage / "data" / f"{stem}.csv"))
            summary[key] = res.metrics()
            writing.tick(write_cost(sizes[key]))

        def drawn_here():
            for job in jobs:
                plots.save_figure(
                    main,
                    job["spec"],
                    job["path"],
                    baselines=baselines or None,
                    zoom_result=job["zoom"],
                    formats=formats,
                    dpi=args.dpi,
                )
                yield

        done = figure_process.finished() if figure_process is not None else drawn_here()
        figures = []
        for name in names:
            writing.note(f"figures/{name}")
            next(done)
            figures += [str(out / "figures" / Path(name).with_suffix(f".{f}")) for f in formats]
            writing.tick(figure_cost(len(formats)))
        writing.close()
        from adaptive_ftc.reproduce import _claim_row  # reproduce's claims.csv rows

        verdicts = _run_claims(sc, results, args.no_baselines)
        thesis_verdicts = _thesis_law_claims(sc, results)
        if verdicts:
            _write_claims_csv(stage / "claims.csv", sc, verdicts, thesis_verdicts)
        (stage / "metrics.json").write_text(
            json.dumps(
                {
                    "scenario": sc.name,
                    "runs": summary,
                    "recovery": main.recovery(),
                    "figures": figures,
                    "claims": [_claim_row(sc, c, "adaptive") for c in verdicts]
                    + [_claim_row(sc, c, "thesis_law") for c in thesis_verdicts],
                },
                indent=2,
                default=float,
            ),
            encoding="utf-8",
        )
    except BaseException:
        discard_staged(stage)
        print(
            f"aftc run: nothing written; the earlier results in {out} (if any) are untouched.",
            file=sys.stderr,
        )
        raise
    commit_staged(stage, out)
    m = summary["adaptive"]
    plant = sc.loop.plant
    units = tuple(getattr(plant, "units", ()) or ())
    y_unit = units[plant.position_index[0]] if units else "output units"
    u_unit = getattr(plant, "actuator_units", "") or "actuator units"
    print(
        f"{sc.name}: {main.status}; RMS error {m['rms_error']:.3g} {y_unit}, last "
        f"{m['final_window_s']:.3g} s {m['rms_error_final']:.3g} {y_unit}; peak command "
        f"{m['peak_command']:.3g} {u_unit}"
    )
    for key in variants:
        if key != "adaptive" and key in summary:
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
    if verdicts:
        _print_claims(verdicts)
        from adaptive_ftc.claims import unjudged_activity

        note = unjudged_activity(sc.loop, sc.claims)
        if note:
            fast = m.get("fast_rms_max", math.nan)
            print(f"{note}; measured: {fast:.3g} {u_unit} RMS above 1 Hz (worst actuator)")
    if thesis_verdicts:
        print("the thesis law beside it (constraint-aware option off; what it fails is a finding):")
        _print_claims(thesis_verdicts)
    print(
        f"wrote {len(figures)} figure(s) and {len(results)} dataset(s)"
        + (" and claims.csv" if verdicts else "")
        + f" to {out}"
    )
    if main.status != "completed":
        return EXIT_DIVERGED
    n_fail = sum(c.status == "FAIL" for c in verdicts)
    if n_fail:
        print(f"aftc run: {n_fail} claim(s) failed (see above).", file=sys.stderr)
        return EXIT_CLAIMS_FAILED
    return EXIT_OK


#: The runs the figures of 'aftc run' draw beside the adaptive one
_OVERLAID = ("frozen", "failure_free", "thesis_law")

#: File-name suffix of each 'aftc run' variant: the spelling of 'aftc reproduce'
#: (reproduce.VARIANTS), so both write data/<name>_fixed-gain.nc
_FILE_SUFFIX = {
    "frozen": "frozen",
    "failure_free": "failure_free",
    "fixed_gain": "fixed-gain",
    "nominal_inverse": "nominal-inverse",
    "oracle": "oracle",
    "thesis_law": "thesis_law",
}


def _run_claims(sc, results: dict, no_baselines: bool) -> list:
    """The scenario's ``[[claims]]`` evaluated on the adaptive run of ``aftc run`` (the fair
    baselines it ran; with ``--no-baselines`` a ``baseline_ratio`` is left unjudged and said
    so in the detail)."""
    from adaptive_ftc.claims import ClaimError, evaluate_claim

    names = {
        "frozen": "frozen",
        "fixed_gain": "fixed-gain",
        "nominal_inverse": "nominal-inverse",
        "oracle": "oracle",
    }
    baselines = {names[k]: v for k, v in results.items() if k in names}
    has_fair = any(k != "oracle" for k in baselines)
    out = []
    for i, claim in enumerate(sc.claims):
        claim = dict(claim)
        note = ""
        if claim.get("baseline_ratio") is not None and not has_fair:
            claim.pop("baseline_ratio")
            note = " [baseline_ratio not judged: no baseline run (--no-baselines)]"
        try:
            verdict = evaluate_claim(
                claim, results["adaptive"], baselines=baselines, duration=sc.loop.t_final
            )
        except ClaimError as exc:
            raise ClaimError(f"{sc.name}: [[claims]] #{i + 1}: {exc}") from None
        if note:
            verdict = replace(verdict, detail=verdict.detail + note)
        out.append(verdict)
    return out


def _thesis_law_claims(sc, results: dict) -> list:
    """The scenario's claims judged on the thesis law's companion run (a constraint-aware
    scenario; ``[]`` otherwise): FINDING where it fails, never FAIL."""
    from adaptive_ftc.claims import evaluate_thesis_law_claims

    if "thesis_law" not in results or not sc.claims:
        return []
    names = {"fixed_gain": "fixed-gain", "nominal_inverse": "nominal-inverse", "oracle": "oracle"}
    baselines = {names.get(k, k): v for k, v in results.items() if k in (*names, "frozen")}
    return evaluate_thesis_law_claims(
        sc.claims, results["thesis_law"], baselines=baselines, duration=sc.loop.t_final
    )


def _write_claims_csv(path: Path, sc, verdicts: list, thesis_verdicts: Sequence = ()) -> None:
    import csv

    from adaptive_ftc.reproduce import _claim_row  # one row format with reproduce's claims.csv

    rows = [_claim_row(sc, c, "adaptive") for c in verdicts]
    rows += [_claim_row(sc, c, "thesis_law") for c in thesis_verdicts]
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def _print_claims(verdicts: list) -> None:
    counts: dict[str, int] = {}
    for c in verdicts:
        counts[c.verdict] = counts.get(c.verdict, 0) + 1
    print("claims: " + ", ".join(f"{n} {v}" for v, n in counts.items()))
    for c in verdicts:
        unit = f" {c.unit}" if c.unit else ""
        text = " ".join(c.text.split())
        text = text if len(text) <= 100 else text[:97] + "..."
        print(
            f"  {c.verdict:<14} {c.kind}: measured {c.measured:.4g}{unit} vs {c.threshold:.4g}"
            f"{unit}: {text}"
        )
        if c.finding:
            print(f"  {'':<14} finding: {c.finding}")


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from adaptive_ftc._atomic import check_output_dir
    from adaptive_ftc.reproduce import run_reproduction

    if args.quick:  # it writes neither figures nor data: options about them would do nothing
        unused = [
            flag
            for flag, given in (
                ("--formats", args.formats),
                ("--dpi", args.dpi),
                ("--baselines", args.baselines),
                ("--float32", args.float32),
                ("--decimate", args.decimate != 1),
            )
            if given
        ]
        if unused:
            raise ConfigurationError(
                f"aftc reproduce --quick draws no figures and writes no data files, so "
                f"{', '.join(unused)} would do nothing: drop {'it' if len(unused) == 1 else 'them'}"
                ", or drop --quick for the full reproduction."
            )
    formats = _formats(args.formats or "png,pdf")
    if args.names:  # every name checked before the output folder is touched
        from adaptive_ftc.scenarios.loader import list_scenarios, load_scenario

        catalogue = set(list_scenarios())
        for name in args.names:
            if name not in catalogue and Path(name).suffix == ".toml":
                raise ConfigurationError(
                    f"aftc reproduce takes catalogue scenario names (aftc list); '{name}' is a "
                    f"file: run it with aftc run {name}."
                )
            load_scenario(name)  # an unknown name: the error says which names exist
    check_output_dir(args.out)
    summary = run_reproduction(
        args.out,
        # --quick: the runs the claims need, at full length (the library's quick=True, for
        # tests, shortens every run instead: most claims are then NOT EVALUATED)
        claims_only=args.quick,
        data=not args.quick,
        jobs=args.jobs,
        progress=not args.quiet,
        baselines=args.baselines,
        fair_baselines=False if args.no_fair_baselines else None,
        formats=formats,
        dpi=args.dpi,
        float32=args.float32,
        decimate=args.decimate,
        names=args.names or None,
        figure_limit=0 if args.quick else None,
    )
    print(
        f"reproduced {summary['n_scenarios']} scenarios in {summary['wall_time_s']:.1f} s: "
        f"{summary['n_pass']}/{summary['n_claims']} thesis claims PASS"
        f" ({summary.get('n_finding', 0)} FINDING, "
        f"{summary.get('n_not_reproduced', 0)} NOT REPRODUCED, "
        f"{summary.get('n_not_evaluated', 0)} NOT EVALUATED, {summary.get('n_fail', 0)} FAIL)"
        + (
            f"; the thesis law beside the constraint-aware designs: "
            f"{summary['n_thesis_law_finding']} FINDING"
            if summary.get("n_thesis_law_finding")
            else ""
        )
        + f"; report: {summary['report']}"
    )
    if args.quick:
        n_claims = int(summary["n_claims"])
        judged = n_claims - int(summary.get("n_not_evaluated", 0))
        print(
            f"quick mode judged {judged} of {n_claims} claims on full-length runs (the verdicts "
            "of a full reproduction). Left out:"
        )
        for what in summary.get("left_out", ()):
            print(f"  - {what}")
        print("Run without --quick for everything.")
    n_fail = int(summary.get("n_fail", 0))
    n_errors = int(summary.get("n_errors", 0))
    if n_fail or n_errors:
        print(
            f"aftc reproduce: {n_fail} claim(s) failed, {n_errors} run(s) raised errors "
            "(see the report).",
            file=sys.stderr,
        )
        return EXIT_CLAIMS_FAILED
    return EXIT_OK


def _cmd_schema(args: argparse.Namespace) -> int:
    from adaptive_ftc._atomic import atomic_write_text
    from adaptive_ftc.scenarios.loader import scenario_schema

    text = json.dumps(scenario_schema(), indent=2, ensure_ascii=False) + "\n"
    if args.out:
        target = Path(args.out)
        if target.is_dir():
            raise ConfigurationError(f"--out '{target}' is a folder; give a file name.")
        try:
            atomic_write_text(target, text)
        except OSError as exc:
            raise ConfigurationError(
                f"--out '{target}': cannot write there ({exc.strerror or exc})."
            ) from None
        print(f"wrote {target}")
    else:
        sys.stdout.write(text)
    return EXIT_OK


def _sigterm(signum, frame):  # pragma: no cover - exercised through a subprocess test
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``aftc``; returns the exit status (see the module docstring)."""
    try:
        args = _parser().parse_args(argv)
    except SystemExit as exc:  # argparse: --help/--version (0) or a bad argument (2)
        return int(exc.code) if isinstance(exc.code, int) else EXIT_INVALID
    from adaptive_ftc.claims import ClaimError  # a malformed [[claims]] table: invalid input

    previous = None
    try:
        previous = signal.signal(signal.SIGTERM, _sigterm)
    except ValueError:  # not the main thread
        previous = None
    try:
        if args.command == "list":
            return _cmd_list(args.long)
        if args.command == "validate":
            return _cmd_validate(args.scenario)
        if args.command == "run":
            return _cmd_run(args)
        if args.command == "schema":
            return _cmd_schema(args)
        if args.command == "campaign":
            from adaptive_ftc.campaigns import cli as campaign_cli

            return campaign_cli.main(args)
        if args.command == "study":
            from adaptive_ftc import study_cli

            return study_cli.cli_main(args)
        if args.command == "export":
            from adaptive_ftc.export import cli as export_cli

            return export_cli.main(args)
        return _cmd_reproduce(args)
    except (ScenarioError, ConfigurationError, ExpressionError, ClaimError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_INVALID
    except KeyboardInterrupt:
        print("interrupted; earlier complete results are kept.", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # pragma: no cover - e.g. `aftc schema | head`
        return EXIT_OK
    except Exception as exc:  # noqa: BLE001 - a bug: one line, not a traceback
        print(
            f"internal error: {type(exc).__name__}: {exc}. This is a bug in adaptive-ftc; "
            "please report it with the command line (set AFTC_DEBUG=1 for the traceback).",
            file=sys.stderr,
        )
        import os

        if os.environ.get("AFTC_DEBUG"):
            raise
        return EXIT_INTERNAL
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
