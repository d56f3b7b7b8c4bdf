"""Issue 25, §4.4: which members of a campaign the integral's damping costs, and what a gate on
the declared hardware would give (docs/hardware.md, "Round 12 (session 15)").

Reads two runs of the same campaign (constraint-aware only): one with the rule
(``C_INTEGRAL_ZETA`` = 1) and one without the damping (``C_INTEGRAL_ZETA`` = 0); members are
independent and the two rules differ only in the ``lam`` of the members that carry the error's
integral, so a gate "damp where the hardware says X" gives, exactly, the damped row where X
holds and the undamped one elsewhere. Prints, per member that carries the integral, its
declared hardware and configuration (loop rate ``w``, ``k_I``, ``lam`` before and after), both
outcomes, the ratios of fast content and error, a summary by sample time, and the campaign's
count under each candidate gate:

    aftc campaign SPEC --out DAMPED --jobs 1
    python -c "import sys; from adaptive_ftc.controllers import constraints; \\
        constraints.C_INTEGRAL_ZETA = 0; from adaptive_ftc.cli import main; \\
        sys.exit(main(sys.argv[1:]))" campaign SPEC --out UNDAMPED --jobs 1
    PYTHONPATH=src python scripts/integral_damping_gate.py SPEC DAMPED UNDAMPED

(SPEC: ``hypersonic-sign-hardware`` with ``designs = ["constraint-aware"]``.)
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from dataclasses import dataclass

import pandas as pd

from adaptive_ftc.campaigns.sampling import draw_member
from adaptive_ftc.campaigns.spec import load_campaign
from adaptive_ftc.controllers import constraints


@dataclass(frozen=True)
class Member:
    """A member that carries the error's integral: its declared hardware and configuration."""

    index: int
    T: float  # sample time (s)
    lag: float  # actuator lag (s)
    delay: float  # the delay budget's lags, lag + T/2 + tau_d (s)
    w: float  # loop rate (1/s)
    k_i: float
    lam0: float  # lam without the damping
    lam: float  # lam with it


def integral_members(spec) -> list[Member]:
    """The members whose constraint-aware law carries the error's integral."""
    out = []
    for i in range(spec.runs):
        mem = draw_member(spec, i)
        if mem.loop is None:
            continue
        loop = mem.design_loop("constraint-aware")
        design = loop.controller.bound(loop)
        ca = design.constraint_aware
        if ca is None or ca.is_ideal:
            continue
        cfg = design.configuration(ca.b_max, ca.input_gain)
        if cfg.error_integral <= 0:
            continue
        zeta = constraints.C_INTEGRAL_ZETA
        constraints.C_INTEGRAL_ZETA = 0.0
        try:
            plain = design.configuration(ca.b_max, ca.input_gain)
        finally:
            constraints.C_INTEGRAL_ZETA = zeta
        w0 = ca.loop_rate if ca.loop_rate is not None else design.loop_rate()
        w, _ = ca.omega_max(w0, ca.b_max)
        lam = design.lam if isinstance(design.lam, (int, float)) else min(design.lam)
        delay = ca.lag + 0.5 * ca.sample_time + ca.s_lag + ca.decimation_delay
        out.append(
            Member(
                i,
                ca.sample_time,
                ca.lag,
                delay,
                w,
                cfg.error_integral,
                lam * plain.lam_factor,
                lam * cfg.lam_factor,
            )
        )
    return out


def gated_count(
    damped: dict[int, bool],
    undamped: dict[int, bool],
    members: list[Member],
    gate: Callable[[Member], bool],
) -> int:
    """The campaign's successes with the damping only where ``gate`` holds: the damped row of
    a gated member, the undamped one elsewhere (the two rules agree on every other member)."""
    ok = dict(damped)
    for m in members:
        if not gate(m):
            ok[m.index] = undamped[m.index]
    return sum(bool(v) for v in ok.values())


GATES: dict[str, Callable[[Member], bool]] = {
    "every member (the rule)": lambda m: True,
    "none (C_INTEGRAL_ZETA = 0)": lambda m: False,
    "the sample's lags at least the actuator's, lag <= T/2 + tau_d": lambda m: (
        m.lag <= m.delay - m.lag + 1e-12
    ),
    "50 Hz and slower, T >= 20 ms": lambda m: m.T >= 0.02 - 1e-12,
    "w T >= 0.15": lambda m: m.w * m.T >= 0.15,
}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("spec")
    ap.add_argument("damped", help="the campaign's folder with the rule")
    ap.add_argument("undamped", help="the campaign's folder with C_INTEGRAL_ZETA = 0")
    args = ap.parse_args(argv)
    spec = load_campaign(args.spec)
    on = pd.read_parquet(f"{args.damped}/results.parquet").set_index("index")
    off = pd.read_parquet(f"{args.undamped}/results.parquet").set_index("index")
    members = integral_members(spec)
    rows = []
    for m in sorted(members, key=lambda m: (m.T, m.w)):
        fr = on.fast_rms_max[m.index] / off.fast_rms_max[m.index]
        er = on.rms_error_final[m.index] / off.rms_error_final[m.index]
        rows.append((m, fr, er))
        print(
            f"{m.index:4d} T {m.T * 1e3:3.0f} ms lag {m.lag * 1e3:4.1f} ms (share "
            f"{m.lag / m.delay:.2f}) w {m.w:5.2f} wT {m.w * m.T:.3f} k_I {m.k_i:5.2f} lam "
            f"{m.lam0:.2f}->{m.lam:.2f} (pair's damping {m.lam0 / (2 * math.sqrt(m.k_i)):.2f}) "
            f"ok {int(off.success[m.index])}->{int(on.success[m.index])} fast "
            f"{off.fast_rms_max[m.index]:.2e}->{on.fast_rms_max[m.index]:.2e} (x{fr:.2f}) error "
            f"x{er:.2f}"
        )
    print()
    for T in sorted({m.T for m in members}):
        sel = [(m, fr, er) for m, fr, er in rows if m.T == T]
        lost = [m.index for m, _, _ in sel if off.success[m.index] and not on.success[m.index]]
        won = [m.index for m, _, _ in sel if on.success[m.index] and not off.success[m.index]]
        frs = sorted(fr for _, fr, _ in sel)
        ers = sorted(er for _, _, er in sel)
        better = sum(er < 1 for er in ers)
        print(
            f"T {T * 1e3:.0f} ms: {len(sel)} members, fast content x{frs[len(frs) // 2]:.2f} "
            f"(median), error x{ers[len(ers) // 2]:.2f}, error better on {better}; lost "
            f"{lost}, gained {won}"
        )
    print()
    damped = {int(i): bool(v) for i, v in on.success.items()}
    undamped = {int(i): bool(v) for i, v in off.success.items()}
    for name, gate in GATES.items():
        n = gated_count(damped, undamped, members, gate)
        print(f"{name}: {n}/{len(damped)} ({sum(gate(m) for m in members)} members damped)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
