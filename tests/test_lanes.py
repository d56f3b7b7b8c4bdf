"""The lane engine (issue 29, stage 1; ``sim/lanes.py``): every member of a lane group gets
its own single run's result, bit for bit (states, adaptive states, signals, status and reason,
the integrator's counts), whatever the other lanes do.

The truth is :func:`simulate` of each member alone. Runs are a few seconds long: the cost is
compiling each lane module once (10-30 s on a loaded machine; cached on disk afterwards).
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc import SolverOptions, load_scenario, simulate
from adaptive_ftc.approximators import FuzzyBasis
from adaptive_ftc.errors import ConfigurationError, DivergenceWarning
from adaptive_ftc.faults import Affine, Bias, LossOfEffectiveness, Stuck
from adaptive_ftc.sim.batch import iter_simulate, simulate_many
from adaptive_ftc.sim.lanes import (
    LANE_WIDTH,
    _lane_level,
    ineligible,
    ineligible_reason,
    lane_source,
    simulate_lanes,
)
from tests.lane_checks import assert_same_run, lane_base, reversed_elevators, single_runs

RK4 = SolverOptions(method="rk4", dt=1e-3, record_dt=0.01)


@pytest.fixture(scope="module")
def base():
    return lane_base()


_reversed = reversed_elevators


_same = assert_same_run


def _singles(loops, solver=RK4):
    return single_runs(loops, solver)


def _members(base) -> list:
    """Eight members, failures at different times in different lanes, every affine kind,
    abrupt and incipient, with a recovery; one diverging lane; one member with other gains and
    another initial state (numbers read per lane)."""
    two = (
        Stuck(actuator=1, onset=1.2345, value=0.05),
        Affine(actuator=2, onset=2.1, effectiveness=0.7, bias=-0.1),
    )
    fails = [
        (),
        (LossOfEffectiveness(actuator=1, onset=0.7, effectiveness=0.4),),
        (Bias(actuator=2, onset=0.25, bias=0.08, recovery=1.9),),
        two,
        _reversed(0.3),
        (Affine(actuator=1, onset=0.5, effectiveness=0.3, bias=0.02, ramp=0.8),),
        (LossOfEffectiveness(actuator=2, onset=1.5005, effectiveness=0.0),),
        (),
    ]
    loops = [replace(base, failures=f) for f in fails]
    ctrl = replace(base.controller, gamma=3.0, k=4.0)
    loops[7] = replace(base, controller=ctrl, initial_state=(0.01, 0.02))
    return loops


def test_every_lane_equals_its_single_run(base):
    loops = _members(base)
    assert len(loops) == LANE_WIDTH
    singles = _singles(loops)
    assert [r.status for r in singles].count("diverged") == 1  # the reversed member
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DivergenceWarning)
        lanes = simulate_lanes(loops, RK4)
    assert sum(issubclass(w.category, DivergenceWarning) for w in caught) == 1
    for a, b in zip(lanes, singles, strict=True):
        _same(a, b)
    # the diverging lane stopped early at its own record, the others went on to the end
    div = lanes[4]
    assert div.time[-1] < 1.5 and div.reason.envelope
    assert all(r.time[-1] == pytest.approx(3.0) for k, r in enumerate(lanes) if k != 4)


def test_lanes_finishing_at_different_times_and_a_partial_group(base):
    """Three members (five padding lanes): different t_final and record grids, one stopping
    early by divergence."""
    loops = [
        replace(base, t_final=1.234),
        replace(base, t_final=2.5, failures=(Bias(actuator=1, onset=0.4, bias=-0.05),)),
        replace(base, failures=_reversed(0.2)),
    ]
    singles = _singles(loops)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        lanes = simulate_lanes(loops, RK4)
    assert len(lanes) == 3
    for a, b in zip(lanes, singles, strict=True):
        _same(a, b)
    assert lanes[0].time[-1] == pytest.approx(1.234)
    assert lanes[2].status == "diverged"


def test_more_members_than_lanes_run_in_groups_in_order(base):
    """simulate_lanes splits 10 members into groups of 8 and 2, results in input order."""
    loops = [
        replace(base, t_final=0.5, failures=(Bias(actuator=1, onset=0.05 * k, bias=0.01 * k),))
        for k in range(1, 11)
    ]
    for a, b in zip(simulate_lanes(loops, RK4), _singles(loops), strict=True):
        _same(a, b)


def test_a_lane_bad_from_its_initial_state(base):
    """A member whose initial state is already outside the envelope stops at once, alone."""
    loops = [replace(base, t_final=1.0), replace(base, t_final=1.0, initial_state=(2.0, 0.0))]
    singles = _singles(loops)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        lanes = simulate_lanes(loops, RK4)
    for a, b in zip(lanes, singles, strict=True):
        _same(a, b)
    assert lanes[1].status == "diverged" and lanes[0].status == "completed"


def test_iter_simulate_with_lanes_keeps_order_and_falls_back(base, monkeypatch):
    """lanes='auto': eligible members in lanes, the others (a failure pattern that is not
    affine; a regressor of another structure) one at a time; results in input order, reduced
    per member, equal to the single runs."""
    from adaptive_ftc.sim import lanes

    # "auto"'s policy would run a group of 5 RK4 members one at a time (AUTO_GROUP_MIN)
    monkeypatch.setitem(lanes.AUTO_GROUP_MIN, ("rk4", False), 2)
    pattern = (Stuck(actuator=2, onset=0.5, value="0.1 + 0.05*cos(0.5*t)"),)
    loops = _members(base)[:5]
    loops.insert(2, replace(base, failures=pattern))  # not affine: one at a time
    singles = _singles(loops)

    def reduce(r):
        return (r.status, r.states.copy(), r.adaptive.copy(), r.meta["steps"])

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        got = list(iter_simulate(loops, RK4, jobs=2, lanes="auto", reduce=reduce))
    assert len(got) == len(loops)
    for (status, states, adaptive, steps), b in zip(got, singles, strict=True):
        assert status == b.status
        np.testing.assert_array_equal(states, b.states)
        np.testing.assert_array_equal(adaptive, b.adaptive)
        assert steps == b.meta["steps"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        many = simulate_many(loops[:3], RK4, jobs=1, lanes="auto")
    for a, b in zip(many, singles[:3], strict=True):
        _same(a, b)


def test_lanes_with_lean_signals_equal_lean_single_runs(base):
    """A campaign asks for lean signals (errors and commands only): the lane path hands the
    flag on, so each member's lean result equals its lean single run and lacks the rest."""
    loops = _members(base)[:3]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        singles = [simulate(loop, RK4, lean_signals=True) for loop in loops]
        got = list(iter_simulate(loops, RK4, jobs=1, lanes=True, lean_signals=True))
    for a, b in zip(got, singles, strict=True):
        np.testing.assert_array_equal(a.states, b.states)
        np.testing.assert_array_equal(a.u_cmd, b.u_cmd)
        np.testing.assert_array_equal(a.u_f, b.u_f)
        assert np.isnan(a.control_gain).all()  # not computed in a lean run


def test_lanes_true_names_why_a_loop_cannot_run_in_lanes(base):
    with pytest.raises(ConfigurationError, match="fixed-step RK4 and DOPRI5 only.*'rodasp'"):
        list(iter_simulate([base], SolverOptions(method="rodasp"), jobs=1, lanes=True))
    pattern = replace(base, failures=(Stuck(actuator=2, onset=0.5, value="0.1*cos(t)"),))
    with pytest.raises(ConfigurationError, match="not affine in u.*lanes=False"):
        list(iter_simulate([base, pattern], RK4, jobs=1, lanes=True))
    with pytest.raises(ConfigurationError, match="`lanes` must be True, False or 'auto'"):
        list(iter_simulate([base], RK4, lanes="yes"))
    assert ineligible(base, RK4) is None
    assert ineligible(base, None) is None  # simulate's default solver is RK4
    assert ineligible_reason(pattern, RK4) is not None
    assert "s' only" in ineligible(base, replace(RK4, sdot="filtered"))
    wing = load_scenario("wingrock-direct-s1").loop
    assert "no lane form of its dynamics" in ineligible(wing, RK4)
    with pytest.raises(ConfigurationError, match="cannot run in SIMD lanes"):
        lane_source(wing, RK4)


def test_a_normalised_fuzzy_basis_and_frozen_adaptation_equal_their_single_runs(base):
    """Another structure: a normalised 1-input basis (the linear regressor runs in the
    equations-plant test below); one member with adaptation frozen."""
    regressor = FuzzyBasis(inputs=("alpha",), centers=(-0.5, 0.0, 0.5), width=0.5, normalised=True)
    ctrl = replace(base.controller, regressor=regressor, theta0=0.0)
    short = replace(base, controller=ctrl, t_final=1.5)
    loops = [
        short,
        replace(short, failures=(Bias(actuator=1, onset=0.3, bias=0.05),)),
        replace(short, adapt=False),
    ]
    singles = _singles(loops)
    for a, b in zip(simulate_lanes(loops, RK4), singles, strict=True):
        _same(a, b)


def test_the_slp_switch_is_on_only_while_a_lane_module_compiles():
    """numba's SLP vectoriser is off by default (numba PR #8852); the lane modules compile
    with it on and leave numba's setting as it was for everything else."""
    from numba.core import config

    before = config.SLP_VECTORIZE
    with _lane_level():
        assert config.SLP_VECTORIZE == 1
    assert config.SLP_VECTORIZE == before


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    """max over columns of max |a - b| / max |b| (the column's signal scale)."""
    scale = np.maximum(np.max(np.abs(b), axis=0), 1e-300)
    return float(np.max(np.max(np.abs(a - b), axis=0) / scale))


def test_vector_kernels_stay_within_1e12_of_the_single_runs(base):
    """Stage 1b (kernels='vector': call-free exp and tanh) is not bit-identical; every lane
    stays within 1e-12 of its single run's signal scale (measured 8.6e-15 over 120 s) with the
    same status and records."""
    loops = _members(base)
    singles = _singles(loops)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        lanes = simulate_lanes(loops, RK4, kernels="vector")
    worst = 0.0
    for a, b in zip(lanes, singles, strict=True):
        assert a.status == b.status
        np.testing.assert_array_equal(a.time, b.time)
        worst = max(worst, _relative(a.states, b.states), _relative(a.adaptive, b.adaptive))
    assert 0.0 < worst <= 1e-12  # not the libm path (> 0), within the bound
    with pytest.raises(ConfigurationError, match="`kernels` must be 'libm'.*got 'fast'"):
        simulate_lanes(loops[:1], RK4, kernels="fast")
    with pytest.raises(ConfigurationError, match="`kernels` must be"):
        list(iter_simulate(loops[:1], RK4, lanes=True, lane_kernels="fast"))


def test_the_call_free_kernels_against_libm():
    """vexp within 1 ulp of libm's exp on [-700, 700], vtanh within 2 ulp on [-20, 20]; nan
    stays nan; exp underflows to 0 below -708."""
    import math

    from numba import njit

    from adaptive_ftc.sim.lane_kernels import vexp, vtanh

    @njit
    def both(x, out):
        for i in range(x.size):
            out[0, i] = vexp(x[i])
            out[1, i] = vtanh(x[i])

    def ulps(a, b):
        ia, ib = a.view(np.int64), b.view(np.int64)
        ia = np.where(ia < 0, np.int64(-(2**63)) - ia, ia)
        ib = np.where(ib < 0, np.int64(-(2**63)) - ib, ib)
        return np.abs(ia - ib)

    rng = np.random.default_rng(1)
    for k, (lo, hi, limit, ref) in enumerate(
        [(-700.0, 700.0, 1, math.exp), (-20.0, 20.0, 2, math.tanh)]
    ):
        x = rng.uniform(lo, hi, 1 << 14)
        out = np.empty((2, x.size))
        both(x, out)
        libm = np.array([ref(v) for v in x])  # libm's, not numpy's own vector exp
        assert int(ulps(out[k], libm).max()) <= limit
    out = np.empty((2, 3))
    both(np.array([math.nan, -800.0, 0.0]), out)
    assert math.isnan(out[0, 0]) and math.isnan(out[1, 0])
    assert out[0, 1] == 0.0 and out[0, 2] == 1.0 and out[1, 2] == 0.0


def test_a_lane_form_that_drifts_from_its_part_is_refused(base):
    """Once per structure the lane rhs is checked against the single run's rhs; a lane form
    that disagrees (here: one that leaves the derivative rows untouched) is refused with an
    error that says what to do, not run."""
    from types import SimpleNamespace

    from adaptive_ftc.sim import lanes
    from adaptive_ftc.sim.engine import CompiledLoop

    cl = CompiledLoop.build(replace(base, failures=_reversed(1.0)), RK4)
    module, plan = lanes.lane_module(cl.loop, cl.asm)
    lanes._self_check(module, plan, cl, LANE_WIDTH, "libm")  # the real one agrees
    broken = SimpleNamespace(rhs_rows=lambda B: None)
    key = f"{LANE_WIDTH} libm rk4\n{cl.asm.source}"
    lanes._checked.discard(key)
    try:
        with pytest.raises(ConfigurationError, match="disagrees with its single run.*lanes=False"):
            lanes._self_check(broken, plan, cl, LANE_WIDTH, "libm")
    finally:
        lanes._checked.add(key)


def test_a_plant_written_as_equations_runs_in_lanes():
    """examples/own_plant.toml (a quadrotor written as equations, four rotors, linear
    regressor): its generated equations in lane form, every lane equal to its single run."""
    from pathlib import Path

    sc = load_scenario(Path(__file__).resolve().parents[1] / "examples" / "own_plant.toml")
    loop = replace(sc.loop, t_final=2.0)
    loops = [
        loop,
        replace(loop, failures=(LossOfEffectiveness(actuator=2, onset=0.5, effectiveness=0.5),)),
        replace(loop, failures=(Stuck(actuator=4, onset=1.1, value=0.0),)),
        replace(loop, initial_state=(0.3, -0.1)),
    ]
    assert ineligible(loop, RK4) is None
    for a, b in zip(simulate_lanes(loops, RK4), _singles(loops), strict=True):
        _same(a, b)
