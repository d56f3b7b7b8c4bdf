"""The form of the vector lane module's rhs (issue 29, ``lane_kernels="vector"`` with RK4): what
keeps LLVM's vectoriser on every lane statement, read from the generated text (the libm module
keeps the single run's form, byte for byte). The numbers are held by
``tests/test_lanes.py::test_vector_kernels_stay_within_1e12_of_the_single_runs`` (every failure
kind, a diverging lane, other gains in one lane) and ``tests/test_lane_trig.py``."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from numba import njit

from adaptive_ftc import SolverOptions, load_scenario
from adaptive_ftc.sim.lane_kernels import vcos, vsin
from adaptive_ftc.sim.lanes import lane_source

RK4 = SolverOptions(method="rk4", dt=1e-3, record_dt=0.01)


@pytest.fixture(scope="module")
def sources():
    loop = replace(load_scenario("hypersonic-direct-s1").loop, t_final=1.0, failures=())
    rhs = {}
    for kernels in ("vector", "libm"):
        text = lane_source(loop, RK4, kernels=kernels)
        rhs[kernels] = text[text.index("def rhs(") : text.index("def commands(")]
    return rhs


def test_the_failures_are_selected_by_weights_not_a_branch(sources):
    vec, libm = sources["vector"], sources["libm"]
    assert "acc if kind < 0.0 else (aff if kind == 0.0 else inc)" in libm
    assert "acc if kind < 0.0" not in vec
    assert "= wh * acc + wa * aff + wi * inc" in vec
    assert "den = c1 if kind > 0.0 else 1.0" in vec  # every term finite


def test_u0_is_written_out_term_by_term(sources):
    vec, libm = sources["vector"], sources["libm"]
    assert "for l in range(25):\n        for w in range(W):\n            B[U0 * W + w] +=" in libm
    terms = [ln.strip() for ln in vec.splitlines() if "B[U0 * W + w] +=" in ln]
    assert terms == [
        f"B[U0 * W + w] += B[(PHI + {k}) * W + w] * B[(y + 2 + {k}) * W + w]" for k in range(25)
    ]


@njit
def _quadrants(x, out):
    for i in range(x.size):
        out[0, i] = vsin(x[i])
        out[1, i] = vcos(x[i])


def test_vsin_vcos_in_every_quadrant_against_the_kernels():
    """The quadrant's selects (bits of q) against sin/cos by symmetry: sin(x + k pi/2) of a
    small x is sin x, cos x, -sin x, -cos x for k = 0, 1, 2, 3 (to rounding of the sums)."""
    x = np.linspace(-0.7, 0.7, 57)
    out = np.empty((2, x.size))
    base = np.empty((2, x.size))
    _quadrants(x, base)
    s, c = base
    for k, (ws, wc) in enumerate([(s, c), (c, -s), (-s, -c), (-c, s)]):
        for turn in (0.0, -8.0, 3.0, -41.0):  # q from n of either sign, odd turns too
            _quadrants(x + k * np.pi / 2 + turn * np.pi, out)
            sign = 1.0 if turn % 2.0 == 0.0 else -1.0
            np.testing.assert_allclose(out[0], sign * ws, atol=1e-13)
            np.testing.assert_allclose(out[1], sign * wc, atol=1e-13)
