"""``aftc export``: the controller of a scenario as C (``aftc export c``) or as an FMU
(``aftc export fmu``)."""

from __future__ import annotations

import argparse

__all__ = ["add_parser", "main"]


def _positive(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds (a number > 0); got {text!r}") from None
    if not v > 0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"expected seconds (a number > 0); got {text!r}")
    return v


def _add_kind(
    kinds, name: str, common: dict, *, help: str, description: str, out: str
) -> argparse.ArgumentParser:
    """``aftc export <name>``: its parser, with the scenario and ``--out`` arguments."""
    p = kinds.add_parser(name, help=help, description=description, **common)
    p.add_argument("scenario", help="scenario name or path to a .toml file")
    p.add_argument("--out", required=True, help=out)
    return p


def _add_sample_time(p: argparse.ArgumentParser, help: str) -> None:
    p.add_argument("--sample-time", type=_positive, metavar="SECONDS", help=help)


def add_parser(sub, **common) -> argparse.ArgumentParser:
    """Add ``export`` (with its ``c`` command) to the ``aftc`` subcommands ``sub``;
    ``common``: keyword arguments of every parser (the exit-status epilog)."""
    ex = sub.add_parser(
        "export",
        help="export a scenario's controller (C99 library, FMU)",
        description="Export the digital controller of a scenario beyond Python: 'aftc export "
        "c' writes it as a C99 library, 'aftc export fmu' as an FMI 2.0 co-simulation FMU.",
        **common,
    )
    kinds = ex.add_subparsers(dest="export_kind", required=True)
    c = _add_kind(
        kinds,
        "c",
        common,
        help="the digital controller as a self-contained C99 library",
        description="Write <prefix>.h and <prefix>.c: the scenario's digital controller "
        "(measurement and reference in, actuator commands out; adaptive laws, regressor, s' "
        "filter, allocation), generated from the code the simulator compiles. No heap, libm "
        "only; the scenario's numbers are a const params struct (retune without "
        "regenerating). See docs/deploying.md.",
        out="folder to write the .h and .c into",
    )
    _add_sample_time(
        c,
        "the controller's period (default: the scenario's [digital] sample_time; "
        "needed for a continuous scenario)",
    )
    c.add_argument("--prefix", default="aftc", help="prefix of every C name (default: aftc)")
    f = _add_kind(
        kinds,
        "fmu",
        common,
        help="the digital controller or the closed loop as an FMI 2.0 co-simulation FMU",
        description="Write <name>.fmu: an FMI 2.0 co-simulation FMU of the scenario's digital "
        "controller (--part controller) or of its closed loop (--part loop), built from the "
        "exported C (its sources and a linux64 binary built with the system C compiler; no "
        "Python inside). Needs FMPy's FMI headers (pip install fmpy). See docs/deploying.md.",
        out="folder to write the .fmu into",
    )
    f.add_argument(
        "--part",
        choices=("controller", "loop"),
        default="controller",
        help="what the FMU holds: the controller (default: inputs y and r, outputs u), or the "
        "scenario's closed loop (plant, failures, actuators, sensors and the controller; no "
        "inputs)",
    )
    _add_sample_time(f, "the controller's period (default: the scenario's [digital] sample_time)")
    f.add_argument("--name", help="model identifier (default: <scenario>_<part>)")
    return ex


def main(args: argparse.Namespace) -> int:
    """Run ``aftc export``; returns the exit status."""
    from adaptive_ftc.export.c import export_c

    if args.export_kind == "fmu":
        from adaptive_ftc.export.fmu import export_fmu

        fmu = export_fmu(
            args.scenario, args.out, part=args.part, sample_time=args.sample_time, name=args.name
        )
        print(
            f"wrote {fmu.path}: FMI 2.0 co-simulation, {len(fmu.variables)} variables, "
            f"sample time {fmu.c.sample_time:g} s"
        )
        return 0

    out = export_c(args.scenario, args.out, sample_time=args.sample_time, prefix=args.prefix)
    print(
        f"wrote {out.header} and {out.source}: {out.n_y} measurements, {out.n_r} reference "
        f"values, {out.n_u} commands, {out.n_states} controller states, every "
        f"{out.sample_time:g} s"
        + (
            f" (the mean of {out.readings} sensor readings: {out.prefix}_read at each)"
            if out.readings > 1
            else ""
        )
    )
    return 0
