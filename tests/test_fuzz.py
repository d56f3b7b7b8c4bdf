"""Fuzz suite (issue 11): every input gives a result or the library's own error, quickly.

Short profile by default (a few seconds). Long profile on demand::

    AFTC_FUZZ=long python -m pytest -q tests/test_fuzz.py --hypothesis-show-statistics

(``AFTC_FUZZ_EXAMPLES=N`` sets the number of examples per test directly.) No simulation is
run: the loader, the expression parser and the command line are fuzzed; ``simulate`` is
replaced by a stub in the command-line test.
"""

from __future__ import annotations

import copy
import math
import os
import time
import tomllib
from pathlib import Path

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from adaptive_ftc import errors  # noqa: E402
from adaptive_ftc.scenarios import loader  # noqa: E402
from adaptive_ftc.scenarios.expressions import FUNCTIONS, Expression  # noqa: E402

_LONG = os.environ.get("AFTC_FUZZ", "") == "long"
_EXAMPLES = int(os.environ.get("AFTC_FUZZ_EXAMPLES", 3000 if _LONG else 30))
PROFILE = settings(
    max_examples=_EXAMPLES,
    deadline=None,  # the per-example time bound is asserted below (fair on a loaded machine)
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    derandomize=not _LONG,
)
#: Largest time one input may take (loader, parser, CLI), seconds.
TIME_BOUND = 5.0
LIBRARY_ERRORS = (
    errors.ScenarioError,
    errors.ConfigurationError,
    errors.ExpressionError,
)
CATALOG_DATA = {
    name: tomllib.loads((loader.CATALOG / f"{name}.toml").read_text())
    for name in loader.list_scenarios()
}

_scalars = st.one_of(
    st.integers(min_value=-(10**320), max_value=10**320),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -1, 1, 1e-200, 1e300, -1e-12, 2**63, 0.5]),
    st.text(max_size=30),
    st.sampled_from(["-" * 992 + "t", "t*" * 300 + "t", "u**3", "sin(t", "__import__", "x9"]),
    st.booleans(),
)
_values = st.recursive(
    _scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=6), st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=12,
)


def _paths(data, prefix=()):
    yield prefix
    if isinstance(data, dict):
        for k, v in data.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            yield from _paths(v, prefix + (i,))


def _load_dict(data: dict) -> None:
    """The loader on an already-parsed file (what tomllib gives for any TOML text)."""
    path = Path("fuzz.toml")
    ctx = loader._Ctx(path)
    try:
        loader._load(data, "", path, ctx)
    except loader._Problems:
        ctx.raise_if_any()
        raise AssertionError("_Problems without a recorded problem") from None


def _timed(fn, *args, allowed=LIBRARY_ERRORS):
    start = time.perf_counter()
    try:
        fn(*args)
    except allowed as exc:
        assert str(exc).strip(), "empty error message"
        assert "Traceback" not in str(exc)
    elapsed = time.perf_counter() - start
    assert elapsed < TIME_BOUND, f"took {elapsed:.1f} s"


@PROFILE
@given(
    name=st.sampled_from(sorted(CATALOG_DATA)),
    data=st.data(),
    mutations=st.integers(min_value=1, max_value=4),
)
def test_mutated_catalogue_files_give_a_scenario_or_a_library_error(name, data, mutations):
    doc = copy.deepcopy(CATALOG_DATA[name])
    doc.pop("extends", None)
    if "extends" in CATALOG_DATA[name]:
        base = copy.deepcopy(CATALOG_DATA[CATALOG_DATA[name]["extends"]])
        doc = loader._merge(base, doc)
    doc["duration"] = min(float(doc.get("duration", 1.0)), 1.0)
    for _ in range(mutations):
        paths = [p for p in _paths(doc) if p]
        path = data.draw(st.sampled_from(paths))
        parent = doc
        for key in path[:-1]:
            parent = parent[key]
        if data.draw(st.booleans()) and isinstance(parent, dict):
            parent.pop(path[-1], None)
        else:
            parent[path[-1]] = data.draw(_values)
    _timed(_load_dict, doc, allowed=errors.ScenarioError)  # the loader's own error only


@PROFILE
@given(text=st.text(max_size=300), data=st.data())
def test_mutated_catalogue_text_gives_a_scenario_or_a_library_error(tmp_path, text, data):
    name = data.draw(st.sampled_from(sorted(CATALOG_DATA)))
    src = (loader.CATALOG / f"{name}.toml").read_text()
    at = data.draw(st.integers(min_value=0, max_value=len(src)))
    cut = data.draw(st.integers(min_value=0, max_value=40))
    f = tmp_path / "m.toml"
    f.write_text(src[:at] + text + src[at + cut :], encoding="utf-8")
    _timed(loader.load_scenario, f, allowed=errors.ScenarioError)


_TOKENS = st.sampled_from(
    ["t", "u", "x1", "x2", "pi", "e", "1", "0", "2.5", "1e308", "9" * 40, "+", "-", "*", "/"]
    + ["**", "(", ")", ",", "sin(", "exp(", "log(", "sqrt(", "min(", "clip(", "atan2(", " "]
    + ["abs(", "sign(", "[", "a.b", "lambda", "'s'", "<", "==", "%", "@", "t[0]", "--"]
)


@PROFILE
@given(
    pieces=st.lists(_TOKENS, max_size=60) | st.text(max_size=200).map(lambda s: [s]),
    var=st.sampled_from(["t", "u", "x1"]),
)
def test_random_expressions_parse_differentiate_and_evaluate_or_raise_expression_error(pieces, var):
    import numpy as np

    def go():
        expr = Expression("".join(pieces), ("t", "u", "x1", "x2"))
        d = expr.derivative(var)
        with np.errstate(all="ignore"):
            d(t=np.linspace(0, 1, 3), u=0.5, x1=0.1, x2=-0.2)
        str(d)

    _timed(go)


_ARGS = st.sampled_from(
    ["list", "validate", "run", "reproduce", "schema", "--out", "--dt", "--jobs", "--decimate"]
    + ["--method", "rk4", "bogus", "nan", "-1", "0", "1e-300", "1e300", "x", "", "--quick"]
    + ["hypersonic-direct-s1", "wingrock-free-1deg", "/nonexistent.toml", "--no-baselines"]
    + ["--help", "--version", "--float32", "--csv", "--quiet", "\x00", "/etc/passwd"]
)


@PROFILE
@given(argv=st.lists(_ARGS, max_size=7))
def test_cli_arguments_give_an_exit_status_never_an_internal_error(tmp_path, argv, capsys):
    from adaptive_ftc import cli, reproduce
    from adaptive_ftc.sim import engine

    def no_simulation(loop, solver=None, **kwargs):
        raise errors.ConfigurationError("fuzz: simulation skipped")

    def no_reproduction(out, **kwargs):
        raise errors.ConfigurationError("fuzz: reproduction skipped")

    argv = [str(tmp_path / "out") if a == "--out-dir" else a for a in argv]
    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(tmp_path)
        mp.setattr(engine, "simulate", no_simulation)
        mp.setattr(reproduce, "run_reproduction", no_reproduction)
        start = time.perf_counter()
        code = cli.main(argv)
        assert time.perf_counter() - start < TIME_BOUND
    err = capsys.readouterr().err
    assert code in (0, 2, 3, 4, 5, 130), (argv, code, err)
    assert "internal error" not in err and "Traceback" not in err, (argv, err)


# ------------------------------------------------------------------ issue 26: validation
_CONST_LEAVES = st.one_of(
    st.integers(min_value=-(10**30), max_value=10**30).map(str),
    st.floats(min_value=-1e120, max_value=1e120, allow_nan=False).map(repr),
    st.sampled_from(["0", "1", "-1", "9", "10", "0.5", "1e-300", "1e99", "pi", "e", "9" * 60]),
)


def _const_tree(leaves):
    unary = [n for n, k in FUNCTIONS.items() if k == 1]
    return st.recursive(
        leaves,
        lambda inner: st.one_of(
            st.tuples(inner, st.sampled_from(["+", "-", "*", "/", "**"]), inner).map(
                lambda x: f"({x[0]}){x[1]}({x[2]})"
            ),
            st.tuples(st.sampled_from(unary), inner).map(lambda x: f"{x[0]}({x[1]})"),
            st.tuples(st.sampled_from(["min", "max", "atan2"]), inner, inner).map(
                lambda x: f"{x[0]}({x[1]}, {x[2]})"
            ),
            inner.map(lambda x: f"-({x})"),
        ),
        max_leaves=8,
    )


@PROFILE
@given(text=_const_tree(_CONST_LEAVES), scale=st.sampled_from(["", "t*", "u + "]))
def test_constant_expressions_are_finite_numbers_or_refused(text, scale):
    """A sub-expression of constants is folded at parse time (float arithmetic, bounded
    time: 9**9**9 builds no big integer) to a finite number, or refused naming it."""
    start = time.perf_counter()
    try:
        expr = Expression(scale + text, ("t", "u"))
    except errors.ExpressionError as exc:
        assert str(exc).startswith("Bad expression"), exc
    else:
        assert _constants_folded(expr.node), (scale + text, expr.node)
    assert time.perf_counter() - start < TIME_BOUND


def _constants_folded(node) -> bool:
    """Every constant is a finite number of magnitude <= 1e100, and no operation or call
    has only constants left as operands (they were folded)."""
    kind = node[0]
    if kind == "const":
        return math.isfinite(node[1]) and abs(node[1]) <= 1e100
    if kind == "var":
        return True
    parts = [node[1]] if kind == "neg" else list(node[2:4]) if kind == "bin" else list(node[2])
    if all(p[0] == "const" for p in parts):
        return False
    return all(_constants_folded(p) for p in parts)


_STAGE_PATHS = [
    ("figure",),
    ("claims",),
    ("solver",),
    ("digital",),
    ("plant", "initial_state"),
    ("controller", "allocation"),
    ("reference", "outputs"),
    ("failures",),
    ("sensors",),
    ("actuators",),
]


@PROFILE
@given(
    name=st.sampled_from(sorted(CATALOG_DATA)),
    where=st.lists(st.sampled_from(_STAGE_PATHS), min_size=1, max_size=4),
    data=st.data(),
)
def test_fuzzed_stage_tables_are_refused_only_as_scenario_errors(name, where, data):
    """Every stage the loader runs on a file with problems (figures, claims, solver checks,
    the plant-level checks, the loop's expressions, compensability) reports through the
    loader's own error, whatever the values."""
    doc = copy.deepcopy(CATALOG_DATA[name])
    if "extends" in doc:
        doc = loader._merge(copy.deepcopy(CATALOG_DATA[doc.pop("extends")]), doc)
    doc["duration"] = min(float(doc.get("duration", 1.0)), 1.0)
    for path in where:
        parent = doc
        for key in path[:-1]:
            parent = parent.setdefault(key, {})
        value = data.draw(
            st.one_of(
                _values,
                st.lists(
                    st.dictionaries(
                        st.sampled_from(
                            [
                                "kind",
                                "outputs",
                                "zoom",
                                "text",
                                "window",
                                "threshold",
                                "bound",
                                "number",
                                "x",
                            ]
                        ),
                        _values,
                        max_size=4,
                    ),
                    max_size=3,
                ),
                st.dictionaries(
                    st.sampled_from(
                        ["filter_tau", "divergence_bound", "sample_time", "method", "sdot", "dt"]
                    ),
                    _scalars,
                    max_size=3,
                ),
            )
        )
        parent[path[-1]] = value
    start = time.perf_counter()
    try:
        _load_dict(doc)
    except errors.ScenarioError as exc:
        assert str(exc).strip() and "Traceback" not in str(exc)
    assert time.perf_counter() - start < TIME_BOUND


@PROFILE
@given(unset=st.one_of(_values, st.lists(st.text(max_size=20), max_size=4)))
def test_unset_values_give_a_scenario_or_a_scenario_error(tmp_path, unset):
    import json

    f = tmp_path / "u.toml"
    f.write_text(
        f'extends = "hypersonic-direct-s1"\nduration = 1.0\nunset = {json.dumps(unset)}\n',
        encoding="utf-8",
    )
    try:
        loader.load_scenario(f)
    except errors.ScenarioError as exc:
        assert str(exc).strip()
