"""scripts/combo1_linear_band.py, the linear model behind docs/hardware.md's "Round 7 (session
13)" (issue 25, combination 1): its plant is the library's hypersonic plant linearised, it
reproduces the measured run at the rule's point, and it says what the docs say of the failed
loop (damped only by the rate feedback the learnt theta makes of the fuzzy basis)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from adaptive_ftc.plants.hypersonic import HypersonicAngleOfAttack
from tests.conftest import load_script

ROOT = Path(__file__).resolve().parents[1]


def _script():
    return load_script("combo1_linear_band")


lb = _script()


def test_the_models_plant_is_the_library_plant_linearised():
    plant = HypersonicAngleOfAttack()
    u = np.zeros(2)
    h = 1e-6
    d_alpha = (plant.derivative(0.0, [h, 0.0], u) - plant.derivative(0.0, [-h, 0.0], u)) / (2 * h)
    d_q = (plant.derivative(0.0, [0.0, h], u) - plant.derivative(0.0, [0.0, -h], u)) / (2 * h)
    d_u = (plant.derivative(0.0, [0.0, 0.0], [h, 0.0]) - plant.derivative(0.0, [0.0, 0.0], u)) / h
    assert math.isclose(d_alpha[1], lb.M_ALPHA, rel_tol=1e-6)
    assert math.isclose(d_q[1], lb.M_Q, rel_tol=1e-6)
    # the allocation (1, 2): healthy 3 x the elevator's gain, failed 0.75 x it
    assert math.isclose(3.0 * d_u[1], lb.B_HEALTHY, rel_tol=1e-3)
    assert math.isclose(0.75 * d_u[1], lb.B_FAILED, rel_tol=1e-3)


def test_the_model_reproduces_the_rules_run():
    _, kw, err, fast = lb.CALIBRATION[0]
    r = lb.evaluate(**kw)
    assert abs(r["err"] / err - 1.0) < 0.1
    assert abs(r["u_fast"] / fast - 1.0) < 0.15


def test_the_failed_loop_is_damped_only_by_the_learnt_rate_feedback():
    kw = dict(lb.CALIBRATION[0][1])
    with_rate = lb.evaluate(**kw)
    assert with_rate["maxre_failed"] < 0 and 0.0 < with_rate["zeta_failed"] < 0.15
    kw["dq"] = 0.0
    without = lb.evaluate(**kw)
    assert without["maxre_failed"] > 0  # unstable at a quarter of the input gain
    assert without["maxre_healthy"] < 0
