"""scripts/combo1_noise_paths.py, the tool behind docs/hardware.md's "Round 7: combination 1"
(issue 25): its levers change the rule's configuration for one run only, and its split of the
command's fast content into the regressor path and the theta path is exact where it must be
(no noise: the regressor of the measured states is the regressor of the true states)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from adaptive_ftc.controllers import constraints
from adaptive_ftc.controllers.constraints import ConstraintAware
from tests.conftest import load_script

ROOT = Path(__file__).resolve().parents[1]


def _script():
    return load_script("combo1_noise_paths")


cn = _script()

#: the designer's model of combination 1 on hypersonic-direct-s1, as the compiled loop has it
MODEL = ConstraintAware(
    lag=0.02,
    sample_time=0.005,
    noise=0.0102,
    loop_rate=202.3,
    loop_gain=199.7,
    min_loop_gain=199.7,
    b_max=2.0,
    derivative_lag=0.01,
    gain_growth=1.0,
)


def test_levers_change_the_rules_configuration():
    base = MODEL.configure(w0=202.3, b_max=2.0, lam=2.0, input_gain=9.95)
    w, noisy = MODEL.omega_max(202.3, 2.0)
    assert not noisy and not base.filtered  # the density bound: no filter of the rule's own
    patched = cn.with_levers(command_filter=4.0, scale_g=1.4, scale_k=0.5, lam_factor=3.0)
    cfg = patched(MODEL, w0=202.3, b_max=2.0, lam=2.0, input_gain=9.95)
    assert math.isclose(cfg.omega_f, min(4.0 * w, 1.0 / 0.02, 1.0 / 0.005))
    assert math.isclose(cfg.scale, 1.4 * base.scale)
    assert math.isclose(cfg.slope_scale, 0.5 * base.slope_scale)
    assert cfg.lam_factor == 3.0
    assert math.isinf(cfg.u_max) and math.isinf(cfg.u_rate)  # a low-pass, no limits
    # no lever: the rule's own configuration
    assert cn.with_levers()(MODEL, w0=202.3, b_max=2.0, lam=2.0, input_gain=9.95) == base


def test_a_run_with_levers_restores_the_rule():
    original = constraints.ConstraintAware.configure
    r, _ = cn.run("hypersonic-direct-s1", levers={"command_filter": 4.0}, duration=1.0)
    assert constraints.ConstraintAware.configure is original
    assert "command_filter1" in r.adaptive_names  # the lever reached the compiled loop
    r, _ = cn.run("hypersonic-direct-s1", duration=1.0)
    assert "command_filter1" not in r.adaptive_names


def test_the_regressor_path_is_the_measurement_noise_in_the_regressor():
    window = (2.0, 3.0)
    r, loop = cn.run("hypersonic-direct-s1", noise_off=True, duration=3.0)
    total, theta_path, reg_path = cn.regressor_split(r, loop, window)
    assert reg_path < 1e-9 * total  # no noise: Pi(x_m) = Pi(x)
    assert math.isclose(theta_path, total, rel_tol=1e-9)
    # the latest reading at each sample (session 13's law; the rule's decimation filter
    # averages five readings since session 14)
    r, loop = cn.run("hypersonic-direct-s1", duration=3.0, decimation=False)
    total, theta_path, reg_path = cn.regressor_split(r, loop, window)
    # with noise the measured q in Pi carries a share (in this 1 s window 10.5 % with one draw
    # per sample, 8 % with the latest of the 1 kHz readings, session 14: the draws')
    assert reg_path > 0.05 * total
    bands = cn.band_rms(r, window)
    assert bands.shape == (2, len(cn.BANDS)) and np.all(bands > 0)
