"""Compensability of failure timelines: rank condition (3.6), per-group form (3.9).

With grouped actuators (R = [[1,1,0,0],[0,0,1,1]] for the arm, R = [I3 I3] for the spacecraft)
the rank condition ``rank(rho(x, t) R^T) = p`` holds exactly when every output keeps at least one
actuator whose output still depends on its command. The thesis's four chapter 3 timelines must
pass; a timeline that kills both actuators of one joint (or one axis) must be rejected, naming
the interval and the output group.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from adaptive_ftc import (
    Affine,
    LossOfEffectiveness,
    NonAffine,
    Reversal,
    Stuck,
    check_compensability,
    load_scenario,
)
from adaptive_ftc.faults import FailureSchedule

CHAPTER3 = (
    "manipulator-mimo-s1",
    "manipulator-mimo-s2",
    "spacecraft-mimo-s1",
    "spacecraft-mimo-s2",
)


def with_failures(name: str, *extra):
    """The scenario's closed loop with ``extra`` failures added to its timeline."""
    loop = load_scenario(name).loop
    return replace(loop, failures=tuple(loop.failures.failures) + tuple(extra))


def intervals_lost(report):
    return [(iv.start, iv.end, iv.lost_groups) for iv in report.intervals if not iv.ok]


@pytest.mark.parametrize("name", CHAPTER3)
def test_thesis_timelines_are_compensable_on_every_interval(name):
    # Time-varying (exp(-(t - 25)), (3 + tanh((50 - t)/10))/4) and state-dependent failures keep
    # the actuator effective; stuck ones are lost, but never both actuators of one group.
    loop = load_scenario(name).loop
    report = loop.compensability()
    assert report.ok, report.describe(loop.plant.output_names)
    bps = loop.failures.breakpoints(0.0, loop.t_final)
    assert [(iv.start, iv.end) for iv in report.intervals] == list(zip(bps, bps[1:], strict=False))


def test_manipulator_s1_counts_stuck_actuators_as_lost_and_fading_ones_as_effective():
    report = load_scenario("manipulator-mimo-s1").loop.compensability()
    by_start = {iv.start: iv.effective for iv in report.intervals}
    # [8, 12): tau22 stuck; [12, 18): tau12 and tau22 stuck; [18, 25): tau22 recovered;
    # [25, 30): tau21 fades as exp(-(t - 25)) but still responds to its command
    assert by_start[0.0] == (True, True, True, True)
    assert by_start[8.0] == (True, True, True, False)
    assert by_start[12.0] == (True, False, True, False)
    assert by_start[18.0] == (True, False, True, True)
    assert by_start[25.0] == (True, False, True, True)


def test_both_actuators_of_joint_1_stuck_at_overlapping_times_is_rejected_naming_q1():
    # tau12 sticks at 12 s (thesis); tau11 also locks on [10, 20): joint 1 has no actuator left
    # on [12, 20) while joint 2 is fine.
    loop = with_failures(
        "manipulator-mimo-s1", Stuck(actuator=1, onset=10.0, recovery=20.0, value=1.0)
    )
    report = loop.compensability()
    assert not report.ok
    assert intervals_lost(report) == [(12.0, 18.0, (0,)), (18.0, 20.0, (0,))]
    text = report.describe(loop.plant.output_names)
    assert "[12 s, 18 s): NOT compensable - no effective actuator left for q1" in text
    assert "[18 s, 20 s): NOT compensable - no effective actuator left for q1" in text
    assert "[20 s, 25 s): compensable" in text
    assert "q2" not in text


def test_joint_2_lost_when_tau22_is_locked_and_tau21_floats():
    # tau22 locked on [8, 18) (thesis); tau21 fully ineffective (rho = 0) on [15, 17).
    loop = with_failures(
        "manipulator-mimo-s1",
        LossOfEffectiveness(actuator=3, onset=15.0, recovery=17.0, effectiveness=0.0),
    )
    report = loop.compensability()
    assert intervals_lost(report) == [(15.0, 17.0, (1,))]
    assert "[15 s, 17 s): NOT compensable - no effective actuator left for q2" in report.describe(
        loop.plant.output_names
    )


def test_both_joints_lost_at_once_are_both_named():
    R = np.array([[1, 1, 0, 0], [0, 0, 1, 1]], dtype=float)
    sched = FailureSchedule(tuple(Stuck(actuator=j, onset=5.0, value=0.0) for j in (1, 2, 3, 4)), 4)
    report = check_compensability(sched, R, 10.0)
    assert intervals_lost(report) == [(5.0, 10.0, (0, 1))]
    assert "no effective actuator left for q1, q2" in report.describe(["q1", "q2"])


def test_incipient_stuck_failures_are_lost_only_once_their_ramps_complete():
    # During its ramp an incipient failure still passes part of the command (u + w (ubar - u)).
    loop = with_failures("manipulator-mimo-s2", Stuck(actuator=1, onset=16.0, ramp=4.0, value=0.5))
    report = loop.compensability()
    # tau12 is stuck from 15 s; tau11 ramps into a lock on [16, 20) and is lost from 20 s.
    assert intervals_lost(report) == [(20.0, 30.0, (0,))]


@pytest.mark.parametrize(
    ("failure", "effective"),
    [
        (Affine(actuator=1, onset=0.0, effectiveness="0.5 + 0.4*sin(t)", bias=3.0), True),
        (Affine(actuator=1, onset=0.0, effectiveness="x1", bias=-7.0), True),
        (Affine(actuator=1, onset=0.0, effectiveness=0.0, bias="x5 + x6"), False),
        (NonAffine(actuator=1, onset=0.0, output="0.4*u**3 + 0.5*x1*x2"), True),
        (NonAffine(actuator=1, onset=0.0, output="5 + 0.1*x4*cos(3*t)"), False),
        (Reversal(actuator=1, onset=0.0), True),
        (Stuck(actuator=1, onset=0.0, value="(4 + x3)*cos(2*t) - (2 + x4)*sin(2*t)"), False),
    ],
)
def test_effectiveness_is_read_from_the_dependence_on_the_command(failure, effective):
    # Roll is driven by wheels 1 and 4; with wheel 4 stuck, roll is compensable iff wheel 1's
    # failed output still depends on its command.
    loop = replace(
        load_scenario("spacecraft-mimo-s1").loop,
        failures=(failure, Stuck(actuator=4, onset=0.0, value=4.0)),
    )
    report = loop.compensability()
    assert report.intervals[0].effective[0] is effective
    assert report.ok is effective
    if not effective:
        assert intervals_lost(report) == [(0.0, 150.0, (0,))]
        assert "no effective actuator left for phi" in report.describe(loop.plant.output_names)


def test_spacecraft_s2_with_wheel_3_also_stuck_loses_yaw_from_30_s(tmp_path: Path):
    # The same check through a user scenario file that extends the thesis one.
    base = load_scenario("spacecraft-mimo-s2")
    text = ['extends = "spacecraft-mimo-s2"', 'name = "yaw-lost"']
    for f in base.loop.failures.failures:
        if f.actuator == 3:
            continue
        text.append("[[failures]]")
        text.append(f"actuator = {f.actuator}\nonset = {f.onset}")
        text.append(
            f'model = "stuck"\nvalue = "{f.pattern()}"'
            if isinstance(f, Stuck)
            else f'model = "nonaffine"\noutput = "{f.pattern()}"'
        )
    text.append('[[failures]]\nactuator = 3\nmodel = "stuck"\nonset = 40.0\nvalue = 0.0')
    path = tmp_path / "yaw-lost.toml"
    path.write_text("\n".join(text) + "\n")
    loop = load_scenario(path).loop
    report = loop.compensability()
    # roll and pitch keep wheels 1 and 2 (0.6 u1 + 8 and 0.4 u2 respond to their commands)
    assert intervals_lost(report) == [
        (40.0, 60.0, (2,)),
        (60.0, 80.0, (2,)),
        (80.0, 100.0, (2,)),
        (100.0, 150.0, (2,)),
    ]
    assert "[40 s, 60 s): NOT compensable - no effective actuator left for psi" in report.describe(
        loop.plant.output_names
    )
