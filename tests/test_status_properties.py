"""Property test (issue 26): a run whose failure pattern or reference goes non-finite at a random
time stops with status ``nonfinite``, its reason naming that expression and the time it went
non-finite, never ``step_underflow`` with the stiffness advice.

Small profile (a few examples, derandomised: seconds); ``AFTC_FUZZ=long`` for more. The
expressions keep a few structures with random numbers, so the compiled pattern modules are
shared between examples (numbers are data of the compiled loop)."""

from __future__ import annotations

import os
import warnings

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from adaptive_ftc import DivergenceWarning, RunStatus, load_scenario, simulate  # noqa: E402

_LONG = os.environ.get("AFTC_FUZZ", "") == "long"
PROFILE = settings(
    max_examples=200 if _LONG else 8,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    derandomize=not _LONG,
)

#: (where, template): ``{a}`` is the time the expression leaves its domain, ``{c}`` a scale
PATTERNS = [
    ("failure", "{c}*sqrt({a} - t)"),
    ("failure", "log({a} - t) + {c}"),
    ("failure", "u + {c}*sqrt({a} - t)"),
    ("reference", "0.05*sin(0.2*t) + {c}*sqrt({a} - t)"),
    ("reference", "0.05*sin(0.2*t) + {c}*log({a} - t)"),
]


@PROFILE
@given(
    kind=st.sampled_from(PATTERNS),
    a=st.floats(min_value=1.0, max_value=3.5).map(lambda v: round(v, 6)),
    c=st.floats(min_value=0.001, max_value=0.05).map(lambda v: round(v, 6)),
    method=st.sampled_from(["dopri5", "rodasp", "rk4"]),
)
def test_an_expression_going_non_finite_is_named_never_called_stiff(tmp_path, kind, a, c, method):
    where, template = kind
    text = template.format(a=a, c=c)
    body = 'extends = "hypersonic-direct-s1"\nname = "prop"\nduration = 4.0\nclaims = []\n'
    body += f'[solver]\nmethod = "{method}"\ndt = 0.001\n'
    if where == "failure":
        body += f'[[failures]]\nactuator = 2\nmodel = "stuck"\nonset = 0.5\nvalue = "{text}"\n'
    else:
        body += f'[reference]\noutputs = ["{text}"]\n'
    path = tmp_path / "prop.toml"
    path.write_text(body)
    sc = load_scenario(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        r = simulate(sc.loop, sc.solver)
    assert r.status == RunStatus.NONFINITE, r.message
    assert r.reason.expression == text, r.message
    assert r.reason.advice == "" and "rodasp" not in r.message
    # it went non-finite at a (to the step of the fixed-step method; a log's second
    # derivative c/(a - t)**2 passes the pole threshold 1e10 a few microseconds before a)
    assert r.reason.time == pytest.approx(a, abs=1.5e-3 if method == "rk4" else 2e-5)
