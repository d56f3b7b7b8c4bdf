"""The lane engine's DOPRI5 (issue 29, stage 2; ``sim/templates/lanes_dopri5.py``): every
member of a lane group gets its own single run's result bit for bit (states, adaptive states,
signals, status and reason, accepted and rejected steps, rhs evaluations), although each lane
keeps its own step size, error control, break times and records.

The truth is :func:`simulate` of each member alone with ``method="dopri5"``. Runs are a few
seconds long: the cost is compiling the DOPRI5 lane module once (cached on disk afterwards).
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import pytest

from adaptive_ftc import SolverOptions, load_scenario
from adaptive_ftc.errors import ConfigurationError, DivergenceWarning
from adaptive_ftc.faults import Affine, Bias, LossOfEffectiveness, Stuck
from adaptive_ftc.sim import lanes as lane_engine
from adaptive_ftc.sim.batch import iter_simulate, simulate_many
from adaptive_ftc.sim.lanes import LANE_WIDTH, ineligible, lane_source, simulate_lanes
from tests.lane_checks import assert_same_run, lane_base, reversed_elevators, single_runs

#: the catalogue's and the campaigns' DOPRI5 setting on the hypersonic loop
DP = SolverOptions(method="dopri5", rtol=1e-6, atol=1e-9, record_dt=0.01)


@pytest.fixture(scope="module")
def base():
    return lane_base()


_reversed = reversed_elevators


_same = assert_same_run


def _singles(loops, solver=DP):
    return single_runs(loops, solver)


def _lanes(loops, solver=DP):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        return simulate_lanes(loops, solver)


def _members(base) -> list:
    """Eight members: failures at different times in different lanes (every affine kind,
    abrupt and incipient, a recovery: different break times per lane), one diverging lane,
    one member with other gains and initial state."""
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


def test_every_dopri5_lane_equals_its_single_run(base):
    """Each lane on its own steps: different step counts, rejected steps in every lane (the
    masked rejection path), one lane diverging among healthy ones."""
    loops = _members(base)
    assert len(loops) == LANE_WIDTH
    singles = _singles(loops)
    assert [r.status for r in singles].count("diverged") == 1  # the reversed member
    assert all(r.meta["rejected_steps"] > 0 for r in singles)  # rejections in every lane
    assert len({r.meta["steps"] for r in singles}) >= 6  # lanes on their own step sequences
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DivergenceWarning)
        lanes = simulate_lanes(loops, DP)
    assert sum(issubclass(w.category, DivergenceWarning) for w in caught) == 1
    for a, b in zip(lanes, singles, strict=True):
        _same(a, b)
    div = lanes[4]  # stopped early at its own record, the others went on to the end
    assert div.time[-1] < 1.5 and div.reason.envelope
    assert all(r.time[-1] == pytest.approx(3.0) for k, r in enumerate(lanes) if k != 4)


def test_a_tight_tolerance_rejects_more_and_still_equals_the_single_runs(base):
    """rtol 1e-9: many more (rejected) steps; per-state atol and a largest step, each lane's
    tolerances read from its rows."""
    n = 2 + 25  # the plant states (alpha, q) and the 5x5 basis' theta
    tight = replace(DP, rtol=1e-9, atol=tuple(1e-12 * (1 + i % 3) for i in range(n)))
    loops = [
        replace(base, t_final=1.0, failures=(Bias(actuator=1, onset=0.31, bias=0.1),)),
        replace(base, t_final=1.0, failures=_reversed(0.6)),
    ]
    singles = _singles(loops, tight)
    assert singles[0].meta["rejected_steps"] > 0
    assert singles[0].meta["steps"] > 2 * _singles(loops[:1])[0].meta["steps"]
    for a, b in zip(_lanes(loops, tight), singles, strict=True):
        _same(a, b)
    capped = replace(DP, max_step=0.01)
    singles = _singles(loops[:1], capped)
    assert singles[0].meta["steps"] >= 100  # the cap sets the step
    _same(_lanes(loops[:1], capped)[0], singles[0])


def test_lanes_finishing_at_different_times_and_a_partial_group(base):
    """Three members (five padding lanes): different t_final and record grids, one stopping
    early by divergence, one starting at a break (a failure at t0)."""
    loops = [
        replace(base, t_final=1.234),
        replace(base, t_final=2.5, failures=(Bias(actuator=1, onset=0.0, bias=-0.05),)),
        replace(base, failures=_reversed(0.2)),
    ]
    singles = _singles(loops)
    lanes = _lanes(loops)
    assert len(lanes) == 3
    for a, b in zip(lanes, singles, strict=True):
        _same(a, b)
    assert lanes[0].time[-1] == pytest.approx(1.234)
    assert lanes[1].time[-1] == pytest.approx(2.5)
    assert lanes[2].status == "diverged"


def test_more_members_than_lanes_and_a_lane_bad_from_its_initial_state(base):
    """simulate_lanes splits 10 members into groups of 8 and 2, results in input order; a
    member whose initial state is already outside the envelope stops at once, alone."""
    loops = [
        replace(base, t_final=0.5, failures=(Bias(actuator=1, onset=0.05 * k, bias=0.01 * k),))
        for k in range(1, 11)
    ]
    loops[3] = replace(base, t_final=0.5, initial_state=(2.0, 0.0))
    singles = _singles(loops)
    assert singles[3].status == "diverged" and singles[3].time.size <= 1
    for a, b in zip(_lanes(loops), singles, strict=True):
        _same(a, b)


def test_a_step_size_underflow_in_one_lane(base):
    """A member whose derivative has a pole at t = 0.7 (a plant written as equations with
    ``1/(ts - t)``): its single run stops with a step-size underflow; in lanes it stops the
    same way at the same place (the state kept at the stop, the same diagnosis), and the other
    lanes go on."""
    from pathlib import Path

    sc = load_scenario(Path(__file__).resolve().parents[1] / "examples" / "own_plant.toml")
    plant = sc.loop.plant
    dynamics = {**plant.dynamics, "w": plant.dynamics["w"] + " + 1/(ts - t)"}
    pole = replace(plant, parameters={**plant.parameters, "ts": 0.7}, dynamics=dynamics)
    far = replace(pole, parameters={**plant.parameters, "ts": 50.0})
    loop = replace(sc.loop, plant=far, t_final=1.5, failures=())
    loops = [
        loop,
        replace(loop, plant=pole),
        replace(loop, failures=(LossOfEffectiveness(actuator=2, onset=0.5, effectiveness=0.5),)),
    ]
    assert ineligible(loop, DP) is None
    singles = _singles(loops)
    # the step size underflows just short of the pole (the integrator's status 2), which the
    # engine's diagnosis names a singular plant equation
    assert [r.status for r in singles] == ["completed", "singular", "completed"]
    assert singles[1].time[-1] < 0.7 < singles[1].time[-1] + 0.011
    for a, b in zip(_lanes(loops), singles, strict=True):
        _same(a, b)


def test_iter_simulate_takes_dopri5_members_in_lanes(base, monkeypatch):
    """lanes='auto' and True run DOPRI5 members in lane groups (counted here), a member that
    cannot (a failure pattern of t) one at a time; results in input order, equal to the
    single runs."""
    groups = []
    integrate = lane_engine.integrate_lanes

    def counting(compiled, *args, **kwargs):
        groups.append((len(compiled), compiled[0].solver.method))
        return integrate(compiled, *args, **kwargs)

    monkeypatch.setattr(lane_engine, "integrate_lanes", counting)
    # "auto"'s policy would run a group of 4 DOPRI5 members one at a time (AUTO_GROUP_MIN)
    monkeypatch.setitem(lane_engine.AUTO_GROUP_MIN, ("dopri5", False), 2)
    pattern = (Stuck(actuator=2, onset=0.5, value="0.1 + 0.05*cos(0.5*t)"),)
    loops = _members(base)[:4]
    loops.insert(2, replace(base, failures=pattern))
    singles = _singles(loops)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        got = list(iter_simulate(loops, DP, jobs=2, lanes="auto"))
        many = simulate_many(loops[:2], DP, jobs=1, lanes=True)
    assert groups == [(4, "dopri5"), (2, "dopri5")]
    for a, b in zip([*got, *many], [*singles, *singles[:2]], strict=True):
        _same(a, b)


def test_only_rk4_and_dopri5_have_a_lane_form(base):
    assert ineligible(base, DP) is None
    for method in ("auto", "rodasp", "rodas5p"):
        why = ineligible(base, SolverOptions(method=method))
        assert why is not None and f"'{method}'" in why
    with pytest.raises(ConfigurationError, match="RK4 and DOPRI5 only.*'auto'.*lanes=False"):
        list(iter_simulate([base], SolverOptions(method="auto"), jobs=1, lanes=True))
    with pytest.raises(ConfigurationError, match="kernels='vector'.*RK4 only.*kernels='libm'"):
        simulate_lanes([base], DP, kernels="vector")
    assert "DOPRI5" in lane_source(base, DP)
    assert "DOPRI5" not in lane_source(base, SolverOptions(method="rk4"))
