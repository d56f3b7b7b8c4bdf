"""The documentation site (issue 28): an API entry for every public name, no raw Sphinx roles,
the scenario format complete against the loader's schema, one quoted first-run cost, and the
site in a real browser (headless Chromium) at 1400 px and 390 px."""

from __future__ import annotations

import importlib
import os
import pkgutil
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pagecheck
import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
sys.path.insert(0, str(DOCS / "hooks"))  # griffe_rst: the extension mkdocs.yml names

ROLE_RE = re.compile(r":(?:py:)?(?:class|func|meth|attr|data|mod|exc|obj|const|math|any):")


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    pytest.importorskip("mkdocs", reason="install the docs extra: pip install -e '.[docs]'")
    pytest.importorskip("mkdocstrings", reason="install the docs extra")
    pytest.importorskip("material", reason="install the docs extra")
    out = tmp_path_factory.mktemp("docs") / "site"
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet", "--site-dir", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return out


def public_names() -> set[str]:
    """``module.name`` for every name of ``adaptive_ftc.__all__`` and of the ``__all__`` of
    each public module directly under it."""
    import adaptive_ftc

    names = {f"adaptive_ftc.{n}" for n in adaptive_ftc.__all__}
    for info in pkgutil.iter_modules(adaptive_ftc.__path__):
        if info.name.startswith("_"):
            continue
        mod = importlib.import_module(f"adaptive_ftc.{info.name}")
        names |= {f"{mod.__name__}.{n}" for n in getattr(mod, "__all__", ())}
    return names


# ------------------------------------------------------------------------------ API reference
def test_every_public_name_has_an_entry_in_the_api_reference(site):
    page = (site / "api" / "index.html").read_text(encoding="utf-8")
    ids = set(re.findall(r'\bid="([^"]+)"', page))
    names = public_names()
    # the subpackages' names are there, not only the top-level ones
    assert {"adaptive_ftc.controllers.ConstraintAware", "adaptive_ftc.hardware.Actuators"} <= names
    assert {"adaptive_ftc.campaigns.run_campaign", "adaptive_ftc.studies.delay_margin"} <= names
    missing = sorted(names - ids)
    assert not missing, f"no API entry (HTML id) for {missing}"


def test_each_object_is_documented_once_and_linked_from_its_other_exports(site):
    page = (site / "api" / "index.html").read_text(encoding="utf-8")
    # DirectAdaptive is exported by adaptive_ftc and adaptive_ftc.controllers: one full entry
    headings = re.findall(r'<h\d id="([^"]*\.DirectAdaptive)" class="doc doc-heading"', page)
    assert headings == ["adaptive_ftc.controllers.DirectAdaptive"]
    top = re.search(r'<span id="adaptive_ftc\.DirectAdaptive"></span>\s*<a href="([^"]+)"', page)
    assert top and top.group(1) == "#adaptive_ftc.controllers.DirectAdaptive"


def test_no_raw_sphinx_roles_in_the_built_site(site):
    hits = []
    for page in site.rglob("*.html"):
        text = page.read_text(encoding="utf-8")
        for m in ROLE_RE.finditer(text):
            hits.append(f"{page.relative_to(site)}: ...{text[m.start() - 40 : m.end() + 40]!r}")
    assert not hits, "raw Sphinx roles in the site:\n" + "\n".join(hits[:20])


def test_no_raw_rst_directives_or_table_rules_in_the_api_page(site):
    page = (site / "api" / "index.html").read_text(encoding="utf-8")
    assert ".. math::" not in page
    assert not re.search(r"={4,} +={4,}", page)  # RST simple-table rules became tables


# --------------------------------------------------------------------- the griffe extension
@pytest.fixture(scope="module")
def hardware_module():
    griffe = pytest.importorskip("griffe", reason="install the docs extra")
    pkg = griffe.load("adaptive_ftc", search_paths=[str(ROOT / "src")])
    return pkg["hardware"]


@pytest.fixture(scope="module")
def griffe_rst():
    pytest.importorskip("griffe", reason="install the docs extra")
    return importlib.import_module("griffe_rst")


def test_roles_become_optional_cross_references_resolved_in_scope(griffe_rst, hardware_module):
    out = griffe_rst.rst_to_markdown(
        hardware_module,
        "See :class:`Actuators`, :func:`~adaptive_ftc.hardware.pade_realization` and "
        ":class:`scipy.integrate.OdeSolver`; :math:`x^2` and :mod:`.claims`.",
    )
    assert not ROLE_RE.search(out)
    # a name of the module's own scope resolves to its full path
    assert '<autoref identifier="adaptive_ftc.hardware.Actuators" optional>' in out
    assert "<code>Actuators</code>" in out
    # ~ shows the last component; a function gets ()
    assert '<autoref identifier="adaptive_ftc.hardware.pade_realization" optional>' in out
    assert "<code>pade_realization()</code>" in out
    # an outside name keeps its path (optional: plain code when the site does not have it)
    assert 'identifier="scipy.integrate.OdeSolver"' in out
    assert "<code>x^2</code>" in out
    assert 'identifier="adaptive_ftc.claims"' in out


def test_math_directive_tables_and_headings_become_markdown(griffe_rst, hardware_module):
    text = (
        "Intro::\n\n    code\n\nA rule\n------\n\n.. math:: a = b\n          + c\n\nafter\n\n"
        "=== ===\nx   y\n=== ===\n1   2\n3   4\n=== ===\n"
    )
    out = griffe_rst.rst_to_markdown(hardware_module, text)
    assert "Intro:\n" in out and "::" not in out
    assert "**A rule**" in out and "------" not in out
    assert "`a = b + c`" in out and ".. math" not in out
    assert "| x | y |\n| --- | --- |\n| 1 | 2 |\n| 3 | 4 |" in out


def test_bullet_bodies_are_indented_for_markdown(griffe_rst, hardware_module):
    text = "Parts:\n\n- one, with\n  a formula:\n\n  .. math:: x\n\n  more.\n- two\n\nAfter.\n"
    out = griffe_rst.rst_to_markdown(hardware_module, text)
    # the item's later blocks stay in the item (4 spaces), the next item starts a new one
    assert "- one, with\n    a formula:\n\n    `x`\n\n    more.\n\n- two\n\nAfter." in out


def test_numpy_section_names_keep_their_underlines(griffe_rst, hardware_module):
    text = "Parameters\n----------\nx\n    A number.\n\nA closing remark.\n"
    out = griffe_rst.rst_to_markdown(hardware_module, text)
    assert "Parameters\n----------\nx\n" in out
    # prose after the entries is not read as a parameter named "A"
    assert "Notes\n-----\nA closing remark." in out


# -------------------------------------------------------------------------- scenario format
def _toml_blocks(text: str) -> list[str]:
    return re.findall(r"```toml\n(.*?)```", text, flags=re.S)


def test_scenario_format_documents_every_top_level_key_plant_model_and_claim_kind():
    from adaptive_ftc.claims import CLAIM_KINDS
    from adaptive_ftc.plants import PLANTS
    from adaptive_ftc.scenarios.loader import scenario_schema

    page = (DOCS / "scenario-format.md").read_text(encoding="utf-8")
    toml = "\n".join(_toml_blocks(page))
    top = scenario_schema()["propertyNames"]["enum"]
    undocumented = [
        k for k in top if not re.search(rf"^(\[{k}\]|\[\[{k}\]\]|{k} =|# {k} =)", toml, flags=re.M)
    ]
    assert not undocumented, f"top-level keys/tables missing from the example: {undocumented}"
    models = [m for m in PLANTS if f'model = "{m}"' not in toml]
    assert not models, f"plant models without an example: {models}"
    assert "[controller.constraint_aware]" in toml and "delay" in toml
    kinds = [k for k in CLAIM_KINDS if k not in toml]
    assert not kinds, f"claim kinds not listed: {kinds}"
    assert "finding" in toml
    from adaptive_ftc.controllers import DESIGNS
    from adaptive_ftc.faults import FAILURE_MODELS
    from adaptive_ftc.plots import KINDS

    for what, names in (("design", DESIGNS), ("failure model", FAILURE_MODELS), ("figure", KINDS)):
        missing = [n for n in names if not re.search(rf"\b{re.escape(n)}\b", toml)]
        assert not missing, f"{what}s not listed in the example: {missing}"


def test_scenario_format_example_uses_the_catalogue_raw_firing_strengths():
    page = (DOCS / "scenario-format.md").read_text(encoding="utf-8")
    assert "normalised = true" not in "\n".join(_toml_blocks(page))


def _catalogue_with(model: str) -> str:
    from adaptive_ftc.scenarios.loader import CATALOG

    for path in sorted(Path(CATALOG).glob("*.toml")):
        data = tomllib.loads(path.read_text(encoding="utf-8"))
        if data.get("plant", {}).get("model") == model and "extends" not in data:
            return path.stem
    raise AssertionError(f"no catalogue scenario uses plant model {model!r}")


def test_every_plant_model_example_loads(tmp_path):
    from adaptive_ftc import load_scenario

    page = (DOCS / "scenario-format.md").read_text(encoding="utf-8")
    section = page.split("## Plant models", 1)[1]
    examples = [b for b in _toml_blocks(section) if "[plant]" in b]
    assert len(examples) >= 6
    for i, block in enumerate(examples):
        model = tomllib.loads(block)["plant"]["model"]
        if model == "equations":  # single output: open loop
            head = 'duration = 1.0\n[reference]\noutputs = ["0"]\n[controller]\ndesign = "none"\n'
        else:
            head = f'extends = "{_catalogue_with(model)}"\nunset = ["plant"]\n'
        path = tmp_path / f"plant{i}.toml"
        path.write_text(head + block, encoding="utf-8")
        scenario = load_scenario(path)
        assert scenario.loop.plant is not None, model


def test_tutorial_campaign_section_is_current():
    page = (DOCS / "tutorial.md").read_text(encoding="utf-8")
    section = page.split("## 4. Run a campaign", 1)[1].split("## 5.", 1)[0]
    assert "being added" not in section
    assert "aftc campaign" in section


# -------------------------------------------------------------------------- first-run cost
FIRST_RUN_NUMBER = re.compile(
    r"(first[- ]run|first (simulation|time)|empty cache|fresh install|cold|compil\w*|"
    r"whole thesis|full reproduction|takes about)[^.\n]{0,120}?"
    r"(\b\d+(\.\d+)?\s?((-|to)\s?\d+(\.\d+)?\s?)?s\b|minute)",
    flags=re.I,
)
#: what a page may quote: the compile cost of one part, not what a first run costs
ONE_PART = ("integrator", "per entry")


def test_one_page_states_the_first_run_cost_and_the_others_link_to_it():
    install = (DOCS / "installation.md").read_text(encoding="utf-8")
    first = install.split("## First run", 1)[1].split("\n## ", 1)[0]
    assert re.search(r"\*\*\d+ s\*\*", first)  # the number
    assert "benchmarks/bench_first_run.py" in first  # and the command that measures it
    assert (ROOT / "benchmarks" / "bench_first_run.py").is_file()
    quoted = []
    for page in DOCS.glob("*.md"):
        if page.name in ("installation.md", "performance.md"):
            # performance.md is the dated log of every measurement (history, by session);
            # installation.md states the current first-run cost
            continue
        text = " ".join(page.read_text(encoding="utf-8").split())
        for m in FIRST_RUN_NUMBER.finditer(text):
            if not any(w in text[m.start() : m.end() + 40] for w in ONE_PART):
                quoted.append(f"{page.name}: {m.group(0)}")
    assert not quoted, f"first-run costs quoted outside installation.md: {quoted}"
    tutorial = (DOCS / "tutorial.md").read_text(encoding="utf-8")
    assert "installation.md#first-run" in tutorial
    # the pattern finds the five costs the pages used to quote
    for old in (
        "The whole thesis at once (about a minute on two cores)",
        "The first simulation compiles the numba kernel (20-30 s on a small machine)",
        "a full reproduction from an empty cache takes about 38 s on 2 cores",
        "the first run after install took 13 s",
        "cold: 29 s",
    ):
        assert FIRST_RUN_NUMBER.search(old), old


# --------------------------------------------------------------------------- a real browser
def _require_browser() -> None:
    if pagecheck.find_chromium() is None:
        if os.environ.get("AFTC_REQUIRE_BROWSER") == "1":
            pytest.fail("AFTC_REQUIRE_BROWSER=1 but no chromium is installed")
        pytest.skip("no chromium on PATH (Debian: apt-get install chromium)")


def test_the_site_needs_no_network(site):
    remote = []
    for page in site.rglob("*.html"):
        text = page.read_text(encoding="utf-8")
        for m in re.finditer(r'<(?:link|script|img)[^>]+(?:href|src)="(https?:)?//[^"]+"', text):
            remote.append(f"{page.relative_to(site)}: {m.group(0)[:120]}")
    assert not remote, "pages load from the network:\n" + "\n".join(remote[:10])


@pytest.mark.parametrize("width", [1400, 390])
@pytest.mark.parametrize("page", ["index.html", "tutorial/index.html", "api/index.html"])
def test_docs_pages_in_a_real_browser(site, page, width):
    _require_browser()
    check = pagecheck.check_page(site / page, width, timeout=120)
    assert not check.problems(), "\n".join(check.problems())
