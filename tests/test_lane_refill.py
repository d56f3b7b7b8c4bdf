"""Lane refill of the DOPRI5 lane engine (issue 29): a lane group runs a *queue* of members
longer than its ``LANE_WIDTH`` lanes; a lane whose member ends (its final time, a divergence,
a bad initial state) takes the next member of the queue with its own time, step size, state,
failure schedule and records, so the group runs until the queue is empty.

The truth is :func:`simulate` of each member alone with ``method="dopri5"``: every member's
result is its own run's bit for bit (states, adaptive states, signals, status, reason, counts).
The lane module is the one of ``test_lanes_dopri5.py`` (the same structure and method).
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc import SolverOptions, simulate
from adaptive_ftc.errors import DivergenceWarning
from adaptive_ftc.faults import Affine, Bias, LossOfEffectiveness, Stuck
from adaptive_ftc.sim import lanes as lane_engine
from adaptive_ftc.sim.batch import iter_simulate
from adaptive_ftc.sim.engine import CompiledLoop
from adaptive_ftc.sim.lanes import LANE_WIDTH, integrate_lanes, lane_occupancy, simulate_lanes
from tests.lane_checks import assert_same_run, lane_base, reversed_elevators, single_runs

DP = SolverOptions(method="dopri5", rtol=1e-6, atol=1e-9, record_dt=0.01)


@pytest.fixture(scope="module")
def base():
    return lane_base()


def _queue(base, n: int = 21) -> list:
    """``n`` members (more than two groups' worth) that end at different times: final times
    from 0.4 s to 3 s, failures at different times (every affine kind, a recovery, an
    incipient one), diverging members (at different times), a member bad from its initial
    state, other gains and initial states."""
    fails = [
        (),
        (LossOfEffectiveness(actuator=1, onset=0.2, effectiveness=0.4),),
        (Bias(actuator=2, onset=0.25, bias=0.08, recovery=0.9),),
        reversed_elevators(0.1),
        (Stuck(actuator=1, onset=0.61, value=0.05),),
        (Affine(actuator=1, onset=0.3, effectiveness=0.3, bias=0.02, ramp=0.5),),
        (Affine(actuator=2, onset=1.1, effectiveness=0.7, bias=-0.1),),
        reversed_elevators(0.9),
    ]
    loops = []
    for k in range(n):
        t_final = 0.4 + (k * 7 % 12) * 0.22  # 0.4 .. 2.82 s, in no order
        loops.append(replace(base, t_final=t_final, failures=fails[k % len(fails)]))
    ctrl = replace(base.controller, gamma=3.0, k=4.0)
    loops[5] = replace(loops[5], controller=ctrl, initial_state=(0.01, 0.02))
    loops[12] = replace(loops[12], initial_state=(2.0, 0.0))  # outside the envelope at t0
    loops[-1] = replace(loops[-1], t_final=3.0)
    return loops


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        return fn(*args, **kwargs)


def _groups_of_eight(attempts: list) -> float:
    """The occupancy that groups of LANE_WIDTH members without refill would have: each
    group runs until its slowest member."""
    groups = [attempts[i : i + LANE_WIDTH] for i in range(0, len(attempts), LANE_WIDTH)]
    return sum(attempts) / sum(LANE_WIDTH * max(g) for g in groups)


def test_a_queue_longer_than_the_lanes_gives_each_member_its_own_run(base, monkeypatch):
    """21 members in ONE lane group of 8 lanes (counted): each lane takes the next member
    when its own ends; every result equals the member's single run bit for bit, and the
    lanes are busier than in groups of 8 that run until their slowest member."""
    calls: list[int] = []
    real = lane_engine.integrate_lanes

    def counted(compiled, *args, **kwargs):
        calls.append(len(compiled))
        return real(compiled, *args, **kwargs)

    monkeypatch.setattr(lane_engine, "integrate_lanes", counted)
    loops = _queue(base)
    singles = single_runs(loops, DP)
    statuses = [r.status for r in singles]
    assert statuses.count("diverged") >= 3 and statuses.count("completed") >= 10
    assert singles[12].time.size <= 1  # bad from its initial state
    ends = {float(r.time[-1]) for r in singles if r.time.size}
    assert len(ends) >= 10  # members end at many different times
    before = lane_occupancy()
    got = _quiet(simulate_lanes, loops, DP)
    after = lane_occupancy()
    # queues of QUEUE_MEMBERS (16), not groups of 8
    assert calls == [16, len(loops) - 16]
    for a, b in zip(got, singles, strict=True):
        assert_same_run(a, b)
    attempts = [r.meta["steps"] + r.meta["rejected_steps"] for r in singles]
    used = after.attempts - before.attempts
    slots = after.slots - before.slots
    assert used == sum(attempts)
    assert slots % LANE_WIDTH == 0 and slots >= sum(attempts)
    # refill: the lanes idle only for the queue's tail, not for each group's
    assert used / slots > _groups_of_eight(attempts) + 0.05


def test_refill_matches_the_groups_of_eight_and_the_single_runs(base):
    """The same members through integrate_lanes as a queue and in groups of at most 8 (no
    refill): the same integrations, bit for bit, and the queue takes fewer lane slots."""
    loops = _queue(base, 14)
    compiled = [CompiledLoop.build(loop, DP) for loop in loops]
    before = lane_occupancy()
    queued = integrate_lanes(compiled)
    mid = lane_occupancy()
    grouped = integrate_lanes(compiled[:8]) + integrate_lanes(compiled[8:])
    after = lane_occupancy()
    for q, g in zip(queued, grouped, strict=True):
        assert q.status == g.status and q.nrec == g.nrec
        np.testing.assert_array_equal(q.Y[: q.nrec], g.Y[: g.nrec])
        np.testing.assert_array_equal(q.phases[: q.nrec], g.phases[: g.nrec])
        np.testing.assert_array_equal(q.stats, g.stats)
    assert mid.attempts - before.attempts == after.attempts - mid.attempts
    assert mid.slots - before.slots < after.slots - mid.slots


def test_iter_simulate_refills_lanes_with_lean_signals(base, monkeypatch):
    """iter_simulate with lanes: DOPRI5 members go in queues of QUEUE_MEMBERS (more than the
    lanes), results in input order; with lean signals the lanes' own pass runs over each
    queue's members in groups of 8, each member's lean result its lean single run's."""
    calls: list[tuple[int, bool]] = []
    real = lane_engine.integrate_lanes

    def counted(compiled, *args, **kwargs):
        calls.append((len(compiled), bool(kwargs.get("lean"))))
        return real(compiled, *args, **kwargs)

    monkeypatch.setattr(lane_engine, "integrate_lanes", counted)
    queue = lane_engine.QUEUE_MEMBERS["dopri5"]
    assert queue > LANE_WIDTH
    loops = _queue(base, queue + 3)
    lean = replace(DP, record_dt=1e-3)
    got = _quiet(list, iter_simulate(loops, lean, jobs=2, lanes=True, lean_signals=True))
    assert calls == [(queue, True), (3, True)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        want = [simulate(loop, lean, lean_signals=True) for loop in loops]
    for a, b in zip(got, want, strict=True):
        assert a.status == b.status and a.reason == b.reason and a.message == b.message
        np.testing.assert_array_equal(a.time, b.time)
        np.testing.assert_array_equal(a.states, b.states)
        np.testing.assert_array_equal(a.adaptive, b.adaptive)
        for name in ("e", "u_cmd", "u_applied"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
        for key in ("steps", "rejected_steps", "rhs_evaluations"):
            assert a.meta.get(key) == b.meta.get(key), key


def test_an_rk4_group_still_holds_at_most_the_lanes(base):
    """RK4 lanes run in lockstep of steps: no queue (a group of more than 8 is refused with
    the fix named)."""
    rk4 = SolverOptions(method="rk4", dt=1e-3)
    compiled = [CompiledLoop.build(base, rk4)] * (LANE_WIDTH + 1)
    with pytest.raises(lane_engine.ConfigurationError, match="RK4 lane group holds 1 to 8"):
        integrate_lanes(compiled)


def test_a_queue_holds_more_members_only_while_their_records_fit(base):
    """A DOPRI5 job's records stay in memory until it ends: members of 120 s recorded every
    10 ms (2.6 MB each) queue 16 to a job, every millisecond (26 MB, a campaign's) 8, as
    without refill; RK4 groups stay at 8."""
    long = replace(base, t_final=120.0)
    coarse = CompiledLoop.build(long, DP)
    fine = CompiledLoop.build(long, replace(DP, record_dt=1e-3))
    rk4 = CompiledLoop.build(long, SolverOptions(method="rk4", dt=1e-3, record_dt=0.01))
    assert lane_engine.queue_members(coarse) == 2 * LANE_WIDTH
    assert fine.t_rec.size * 27 * 8 > lane_engine.QUEUE_BYTES // LANE_WIDTH
    assert lane_engine.queue_members(fine) == LANE_WIDTH
    assert lane_engine.queue_members(rk4) == LANE_WIDTH


def test_a_lane_stopped_by_a_step_size_underflow_is_refilled():
    """A plant written as equations with a pole at ``ts`` (``1/(ts - t)``): the members whose
    pole is inside their run stop with a step-size underflow (the single run's status 2,
    diagnosed ``singular``) at different times, their lanes take the next members; 11
    members in one queue, each its own run."""
    from pathlib import Path

    from adaptive_ftc import load_scenario

    sc = load_scenario(Path(__file__).resolve().parents[1] / "examples" / "own_plant.toml")
    plant = sc.loop.plant
    dynamics = {**plant.dynamics, "w": plant.dynamics["w"] + " + 1/(ts - t)"}
    loops = []
    for k in range(11):
        ts = 0.3 + 0.2 * k if k % 3 == 1 else 50.0  # a pole at 0.5, 1.1, 1.7 s in three
        pole = replace(plant, parameters={**plant.parameters, "ts": ts}, dynamics=dynamics)
        fails = (LossOfEffectiveness(actuator=2, onset=0.1 * k, effectiveness=0.5),)
        loops.append(replace(sc.loop, plant=pole, t_final=1.0 + 0.1 * k, failures=fails))
    singles = single_runs(loops, DP)
    assert [r.status for r in singles].count("singular") == 3
    got = _quiet(simulate_lanes, loops, DP)
    for a, b in zip(got, singles, strict=True):
        assert_same_run(a, b)
