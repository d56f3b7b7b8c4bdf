"""Every docstring example of the package runs (issue 27, "doctests collected automatically
from every module"): each module under ``src/adaptive_ftc`` is found by walking the package,
so a new module's examples are tested without being listed anywhere."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import adaptive_ftc


def _modules() -> list[str]:
    names = [adaptive_ftc.__name__]
    prefix = adaptive_ftc.__name__ + "."
    names += [m.name for m in pkgutil.walk_packages(adaptive_ftc.__path__, prefix)]
    return sorted(names)


MODULES = _modules()


def test_every_module_is_collected():
    """The walk finds the modules of every subpackage (a guard against an empty list)."""
    for name in ("adaptive_ftc.expressions", "adaptive_ftc.sim.engine", "adaptive_ftc.studies"):
        assert name in MODULES


@pytest.mark.parametrize("module", MODULES)
def test_docstring_examples_run(module, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # an example that writes a file writes it here
    mod = importlib.import_module(module)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for test in finder.find(mod, module):
        runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples of {module} fail"
