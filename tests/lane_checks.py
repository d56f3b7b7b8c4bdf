"""What the lane-engine tests share (``test_lanes*.py``): the base loop, a diverging member,
and the bit-for-bit comparison of a lane's result with its own single run (the truth)."""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np

from adaptive_ftc import load_scenario, simulate
from adaptive_ftc.errors import DivergenceWarning
from adaptive_ftc.faults import Affine


def lane_base():
    """hypersonic-direct-s1's loop over 3 s without failures (members add their own)."""
    sc = load_scenario("hypersonic-direct-s1")
    return replace(sc.loop, t_final=3.0, failures=())


def reversed_elevators(onset: float) -> tuple:
    """Both elevators reversed: alpha leaves the plant's envelope within a second."""
    return tuple(Affine(actuator=j, onset=onset, effectiveness=-1.0, bias=0.0) for j in (1, 2))


def assert_same_run(a, b) -> None:
    """``a`` (lanes) is ``b`` (its single run) bit for bit."""
    assert a.status == b.status
    assert a.reason == b.reason
    assert a.message == b.message
    np.testing.assert_array_equal(a.time, b.time)
    np.testing.assert_array_equal(a.states, b.states)
    np.testing.assert_array_equal(a.adaptive, b.adaptive)
    for name in ("u_cmd", "u_f", "s", "sdot", "control_gain"):  # the signals' pass
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    for key in ("steps", "rhs_evaluations", "rejected_steps"):
        assert a.meta[key] == b.meta[key], key


def single_runs(loops, solver) -> list:
    """Each loop simulated alone (divergence warnings silenced: some members diverge)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        return [simulate(loop, solver) for loop in loops]
