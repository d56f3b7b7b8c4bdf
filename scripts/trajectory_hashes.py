"""Record (or check) the fingerprint of every catalogue trajectory.

A refactoring of the generator, the engine or the solvers must leave every trajectory
bit-identical. This script runs every catalogue scenario (its own design, the thesis law beside a
constraint-aware design, and each fair baseline plus the oracle on a short horizon) and writes one
fingerprint per run to ``tests/data/trajectory_hashes.json``: the SHA-256 of the recorded arrays'
bytes, plus a few float64 summaries (sums of every array, the final state) so a change on another
CPU can be judged at a stated tolerance. ``tests/test_trajectory_hashes.py`` compares against it.

    python scripts/trajectory_hashes.py          # record (before a refactoring)
    python scripts/trajectory_hashes.py --check  # compare, print the runs that changed
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from trajectory_fingerprints import OUT, compare, fingerprints  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="compare with the stored file")
    args = ap.parse_args()
    now = fingerprints()
    if args.check:
        stored = json.loads(OUT.read_text())
        problems = compare(stored, now)
        for p in problems:
            print(p)
        print(f"{len(now['runs'])} runs, {len(problems)} differ")
        return 1 if problems else 0
    OUT.write_text(json.dumps(now, indent=1, sort_keys=True) + "\n")
    print(f"wrote {len(now['runs'])} fingerprints to {OUT.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
