"""The input-gain lever of scripts/combo1_noise_paths.py (``--gain-estimate``, docs/hardware.md
"Round 8: the input-gain lever, built"): the online estimate of the loop's input gain tracks
the plant's true gain along the allocation (the truth: the plant's input gains, elevator 2
stuck from 40 s), the command is the law's normalised by it (wholly, or below the low band
only), and it exists only in the runs that ask for it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from adaptive_ftc.controllers import constraints
from tests.conftest import load_script

ROOT = Path(__file__).resolve().parents[1]


def _script():
    return load_script("combo1_noise_paths")


cn = _script()


def _window(r, values, t0, t1):
    sel = (r.time >= t0) & (r.time <= t1)
    return values[sel]


def test_the_estimate_tracks_the_input_gain_lost_at_the_stuck_elevator():
    emit = constraints.emit
    r, loop = cn.run("hypersonic-direct-s1", duration=48.0, gain_estimate=(10.0, 0.5))
    assert constraints.emit is emit  # the lever is for that run only
    assert r.status == "completed"
    # the truth: the plant's input gains along the allocation (1, 2), healthy and with
    # elevator 2 stuck (it then moves with no command: its share of the gain is gone)
    G = np.asarray(loop.plant.input_gains(loop.t0, np.asarray(loop.initial_state, float)))[0]
    R = np.ravel(np.asarray(loop.R, dtype=float))
    healthy, stuck = float(G @ R), float(G[0] * R[0])
    assert np.isclose(cn.nominal_gain(loop), healthy)
    assert stuck < 0.5 * healthy
    bh = cn.gain_estimate(r, loop)
    before = _window(r, bh, 30.0, 40.0)
    after = _window(r, bh, 43.0, 48.0)
    assert np.all(before >= 0.85 * healthy) and np.all(before <= healthy)
    assert abs(np.mean(after) - stuck) < 0.2 * stuck
    assert f"gain_estimate{cn.GAIN_STATES}" in r.adaptive_names


def test_without_the_lever_the_loop_has_no_estimate():
    r, _ = cn.run("hypersonic-direct-s1", duration=1.0)
    assert not any(n.startswith("gain_estimate") for n in r.adaptive_names)


@pytest.mark.parametrize("low_band", [0.0, 0.5])
def test_the_command_is_the_laws_normalised_by_the_estimate(low_band):
    # no noise (the designer's model keeps it: the same configuration), so the law's own
    # command Pi(x)^T theta is recomputed from the recorded states and estimates
    r, loop = cn.run(
        "hypersonic-direct-s1",
        noise_off=True,
        duration=44.0,
        gain_estimate=(10.0, 0.2, low_band),
    )
    a = loop.controller.thesis_assembled(loop)
    y = np.array(a.y0, dtype=float)
    nx = loop.plant.n_states
    X, th = np.asarray(r.states, dtype=float), np.asarray(r.theta, dtype=float)
    sl = a.theta_slices[0]
    b_nom, bh = cn.nominal_gain(loop), cn.gain_estimate(r, loop)
    rows = np.nonzero(r.time >= 42.0)[0][::50]
    law = np.empty(rows.size)
    for k, n in enumerate(rows):
        y[:nx] = X[n]
        law[k] = float(np.dot(a.regressor_values(float(r.time[n]), y)[sl], th[n]))
    boost = b_nom / bh[rows]
    assert np.all(boost > 2.0)  # elevator 2 stuck: the estimate a third of the nominal
    if low_band > 0:
        lp = r.adaptive_state("gain_low_pass")[rows]
        expected = law + (boost - 1.0) * lp
        assert np.max(np.abs(expected - law)) > 0.05  # the boost is material
    else:
        expected = boost * law
        assert "gain_low_pass" not in r.adaptive_names
    assert np.allclose(np.asarray(r.u0, dtype=float)[rows, 0], expected, rtol=1e-9, atol=1e-12)
