"""The oracle's compensated error (issue 25, item 3; session 15): the campaigns' ``oracle``
of a MIMO law with a floor puts the robust term of its raised outputs on ``s - xi``, as the
law puts its own, with ``xi = G zeta`` and ``zeta`` the leaky integral of the command its
limited command filter holds back (:meth:`OracleInverse.compensated_outputs`). Without it
the oracle's exact inverse, whose demand at the initial errors exceeds the filter's rate
limit, falls into a rate-limit limit cycle that it never leaves (the manipulator-hardware
oracle's 88 failures with a raised joint 1; docs/hardware.md, session 15)."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

from adaptive_ftc import simulate
from adaptive_ftc.campaigns import draw_member, load_campaign
from adaptive_ftc.campaigns.spec import EXAMPLES
from adaptive_ftc.controllers import nominal
from adaptive_ftc.sim.compose import Generator, generate


def spec_of(name: str, runs: int = 30):
    data = tomllib.loads((EXAMPLES / f"{name}.toml").read_text(encoding="utf-8"))
    data.update(runs=runs, chunk_size=10)
    return load_campaign(data)


def final_error(loop, solver, t_final: float, window: float) -> np.ndarray:
    result = simulate(dataclasses.replace(loop, t_final=t_final), solver)
    assert result.status == "completed"
    keep = result.time >= t_final - window
    return np.sqrt(np.mean(result.e[keep] ** 2, axis=0)), result


def test_the_oracle_holds_the_arm_that_the_uncompensated_one_loses(monkeypatch):
    """Member 24 of manipulator-hardware (continuous, 8.6 ms of lag, 56.6 N m/s, the law's
    joint 1 raised and joint 2 floored): in its first 8 s, before the drawn failure at 15 s,
    the session-13 oracle swings between the command filter's travel at its rate limit
    (errors of 0.2-0.6 rad for good); with the compensated error it tracks to a few
    milliradians, and ``zeta`` runs during the transient (it is not frozen with the
    adaptation the oracle does not have) and has decayed by the window."""
    spec = spec_of("manipulator-hardware")
    member = draw_member(spec, 24)
    loop = member.design_loop("oracle")
    assert loop.controller.law.output_floor()[0] == 0.0  # joint 1 raised, no floor
    err, result = final_error(loop, spec.solver, 8.0, 2.0)
    assert np.all(err < 1e-2), err
    zeta = result.adaptive_state("oracle_hedge1")
    assert np.abs(zeta).max() > 0.1  # it held back command during the transient
    assert np.abs(zeta[result.time >= 6.0]).max() < 1e-6
    monkeypatch.setattr(nominal, "C_ORACLE_COMPENSATED", False)
    old, result = final_error(member.design_loop("oracle"), spec.solver, 8.0, 2.0)
    assert "oracle_hedge1" not in result.adaptive_names
    assert old.max() > 0.1, old


def _generated(loop):
    text, data, g, _ = generate(loop, sdot="filtered")
    return text, tuple(np.asarray(data.c).tolist())


@pytest.mark.parametrize(
    ("name", "index"),
    [
        ("manipulator-hardware", 1),  # both joints floored: no raised output
        ("hypersonic-hardware", 1),  # no floor
        ("spacecraft-hardware", 1),  # raised outputs, no floor
        ("wingrock-hardware", 1),  # the placed PID: no output keeps the robust term
    ],
)
def test_elsewhere_the_oracle_is_the_session_13_one_bit_for_bit(monkeypatch, name, index):
    """Only a law with a floor beside a raised output gets it: elsewhere the generated
    module and its numbers are those of the oracle without it."""
    member = draw_member(spec_of(name), index)
    loop = member.design_loop("oracle")
    ctrl = loop.controller
    assert ctrl.law is not None
    assert ctrl.compensated_outputs(Generator(loop=loop, sdot="filtered")) == ()
    new = _generated(loop)
    monkeypatch.setattr(nominal, "C_ORACLE_COMPENSATED", False)
    assert _generated(member.design_loop("oracle")) == new
    assert "the oracle's compensated error" not in new[0]


def test_only_the_raised_output_is_compensated():
    """On member 24 the law floors joint 2 (its target is the designer's model, ``y_d''``)
    and raises joint 1 (the robust term): only joint 1's target reads ``xi``, while
    ``zeta`` has one state per command (the held-back command of either joint moves joint
    1's acceleration through the coupled inertia, ``xi = G zeta``)."""
    member = draw_member(spec_of("manipulator-hardware"), 24)
    loop = member.design_loop("oracle")
    g = Generator(loop=loop, sdot="filtered")
    assert loop.controller.compensated_outputs(g) == (0,)
    text = _generated(loop)[0]
    assert "xih0 = wb[0] * Y[" in text and "wb[1] * Y[" in text
    assert "xih1" not in text
    assert text.count("the oracle's compensated error") == 2  # xi, and zeta's derivative


def _motor_steps(loop, solver, t_final: float = 6.0, start: float = 4.0) -> float:
    """Std of the per-sample step of motor 1's command (joint 1) over ``[start, t_final]``."""
    result = simulate(dataclasses.replace(loop, t_final=t_final), solver)
    assert result.status == "completed"
    keep = result.time >= start
    every = int(round(loop.sample_time / 1e-3))  # the record is at 1 ms
    held = result.u_cmd[keep][::every, 0]
    return float(np.std(np.diff(held)))


def _bare(loop):
    """The loop on ideal motors (no lag, rate or travel) and without its failures: only the
    measured noise moves the command."""
    act = dataclasses.replace(loop.actuators, tau=0.0, rate=np.inf, lower=-np.inf, upper=np.inf)
    return dataclasses.replace(loop, actuators=act, failures=())


def test_the_raised_joints_robust_term_goes_through_its_own_input_gain(monkeypatch):
    """Member 187 (100 Hz, 0.5 ms, 3.6e-3 rad of noise on q1; joint 1 raised): on ideal
    motors and without its failure, so that only the measured noise moves the command, the
    oracle's per-sample step of motor 1's command is 0.56 N m when the raised joint's robust
    term is decoupled through the whole inverse (its torque is ``M11 M22 / det M``, about 4.4
    times the one through ``G_11``) and less than half of it through ``G_11`` (the law's own:
    0.11). The session-14 run failed the member on activity (0.47 N m of fast content)."""
    spec = spec_of("manipulator-hardware", runs=200)
    member = draw_member(spec, 187)

    loop = member.design_loop("oracle")
    assert loop.sample_time == 0.01 and loop.controller.law.output_floor()[0] == 0.0
    own = _motor_steps(_bare(loop), spec.solver)
    text = _generated(loop)[0]
    assert "gii0 = " in text and "u0[0] += (" in text
    monkeypatch.setattr(nominal, "C_ORACLE_OWN_GAIN", False)
    decoupled = _motor_steps(_bare(member.design_loop("oracle")), spec.solver)
    assert own < 0.5 * decoupled, (own, decoupled)
    assert decoupled > 0.3, decoupled


def test_the_raised_joints_feedback_is_at_the_laws_proportional_loop_gain(monkeypatch):
    """The law's robust slope ``w`` on a raised output is the integral corner of its
    adaptation; its proportional loop gain at the operating point is the normalised ``m g /
    (1 + m g / w)`` = ``3w/4`` (``C_RAISE`` = 3). The oracle's robust term, its only feedback
    on that output, runs at the latter: on member 187 (ideal motors, noise only) the
    per-sample step of motor 1's command falls with it (the campaign member then passes the
    activity verdict, 4.7 % of the window at a rate limit against 8.5 %)."""
    from adaptive_ftc.controllers import mimo

    spec = spec_of("manipulator-hardware", runs=200)
    member = draw_member(spec, 187)

    loop = member.design_loop("oracle")
    scale = loop.controller.proportional_scale(2)
    assert scale[0] == pytest.approx(mimo.C_RAISE / (1.0 + mimo.C_RAISE))
    at_gain = _motor_steps(_bare(loop), spec.solver)
    monkeypatch.setattr(nominal, "C_ORACLE_PROPORTIONAL", False)
    assert member.design_loop("oracle").controller.proportional_scale(2) == (1.0, 1.0)
    at_slope = _motor_steps(_bare(member.design_loop("oracle")), spec.solver)
    assert at_gain < 0.9 * at_slope, (at_gain, at_slope)
