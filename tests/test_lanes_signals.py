"""The lane engine's lean signals' pass (issue 29, stage 3; ``sim/lanes.py``: the module's
``commands`` and ``lean_pass``): with ``lean_signals``, a lane group computes the tracking
error, the commands and the applied commands of every record of every lane itself, instead of
one member at a time, and each member's lean result is its own lean single run's bit for bit.

The truth is :func:`simulate` of each member alone with ``lean_signals=True``. Runs are a few
seconds long, recorded every millisecond (a campaign's records).
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc import SolverOptions, simulate
from adaptive_ftc.errors import DivergenceWarning
from adaptive_ftc.faults import Affine, Bias, LossOfEffectiveness, Stuck
from adaptive_ftc.sim.batch import iter_simulate
from adaptive_ftc.sim.compose import Assembled
from adaptive_ftc.sim.engine import CompiledLoop
from adaptive_ftc.sim.lanes import LANE_WIDTH, integrate_lanes, lane_groups
from tests.lane_checks import lane_base, reversed_elevators

SOLVERS = {
    "rk4": SolverOptions(method="rk4", dt=1e-3, record_dt=1e-3),
    "dopri5": SolverOptions(method="dopri5", rtol=1e-6, atol=1e-9, record_dt=1e-3),
}


@pytest.fixture(scope="module")
def base():
    return lane_base()


_reversed = reversed_elevators


def _members(base) -> list:
    """Eight members: failures at different times in different lanes (every affine kind,
    abrupt and incipient, a recovery), one diverging lane, other gains and initial state,
    a shorter run."""
    fails = [
        (),
        (LossOfEffectiveness(actuator=1, onset=0.7, effectiveness=0.4),),
        (Bias(actuator=2, onset=0.25, bias=0.08, recovery=1.9),),
        (
            Stuck(actuator=1, onset=1.2345, value=0.05),
            Affine(actuator=2, onset=2.1, effectiveness=0.7, bias=-0.1),
        ),
        _reversed(0.3),
        (Affine(actuator=1, onset=0.5, effectiveness=0.3, bias=0.02, ramp=0.8),),
        (LossOfEffectiveness(actuator=2, onset=1.5005, effectiveness=0.0),),
        (),
    ]
    loops = [replace(base, failures=f) for f in fails]
    loops[6] = replace(loops[6], t_final=2.2)
    # other reference numbers (one structure): this lane computes its own reference, the
    # others share lane 0's (the same numbers, the same time)
    loops[5] = replace(loops[5], reference=("pi/30*sin(0.25*t)",))
    ctrl = replace(base.controller, gamma=3.0, k=4.0)
    loops[7] = replace(base, controller=ctrl, initial_state=(0.01, 0.02))
    return loops


def _same_lean(a, b) -> None:
    """``a`` (lanes, lean) is ``b`` (its lean single run) bit for bit."""
    assert a.status == b.status
    assert a.reason == b.reason
    assert a.message == b.message
    np.testing.assert_array_equal(a.time, b.time)
    np.testing.assert_array_equal(a.states, b.states)
    np.testing.assert_array_equal(a.adaptive, b.adaptive)
    for name in ("e", "u_cmd", "u_applied"):  # the lean signals' pass
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    for key in ("steps", "rejected_steps", "rhs_evaluations"):
        assert a.meta.get(key) == b.meta.get(key), key


def _singles(loops, solver):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        return [simulate(loop, solver, lean_signals=True) for loop in loops]


def _no_scalar_pass(monkeypatch) -> None:
    """The member-at-a-time signals' pass refuses to run: the lanes must compute their own."""

    def refuse(self, *args, **kwargs):
        raise AssertionError("the scalar signals' pass ran for a lean lane group")

    monkeypatch.setattr(Assembled, "signals", refuse)


def _lean_lanes(loops, solver, monkeypatch, jobs=1):
    with monkeypatch.context() as mp:
        _no_scalar_pass(mp)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DivergenceWarning)
            return list(iter_simulate(loops, solver, jobs=jobs, lanes=True, lean_signals=True))


@pytest.mark.parametrize("method", sorted(SOLVERS))
def test_lean_lanes_equal_lean_single_runs(base, method, monkeypatch):
    """Failures at different times in different lanes, a diverging lane among healthy ones,
    a shorter run: every member's lean result is its lean single run's, and the lanes'
    own pass computed the signals."""
    solver = SOLVERS[method]
    loops = _members(base)
    assert len(loops) == LANE_WIDTH
    groups, _ = lane_groups(loops, solver)
    assert groups == [("lanes", list(range(LANE_WIDTH)))]  # one structure, one group
    singles = _singles(loops, solver)
    assert not np.array_equal(singles[5].e[:400], singles[0].e[:400])  # before its failure
    statuses = [r.status for r in singles]
    assert statuses.count("diverged") == 1 and singles[4].reason.envelope
    lanes = _lean_lanes(loops, solver, monkeypatch)
    for a, b in zip(lanes, singles, strict=True):
        _same_lean(a, b)
    assert lanes[4].time[-1] < 1.5  # stopped early, the others went on
    assert lanes[6].time[-1] == pytest.approx(2.2)
    assert lanes[0].time.size == 3001  # every millisecond


@pytest.mark.parametrize("method", sorted(SOLVERS))
def test_a_partial_group_and_more_members_than_lanes(base, method, monkeypatch):
    """Ten members: a group of 8 and a group of 2 (six padding lanes that record nothing);
    a failure at t0 in one lane; the two groups on two threads."""
    solver = SOLVERS[method]
    loops = _members(base) + [
        replace(base, t_final=1.0, failures=(Bias(actuator=1, onset=0.0, bias=0.05),)),
        replace(base, t_final=1.7, failures=_reversed(1.0)),
    ]
    singles = _singles(loops, solver)
    lanes = _lean_lanes(loops, solver, monkeypatch, jobs=2)
    assert len(lanes) == 10
    for a, b in zip(lanes, singles, strict=True):
        _same_lean(a, b)


def test_integrate_lanes_returns_the_lean_blocks_only_when_asked(base):
    """A group of three (five padding lanes): one lean block per member with a row per
    record, the first record outside the envelope (-1 for a run that stays inside); none
    without ``lean``."""
    solver = SOLVERS["dopri5"]
    loops = _members(base)[3:6]  # the diverging member in the middle
    compiled = [CompiledLoop.build(loop, solver) for loop in loops]
    plain = integrate_lanes(compiled)
    assert all(run.lean_signals is None for run in plain)
    runs = integrate_lanes(compiled, lean=True)
    assert len(runs) == 3
    for cl, run in zip(compiled, runs, strict=True):
        assert run.lean_signals is not None
        block, first = run.lean_signals
        m = cl.loop.plant.n_actuators
        assert block.shape == (run.nrec, 1 + 2 * m)
        want = np.zeros_like(block)
        nrec = run.nrec
        got_first = cl.asm.signals(
            cl.t_rec[:nrec], run.Y[:nrec], run.phases[:nrec], want, lean=True
        )
        np.testing.assert_array_equal(block, want)
        assert first == got_first
    assert runs[0].lean_signals[1] == -1
