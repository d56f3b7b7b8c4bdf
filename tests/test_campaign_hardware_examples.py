"""The shipped hardware campaigns (issue 25 item 5): hypersonic (§2.3 and, since session 15,
§4.4), wing rock, manipulator and spacecraft, each comparing the thesis law, the
constraint-aware law, the fixed-gain and nominal-inverse baselines and the oracle under drawn
hardware and failures, >= 500 members.
Each runs here at reduced size (2 members, a short duration): every design of every member
completes a row, and success is tracking and activity."""

from __future__ import annotations

import tomllib

import pytest

from adaptive_ftc.campaigns import CampaignError, load_campaign, read_results, run_campaign
from adaptive_ftc.campaigns.spec import EXAMPLES

HARDWARE_CAMPAIGNS = {
    "hypersonic-hardware": 4.0,
    "hypersonic-sign-hardware": 4.0,
    "wingrock-hardware": 2.0,
    "manipulator-hardware": 3.0,
    "spacecraft-hardware": 4.0,
}
DESIGNS = ("thesis-law", "constraint-aware", "fixed-gain", "nominal-inverse", "oracle")


def reduced(name: str, duration: float) -> dict:
    data = tomllib.loads((EXAMPLES / f"{name}.toml").read_text(encoding="utf-8"))
    data.update(runs=2, chunk_size=2, duration=duration)
    data["success"]["final_window"] = duration / 4
    data["failures"]["onset"] = {"uniform": [duration / 4, duration / 2]}
    if name == "wingrock-hardware":  # its ideal command settles within 1.5 s (test below)
        data["success"].update(reference_peak_to_peak=6.17, reference_peak_command=6.17)
    return data


@pytest.mark.parametrize("name", sorted(HARDWARE_CAMPAIGNS))
def test_a_shipped_hardware_campaign_compares_every_design_at_full_size(name):
    spec = load_campaign(name)
    assert spec.runs >= 500 and spec.designs == DESIGNS
    hw = spec.hardware
    assert None not in (hw.lag, hw.rate_limit, hw.travel, hw.sample_time) and hw.noise
    assert spec.activity is not None and spec.max_failures >= 1


@pytest.mark.parametrize("name", sorted(HARDWARE_CAMPAIGNS))
def test_a_shipped_hardware_campaign_runs_at_reduced_size(name, tmp_path):
    spec = load_campaign(reduced(name, HARDWARE_CAMPAIGNS[name]))
    run = run_campaign(spec, tmp_path / "c", jobs=1, progress=False, summary=False)
    assert run.complete
    df = read_results(tmp_path / "c")
    assert len(df) == 2 * len(DESIGNS) and tuple(df["design"].unique()) == DESIGNS
    assert df["activity_record_ok"].all() or (df["status"] != "completed").any()
    assert (df["success"] == (df["tracking_ok"] & df["activity_ok"])).all()
    assert not (df["status"] == "invalid").any()


def test_a_flat_ideal_command_asks_for_stated_references(tmp_path):
    """Wing rock regulates roll to 0: over its last second the ideal command has settled to
    3e-6 rad peak to peak (of a 6.2 rad peak), no reference for the fast content."""
    data = tomllib.loads((EXAMPLES / "wingrock-hardware.toml").read_text(encoding="utf-8"))
    data.update(runs=2, chunk_size=2)
    data["success"]["final_window"] = 1.0
    with pytest.raises(CampaignError, match="ideal command is flat.*reference_peak_to_peak"):
        run_campaign(load_campaign(data), tmp_path / "c", jobs=1, progress=False)
    assert not (tmp_path / "c" / "parts").exists() or not any((tmp_path / "c" / "parts").iterdir())
    data["success"].update(reference_peak_to_peak=6.17, reference_peak_command=6.17)
    stated = load_campaign(data)
    assert stated.activity.thresholds(stated) == pytest.approx((0.03 * 6.17, 61.7))


def test_a_baseline_that_cannot_be_built_is_a_failed_row_not_a_crash(tmp_path):
    """The §4.4 thesis law diverges under the drawn hardware even without failures, so the
    fixed-gain baseline has no healthy tuning run to freeze: that member's fixed-gain row is
    a failed run with the reason (status ``not_built``), the campaign and its page complete
    and the other designs run (session 15; before, the ConfigurationError stopped the whole
    campaign)."""
    from adaptive_ftc.campaigns.runner import UNBUILT

    spec = load_campaign(reduced("hypersonic-sign-hardware", 4.0))
    run = run_campaign(spec, tmp_path / "c", jobs=1, progress=False, summary=True)
    assert run.complete and (tmp_path / "c" / "summary.html").exists()
    df = read_results(tmp_path / "c")
    fixed = df[df["design"] == "fixed-gain"]
    assert (fixed["status"] == UNBUILT).all() and not fixed["success"].any()
    assert fixed["message"].str.contains("failure-free tuning run").all()
    assert (df[df["design"] == "constraint-aware"]["status"] == "completed").all()
