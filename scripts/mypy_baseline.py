"""Type-check ``src/adaptive_ftc`` with mypy against a baseline that may only shrink (issue 27).

The package is not mypy-clean yet: ``mypy-baseline.json`` holds the number of errors per file
when the check was introduced. CI fails when a file has more errors than its baseline (a new
file: more than none); fixing errors lowers the count, and ``--update`` writes the lower
counts (it refuses to raise any). Settings: ``[tool.mypy]`` in pyproject.toml.

    python scripts/mypy_baseline.py            # check (exit 1 on a file with more errors)
    python scripts/mypy_baseline.py --update   # lower the baseline to the current counts
                                               # (or, without a baseline file, write the first)
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BASELINE = ROOT / "mypy-baseline.json"
_ERROR = re.compile(r"^(?P<path>[^:\n]+\.pyi?):\d+:(?:\d+:)? error:", re.M)


def error_counts(output: str) -> dict[str, int]:
    """``{file: number of errors}`` from mypy's output (notes are not errors)."""
    return dict(
        sorted(Counter(m["path"].replace("\\", "/") for m in _ERROR.finditer(output)).items())
    )


def compare(counts: dict[str, int], baseline: dict[str, int]) -> tuple[list[str], list[str]]:
    """``(worse, better)``: one line per file with more / fewer errors than its baseline."""
    worse, better = [], []
    for path in sorted({*counts, *baseline}):
        now, allowed = counts.get(path, 0), baseline.get(path, 0)
        if now > allowed:
            worse.append(f"{path}: {now} mypy errors, baseline {allowed}")
        elif now < allowed:
            better.append(f"{path}: {now} mypy errors, baseline {allowed}")
    return worse, better


def run_mypy() -> str:
    proc = subprocess.run(
        [sys.executable, "-m", "mypy", "src/adaptive_ftc"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
    )
    if proc.returncode not in (0, 1):  # 2: mypy itself failed (bad config, crash)
        sys.exit(f"mypy failed (exit {proc.returncode}):\n{proc.stdout}{proc.stderr}")
    return proc.stdout


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--update", action="store_true", help="lower the baseline")
    args = parser.parse_args(argv)
    output = run_mypy()
    counts = error_counts(output)
    baseline = json.loads(BASELINE.read_text()) if BASELINE.exists() else {}
    worse, better = compare(counts, baseline)
    if worse and not (args.update and not BASELINE.exists()):  # the first baseline: any counts
        print(output, end="")
        print("\nMore mypy errors than the baseline allows (fix them; the baseline only shrinks):")
        print("\n".join(worse))
        return 1
    if args.update:
        BASELINE.write_text(json.dumps(counts, indent=1, sort_keys=True) + "\n")
        print(f"wrote {BASELINE.name}: {sum(counts.values())} errors in {len(counts)} files")
        return 0
    elif better:
        print("Fewer mypy errors than the baseline; lower it with --update:")
        print("\n".join(better))
    print(f"mypy: {sum(counts.values())} errors, baseline {sum(baseline.values())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
