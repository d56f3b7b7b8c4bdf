"""Fuzzed campaign specs (issue 26): any spec gives a campaign or a :class:`CampaignError`,
quickly, and a loaded campaign draws its members without raising.

Short profile by default (seconds); ``AFTC_FUZZ=long`` or ``AFTC_FUZZ_EXAMPLES=N`` as in
``tests/test_fuzz.py``. No simulation is run.
"""

from __future__ import annotations

import copy
import os
import time
import tomllib

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from adaptive_ftc.campaigns import CampaignError, draw_member, load_campaign  # noqa: E402
from adaptive_ftc.campaigns.spec import EXAMPLES, list_campaigns  # noqa: E402

_LONG = os.environ.get("AFTC_FUZZ", "") == "long"
_EXAMPLES = int(os.environ.get("AFTC_FUZZ_EXAMPLES", 3000 if _LONG else 40))
PROFILE = settings(
    max_examples=_EXAMPLES,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    derandomize=not _LONG,
)
TIME_BOUND = 5.0

TINY = {
    "name": "tiny",
    "base": "hypersonic-direct-s1",
    "designs": ["adaptive", "frozen"],
    "runs": 6,
    "seed": 7,
    "chunk_size": 2,
    "duration": 3.0,
    "success": {"rms_error_final": 0.01, "final_window": 1.0, "recovery_tolerance": 0.1},
    "failures": {
        "count": {"integers": [1, 2]},
        "actuators": [1, 2],
        "onset": {"uniform": [0.5, 2.5]},
        "ramp": {"choice": [0.0, 0.5], "weights": [3, 1]},
        "recovery_probability": 0.3,
        "duration": {"uniform": [0.2, 1.0]},
        "keep_base": False,
        "models": {
            "loss_of_effectiveness": {"effectiveness": {"normal": [0.5, 0.2], "clip": [0, 1]}},
            "stuck": {"value": {"uniform": [-0.2, 0.2]}, "weight": 0.5},
            "nonaffine": {
                "output": "{a}*u**3 + {c}",
                "params": {"a": {"uniform": [0.3, 1.0]}, "c": {"uniform": [-0.1, 0.1]}},
                "severity": "c",
            },
        },
    },
    "ranges": {
        "initial_state": [{"uniform": [0.0, 0.04]}, 0.0],
        "reference_amplitude": {"loguniform": [0.5, 2.0]},
        "gains": {"gamma": {"uniform": [0.5, 2.0]}},
    },
    "hardware": {
        "lag": {"uniform": [0.0, 0.05]},
        "rate_limit": [{"loguniform": [0.5, 10.0]}, 5.0],
        "travel": {"uniform": [0.3, 1.0]},
        "sample_time": {"choice": [0.0, 0.005]},
        "noise": {"alpha": {"uniform": [0.0, 1e-3]}},
    },
}
SEEDS = [TINY] + [tomllib.loads((EXAMPLES / f"{n}.toml").read_text()) for n in list_campaigns()]

_scalars = st.one_of(
    st.integers(min_value=-(10**30), max_value=10**30),
    st.sampled_from([0, -1, 1, 2, 2**63 - 1, 10**8, 10**15, 0.5, 1e300, -1e-12, 1e-300]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=20),
    st.sampled_from(
        ["{0}*u", "{a:>3000000000}*u", "{{a}}", "{b}*u", "u}", "adaptive", "frozen", "no"]
        + ["../../x", "/tmp/x", "hypersonic-direct-s1", "x.toml", "uniform", "normal"]
    ),
    st.booleans(),
)
_dists = st.one_of(
    st.fixed_dictionaries(
        {
            st.sampled_from(
                ["uniform", "loguniform", "normal", "integers", "choice", "constant"]
            ): (st.lists(_scalars, max_size=3))
        }
    ),
    st.fixed_dictionaries({"normal": st.lists(_scalars, max_size=3), "clip": st.lists(_scalars)}),
)
_values = st.recursive(
    st.one_of(_scalars, _dists),
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=3)
    ),
    max_leaves=8,
)


def _paths(data, prefix=()):
    yield prefix
    if isinstance(data, dict):
        for k, v in data.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            yield from _paths(v, prefix + (i,))


def _load_and_draw(data):
    try:
        spec = load_campaign(data)
    except CampaignError as exc:
        assert str(exc).strip() and "Traceback" not in str(exc)
        return
    for i in range(min(spec.runs, 3)):  # a loaded spec draws; a refused draw is recorded
        member = draw_member(spec, i)
        assert member.loop is not None or member.error


@PROFILE
@given(seed=st.sampled_from(range(len(SEEDS))), data=st.data(), n=st.integers(1, 4))
def test_fuzzed_campaign_specs_give_a_campaign_or_a_campaign_error(seed, data, n):
    doc = copy.deepcopy(SEEDS[seed])
    for _ in range(n):
        paths = [p for p in _paths(doc) if p]
        path = data.draw(st.sampled_from(paths))
        parent = doc
        for key in path[:-1]:
            parent = parent[key]
        action = data.draw(st.sampled_from(["drop", "set", "add"]))
        if action == "drop" and isinstance(parent, dict):
            parent.pop(path[-1], None)
        elif action == "add" and isinstance(parent, dict):
            parent[data.draw(st.text(max_size=8))] = data.draw(_values)
        else:
            parent[path[-1]] = data.draw(_values)
    start = time.perf_counter()
    _load_and_draw(doc)  # anything but CampaignError fails the test
    elapsed = time.perf_counter() - start
    assert elapsed < TIME_BOUND, f"took {elapsed:.1f} s"


@pytest.mark.parametrize("seed", range(len(SEEDS)))
def test_the_fuzz_seeds_themselves_load(seed):
    load_campaign(copy.deepcopy(SEEDS[seed]))
