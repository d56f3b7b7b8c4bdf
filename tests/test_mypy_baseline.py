"""The mypy baseline of CI (scripts/mypy_baseline.py): errors are counted per file, a file
with more errors than its baseline fails, and the baseline only shrinks (issue 27)."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("mypy_baseline", ROOT / "scripts/mypy_baseline.py")
assert _spec is not None and _spec.loader is not None
mb = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(mb)

OUTPUT = """\
src/adaptive_ftc/cli.py:343: error: Item "tuple" has no attribute "failures"  [union-attr]
src/adaptive_ftc/cli.py:655:12: error: Incompatible default for parameter  [assignment]
src/adaptive_ftc/cli.py:656: note: PEP 484 prohibits implicit Optional
src/adaptive_ftc/sim/result.py:10: error: Name "x" is not defined  [name-defined]
Found 3 errors in 2 files (checked 78 source files)
"""


def test_errors_are_counted_per_file_and_notes_are_not_errors():
    assert mb.error_counts(OUTPUT) == {
        "src/adaptive_ftc/cli.py": 2,
        "src/adaptive_ftc/sim/result.py": 1,
    }


def test_a_file_with_more_errors_than_its_baseline_is_worse_and_fewer_is_better():
    baseline = {"src/adaptive_ftc/cli.py": 2, "src/adaptive_ftc/plots.py": 4}
    worse, better = mb.compare(mb.error_counts(OUTPUT), baseline)
    assert worse == ["src/adaptive_ftc/sim/result.py: 1 mypy errors, baseline 0"]
    assert better == ["src/adaptive_ftc/plots.py: 0 mypy errors, baseline 4"]


def test_update_refuses_to_raise_the_baseline(tmp_path, monkeypatch, capsys):
    path = tmp_path / "mypy-baseline.json"
    path.write_text(json.dumps({"src/adaptive_ftc/cli.py": 1}))
    monkeypatch.setattr(mb, "BASELINE", path)
    monkeypatch.setattr(mb, "run_mypy", lambda: OUTPUT)
    assert mb.main(["--update"]) == 1
    assert json.loads(path.read_text()) == {"src/adaptive_ftc/cli.py": 1}
    path.write_text(json.dumps({"src/adaptive_ftc/cli.py": 5, "src/adaptive_ftc/sim/result.py": 1}))
    assert mb.main([]) == 0 and "lower it with --update" in capsys.readouterr().out
    assert mb.main(["--update"]) == 0
    assert json.loads(path.read_text()) == mb.error_counts(OUTPUT)


def test_the_committed_baseline_names_existing_files_only():
    baseline = json.loads((ROOT / "mypy-baseline.json").read_text())
    assert baseline and all((ROOT / path).is_file() for path in baseline)
