"""The numbers the README, the docs and the CLI help quote agree with the code (issue 28)."""

from __future__ import annotations

import re
from pathlib import Path

from adaptive_ftc.cli import _parser

ROOT = Path(__file__).resolve().parents[1]


def _help(command: str, option: str) -> str:
    """The help text of ``aftc COMMAND OPTION`` as written (not wrapped to a terminal)."""
    parser = _parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    action = next(a for a in sub.choices[command]._actions if option in a.option_strings)
    return action.help.replace("%%", "%")


def test_study_quick_help_and_docs_state_the_quick_settings_of_the_code():
    from adaptive_ftc.studies import QUICK_VALUES

    (n,) = {len(v) for v in QUICK_VALUES.values()}
    text = _help("study", "--quick")
    # both studies' --quick are described (the help spoke of the robustness sweep only)
    assert f"robustness: {n} values per knob, one noise seed" in text
    assert "delay-margin: the thesis law only, a third of each horizon, 20 % resolution" in text
    hardware = (ROOT / "docs" / "hardware.md").read_text(encoding="utf-8")
    assert f"--quick  # {n} values per knob, one seed" in hardware


def test_reproduce_quick_help_and_tutorial_say_what_quick_does():
    text = _help("reproduce", "--quick")
    assert "at full length" in text and "no data files, no figures" in text
    tutorial = " ".join((ROOT / "docs" / "tutorial.md").read_text(encoding="utf-8").split())
    assert "--quick` makes only the runs the claims are judged on, at full length" in tutorial
    assert "shortened smoke test" not in tutorial


def test_readme_claim_count_is_the_catalogues():
    from adaptive_ftc.scenarios.loader import list_scenarios, load_scenario

    n = sum(len(load_scenario(name).claims) for name in list_scenarios())
    readme = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    quoted = re.findall(r"(\d+) of the (\d+) encoded claims", readme)
    assert quoted, "the README no longer quotes the claim count"
    assert {int(total) for _, total in quoted} == {n}


def test_the_first_run_cost_is_quoted_from_one_page():
    # docs/installation.md ("First run") measures it; other pages link there
    pattern = re.compile(r"first[- ]run[^.|]*?\b\d+(\.\d+)?\s*(s|seconds|minutes?)\b", re.I)
    for page in sorted((ROOT / "docs").glob("*.md")):
        if page.name == "installation.md":
            continue
        text = " ".join(page.read_text(encoding="utf-8").split())
        assert not pattern.search(text), (page.name, pattern.search(text).group(0))
    install = (ROOT / "docs" / "installation.md").read_text(encoding="utf-8")
    assert "bench_first_run.py" in install
