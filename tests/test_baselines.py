"""Fixed-gain baseline: parameters of a failure-free adaptive run, frozen."""

import warnings
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc import ConfigurationError, SolverOptions, fixed_gain, load_scenario, simulate
from adaptive_ftc.baselines import CAMPAIGN_SOLVER, healthy_parameters
from adaptive_ftc.campaigns import DESIGN_VARIANTS, draw_member, load_campaign


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("hypersonic-direct-s1")


@pytest.fixture(scope="module")
def healthy_run(scenario):
    return simulate(scenario.loop.without_failures(), scenario.solver)


def _run(loop, solver):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(loop, solver)


def test_parameters_are_those_the_healthy_run_ended_with(scenario, healthy_run):
    fg = fixed_gain(scenario.loop, scenario.solver)
    assert fg.adapt is False
    assert fg.failures == scenario.loop.failures  # the failures are kept
    np.testing.assert_array_equal(fg.adaptive_initial, healthy_run.adaptive[-1])
    assert fg.name == "hypersonic-direct-s1 (fixed-gain)"
    # and they stay there: every adaptive state is constant through the failures
    r = _run(replace(fg, t_final=50.0), scenario.solver)
    np.testing.assert_array_equal(r.adaptive, np.broadcast_to(r.adaptive[0], r.adaptive.shape))
    np.testing.assert_array_equal(r.adaptive[0], healthy_run.adaptive[-1])


def test_filter_states_are_not_parameters(scenario):
    solver = SolverOptions(sdot="filtered", record_dt=0.1)
    params = healthy_parameters(replace(scenario.loop, t_final=5.0), solver)
    assert len(params) == 25  # theta only, the s filter state is left out
    r = simulate(fixed_gain(replace(scenario.loop, t_final=5.0), solver), solver)
    assert r.status == "completed"


def test_direct_design_frozen_is_blind_to_the_reference(scenario):
    """Truth: with regressor inputs (alpha, q), u0 = Pi(alpha, q)^T theta (2.22) is a static
    state feedback once theta is frozen: the reference y_d enters the direct design only
    through the adaptive law (2.29). Two references give the very same trajectory."""
    fg = fixed_gain(scenario.loop.without_failures(), scenario.solver)
    a = _run(replace(fg, t_final=20.0), scenario.solver)
    # twice the amplitude, 2.5 times the frequency; the same expression shape, so the same
    # compiled loop (its numbers are data)
    b = _run(replace(fg, t_final=20.0, reference=("pi/18*sin(0.5*t)",)), scenario.solver)
    assert np.max(np.abs(a.yd - b.yd)) > 0.05  # rad: the references differ
    np.testing.assert_array_equal(a.states, b.states)
    np.testing.assert_array_equal(a.u_cmd, b.u_cmd)


def test_fixed_gain_does_not_track_the_healthy_plant(scenario, healthy_run):
    """Measured finding (README 'Fair baselines'): because of the blindness above, the
    fixed-gain baseline of the §2.3 design does not track even without failures (RMS over the
    last 20 s: adaptive 1.4e-7 rad, fixed-gain 0.30 rad, frozen at theta0 0.55 rad)."""
    loop = scenario.loop.without_failures()
    window = (100.0, 120.0)
    adaptive = healthy_run.rms_error(*window)[0]
    fixed = _run(fixed_gain(loop, scenario.solver), scenario.solver)
    assert fixed.status == "completed"
    assert fixed.rms_error(*window)[0] > 1e4 * adaptive
    frozen = _run(loop.frozen(), scenario.solver)
    assert fixed.rms_error(*window)[0] < frozen.rms_error(*window)[0]


def test_failed_tuning_run_is_a_clear_error(scenario):
    with pytest.raises(ConfigurationError, match="failure-free tuning run"):
        fixed_gain(scenario.loop, SolverOptions(divergence_bound=1e-3))
    with pytest.raises(ConfigurationError, match="needs a ClosedLoop"):
        fixed_gain(scenario)


def test_registered_for_campaigns():
    assert "fixed-gain" in DESIGN_VARIANTS
    spec = load_campaign(
        {
            "name": "fg",
            "base": "hypersonic-direct-s1",
            "designs": ["adaptive", "fixed-gain", "frozen"],
            "runs": 2,
            "seed": 3,
            "duration": 2.0,
            "success": {"rms_error_final": 0.01, "final_window": 1.0},
            "failures": {
                "count": 1,
                "onset": {"uniform": [0.5, 1.5]},
                "models": {"loss_of_effectiveness": {"effectiveness": {"uniform": [0.2, 0.8]}}},
            },
        }
    )
    member = draw_member(spec, 0)
    loop = member.design_loop("fixed-gain")
    assert loop.adapt is False and loop.failures == member.loop.failures
    assert loop.adaptive_initial == healthy_parameters(member.loop, CAMPAIGN_SOLVER)
