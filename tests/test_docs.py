"""README examples and docstring examples are executed, so they cannot rot."""

from __future__ import annotations

import doctest
import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_readme_python_examples_run(tmp_path, monkeypatch):
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks, "the README has no python example"
    monkeypatch.chdir(tmp_path)
    for block in blocks:
        exec(compile(block, "README.md", "exec"), {"__name__": "readme"})  # noqa: S102


def test_readme_quick_start_is_two_commands_matching_ci():
    text = (ROOT / "README.md").read_text()
    quick = text.split("## Quick start", 1)[1].split("##", 1)[0]
    commands = re.findall(r"```(?:bash|sh)\n(.*?)```", quick, flags=re.S)
    lines = [ln for block in commands for ln in block.strip().splitlines()]
    assert len(lines) == 2, lines
    assert "aftc reproduce" in lines[0]
    ci = (ROOT / ".ci" / "run").read_text()
    assert lines[1].strip() in ci


@pytest.mark.parametrize(
    "module",
    [
        "adaptive_ftc.scenarios.expressions",
        "adaptive_ftc.faults.models",
        "adaptive_ftc.faults.schedule",
        "adaptive_ftc.approximators.fuzzy",
        "adaptive_ftc.approximators.linear",
        "adaptive_ftc.plants.hypersonic",
        "adaptive_ftc.sim.engine",
        "adaptive_ftc.sim.batch",
        "adaptive_ftc.scenarios.loader",
    ],
)
def test_docstring_examples(module):
    mod = importlib.import_module(module)
    failures, _ = doctest.testmod(mod, optionflags=doctest.ELLIPSIS)
    assert failures == 0
