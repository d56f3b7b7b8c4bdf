"""The registry of solver methods (sim/solvers.py) is what every reader of method names uses."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from adaptive_ftc import SolverOptions
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim import solvers

ROOT = Path(__file__).resolve().parents[1]
BEGIN, END = "<!-- solver-methods:begin -->", "<!-- solver-methods:end -->"


def test_docs_table_is_the_registry():
    text = (ROOT / "docs" / "solvers.md").read_text(encoding="utf-8")
    table = text.split(BEGIN)[1].split(END)[0].strip()
    want = solvers.methods_table()
    assert table == want, "docs/solvers.md is out of date; the table should read:\n" + want


def test_cli_method_choices_are_the_registry():
    from adaptive_ftc.cli import _parser

    parser = _parser()
    run = next(a for a in parser._subparsers._group_actions[0].choices["run"]._actions
               if "--method" in a.option_strings)  # fmt: skip
    assert tuple(run.choices) == solvers.names()


def test_every_compiled_method_has_an_entry_point_in_the_shared_integrators():
    from adaptive_ftc.sim import compose
    from adaptive_ftc.sim.templates import adaptive

    source = compose._integrators_source()
    for entry in solvers.compiled_entries():
        assert f"\ndef {entry}(" in source, entry
    # the adaptive template's per-method cores are exactly the registry's adaptive methods
    assert {name for name, *_ in adaptive._CORES} == {
        solvers.method(n).entry for n in solvers.names("adaptive")
    }


@pytest.mark.parametrize("name", solvers.names())
def test_solver_options_accept_every_registered_method(name):
    m = solvers.method(name)
    assert SolverOptions(method=name).compiled_method == m.compiled
    assert (m.compiled is None) == (m.kind == "scipy")


def test_unknown_method_names_the_registered_ones():
    with pytest.raises(ConfigurationError, match="Did you mean 'rodasp'.*Use one of rk4, dopri5"):
        SolverOptions(method="rodas")


def test_a_newly_registered_method_is_accepted_without_touching_solver_options(monkeypatch):
    fast = solvers.SolverMethod(name="fast", kind="alias", alias_of="rk4", summary="RK4")
    monkeypatch.setattr(solvers, "METHODS", (*solvers.METHODS, fast))
    monkeypatch.setitem(solvers._BY_NAME, "fast", fast)
    assert SolverOptions(method="fast").compiled_method == "rk4"
    assert "fast" in solvers.names()


def test_method_declarations_are_checked():
    with pytest.raises(ConfigurationError, match="`kind` of SolverMethod 'x'"):
        solvers.SolverMethod(name="x", kind="implicit", summary="")
    with pytest.raises(ConfigurationError, match="`alias_of` exactly when"):
        solvers.SolverMethod(name="x", kind="alias", summary="")
    m = solvers.method("dopri5")
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.name = "y"  # type: ignore[misc]
