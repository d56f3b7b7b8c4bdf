"""Lanes by default (issue 29): ``lanes="auto"`` is the default of ``iter_simulate``,
``simulate_many`` and campaigns, with a policy (``sim/lanes.py``: ``auto_uses_lanes``,
``AUTO_COMPILE_MIN``, ``AUTO_GROUP_MIN``) that runs members in SIMD lanes only where they pay,
and the same results either way.

The truth is the same batch with ``lanes=False`` (every member its own single run). The policy
and the grouping are tested with a stand-in for ``integrate_lanes`` that integrates each member
alone and records the groups (nothing compiles); the default's equality with real lanes uses
the lane modules of ``test_lanes.py`` and ``test_lanes_dopri5.py`` (the same structure).
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc import SolverOptions
from adaptive_ftc.campaigns import load_campaign, run_campaign
from adaptive_ftc.campaigns.store import read_results
from adaptive_ftc.errors import ConfigurationError, DivergenceWarning
from adaptive_ftc.faults import Affine, Bias, LossOfEffectiveness, Stuck
from adaptive_ftc.sim import lanes
from adaptive_ftc.sim.batch import iter_simulate, simulate_many
from adaptive_ftc.sim.engine import CompiledLoop
from tests.lane_checks import assert_same_run, lane_base, reversed_elevators

RK4 = SolverOptions(method="rk4", dt=1e-3)


@pytest.fixture(scope="module")
def base():
    return lane_base()


def _members(base, n: int = 8) -> list:
    """``n`` members: failures at different times (every affine kind, a recovery), one
    diverging member (both elevators reversed), one shorter run."""
    fails = [
        (),
        (LossOfEffectiveness(actuator=1, onset=0.7, effectiveness=0.4),),
        (Bias(actuator=2, onset=0.25, bias=0.08, recovery=1.9),),
        (Stuck(actuator=1, onset=1.2345, value=0.05),),
        reversed_elevators(0.3),
        (Affine(actuator=2, onset=2.1, effectiveness=0.7, bias=-0.1),),
        (LossOfEffectiveness(actuator=2, onset=1.5005, effectiveness=0.0),),
        (Bias(actuator=1, onset=0.9, bias=-0.05),),
    ]
    loops = [replace(base, failures=fails[k % len(fails)]) for k in range(n)]
    loops[min(6, n - 1)] = replace(loops[min(6, n - 1)], t_final=2.2)
    return loops


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        return fn(*args, **kwargs)


@pytest.fixture
def groups(monkeypatch):
    """The lane groups run (their sizes), with each member integrated alone instead of in a
    compiled lane module (the grouping and policy without compiling anything)."""
    seen: list[int] = []

    def each_alone(compiled, *args, **kwargs):
        seen.append(len(compiled))
        assert not kwargs.get("lean")  # these tests run full signals
        return [cl.integrate() for cl in compiled]

    monkeypatch.setattr(lanes, "integrate_lanes", each_alone)
    return seen


def _state(monkeypatch, state: str) -> None:
    monkeypatch.setattr(lanes, "lane_module_state", lambda *a, **k: state)


# ----------------------------------------------------------------------------- the policy
def test_the_default_is_auto_and_a_small_batch_does_not_compile(base, monkeypatch, groups):
    """With no lane module compiled, a batch of 8 members (far below AUTO_COMPILE_MIN) runs
    one member at a time: no lane group, and the results of lanes=False."""
    _state(monkeypatch, "absent")
    loops = _members(base)
    got = _quiet(simulate_many, loops, RK4, jobs=2)
    assert groups == []
    for a, b in zip(got, _quiet(simulate_many, loops, RK4, jobs=2, lanes=False), strict=True):
        assert_same_run(a, b)


def test_a_compiled_lane_module_or_a_large_batch_turns_lanes_on(base, monkeypatch):
    cl = CompiledLoop.build(base, RK4)
    need = lanes.AUTO_COMPILE_MIN[("rk4", False)]
    _state(monkeypatch, "absent")
    assert not lanes.auto_uses_lanes(cl, None)  # a stream of unknown length
    assert not lanes.auto_uses_lanes(cl, need - 1)
    assert lanes.auto_uses_lanes(cl, need)
    # a campaign's lean DOPRI5 members save less each: more of them repay the compile
    assert lanes.AUTO_COMPILE_MIN[("dopri5", True)] > lanes.AUTO_COMPILE_MIN[("dopri5", False)]
    for state in ("cached", "loaded"):
        _state(monkeypatch, state)
        assert lanes.auto_uses_lanes(cl, None)
        assert lanes.auto_uses_lanes(cl, 1)


def test_rk4_members_recorded_every_step_stay_one_at_a_time(base, monkeypatch):
    """RK4 lanes write their records per lane: with a record every step they are slower
    than one at a time, so "auto" keeps such members on the single path, however many and
    whether or not the lane module is compiled (lanes=True still runs them in lanes)."""
    _state(monkeypatch, "loaded")
    steps = lanes.RK4_RECORD_STEPS
    every = CompiledLoop.build(base, replace(RK4, record_dt=RK4.dt * (steps - 1)))
    sparse = CompiledLoop.build(base, replace(RK4, record_dt=RK4.dt * steps))
    assert not lanes.auto_uses_lanes(every, 10**9)
    assert lanes.auto_uses_lanes(sparse, 1)
    dopri5 = CompiledLoop.build(base, SolverOptions(method="dopri5", record_dt=1e-3))
    assert lanes.auto_uses_lanes(dopri5, 1)  # DOPRI5 records from its dense output


def test_a_group_runs_in_lanes_only_when_full_enough(base, monkeypatch, groups):
    """AUTO_GROUP_MIN members or more: one lane group; fewer: one at a time. lanes=True runs
    any group in lanes."""
    _state(monkeypatch, "loaded")
    least = lanes.auto_group_min("rk4")
    assert 1 < least <= lanes.LANE_WIDTH
    _quiet(simulate_many, _members(base, least - 1), RK4, jobs=1)
    assert groups == []
    _quiet(simulate_many, _members(base, least), RK4, jobs=1)
    assert groups == [least]
    _quiet(simulate_many, _members(base, 2), RK4, jobs=1, lanes=True)
    assert groups == [least, 2]


def test_interleaved_members_fill_whole_groups_in_input_order(base, monkeypatch, groups):
    """Members of one structure with members that cannot run in lanes between them (a
    failure pattern of t, as a campaign's ineligible design between its eligible ones): the
    eligible ones still fill groups of 8, and every result comes back in input order."""
    _state(monkeypatch, "loaded")
    pattern = replace(base, failures=(Stuck(actuator=2, onset=0.5, value="0.1 + 0.05*t"),))
    eligible = _members(base, 19)
    loops = []
    for loop in eligible:
        loops += [loop, pattern]

    def reduce(r):
        return (r.status, r.states[-1].copy(), r.time[-1])

    got = _quiet(list, iter_simulate(loops, RK4, jobs=2, reduce=reduce))
    assert groups == [8, 8]  # the last 3 are too few: one at a time
    want = _quiet(list, iter_simulate(loops, RK4, jobs=2, reduce=reduce, lanes=False))
    assert len(got) == len(want) == 38
    for (s1, x1, t1), (s2, x2, t2) in zip(got, want, strict=True):
        assert s1 == s2 and t1 == t2
        np.testing.assert_array_equal(x1, x2)


def test_a_lane_group_the_engine_refuses_runs_one_at_a_time_under_auto(base, monkeypatch):
    """The default must not break a batch that lanes=False runs: a lane group that the lane
    engine refuses (here every one) warns and runs its members alone; lanes=True raises."""
    _state(monkeypatch, "loaded")

    def refuse(compiled, *args, **kwargs):
        raise ConfigurationError("The lane form disagrees (a stand-in).")

    monkeypatch.setattr(lanes, "integrate_lanes", refuse)
    loops = _members(base)
    with pytest.warns(RuntimeWarning, match="stand-in.*one at a time"):
        got = _quiet(simulate_many, loops, RK4, jobs=2)
    for a, b in zip(got, _quiet(simulate_many, loops, RK4, jobs=2, lanes=False), strict=True):
        assert_same_run(a, b)
    with pytest.raises(ConfigurationError, match="stand-in"):
        _quiet(simulate_many, loops, RK4, jobs=2, lanes=True)


def test_expected_members_is_checked(base):
    with pytest.raises(ConfigurationError, match="expected_members"):
        simulate_many([base], RK4, expected_members=-1)
    with pytest.raises(ConfigurationError, match="expected_members"):
        list(iter_simulate([base], RK4, expected_members=2.5))  # type: ignore[arg-type]


def test_a_lane_module_that_compiles_is_announced_once(base, monkeypatch, capsys):
    """One line on stderr before a lane module that is not in the disk cache compiles (the
    single path's 'compiling ...' line of the command-line tools); none when it loads."""
    from adaptive_ftc.sim import codegen

    cl = CompiledLoop.build(base, RK4)
    monkeypatch.setattr(lanes, "_modules", {})
    monkeypatch.setattr(lanes, "_announced", set())
    monkeypatch.setattr(codegen, "load_module", lambda *a, **k: object())
    monkeypatch.setattr(codegen, "is_cached", lambda *a, **k: True)
    lanes.lane_module(cl.loop, cl.asm, method="rk4")
    assert capsys.readouterr().err == ""
    monkeypatch.setattr(lanes, "_modules", {})
    monkeypatch.setattr(codegen, "is_cached", lambda *a, **k: False)
    lanes.lane_module(cl.loop, cl.asm, method="dopri5")
    monkeypatch.setattr(lanes, "_modules", {})
    lanes.lane_module(cl.loop, cl.asm, method="dopri5")  # the same module: announced already
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1
    assert err[0].startswith("compiling the SIMD lane module of ")
    assert "dopri5" in err[0] and "first use on this machine only" in err[0]


# ----------------------------------------------------------------------------- real lanes
def test_simulate_many_by_default_equals_lanes_false_bit_for_bit(base, monkeypatch):
    """A batch that repays the compile (expected_members) runs its RK4 members in one real
    lane group by default: each result equals the lanes=False one bit for bit, the diverging
    member and the shorter run included."""
    sizes: list[int] = []
    real = lanes.integrate_lanes

    def counted(compiled, *args, **kwargs):
        sizes.append(len(compiled))
        return real(compiled, *args, **kwargs)

    monkeypatch.setattr(lanes, "integrate_lanes", counted)
    loops = _members(base)
    need = lanes.AUTO_COMPILE_MIN[("rk4", False)]
    got = _quiet(simulate_many, loops, RK4, jobs=2, expected_members=need)
    assert sizes == [8]
    want = _quiet(simulate_many, loops, RK4, jobs=2, lanes=False)
    assert {r.status for r in want} == {"completed", "diverged"}
    for a, b in zip(got, want, strict=True):
        assert_same_run(a, b)


#: a campaign whose members fail at different times, some of them diverging (a reversed
#: elevator), beside an ineligible design (the nominal inverse) between its eligible members
CAMPAIGN = {
    "name": "lanes-default",
    "base": "hypersonic-direct-s1",
    "designs": ["adaptive", "nominal-inverse"],
    "runs": 16,
    "seed": 3,
    "chunk_size": 16,
    "duration": 4.0,
    "success": {"rms_error_final": 8.7e-4, "final_window": 1.0},
    "failures": {
        "count": {"integers": [1, 2]},
        "onset": {"uniform": [0.2, 3.0]},
        "models": {
            "affine": {"effectiveness": {"uniform": [-1.0, 1.0]}, "bias": {"uniform": [-0.1, 0.1]}}
        },
    },
}


def test_a_campaign_by_default_equals_lanes_false_bit_for_bit(tmp_path, monkeypatch):
    """A campaign whose runs repay the compile (AUTO_COMPILE_MIN lowered to its 16 runs)
    runs its DOPRI5 members in a real lane queue by default; its table equals the
    lanes=False table, every column (diverged members and failures at different times
    included)."""
    sizes: list[tuple[int, bool]] = []
    real = lanes.integrate_lanes

    def counted(compiled, *args, **kwargs):
        sizes.append((len(compiled), bool(kwargs.get("lean"))))
        return real(compiled, *args, **kwargs)

    monkeypatch.setattr(lanes, "integrate_lanes", counted)
    spec = load_campaign(CAMPAIGN)
    assert spec.solver.method == "dopri5"
    monkeypatch.setitem(lanes.AUTO_COMPILE_MIN, ("dopri5", True), spec.runs)
    run_campaign(spec, tmp_path / "default", jobs=2, progress=False, summary=False)
    # the campaign's lean signals, in the lanes: its 16 DOPRI5 members in one refilled queue
    assert sizes == [(16, True)] and lanes.QUEUE_MEMBERS["dopri5"] == 16
    run_campaign(spec, tmp_path / "off", jobs=2, progress=False, summary=False, lanes=False)
    assert len(sizes) == 1
    a, b = read_results(tmp_path / "default"), read_results(tmp_path / "off")
    timing = [c for c in a.columns if "wall" in c]  # the runs' own timings differ
    adaptive = b[b["design"] == "adaptive"]
    assert {"completed", "diverged"} <= set(adaptive["status"])
    assert a.drop(columns=timing).equals(b.drop(columns=timing))


@pytest.mark.parametrize(("flag", "lanes_arg"), [(None, "auto"), ("off", False), ("on", True)])
def test_aftc_campaign_lanes_flag_reaches_the_runner(tmp_path, monkeypatch, flag, lanes_arg):
    """``aftc campaign --lanes auto|on|off`` passes "auto" (the default), True or False."""
    from types import SimpleNamespace

    from adaptive_ftc.campaigns import runner
    from adaptive_ftc.cli import main as aftc

    seen = {}

    def fake_run(spec, out, **kwargs):
        seen.update(kwargs)
        return SimpleNamespace(
            runs_done_now=0, runs_resumed=0, runs_total=1, wall_time_s=0.0, complete=False, out=out
        )

    monkeypatch.setattr(runner, "run_campaign", fake_run)  # the command imports it on use
    argv = ["campaign", "hypersonic-loe", "--out", str(tmp_path / "o"), "--quiet"]
    assert aftc(argv + ([] if flag is None else ["--lanes", flag])) == 0
    assert seen["lanes"] == lanes_arg
