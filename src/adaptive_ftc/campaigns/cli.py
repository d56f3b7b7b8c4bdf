"""``aftc campaign``: run, resume and replay fault campaigns.

Usage::

    aftc campaign SPEC --out DIR [--jobs N] [--scheduler ADDRESS]   # run or resume
    aftc campaign replay DIR INDEX [--out REPLAY_DIR] [--design D]   # rerun one member
    aftc campaign list                                               # example specs
    aftc campaign show NAME                                          # print a shipped spec
    aftc campaign init NAME FILE                                     # copy it to edit
"""

from __future__ import annotations

import argparse
import sys

__all__ = ["add_parser", "main"]

_EPILOG = """exit status:
  0    success (or an incomplete campaign: run the same command again to resume)
  1    replay: a member's rerun differs from the results table
  2    invalid input (spec, argument, folder) or a missing optional dependency
  130  interrupted; finished chunks are kept (run the same command again to resume)
"""


#: ``--lanes``: run_campaign's ``lanes``
_LANES: dict[str, bool | str] = {"auto": "auto", "on": True, "off": False}


def add_parser(
    subparsers, formatter_class: type[argparse.HelpFormatter] = argparse.HelpFormatter
) -> argparse.ArgumentParser:
    """Add the ``campaign`` command to the ``aftc`` sub-parsers (``formatter_class``: the
    ``aftc`` help formatter, which wraps the descriptions and keeps the epilog's lines)."""
    c = subparsers.add_parser(
        "campaign",
        help="Monte Carlo fault campaign (run/resume), 'replay DIR INDEX', 'list', 'show NAME', "
        "'init NAME FILE'",
        description="Run or resume a fault campaign: aftc campaign SPEC --out DIR. Replay a "
        "member: aftc campaign replay DIR INDEX. Shipped specs: aftc campaign list; print one: "
        "aftc campaign show NAME; copy one to edit: aftc campaign init NAME FILE.",
        epilog=_EPILOG,
        formatter_class=formatter_class,
    )
    c.add_argument(
        "target",
        nargs="+",
        help="SPEC (name or .toml) | replay DIR INDEX | list | show NAME | init NAME FILE",
    )
    c.add_argument("--out", help="results folder (run) or replay folder (replay)")
    c.add_argument("--jobs", type=int, default=None, help="threads (default: all cores)")
    c.add_argument("--scheduler", help="Dask scheduler address, e.g. tcp://10.0.0.5:8786")
    c.add_argument("--max-chunks", type=int, default=None, help="stop after N new chunks")
    c.add_argument(
        "--lanes",
        choices=("auto", "on", "off"),
        default="auto",
        help="members in SIMD lanes: where they pay (auto, default), always, never; same table",
    )
    c.add_argument("--design", action="append", help="replay only this design (repeatable)")
    c.add_argument("--quiet", action="store_true", help="no progress bar")
    return c


def _run(args: argparse.Namespace) -> int:
    from adaptive_ftc.campaigns.runner import run_campaign
    from adaptive_ftc.campaigns.spec import CampaignError, load_campaign

    if len(args.target) != 1:
        raise CampaignError(
            f"'aftc campaign' takes one SPEC; got {' '.join(args.target)}. Use "
            "'aftc campaign replay DIR INDEX' to replay a member."
        )
    if not args.out:
        raise CampaignError("Give the results folder: aftc campaign SPEC --out DIR.")
    if args.jobs is not None and args.jobs < 1:
        raise CampaignError(f"--jobs must be >= 1; got {args.jobs}.")
    from adaptive_ftc.campaigns.store import require_pyarrow

    spec = load_campaign(args.target[0])  # every problem of the spec, before anything runs
    require_pyarrow()  # before the results folder or the progress bar exist
    try:
        run = run_campaign(
            spec,
            args.out,
            jobs=args.jobs,
            scheduler=args.scheduler,
            progress=not args.quiet,
            max_chunks=args.max_chunks,
            lanes=_LANES[args.lanes],
        )
    except KeyboardInterrupt:
        print(
            f"interrupted: finished chunks are kept in {args.out}; run the same command again "
            "to resume.",
            file=sys.stderr,
        )
        return 130
    print(
        f"{spec.name}: {run.runs_done_now} runs now, {run.runs_resumed} resumed, "
        f"{run.runs_total} in all, {run.wall_time_s:.1f} s"
    )
    if not run.complete:
        print(f"incomplete: run the same command again to resume ({run.out})")
        return 0
    per = run.summary.get("per_design", {})
    for design, rate in run.summary.get("success_rate", {}).items():
        r = per.get(design)
        ci = (
            f" ({r['successes']}/{r['runs']}; 95 % CI {r['ci_low']:.1%}-{r['ci_high']:.1%})"
            if r and r["runs"]
            else ""
        )
        print(f"  {design}: success rate {rate:.1%}{ci}")
    if run.summary.get("headline"):
        print(run.summary["headline"].replace("\u00a0", " "))
    print(f"results: {run.results}; summary: {run.out / 'summary.html'}")
    return 0


def _replay(args: argparse.Namespace) -> int:
    from adaptive_ftc.campaigns.replay import replay_member
    from adaptive_ftc.campaigns.spec import CampaignError

    if len(args.target) != 3:
        raise CampaignError("Usage: aftc campaign replay DIR INDEX [--out REPLAY_DIR].")
    folder, index = args.target[1], args.target[2]
    try:
        idx = int(index)
    except ValueError:
        raise CampaignError(f"INDEX must be a member number; got '{index}'.") from None
    out = args.out or f"{folder.rstrip('/')}/replay-{idx}"
    info = replay_member(folder, idx, out, designs=tuple(args.design) if args.design else None)
    for line in info["failures"]:
        print(f"  failure {line}")
    for d, row in info["rows"].items():
        same = info["matches_table"][d]
        verdict = {True: "identical to the table", False: "DIFFERS from the table"}.get(
            same, "not in the table yet"
        )
        print(f"  {d}: {row['status']}; final RMS error {row['rms_error_final']:.3g} ({verdict})")
    print(f"wrote data, figures and metrics.json to {out}")
    return 0 if all(v is not False for v in info["matches_table"].values()) else 1


def _show(args: argparse.Namespace) -> int:
    """``show NAME``: print a shipped spec; ``init NAME FILE``: copy it to FILE."""
    from adaptive_ftc.campaigns.spec import EXAMPLES, CampaignError, list_campaigns

    command = args.target[0]
    want = 2 if command == "show" else 3
    if len(args.target) != want:
        usage = "show NAME" if command == "show" else "init NAME FILE"
        raise CampaignError(
            f"Usage: aftc campaign {usage} (NAME: one of {', '.join(list_campaigns())})."
        )
    name = args.target[1]
    source = EXAMPLES / f"{name}.toml"
    if name not in list_campaigns():
        from adaptive_ftc.errors import did_you_mean

        raise CampaignError(
            f"No shipped campaign '{name}'.{did_you_mean(name, list_campaigns())} Shipped: "
            f"{', '.join(list_campaigns())} (aftc campaign list)."
        )
    text = source.read_text(encoding="utf-8")
    if command == "show":
        sys.stdout.write(text)
        return 0
    from pathlib import Path

    target = Path(args.target[2])
    if target.is_dir():
        target = target / source.name
    if target.exists():
        raise CampaignError(
            f"'{target}' exists; init does not overwrite it. Give another FILE or remove it."
        )
    if not target.parent.is_dir():
        raise CampaignError(f"Folder '{target.parent}' does not exist; create it first.")
    target.write_text(text, encoding="utf-8")
    print(f"wrote {target}; edit it and run: aftc campaign {target} --out DIR")
    return 0


def main(args: argparse.Namespace) -> int:
    """Run the ``campaign`` command; returns the exit status."""
    first = args.target[0]
    if first == "replay":
        return _replay(args)
    if first in ("show", "init"):
        return _show(args)
    if first == "list" and len(args.target) == 1:
        from adaptive_ftc.campaigns.spec import EXAMPLES, list_campaigns, load_campaign

        for name in list_campaigns():
            spec = load_campaign(EXAMPLES / f"{name}.toml")
            print(f"{name:<20} {spec.runs:>5} runs x {len(spec.designs)} designs  {spec.title}")
        return 0
    return _run(args)
