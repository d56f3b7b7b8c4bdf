"""The allocation layer in the generated closed loops (issue 31): the fixed default leaves the
thesis's loops untouched, every allocator gives the thesis's commands while the actuators are
healthy, annunciated failures leave the allocation at onset + delay, and the adaptive
allocator's estimate finds a silent loss of effectiveness."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc.allocation import (
    AdaptiveAllocation,
    Annunciation,
    FixedAllocation,
    PseudoInverse,
    WeightedLeastSquares,
)
from adaptive_ftc.errors import ConfigurationError, ScenarioError
from adaptive_ftc.faults import LossOfEffectiveness, Stuck
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim.compose import assemble, source_of
from adaptive_ftc.sim.engine import simulate


def _short(name: str, t_final: float):
    sc = load_scenario(name)
    return sc, replace(sc.loop, t_final=t_final, failures=())


@pytest.mark.parametrize("name", ["spacecraft-mimo-s1", "manipulator-mimo-s1"])
def test_the_fixed_default_is_the_thesis_text(name):
    sc = load_scenario(name)
    text = source_of(sc.loop)
    assert not re.search(r"\b(ALLOC|ALW|alw)\b", text)
    assert "acc += c[RMAT + i *" in text  # u = R^T u0 (3.14)
    same = replace(sc.loop, allocator=FixedAllocation(nominal=sc.loop.R))
    assert same.allocator is None
    assert source_of(same) == text


@pytest.mark.parametrize(
    ("name", "t_final"),
    [("spacecraft-mimo-s1", 20.0), ("manipulator-mimo-s1", 5.0), ("hypersonic-direct-s1", 20.0)],
)
def test_every_allocator_gives_the_thesis_commands_with_healthy_actuators(name, t_final):
    sc, loop = _short(name, t_final)
    ref = simulate(loop, sc.solver)
    for alloc in (PseudoInverse(), WeightedLeastSquares(gamma=1e9), AdaptiveAllocation(gamma=1e9)):
        run = simulate(replace(loop, allocator=alloc), sc.solver)
        assert run.status == ref.status
        scale = np.max(np.abs(ref.u_cmd))
        assert np.max(np.abs(run.u_cmd - ref.u_cmd)) < 1e-6 * scale, alloc.kind
        np.testing.assert_allclose(run.y, ref.y, atol=1e-9, err_msg=alloc.kind)


def test_an_annunciated_failure_leaves_the_allocation_at_onset_plus_delay():
    sc, loop = _short("spacecraft-mimo-s1", 20.0)
    fail = Stuck(actuator=1, onset=5.0, value=0.0)
    loop = replace(
        loop,
        failures=(fail,),
        allocator=PseudoInverse(),
        annunciations=(Annunciation(actuator=1, onset=5.0, delay=1.5),),
    )
    assert 6.5 in assemble(loop).breakpoints  # the integration restarts where it is known
    run = simulate(loop, sc.solver)
    t, u = run.time, run.u_cmd
    before, after = t < 6.5, t >= 6.5
    np.testing.assert_array_equal(u[after, 0], 0.0)  # removed from the allocation
    # before: the equal split of R^T u0 (wheels 1 and 4 both roll)
    np.testing.assert_allclose(u[before, 0], u[before, 3], rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(u[before, 0])) > 0.1
    # silent: the allocator keeps commanding the stuck wheel
    silent = simulate(replace(loop, annunciations=()), sc.solver)
    np.testing.assert_allclose(silent.u_cmd[:, 0], silent.u_cmd[:, 3], rtol=1e-12, atol=1e-12)


def test_adaptive_allocation_learns_a_silent_loss_of_effectiveness():
    sc, loop = _short("spacecraft-mimo-s1", 40.0)
    loop = replace(
        loop,
        failures=(LossOfEffectiveness(actuator=2, onset=5.0, effectiveness=0.2),),
        allocator=AdaptiveAllocation(gain=5.0),
    )
    run = simulate(loop, sc.solver)
    names = list(run.adaptive_names)
    rho = np.array([run.adaptive[-1, names.index(f"rho_hat_{a}")] for a in run.actuator_names])
    assert rho[1] == pytest.approx(0.2, abs=0.01)
    np.testing.assert_allclose(np.delete(rho, 1), 1.0, atol=1e-6)
    # the healthy pitch wheel (5) then carries most of the pitch command
    late = run.time > 30.0
    assert np.mean(np.abs(run.u_cmd[late, 4])) > 3 * np.mean(np.abs(run.u_cmd[late, 1]))


SCENARIO = """
extends = "spacecraft-mimo-s1"
duration = 5.0
unset = ["failures"]

[allocation]
kind = "wls"
gamma = 1e4

[[failures]]
actuator = 4
model = "stuck"
onset = 1.0
value = 0.0
annunciated = true
detection_delay = 0.25

[[failures]]
actuator = 2
model = "loss_of_effectiveness"
onset = 2.0
effectiveness = 0.5
"""


def test_a_scenario_file_names_its_allocator_and_annunciated_failures(tmp_path):
    path = tmp_path / "alloc.toml"
    path.write_text(SCENARIO)
    loop = load_scenario(path).loop
    assert loop.allocator == WeightedLeastSquares(gamma=1e4)
    assert loop.annunciations == (Annunciation(actuator=4, onset=1.0, delay=0.25),)


@pytest.mark.parametrize(
    ("old", "new", "match"),
    [
        ('kind = "wls"', 'kind = "wsl"', "Did you mean 'wls'"),
        ("gamma = 1e4", "gama = 1e4", "unknown key 'gama'"),
        ("annunciated = true\n", "", "add `annunciated = true`"),
        ("detection_delay = 0.25", "detection_delay = -1.0", "detection_delay"),
        ("annunciated = true", 'annunciated = "yes"', "annunciated"),
    ],
)
def test_bad_allocation_settings_in_a_file_name_the_culprit(tmp_path, old, new, match):
    path = tmp_path / "alloc.toml"
    path.write_text(SCENARIO.replace(old, new))
    with pytest.raises(ScenarioError, match=match):
        load_scenario(path)


def test_a_loop_refuses_an_allocator_it_cannot_run():
    sc = load_scenario("spacecraft-mimo-s1")
    with pytest.raises(ConfigurationError, match="loop's own `allocation`"):
        replace(sc.loop, allocator=FixedAllocation(nominal=np.eye(3, 6)))
    with pytest.raises(ConfigurationError, match="`allocator` must be None"):
        replace(sc.loop, allocator="wls")
    with pytest.raises(ConfigurationError, match="names actuator 7"):
        replace(sc.loop, annunciations=(Annunciation(actuator=7, onset=1.0),))


def test_an_annunciated_actuator_stays_allocated_when_it_is_the_last_of_its_axis():
    from adaptive_ftc.allocation.inloop import known_table

    R = np.hstack([np.eye(3), np.eye(3)])  # the spacecraft: roll 1, 4; pitch 2, 5; yaw 3, 6
    anns = [
        Annunciation(actuator=3, onset=1.0),
        Annunciation(actuator=6, onset=2.0),  # the second yaw wheel: yaw would be lost
        Annunciation(actuator=1, onset=3.0),
    ]
    table = known_table(anns, (0.0, 1.5, 2.5, 4.0), 6, R)
    # both yaw wheels annunciated: both stay (as if silent); roll wheel 1 leaves
    np.testing.assert_array_equal(
        table, [[0, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0], [1, 0, 0, 0, 0, 0]]
    )
    # without R (no reachability check) every annunciated actuator is removed
    np.testing.assert_array_equal(known_table(anns, (0.0, 1.5, 2.5, 4.0), 6)[2], [1, 0, 1, 0, 0, 1])


def test_campaign_members_keep_the_allocator_but_not_the_dropped_failures_annunciations():
    from adaptive_ftc.campaigns import draw_member, load_campaign

    data = {
        "name": "alloc",
        "base": {"name": "alloc", "text": SCENARIO},
        "designs": ["adaptive"],
        "runs": 2,
        "seed": 3,
        "duration": 5.0,
        "success": {"rms_error_final": 0.01, "final_window": 1.0},
        "failures": {
            "count": 1,
            "onset": {"uniform": [0.5, 1.5]},
            "models": {"loss_of_effectiveness": {"effectiveness": {"uniform": [0.2, 0.9]}}},
        },
    }
    member = draw_member(load_campaign(data), 0)
    assert member.loop.allocator == WeightedLeastSquares(gamma=1e4)
    assert member.loop.annunciations == ()  # the base's stuck wheel 4 is not in this member


def test_wls_and_pinv_respect_the_declared_actuator_limits():
    from adaptive_ftc.hardware import Actuators

    sc, loop = _short("spacecraft-mimo-s1", 10.0)
    loop = replace(loop, actuators=Actuators(lower=-12.0, upper=12.0))
    fixed = simulate(loop, sc.solver)
    assert np.max(np.abs(fixed.u_cmd)) > 12.5  # the thesis's commands go beyond the limits
    for alloc in (WeightedLeastSquares(), PseudoInverse()):
        run = simulate(replace(loop, allocator=alloc), sc.solver)
        assert run.status == fixed.status
        assert np.max(np.abs(run.u_cmd)) <= 12.0 + 1e-9, alloc.kind


def test_the_fixed_allocation_ignores_annunciations_entirely():
    sc, loop = _short("spacecraft-mimo-s1", 5.0)
    loop = replace(loop, failures=(Stuck(actuator=1, onset=1.0, value=0.0),))
    told = replace(loop, annunciations=(Annunciation(actuator=1, onset=1.0, delay=0.5),))
    assert assemble(told).breakpoints == assemble(loop).breakpoints  # no restart at 1.5 s
    np.testing.assert_array_equal(simulate(told, sc.solver).y, simulate(loop, sc.solver).y)
