"""Reachability on constructed rank-deficient cases: the axes lost are named, never inverted
into huge gains (issue 31; PX4 #28589's hexarotor)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from adaptive_ftc.allocation import PseudoInverse
from adaptive_ftc.allocation.reachable import reachability, reachability_timeline
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.faults import LossOfEffectiveness, Stuck
from adaptive_ftc.scenarios.loader import load_scenario

SPACECRAFT_R = np.array(
    [[1.0, 0, 0, 1, 0, 0], [0, 1.0, 0, 0, 1, 0], [0, 0, 1.0, 0, 0, 1]]
)  # R = [I3 I3]: roll wheels 1, 4; pitch 2, 5; yaw 3, 6
AXES = ("roll", "pitch", "yaw")


def _hexarotor():
    """Roll, pitch, yaw, thrust rows of a PNPNPN hexarotor (rotors every 60 degrees)."""
    ang = np.deg2rad(np.arange(6) * 60.0)
    spin = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0])
    return np.vstack([-np.sin(ang), np.cos(ang), 0.1 * spin, np.ones(6)])


def test_healthy_matrices_reach_every_axis():
    r = reachability(SPACECRAFT_R, axis_names=AXES)
    assert r.full and r.rank == 3 and r.unreachable == ()
    assert r.condition == pytest.approx(1.0)
    assert reachability(_hexarotor()).full


def test_two_opposing_hexarotor_rotors_lose_a_combined_pitch_yaw_direction():
    B = _hexarotor()
    r = reachability(B, failed=(1, 4), axis_names=("roll", "pitch", "yaw", "thrust"))
    assert r.rank == 3 and (math.isinf(r.condition) or r.condition > 1e12)
    # the lost direction mixes pitch and yaw; roll and thrust stay reachable
    assert r.unreachable == ("pitch", "yaw")
    assert r.reach[0] == pytest.approx(1.0) and r.reach[3] == pytest.approx(1.0)
    (d,) = r.lost_directions
    Bw = B[:, [1, 2, 4, 5]]
    assert np.linalg.norm(np.asarray(d) @ Bw) < 1e-12  # truly unreachable: d^T B_w = 0
    # the guarded pseudo-inverse gives bounded commands there; the plain one does not
    v = np.array([0.0, 0.3, 0.3, 1.0])
    Bf = B * np.array([0.0, 1, 1, 0, 1, 1])  # rotors 1 and 4 removed
    Bf[2, 1] += 1e-9  # a near-singular matrix (rounding away from exact rank loss)
    naive = np.linalg.pinv(Bf, rcond=1e-15) @ v
    guarded = PseudoInverse(max_condition=1e3).allocate(v, Bf)
    assert np.max(np.abs(naive)) > 1e5
    assert np.max(np.abs(guarded)) < 2.0


def test_spacecraft_two_wheel_losses_at_and_beyond_the_rank_limit():
    # one wheel left per axis (wheels 1 and 2 lost): at the rank limit, still reachable
    at_limit = reachability(SPACECRAFT_R, failed=(1, 2), axis_names=AXES)
    assert at_limit.full and at_limit.rank == 3 and at_limit.working == (3, 4, 5, 6)
    # both roll wheels lost: roll is gone by name, pitch and yaw stay
    lost = reachability(SPACECRAFT_R, failed=(1, 4), axis_names=AXES)
    assert lost.unreachable == ("roll",)
    assert lost.rank == 2 and math.isinf(lost.condition)
    assert lost.reach == pytest.approx((0.0, 1.0, 1.0))
    assert "NOT reachable: roll" in lost.describe()


def test_conditioning_guard_counts_a_weak_axis_as_lost():
    B = SPACECRAFT_R * np.array([1e-5, 1, 1, 1e-5, 1, 1])  # roll wheels at 1e-5 effectiveness
    assert reachability(B, axis_names=AXES, max_condition=1e3).unreachable == ("roll",)
    assert reachability(B, axis_names=AXES, max_condition=1e6).full


def test_timeline_names_the_axis_and_the_time_it_is_lost():
    sc = load_scenario("spacecraft-mimo-s1")
    from dataclasses import replace

    loop = replace(
        sc.loop,
        failures=(
            Stuck(actuator=1, onset=30.0, value=0.5),
            LossOfEffectiveness(actuator=2, onset=40.0, effectiveness=0.5),
            Stuck(actuator=4, onset=60.0, recovery=90.0, value=1.0),
        ),
    )
    events = reachability_timeline(loop)
    assert [e.time for e in events] == [0.0, 30.0, 60.0, 90.0]
    assert [e.failed for e in events] == [(), (1,), (1, 4), (1,)]
    assert [e.report.unreachable for e in events] == [(), (), ("phi",), ()]
    assert "t = 60 s" in events[2].describe() and "phi" in events[2].describe()


def test_bad_reachability_inputs_name_the_culprit():
    with pytest.raises(ConfigurationError, match="names actuator 7"):
        reachability(SPACECRAFT_R, failed=(7,))
    with pytest.raises(ConfigurationError, match="one name per row"):
        reachability(SPACECRAFT_R, axis_names=("roll",))
