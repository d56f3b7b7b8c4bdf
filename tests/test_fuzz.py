"""Fuzz suite (issue 11): every input gives a result or the library's own error, quickly.

Short profile by default (a few seconds). Long profile on demand::

    AFTC_FUZZ=long python -m pytest -q tests/test_fuzz.py --hypothesis-show-statistics

(``AFTC_FUZZ_EXAMPLES=N`` sets the number of examples per test directly.) No simulation is
run: the loader, the expression parser and the command line are fuzzed; ``simulate`` is
replaced by a stub in the command-line test.
"""

from __future__ import annotations

import copy
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
from adaptive_ftc.scenarios.expressions import Expression  # noqa: E402

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


def _timed(fn, *args):
    start = time.perf_counter()
    try:
        fn(*args)
    except LIBRARY_ERRORS as exc:
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
    _timed(_load_dict, doc)


@PROFILE
@given(text=st.text(max_size=300), data=st.data())
def test_mutated_catalogue_text_gives_a_scenario_or_a_library_error(tmp_path, text, data):
    name = data.draw(st.sampled_from(sorted(CATALOG_DATA)))
    src = (loader.CATALOG / f"{name}.toml").read_text()
    at = data.draw(st.integers(min_value=0, max_value=len(src)))
    cut = data.draw(st.integers(min_value=0, max_value=40))
    f = tmp_path / "m.toml"
    f.write_text(src[:at] + text + src[at + cut :], encoding="utf-8")
    _timed(loader.load_scenario, f)


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
