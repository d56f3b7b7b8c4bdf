"""README examples and docstring examples are executed, so they cannot rot."""

from __future__ import annotations

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


# ---------------------------------------------------------------------------- documentation site
def _python_blocks(path: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", path.read_text(encoding="utf-8"), flags=re.S)


def test_tutorial_python_blocks_run_in_order(tmp_path, monkeypatch):
    # one namespace for the whole page: later blocks use what earlier ones defined
    blocks = _python_blocks(ROOT / "docs" / "tutorial.md")
    assert len(blocks) >= 4
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "tutorial"}
    for block in blocks:
        exec(compile(block, "docs/tutorial.md", "exec"), namespace)  # noqa: S102
    assert (tmp_path / "fig_2.1.png").is_file() and (tmp_path / "fig_2.1.pdf").is_file()


def test_mkdocs_site_builds_with_warnings_as_errors(tmp_path):
    pytest.importorskip("mkdocs", reason="install the docs extra: pip install -e '.[docs]'")
    pytest.importorskip("mkdocstrings", reason="install the docs extra")
    pytest.importorskip("material", reason="install the docs extra")
    import subprocess
    import sys

    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "mkdocs",
            "build",
            "--strict",
            "--quiet",
            "--site-dir",
            str(tmp_path / "site"),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        env={**__import__("os").environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert (tmp_path / "site" / "api" / "index.html").is_file()
    api = (tmp_path / "site" / "api" / "index.html").read_text(encoding="utf-8")
    assert "evaluate_claim" in api and "FigurePlot" in api  # rendered from the docstrings


def test_gallery_shows_every_thesis_figure_of_the_catalogue():
    from adaptive_ftc import list_scenarios, load_scenario

    page = (ROOT / "docs" / "gallery.md").read_text(encoding="utf-8")
    for name in list_scenarios():
        for spec in load_scenario(name).figure_specs:
            assert f"**Fig. {spec['number']}**" in page, spec["number"]
    for img in re.findall(r"\]\((gallery/[^)]+)\)", page):
        assert (ROOT / "docs" / img).is_file(), img
