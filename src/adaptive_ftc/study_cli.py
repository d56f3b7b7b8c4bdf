"""The ``aftc study`` command: runs the studies of :mod:`adaptive_ftc.studies` and draws their
figures with :mod:`adaptive_ftc.study_plots` (kept apart from both: the figures import the
studies, so the studies cannot import the figures)."""

from __future__ import annotations

from collections.abc import Callable

from adaptive_ftc.errors import ConfigurationError


class _Help(str):
    """A help text whose ``{names}`` are filled in when argparse prints it (``aftc study
    --help``), not when the parser is built: the default scenarios live in
    :mod:`adaptive_ftc.studies`, which imports pandas and the engine, and ``aftc --help`` or
    any other command should not pay for that."""

    _fill: Callable[[], dict[str, str]]

    def __new__(cls, text: str, fill: Callable[[], dict[str, str]]):
        self = super().__new__(cls, text)
        self._fill = fill
        return self

    def __mod__(self, params):  # argparse expands a help text with ``help % params``
        return str.__mod__(str(self).format(**self._fill()), params)


def _defaults() -> dict[str, str]:
    from adaptive_ftc import studies

    return {
        "delay": ", ".join(studies.DELAY_SCENARIOS),
        "study": ", ".join(studies.STUDY_SCENARIOS),
    }


def add_parser(subparsers):
    """Add the ``study`` command to the ``aftc`` sub-parsers."""
    st = subparsers.add_parser(
        "study",
        help="robustness studies beyond the thesis (sensor noise, digital control, actuators)",
        description="aftc study robustness --out DIR: sweep sensor noise, controller rate, "
        "actuator lag and rate limit on the §2.3 and §4.4 hypersonic designs; write "
        "robustness.csv, break_points.csv and robustness.png/.pdf. "
        "aftc study delay-margin --out DIR [SCENARIO ...]: the time-delay margin of each "
        "scenario under the thesis law and the constraint-aware law (bisection on an injected "
        "input delay); write delay_margin.csv and delay_margin.png/.pdf.",
    )
    st.add_argument("study", choices=["robustness", "delay-margin"], help="which study")
    st.add_argument(
        "scenarios",
        nargs="*",
        metavar="SCENARIO",
        help=_Help("scenarios (as --scenario; delay-margin default: {delay})", _defaults),
    )
    st.add_argument("--out", default="study", help="output folder (default: ./study)")
    st.add_argument(
        "--quick",
        action="store_true",
        help="robustness: 3 values per knob, one noise seed; delay-margin: the thesis law "
        "only, a third of each horizon, 20 %% resolution",
    )
    st.add_argument(
        "--scenario",
        action="append",
        help=_Help("scenario to sweep (repeatable; default: {study})", _defaults),
    )
    st.add_argument("--jobs", type=int, default=None, help="threads (default: all cores)")
    st.add_argument("--quiet", action="store_true", help="no progress bar")
    return st


def cli_main(args) -> int:
    """Run ``aftc study robustness``; print the break points; return the exit status."""
    from pathlib import Path

    import pandas as pd

    from adaptive_ftc import studies
    from adaptive_ftc.study_plots import save_delay_margin_figure, save_robustness_figure

    if args.jobs is not None and args.jobs < 1:
        raise ConfigurationError(f"--jobs must be >= 1; got {args.jobs}.")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    chosen = [*(getattr(args, "scenarios", None) or []), *(args.scenario or [])]
    if args.study == "delay-margin":
        table = studies.delay_margin_study(
            tuple(chosen or studies.DELAY_SCENARIOS), quick=args.quick, progress=not args.quiet
        )
        table.to_csv(out / "delay_margin.csv", index=False)
        files = save_delay_margin_figure(table, out / "delay_margin.png", formats=("png", "pdf"))
        show = table[["scenario", "law", "margin", "upper", "how", "runs"]]
        with pd.option_context("display.width", 200, "display.max_columns", 10):
            print(show.to_string(index=False))
        print(f"wrote {out / 'delay_margin.csv'}, " + ", ".join(map(str, files)))
        return 0
    table = studies.robustness_study(
        tuple(chosen or studies.STUDY_SCENARIOS),
        quick=args.quick,
        jobs=args.jobs,
        progress=not args.quiet,
    )
    table.to_csv(out / "robustness.csv", index=False)
    bps = studies.break_points(table)
    bps.to_csv(out / "break_points.csv", index=False)
    files = save_robustness_figure(table, out / "robustness.png", formats=("png", "pdf"))
    with pd.option_context("display.width", 200, "display.max_columns", 10):
        print(bps.to_string(index=False))
    print(
        f"wrote {out / 'robustness.csv'}, {out / 'break_points.csv'}, " + ", ".join(map(str, files))
    )
    return 0
