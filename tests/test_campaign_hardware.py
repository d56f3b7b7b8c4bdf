"""Hardware campaigns (issue 25 item 5): members draw actuator lag, rate limit, travel,
controller sample time and sensor noise, combined with drawn failures."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from adaptive_ftc.campaigns import (
    CampaignError,
    draw_member,
    load_campaign,
    read_results,
    run_campaign,
)
from adaptive_ftc.campaigns.store import schema

HW = {
    "name": "hw",
    "base": "hypersonic-direct-s1",
    "designs": ["adaptive"],
    "runs": 40,
    "seed": 5,
    "chunk_size": 20,
    "duration": 2.0,
    "success": {"rms_error_final": 0.01, "final_window": 0.5},
    "failures": {
        "count": 1,
        "onset": {"uniform": [0.5, 1.0]},
        "models": {
            "stuck": {"value": {"uniform": [-0.1, 0.1]}},
            "rate_limited": {"rate": {"uniform": [0.5, 2.0]}},
        },
    },
    "hardware": {
        "lag": {"uniform": [0.01, 0.05]},
        "rate_limit": [{"loguniform": [0.5, 10.0]}, 5.0],
        "travel": {"uniform": [0.3, 1.0]},
        "sample_time": {"choice": [0.0, 0.005]},
        "noise": {"alpha": {"uniform": [0.0, 1e-3]}},
    },
}


def hw(**changes):
    data = copy.deepcopy(HW)
    data["hardware"].update(changes)
    return data


def test_members_draw_their_hardware_within_the_spec():
    spec = load_campaign(hw())
    members = [draw_member(spec, i) for i in range(spec.runs)]
    for mem in members:
        act, c = mem.loop.actuators, mem.columns
        assert act.tau == (c["hw_lag"],) * 2 and 0.01 <= c["hw_lag"] <= 0.05
        assert act.rate == (c["hw_rate_limit_1"], 5.0) and c["hw_rate_limit_2"] == 5.0
        assert act.upper == (c["hw_travel"],) * 2 and act.lower == (-c["hw_travel"],) * 2
        assert mem.loop.sample_time == c["hw_sample_time"] in (0.0, 0.005)
        assert mem.loop.sensors.noise == {"alpha": c["noise_alpha"]}
        assert len(mem.failures) == 1  # combined with the drawn failure
    seeds = {m.loop.sensors.seed for m in members}
    assert len(seeds) == len(members)  # each member its own noise
    assert {m.columns["hw_sample_time"] for m in members} == {0.0, 0.005}
    again = draw_member(spec, 7)
    assert again.columns == members[7].columns and again.loop == members[7].loop
    names = schema(spec).names
    for col in ("hw_lag", "hw_rate_limit_1", "hw_rate_limit_2", "hw_travel", "noise_alpha"):
        assert col in names


def test_without_a_hardware_table_members_are_drawn_as_before():
    data = hw()
    del data["hardware"]
    plain = draw_member(load_campaign(data), 3)
    drawn = draw_member(load_campaign(hw()), 3)
    assert plain.loop.actuators is None and plain.loop.sensors is None
    assert plain.failures == drawn.failures  # hardware is drawn after everything else


@pytest.mark.parametrize(
    "change, culprit",
    [
        ({"lags": 0.1}, "unknown key 'lags'. Did you mean 'lag'?"),
        ({"lag": -0.01}, "[hardware.lag] first-order lag"),
        ({"rate_limit": 0.0}, "[hardware.rate_limit] rate limit"),
        ({"travel": [0.5, 0.5, 0.5]}, "gives 3 distributions; plant"),
        ({"noise": {"alpah": 1e-3}}, "unknown state 'alpah'. Did you mean 'alpha'?"),
        ({"noise": {"alpha": -1.0}}, "a standard deviation must be >= 0"),
        ({"sample_time": {"uniform": [0.0, 5.0]}}, "`sample_time` must be 0"),
        ({"lag": {"normal": [0.02, 0.01]}}, "`normal` without `clip`"),
        ({"lag": []}, "an empty list"),
        ({"lag": [0.01, []]}, "[hardware.lag.2] must be one number"),
    ],
)
def test_impossible_hardware_is_refused_at_validation(change, culprit):
    with pytest.raises(CampaignError) as err:
        load_campaign(hw(**change))
    assert culprit in str(err.value)


def test_a_drawn_hardware_failure_overlapping_a_kept_failure_is_refused():
    data = hw()
    data["duration"] = 60.0
    data["success"]["final_window"] = 5.0
    data["failures"]["keep_base"] = True  # the base keeps a stuck elevator 2 from 40 s
    data["failures"]["actuators"] = [2]
    data["failures"]["onset"] = {"uniform": [30.0, 50.0]}
    data["failures"]["models"] = {"rate_limited": {"rate": 0.5}}
    with pytest.raises(CampaignError, match=r"Stuck on actuator 2 over \[40, end of run\)"):
        load_campaign(data)


def test_a_hardware_campaign_runs_and_the_travel_bounds_the_applied_command(tmp_path):
    data = hw()
    data.update(runs=2, chunk_size=2, duration=0.6)
    data["success"]["final_window"] = 0.2
    data["failures"]["onset"] = {"uniform": [0.2, 0.4]}
    run = run_campaign(load_campaign(data), tmp_path / "c", progress=False, summary=False)
    assert run.complete
    df = read_results(tmp_path / "c")
    assert len(df) == 2 and set(df["status"]) <= {"completed", "diverged"}
    assert np.all(df["peak_applied"] <= df["hw_travel"] + 1e-9)


def test_drawn_noise_overrides_only_its_states_of_the_base_sensors():
    """hypersonic-direct-s1-noise measures alpha and q with noise; the spec draws alpha's."""
    data = hw()
    data["base"] = "hypersonic-direct-s1-noise"
    base = load_campaign({**data, "hardware": {}}).loop.sensors
    assert base is not None and base.has_noise
    mem = draw_member(load_campaign(data), 0)
    std, _ = mem.loop.sensors.per_state(mem.loop.plant.aliases(), mem.loop.plant.n_states)
    base_std, _ = base.per_state(mem.loop.plant.aliases(), mem.loop.plant.n_states)
    assert std[0] == mem.columns["noise_alpha"]
    assert std[1:].tolist() == base_std[1:].tolist()  # q keeps the base scenario's noise
