"""The shipped allocation study (issue 31): success rate vs failed actuators and detection
delay, per allocator, on the spacecraft (6 reaction wheels), the manipulator (2 actuators per
joint) and wing rock (3 aileron segments, the single-input §2.4 design). Writes
docs/figures/allocation.csv, allocation_summary.csv and allocation.png.

    PYTHONPATH=src python scripts/allocation_study.py [--draws 10]
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import pandas as pd

from adaptive_ftc.allocation_study import allocation_study, plot_allocation_study, summarize

CASES = {
    # scenario: (failed counts, stuck magnitude, onset window)
    "spacecraft-mimo-s1": ((1, 2, 3), 5.0, (15.0, 75.0)),
    "manipulator-mimo-s1": ((1, 2), 3.0, (3.0, 15.0)),
    "wingrock-estimation-s1": ((1, 2), 10.0, (2.0, 6.0)),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--draws", type=int, default=10)
    ap.add_argument("--out", default=str(Path(__file__).parents[1] / "docs" / "figures"))
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    tables = []
    for name, (failed, stuck, onset) in CASES.items():
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # diverged runs count as failures in the table
            tab = allocation_study(
                name, failed=failed, draws=args.draws, stuck=stuck, onset=onset, seed=1
            )
        print(f"{name}: {len(tab)} rows in {time.perf_counter() - t0:.0f} s")
        tables.append(tab)
    table = pd.concat(tables, ignore_index=True)
    table.to_csv(out / "allocation.csv", index=False)
    summary = summarize(table)
    summary.to_csv(out / "allocation_summary.csv", index=False)
    with pd.option_context("display.width", 200, "display.max_rows", 200):
        print(summary.to_string(index=False))
    fig = plot_allocation_study(table)
    fig.savefig(out / "allocation.png", dpi=110)


if __name__ == "__main__":
    main()
