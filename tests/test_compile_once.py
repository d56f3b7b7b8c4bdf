"""A first run compiles each integrator helper once, and no entry wrapper it does not need.

numba types a variable assigned a literal ``0`` as ``Literal[int](0)`` where it is first
passed to a compiled (not inlined) function, and compiles that function for it as well as for
``int64``: the adaptive integrators' step loop (``_steps_dopri5``) was compiled twice on every
first run, about 2 s of CPU (benchmarks/bench_compile_events.py). The helpers that only
compiled code calls compile without numba's Python and C entry wrappers (the code that
unboxes each argument from Python objects and boxes the result: nothing calls it, and a first
run would lower and optimise it for every helper). Checked in a fresh process with empty
caches (the code must compile here, not load from disk).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"

_CHILD = """
import collections, json
from dataclasses import replace
from numba.core import event

counts = collections.Counter()

class _Count(event.Listener):
    def on_start(self, ev):
        counts[ev.data["dispatcher"].py_func.__name__] += 1

    def on_end(self, ev):
        pass

event.register("numba:compile", _Count())
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim.engine import simulate

sc = load_scenario("hypersonic-direct-s1")
res = simulate(replace(sc.loop, t_final=1.0), replace(sc.solver, method="dopri5"))
assert res.status == "completed", res.status
print("COUNTS " + json.dumps(counts))

# which compiled functions have a Python entry point (numba's wrapper symbol)
from adaptive_ftc.sim.compose import integrators

mod = integrators()
wrapped = {}
for name in ("integrate_dopri5", "_steps_dopri5", "_h_start", "_work_explicit", "_records_at",
             "rhs", "leaves_envelope"):
    for cres in getattr(mod, name).overloads.values():
        wrapped[name] = bool(cres.library.get_pointer_to_function(
            cres.fndesc.llvm_cpython_wrapper_name))
# the plant's control gain (a module of its own per plant), called by address only
import sys

for modname, gain in list(sys.modules.items()):
    if modname.startswith("adaptive_ftc_gain_"):
        for cres in gain.control_gain.overloads.values():
            wrapped["control_gain"] = bool(cres.library.get_pointer_to_function(
                cres.fndesc.llvm_cpython_wrapper_name))
print("WRAPPED " + json.dumps(wrapped))
"""


@pytest.fixture(scope="module")
def first_run(tmp_path_factory) -> str:
    """The child's output: one fresh process with empty caches (compiling takes a while)."""
    tmp = tmp_path_factory.mktemp("first-run")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(SRC), env.get("PYTHONPATH", "")])
    env["ADAPTIVE_FTC_CACHE_DIR"] = str(Path(tmp) / "loops")
    env["NUMBA_CACHE_DIR"] = str(Path(tmp) / "numba")
    env.pop("NUMBA_DISABLE_JIT", None)
    return subprocess.run(
        [sys.executable, "-c", _CHILD], env=env, capture_output=True, text=True, check=True
    ).stdout


def _printed(tag: str, out: str) -> dict:
    return json.loads(out.split(f"{tag} ", 1)[1].splitlines()[0])


def test_adaptive_step_loop_compiles_once(first_run: str) -> None:
    counts = _printed("COUNTS", first_run)
    assert counts["_steps_dopri5"] == 1, counts
    assert counts["_records_at"] == 1, counts


def test_helpers_only_compiled_code_calls_have_no_python_entry(first_run: str) -> None:
    wrapped = _printed("WRAPPED", first_run)
    assert wrapped.pop("integrate_dopri5") is True  # the entry point Python calls has one
    assert len(wrapped) == 7, wrapped  # each helper compiled in this run
    assert not any(wrapped.values()), wrapped


def test_dopri5_compiles_only_its_own_scratch(first_run: str) -> None:
    """A DOPRI5 run allocates :class:`WorkExplicit` (13 rows of one block), not the
    Rosenbrock methods' :class:`Work` of 23 arrays: ``_work`` and its allocations are not
    compiled (less to type, lower and optimise on a first run)."""
    counts = _printed("COUNTS", first_run)
    assert counts["_work_explicit"] == 1, counts
    assert "_work" not in counts, counts


def test_work_explicit_holds_what_the_dopri5_steps_read():
    """The fields of :class:`WorkExplicit` are :class:`Work`'s that the Dormand-Prince code
    (its steps, dense output, the step loop and the initial step) reads, in Work's order."""
    import ast

    from adaptive_ftc.sim.templates import adaptive

    tree = ast.parse(adaptive.template_text())
    used: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef) and (
            node.name.startswith("_dopri5") or node.name == "_steps_dopri5"
        ):
            used |= {
                a.attr
                for a in ast.walk(node)
                if isinstance(a, ast.Attribute)
                and isinstance(a.value, ast.Name)
                and a.value.id == "w"
            }
    fields = adaptive.WorkExplicit._fields
    assert set(fields) == used
    assert list(fields) == [f for f in adaptive.Work._fields if f in used]


def test_the_scratch_is_a_few_allocations_of_few_kinds():
    """numba compiles one implementation per kind of allocation (``np.empty`` of each number
    of dimensions and dtype, ``np.zeros``, ``np.full``, ``copy``): the integrators' scratch
    (``_work``: 23 arrays, ``_work_explicit``: 13) are views of at most three allocations."""
    import ast

    from adaptive_ftc.sim.templates import adaptive

    tree = ast.parse(adaptive.template_text())
    calls: dict[str, list[str]] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef) and node.name in ("_work", "_work_explicit"):
            calls[node.name] = sorted(
                ast.unparse(c.func)
                for c in ast.walk(node)
                if isinstance(c, ast.Call)
                and isinstance(c.func, ast.Attribute)
                and (ast.unparse(c.func).startswith("np.") or c.func.attr == "copy")
            )
    assert calls == {"_work": ["np.empty"] * 3, "_work_explicit": ["np.empty"]}
