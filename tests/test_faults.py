"""Failure models: outputs on known inputs, validation, schedules and the compensability check."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import assert_close

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.faults import (
    Affine,
    Bias,
    FailureSchedule,
    LossOfEffectiveness,
    NonAffine,
    ParameterisedStuck,
    PositionLimit,
    Reversal,
    Stuck,
    check_compensability,
)

VARS = ("t", "u", "x1", "x2")
U = np.array([-2.0, -0.5, 0.0, 0.3, 1.7])
T = np.array([40.0, 41.0, 55.5, 60.0, 99.9])
X1 = np.array([0.1, -0.2, 0.3, 0.0, 1.0])
X2 = np.array([1.0, 0.5, -0.5, 2.0, 0.0])


def out(f):
    return f.expression(VARS)(t=T, u=U, x1=X1, x2=X2)


def test_each_model_outputs_its_definition():
    assert_close(out(LossOfEffectiveness(actuator=1, effectiveness=0.75)), 0.75 * U, atol=0)
    assert_close(
        out(LossOfEffectiveness(actuator=1, effectiveness="exp(-(t - 25))")),
        np.exp(-(T - 25)) * U,
        atol=1e-15,
    )
    assert_close(out(Stuck(actuator=1, value=3.5)), np.full(5, 3.5), atol=0)
    assert_close(
        out(Stuck(actuator=1, value="0.1 + 0.05*cos(0.5*t) - 0.08*sin(0.5*t)")),
        0.1 + 0.05 * np.cos(0.5 * T) - 0.08 * np.sin(0.5 * T),
        atol=1e-15,
    )
    assert_close(
        out(
            ParameterisedStuck(
                actuator=1, coefficients=(1.0, -30.0, 20.0), basis=("1", "sin(5*t)", "cos(5*t)")
            )
        ),
        1 - 30 * np.sin(5 * T) + 20 * np.cos(5 * T),
        atol=1e-12,
    )
    assert_close(out(Bias(actuator=1, bias=2.0)), U + 2, atol=0)
    assert_close(
        out(Affine(actuator=1, effectiveness=0.4, bias="0.5*x1*x2")),
        0.4 * U + 0.5 * X1 * X2,
        atol=1e-15,
    )
    assert_close(
        out(NonAffine(actuator=1, output="0.75*u**3 - 0.2")), 0.75 * U**3 - 0.2, atol=1e-15
    )
    assert_close(out(Reversal(actuator=1)), -U, atol=0)
    assert_close(out(PositionLimit(actuator=1, lower=-1.0, upper=0.5)), np.clip(U, -1, 0.5), atol=0)


def test_incipient_failure_blends_in_over_its_ramp():
    f = LossOfEffectiveness(actuator=1, onset=10.0, ramp=4.0, effectiveness=0.5)
    e = f.expression(VARS)
    assert_close(e(t=10.0, u=2.0), 2.0, atol=1e-15)  # healthy at onset: no jump
    assert_close(e(t=12.0, u=2.0), 1.5, atol=1e-15)  # half way
    assert_close(e(t=20.0, u=2.0), 1.0, atol=1e-15)  # fully failed after the ramp
    assert f.jump_times == (10.0, 14.0)


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: LossOfEffectiveness(actuator=1, effectiveness=1.3), r"\[0, 1\]; got 1.3"),
        (lambda: Stuck(actuator=0, value=1.0), "actuator number from 1"),
        (lambda: Stuck(actuator=1, onset=-1.0), "onset"),
        (lambda: Stuck(actuator=1, onset=5.0, recovery=5.0), "recovery"),
        (lambda: NonAffine(actuator=1, output="u**"), "invalid syntax"),
        (lambda: NonAffine(actuator=1, output="__import__('os')"), "unknown function"),
        (lambda: PositionLimit(actuator=1, lower=1.0, upper=0.0), "lower < upper"),
        (
            lambda: ParameterisedStuck(actuator=1, coefficients=(1.0,), basis=("1", "t")),
            "one coefficient per basis",
        ),
    ],
)
def test_invalid_failures_are_rejected_at_construction(make, match):
    with pytest.raises((ConfigurationError, ValueError), match=match):
        make()


def test_schedule_rejects_overlaps_and_unknown_actuators_and_finds_breakpoints():
    a = Stuck(actuator=2, onset=8.0, recovery=18.0, value=2.5)
    b = LossOfEffectiveness(actuator=2, onset=20.0, effectiveness=0.8)
    s = FailureSchedule((a, b), 4)
    assert s.breakpoints(0.0, 30.0) == (0.0, 8.0, 18.0, 20.0, 30.0)
    assert s.active(10.0)[1] is a and s.active(19.0)[1] is None and s.active(25.0)[1] is b
    with pytest.raises(ConfigurationError, match="overlap"):
        FailureSchedule((a, Stuck(actuator=2, onset=10.0)), 4)
    with pytest.raises(ConfigurationError, match="only 2 actuators"):
        FailureSchedule((Stuck(actuator=3),), 2)


def test_compensability_rejects_a_group_with_every_actuator_lost():
    R = np.array([[1, 1, 0, 0], [0, 0, 1, 1]], dtype=float)
    sched = FailureSchedule(
        (
            Stuck(actuator=1, onset=5.0, value=1.0),
            LossOfEffectiveness(actuator=2, onset=10.0, recovery=15.0, effectiveness=0.0),
        ),
        4,
    )
    report = check_compensability(sched, R, 30.0)
    assert not report.ok
    bad = [iv for iv in report.intervals if not iv.ok]
    assert [(iv.start, iv.end, iv.lost_groups) for iv in bad] == [(10.0, 15.0, (0,))]
    assert "[10 s, 15 s): NOT compensable" in report.describe(["q1", "q2"])
    assert "q1" in report.describe(["q1", "q2"])
    ok = check_compensability(FailureSchedule((Stuck(actuator=1, onset=5.0),), 4), R, 30.0)
    assert ok.ok and math.isclose(ok.intervals[-1].end, 30.0)
