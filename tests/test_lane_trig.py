"""The lane modules' call-free sin and cos (issue 29, ``sim/lane_kernels.py``) against libm:
within 1 ulp on the phases a reference meets, nan for nan, inf and beyond 1e6, exact at
0."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from adaptive_ftc.sim.lane_kernels import vcos, vsin


@njit
def _both(x, out):
    for i in range(x.size):
        out[0, i] = vsin(x[i])
        out[1, i] = vcos(x[i])


def _ulps(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ia, ib = a.view(np.int64), b.view(np.int64)
    ia = np.where(ia < 0, np.int64(-(2**63)) - ia, ia)
    ib = np.where(ib < 0, np.int64(-(2**63)) - ib, ib)
    return np.abs(ia - ib)


@pytest.mark.parametrize("lo, hi", [(0.0, 24.0), (-4.0, 4.0), (-1e4, 1e4)])
def test_vsin_vcos_within_1_ulp_of_libm(lo, hi):
    x = np.random.default_rng(2).uniform(lo, hi, 1 << 14)
    out = np.empty((2, x.size))
    _both(x, out)
    for k, ref in enumerate((math.sin, math.cos)):
        libm = np.array([ref(v) for v in x])  # libm's, not numpy's own
        assert int(_ulps(out[k], libm).max()) <= 1, ref.__name__


def test_vsin_vcos_at_special_points():
    x = np.array([0.0, -0.0, math.nan, math.inf, -math.inf, math.pi / 2, math.pi, 2e6])
    out = np.empty((2, x.size))
    _both(x, out)
    assert out[0, 0] == 0.0 and out[1, 0] == 1.0 and out[1, 1] == 1.0
    assert all(math.isnan(v) for v in out[:, 2:5].ravel())
    assert abs(out[0, 5] - 1.0) <= 2**-52 and abs(out[1, 5]) < 1e-16
    assert abs(out[0, 6]) < 1e-15 and abs(out[1, 6] + 1.0) <= 2**-52
    assert math.isnan(out[0, 7]) and math.isnan(out[1, 7])  # beyond TRIG_MAX: nan, not garbage


def test_only_the_vector_lane_module_uses_the_trig_kernels_and_contraction():
    """kernels='vector' (RK4): the reference through vsin/vcos for every lane (no per-lane
    branch; one branch for the group: only when some lane's time moved) and fused
    multiply-adds only; the libm module keeps libm and strict IEEE."""
    from dataclasses import replace

    from adaptive_ftc import SolverOptions, load_scenario
    from adaptive_ftc.sim.lanes import lane_source

    loop = replace(load_scenario("hypersonic-direct-s1").loop, t_final=1.0, failures=())
    rk4 = SolverOptions(method="rk4", dt=1e-3, record_dt=0.01)
    vec = lane_source(loop, rk4, kernels="vector")
    libm = lane_source(loop, rk4, kernels="libm")
    rhs = vec[vec.index("def rhs(") : vec.index("def commands(")]
    assert "vsin(" in rhs and "vcos(" in rhs and "math.sin(" not in rhs
    assert "if B[REFT * W + w] != t:" not in rhs
    assert rhs.count("if moved:") == 1 and rhs.index("if moved:") < rhs.index("vsin(")
    assert vec.count('fastmath={"contract"}') == 2 and "fastmath=" not in libm
    assert "math.sin(" in libm and "vsin" not in libm
