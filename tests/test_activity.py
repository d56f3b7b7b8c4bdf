"""Control activity (issue 25, item 1): the metrics of ``sim/activity.py`` against signals whose
truth is known (sines of known amplitude above and below the cut-off, ramps of known rate and
total variation, rate- and travel-limited positions of known duty), the ``activity`` claim,
the FINDING verdict, ``bounded`` with a declared travel, the hardware scenarios and
``aftc run``'s claims."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import warnings

import numpy as np
import pytest

from adaptive_ftc.claims import FAIL, FINDING, PASS, ClaimError, evaluate_claim, evaluate_claims
from adaptive_ftc.cli import main
from adaptive_ftc.report import ScenarioEntry, render_report
from adaptive_ftc.scenarios import load_scenario
from adaptive_ftc.sim.activity import command_activity, max_record_dt
from adaptive_ftc.sim.engine import simulate
from adaptive_ftc.sim.result import SimResult
from tests.conftest import assert_close

DT = 1e-3
T = np.round(np.arange(0.0, 30.0 + DT / 2, DT), 12)
HARDWARE = (
    "hypersonic-direct-s1-actuators",
    "hypersonic-direct-s1-digital",
    "hypersonic-direct-s1-noise",
    "hypersonic-direct-s1-sluggish",
)


def sine(amp: float, f: float, t: np.ndarray = T) -> np.ndarray:
    return amp * np.sin(2 * np.pi * f * t)


def act(u, *, t=T, start=10.0, end=30.0, **kw):
    u = np.asarray(u, dtype=float)
    return command_activity(t, u.reshape(t.size, -1), ("u",), start=start, end=end, **kw)["u"]


# ---------------------------------------------------------------------------- metrics
def test_fast_content_is_the_rms_of_the_sine_above_the_cut_off_and_not_the_one_below():
    slow, fast = sine(0.3, 0.05), sine(0.01, 10.0)
    a = act(slow + fast)
    # the window ends at the record's end: the whole record is filtered first, its ends
    # extended, so no edge transient dominates the 7e-3 RMS of the fast sine
    assert_close(a.fast_rms, 0.01 / math.sqrt(2), atol=2e-5, what="fast sine's RMS")
    assert act(slow).fast_rms < 3e-5 * 0.3, "a 0.05 Hz sine has no content above 1 Hz"
    # a sine just below / above the cut-off: the 4th-order filter run twice (8th-order
    # magnitude) leaves 1/(1 + (f/f_c)^8) of it in the low-pass
    below, above = act(sine(1.0, 0.5)), act(sine(1.0, 2.0))
    assert_close(below.fast_rms, (1 / math.sqrt(2)) * 0.5**8 / (1 + 0.5**8), atol=2e-4)
    assert_close(above.fast_rms, (1 / math.sqrt(2)) * 2**8 / (1 + 2**8), atol=2e-4)
    # a higher declared cut-off moves a 2 Hz sine to the slow side
    assert act(sine(1.0, 2.0), f_c=20.0).fast_rms < 1e-3


def test_filtering_only_the_window_would_be_wrong_the_whole_record_is_filtered():
    u = sine(0.3, 0.05) + sine(0.01, 10.0)
    whole = act(u, start=10.0, end=20.0).fast_rms
    cut = (T >= 10.0 - 1e-9) & (T <= 20.0 + 1e-9)
    alone = command_activity(T[cut], u[cut, None], ("u",)).get("u").fast_rms
    assert_close(whole, 0.01 / math.sqrt(2), atol=2e-5)
    assert_close(whole, alone, atol=1e-3, what="both near the truth here, but not equal")
    assert whole != alone


def test_filtering_a_margin_around_the_window_equals_filtering_the_whole_record():
    from adaptive_ftc.sim.activity import _lowpass

    t = np.round(np.arange(0.0, 120.0 + DT / 2, DT), 12)
    rng = np.random.default_rng(0)
    u = sine(0.3, 0.03, t) + 0.02 * np.sin(
        2 * np.pi * 7.0 * t + 0.3 * np.cumsum(rng.normal(size=t.size)) * DT
    )
    for start, end in ((100.0, 120.0), (40.0, 60.0), (0.0, 15.0)):
        whole = _lowpass(u[:, None], 1.0, DT)[:, 0]
        m = (t >= start - 1e-9) & (t <= end + 1e-9)
        truth = float(np.sqrt(np.mean((u[m] - whole[m]) ** 2)))
        got = act(u, t=t, start=start, end=end).fast_rms
        assert_close(got, truth, atol=1e-9 * truth, what=f"window [{start}, {end}]")


def test_ramp_total_variation_peak_rate_and_peak_to_peak():
    rate = 0.7
    a = act(-1.0 + rate * T)
    assert_close(a.tv_per_s, rate, atol=1e-9, what="TV/s of a ramp is its rate")
    assert_close(a.peak_rate, rate, atol=1e-9)
    assert_close(a.peak_to_peak, rate * 20.0, atol=1e-9)
    assert_close(a.peak_command, abs(-1.0 + rate * 30.0), atol=1e-9)
    # a straight line has no content above the cut-off: what remains is the filter's start
    # transient through the 3 s end extension, below 1e-6 of the ramp's span
    assert a.fast_rms < 1e-6 * rate * 30.0
    # a sine over whole periods: TV per period 4 A, peak rate 2 pi f A
    s = act(sine(0.2, 5.0))
    assert_close(s.tv_per_s, 4 * 0.2 * 5.0, atol=1e-3)
    assert_close(s.peak_rate, 2 * np.pi * 5.0 * 0.2, atol=5e-3)


def test_rate_and_travel_limited_fractions_of_the_position():
    r = 2.0
    # in the 20 s window: a triangle of slope +-r between -0.75 and 0.75 for 6 s (12-18 s),
    # the upper travel 1.0 for 5 s (20-25 s), at rest at 0 elsewhere
    t = T
    phase = np.mod(t - 12.0, 1.5)
    pos = np.where((t >= 12.0) & (t < 18.0), 0.75 - np.abs(r * phase - 1.5), 0.0)
    pos = np.where((t >= 20.0) & (t < 25.0), 1.0, pos)
    limits = {
        "declared": {"rate": [r], "lower": [-1.0], "upper": [1.0]},
        "segments": [{"start": 0.0, "rate": [r], "lower": [-1.0], "upper": [1.0]}],
    }
    a = act(pos, position=pos[:, None], limits=limits)
    # moving at |slope| = r for 6 of the 20 s (intervals), at the upper travel 5 s (+ the
    # samples of the triangle within 2e-3 of 1.0: none, it stays in [-0.75, 0.75])
    assert_close(a.rate_limited_fraction, 6.0 / 20.0, atol=2e-3)
    assert_close(a.travel_limited_fraction, 5.0 / 20.0, atol=2e-3)
    assert a.travel == 1.0 and a.peak_command_travel_ratio == pytest.approx(1.0)
    # the limit in effect is used: from 15 s on a faster one (a failure's window ends)
    faster = {**limits["segments"][0], "start": 15.0, "rate": [4.0]}
    b = act(
        pos, position=pos[:, None], limits={**limits, "segments": [*limits["segments"], faster]}
    )
    assert_close(b.rate_limited_fraction, 3.0 / 20.0, atol=2e-3)
    # no declared limits: nan (not 0: nothing to be at)
    c = act(pos)
    assert math.isnan(c.rate_limited_fraction) and math.isnan(c.travel_limited_fraction)
    assert c.travel == math.inf and c.peak_command_travel_ratio == 0.0


def test_a_non_uniform_grid_is_resampled_before_filtering():
    rng = np.random.default_rng(3)
    t = np.sort(np.concatenate(([0.0, 30.0], rng.uniform(0.0, 30.0, 28000))))
    u = sine(0.3, 0.05, t) + sine(0.01, 10.0, t)
    a = act(u, t=t)
    assert_close(a.fast_rms, 0.01 / math.sqrt(2), atol=3e-4, what="resampled onto the median")
    # repeated times (a record at a break time written twice) are dropped, not divided by 0
    t2 = np.concatenate((T[:15000], T[14999:]))
    u2 = np.concatenate((sine(0.01, 10.0)[:15000], sine(0.01, 10.0)[14999:]))
    assert_close(act(u2, t=t2).fast_rms, act(sine(0.01, 10.0)).fast_rms, atol=1e-12)


def test_the_aliasing_rule_flags_a_coarse_record():
    assert max_record_dt(1.0) == 1e-3 and max_record_dt(20.0) == 5e-4
    assert max_record_dt(1.0, sample_time=0.005) == 1e-3
    assert max_record_dt(1.0, sample_time=0.002) == pytest.approx(4e-4)
    coarse = np.round(np.arange(0.0, 30.0 + 5e-3, 1e-2), 12)
    # 90 Hz chatter recorded every 10 ms shows up as 10 Hz: the record cannot be trusted
    a = act(sine(0.1, 90.0, coarse), t=coarse)
    assert not a.record_ok and a.record_dt == pytest.approx(1e-2)
    assert act(sine(0.1, 90.0)).record_ok
    assert not act(sine(0.1, 90.0), sample_time=0.002).record_ok


# ---------------------------------------------------------------------------- runs and claims
@pytest.fixture(scope="module")
def hw_run() -> SimResult:
    """hypersonic-direct-s1-actuators (+-1 rad travel, 50 rad/s), 12 s, recorded at 1 ms."""
    sc = load_scenario("hypersonic-direct-s1-actuators")
    loop = dataclasses.replace(sc.loop, t_final=12.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sc.stamp(simulate(loop, sc.solver))


def with_command(r: SimResult, u: np.ndarray) -> SimResult:
    return dataclasses.replace(r, u_cmd=u, u_applied=np.clip(u, -1.0, 1.0))


def test_a_run_reports_its_activity_and_the_declared_limits(hw_run, tmp_path):
    assert hw_run.meta["actuator_limits"]["declared"]["upper"] == [1.0, 1.0]
    assert hw_run.actuator_position is not None
    # the position of a first-order actuator: never beyond the travel, never faster than
    # the rate limit (to the dense output's error at the limit's kinks: 2e-5 relative)
    assert np.max(np.abs(hw_run.actuator_position)) <= 1.0 + 1e-9
    assert np.max(np.abs(np.diff(hw_run.actuator_position, axis=0))) / DT <= 50.0 * (1 + 1e-4)
    acts = hw_run.activity(2.0, 12.0)
    assert set(acts) == {"delta_e1", "delta_e2"} and acts["delta_e1"].record_ok
    m = hw_run.metrics(final_window=10.0)
    assert m["fast_rms_delta_e1"] == pytest.approx(acts["delta_e1"].fast_rms)
    assert m["fast_rms_max"] == max(a.fast_rms for a in acts.values())
    assert m["activity_record_ok"] is True
    # a file keeps the positions and the limits
    back = SimResult.from_netcdf(hw_run.to_netcdf(tmp_path / "r.nc"))
    assert_close(back.actuator_position, hw_run.actuator_position, atol=0.0)
    assert back.activity(2.0, 12.0)["delta_e2"] == acts["delta_e2"]


def fast_claim(**kw):
    claim = {"kind": "activity", "text": "quiet command", "window": 5.0, "max_fast_rms": 0.01}
    return {**claim, **kw}


def test_activity_claim_measures_the_known_fast_content(hw_run):
    u = np.column_stack(
        [sine(0.2, 0.05, hw_run.time) + sine(a, 10.0, hw_run.time) for a in (0.005, 0.02)]
    )
    r = with_command(hw_run, u)
    c = evaluate_claim(fast_claim(max_fast_rms=[0.01, 0.03]), r)
    assert c.verdict == PASS
    assert_close(c.measured, 0.02 / math.sqrt(2), atol=1e-4, what="worst actuator vs its limit")
    c = evaluate_claim(fast_claim(max_fast_rms=0.01), r)
    assert c.verdict == FAIL and c.threshold == 0.01 and c.unit == "rad"
    assert "delta_e1" in c.detail and "delta_e2" in c.detail
    # relative to the ideal run's peak to peak
    rel = fast_claim(max_fast_rms=None, max_fast_rms_relative=0.03, reference_peak_to_peak=0.4)
    c = evaluate_claim({k: v for k, v in rel.items() if v is not None}, r)
    assert c.verdict == FAIL and c.threshold == pytest.approx(0.012)
    # only the named actuators are judged
    assert evaluate_claim(fast_claim(actuators=[1]), r).verdict == PASS


def test_activity_claim_rate_travel_and_peak_criteria(hw_run):
    c = evaluate_claim(
        {"kind": "activity", "text": "t", "window": 5.0, "within_travel": True}, hw_run
    )
    peak = float(np.max(np.abs(hw_run.u_cmd[hw_run.window(7.0, 12.0)])))
    assert c.measured == pytest.approx(peak) and c.verdict == (PASS if peak <= 1.0 else FAIL)
    seven = with_command(hw_run, np.full_like(hw_run.u_cmd, 7.0))
    c = evaluate_claim({"kind": "activity", "text": "t", "within_travel": True}, seven)
    assert c.verdict == FAIL and c.measured == pytest.approx(7.0) and c.threshold == 1.0
    c = evaluate_claim({"kind": "activity", "text": "t", "max_peak_command": [8.0, 6.0]}, seven)
    assert c.verdict == FAIL and c.measured == 7.0 and c.threshold == 6.0
    frac = evaluate_claim(
        {"kind": "activity", "text": "t", "max_rate_limited_fraction": 0.05}, hw_run
    )
    assert frac.unit == "" and 0.0 <= frac.measured <= 1.0


def test_activity_claim_errors_name_the_fix(hw_run):
    with pytest.raises(ClaimError, match="states no criterion"):
        evaluate_claim({"kind": "activity", "text": "t"}, hw_run)
    with pytest.raises(ClaimError, match="needs 'reference_peak_to_peak'"):
        evaluate_claim({"kind": "activity", "text": "t", "max_fast_rms_relative": 0.03}, hw_run)
    with pytest.raises(ClaimError, match="one positive number per actuator \\(2\\)"):
        evaluate_claim(fast_claim(max_fast_rms=[0.1, 0.1, 0.1]), hw_run)
    with pytest.raises(ClaimError, match="'max_rate_limited_fraction'.*\\[0, 1\\]"):
        evaluate_claim(fast_claim(max_rate_limited_fraction=5.0), hw_run)
    # a record too coarse for the chatter it would judge is refused, with the setting to change
    coarse = hw_run
    keep = np.arange(0, hw_run.time.size, 10)
    arrays = {
        f.name: getattr(coarse, f.name)[keep]
        for f in dataclasses.fields(coarse)
        if isinstance(getattr(coarse, f.name), np.ndarray)
    }
    coarse = dataclasses.replace(coarse, **arrays)
    with pytest.raises(ClaimError, match=r"recorded every 0.01 s.*record_dt = 0.001"):
        evaluate_claim(fast_claim(), coarse)
    # within_travel needs a declared travel
    free = dataclasses.replace(hw_run, meta={**hw_run.meta, "actuator_limits": None})
    with pytest.raises(ClaimError, match="declares no travel.*max_peak_command"):
        evaluate_claim({"kind": "activity", "text": "t", "within_travel": True}, free)


def test_finding_is_never_pass_and_never_fail(hw_run):
    chatter = with_command(hw_run, np.column_stack([sine(0.5, 12.0, hw_run.time)] * 2))
    c = evaluate_claim(fast_claim(finding="the law chatters at 12 Hz"), chatter)
    assert c.verdict == FINDING and not c.passed and c.finding == "the law chatters at 12 Hz"
    assert_close(c.measured, 0.5 / math.sqrt(2), atol=1e-3)
    assert "[finding: the law chatters at 12 Hz]" in c.detail
    quiet = with_command(hw_run, np.zeros_like(hw_run.u_cmd))
    c = evaluate_claim(fast_claim(finding="the law chatters at 12 Hz"), quiet)
    assert c.verdict == PASS and "no longer shows" in c.detail
    # a diverged run fails the claim: a finding still, not a FAIL
    cut = hw_run.time <= 6.0
    arrays = {
        f.name: getattr(hw_run, f.name)[cut]
        for f in dataclasses.fields(hw_run)
        if isinstance(getattr(hw_run, f.name), np.ndarray)
    }
    gone = dataclasses.replace(hw_run, **arrays, status="diverged", message="boom")
    assert evaluate_claim(fast_claim(finding="x"), gone).verdict == FINDING
    assert evaluate_claim(fast_claim(), gone).verdict == FAIL
    with pytest.raises(ClaimError, match="both 'not_reproduced' and 'finding'"):
        evaluate_claim(fast_claim(finding="x", not_reproduced="y"), hw_run)
    with pytest.raises(ClaimError, match="'finding'.*non-empty text"):
        evaluate_claim(fast_claim(finding=""), hw_run)


def test_bounded_holds_actuator_signals_to_the_declared_travel(hw_run):
    claim = {"kind": "bounded", "text": "bounded", "bound": 10.0}
    seven = with_command(hw_run, np.full_like(hw_run.u_cmd, 7.0))
    c = evaluate_claim(claim, seven)
    assert c.verdict == FAIL and c.measured == pytest.approx(7.0) and c.threshold == 1.0
    assert "travel [-1, 1]" in c.detail
    half = with_command(hw_run, np.full_like(hw_run.u_cmd, -0.5))
    c = evaluate_claim(claim, half)
    assert c.verdict == PASS and c.measured == pytest.approx(
        max(0.5, np.max(np.abs(hw_run.states)) / 10)
    )
    # without declared actuators: |.| <= bound as before
    free = dataclasses.replace(seven, meta={**seven.meta, "actuator_limits": None})
    c = evaluate_claim(claim, free)
    assert c.verdict == PASS and c.measured == pytest.approx(7.0) and c.threshold == 10.0


def test_report_shows_findings_apart_from_pass_and_fail(hw_run):
    chatter = with_command(hw_run, np.column_stack([sine(0.5, 12.0, hw_run.time)] * 2))
    verdicts = [
        evaluate_claim(fast_claim(finding="the law chatters at 12 Hz"), chatter),
        evaluate_claim(fast_claim(max_fast_rms=10.0), chatter),
    ]
    entry = ScenarioEntry(name="s", title="S", claims=verdicts)
    page = render_report([entry])
    assert 'badge finding">FINDING' in page and "the law chatters at 12 Hz" in page
    assert "1/1 passed, 1 finding" in page


# ---------------------------------------------------------------------------- catalogue
def test_every_catalogue_scenario_with_hardware_is_judged_on_its_activity():
    from adaptive_ftc.scenarios.loader import list_scenarios

    found = set()
    for name in list_scenarios():
        loop = load_scenario(name).loop
        if loop.actuators is not None or loop.sensors is not None or loop.sample_time > 0:
            found.add(name)
    assert found == set(HARDWARE)  # a new one joins HARDWARE, and the test below


@pytest.mark.parametrize("name", HARDWARE)
def test_hardware_scenarios_cannot_pass_every_claim_while_the_command_chatters(name):
    """Every catalogue scenario with hardware records fast enough and judges its fast command
    content at <= 3 % of the ideal run's peak to peak. Its design is the constraint-aware law
    (issue 25), which passes every claim; the thesis law's companion run chatters above the
    threshold, and its fast-content claims are FINDINGs (never PASS, never FAIL)."""
    from adaptive_ftc.claims import evaluate_thesis_law_claims
    from adaptive_ftc.reproduce import thesis_law_loop

    sc = load_scenario(name)
    loop = sc.loop
    assert loop.actuators is not None or loop.sensors is not None or loop.sample_time > 0
    assert loop.controller.constraint_aware is not None, f"{name} judges the thesis law"
    assert sc.solver.record_dt <= max_record_dt(1.0, loop.sample_time)
    fast = [c for c in sc.claims if c["kind"] == "activity" and "max_fast_rms_relative" in c]
    assert fast, f"{name} has no fast-content claim"
    for c in fast:
        assert c["max_fast_rms_relative"] <= 0.03 and max(c["reference_peak_to_peak"]) <= 0.6
    claims = [c for c in sc.claims if "baseline_ratio" not in c]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = sc.run()
        thesis = sc.stamp(simulate(thesis_law_loop(loop), sc.solver))
    threshold = 0.03 * 0.577
    verdicts = evaluate_claims(claims, r)
    assert all(v.verdict == PASS for v in verdicts), [(v.kind, v.detail) for v in verdicts]
    assert max(a.fast_rms for a in r.activity(100.0, 120.0).values()) <= threshold
    # the thesis law beside it chatters: its fast-content claims are named findings
    assert max(a.fast_rms for a in thesis.activity(100.0, 120.0).values()) > threshold
    companion = evaluate_thesis_law_claims(claims, thesis)
    assert {v.verdict for v in companion} <= {PASS, FINDING}
    judged = [v for v, c in zip(companion, claims, strict=True) if c in fast]
    assert judged and all(v.verdict == FINDING and "thesis law" in v.finding for v in judged)


# ---------------------------------------------------------------------------- aftc run
def _user_file(tmp_path, claims: str, name: str = "mine", record_dt: float = 0.001) -> str:
    """The thesis law run at 200 Hz (hypersonic-direct-s1-digital without its constraint-aware
    option), 6 s, with the given claims."""
    src = tmp_path / f"{name}.toml"
    src.write_text(
        f'extends = "hypersonic-direct-s1"\nname = "{name}"\nduration = 6.0\n'
        "[digital]\nsample_time = 0.005\n"
        '[solver]\nmethod = "dopri5"\nrtol = 1e-7\natol = 1e-10\n'
        f"record_dt = {record_dt}\n" + claims
    )
    return str(src)


CHATTER_CLAIM = """
[[claims]]
kind = "activity"
text = "the command is quiet above 1 Hz"
window = 4.0
max_fast_rms = 1e-3
"""


def test_aftc_run_evaluates_claims_and_exits_4_on_fail(tmp_path, capsys):
    out = tmp_path / "o"
    src = _user_file(tmp_path, CHATTER_CLAIM)
    assert main(["run", src, "--out", str(out), "--quiet", "--no-baselines"]) == 4
    text = capsys.readouterr()
    assert "FAIL" in text.out and "1 claim(s) failed" in text.err
    rows = (out / "claims.csv").read_text().splitlines()
    assert rows[0].startswith("scenario,section,run,kind,verdict") and ",activity,FAIL," in rows[1]
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["claims"][0]["verdict"] == "FAIL" and metrics["claims"][0]["measured"] > 1e-3
    assert metrics["runs"]["adaptive"]["activity_record_ok"] is True


def test_aftc_run_reports_a_finding_and_exits_0(tmp_path, capsys):
    out = tmp_path / "o"
    claims = CHATTER_CLAIM + 'finding = "the thesis law chatters under 200 Hz sampling"\n'
    src = _user_file(tmp_path, claims)
    assert main(["run", src, "--out", str(out), "--quiet", "--no-baselines"]) == 0
    text = capsys.readouterr().out
    assert "FINDING" in text and "the thesis law chatters under 200 Hz sampling" in text
    assert ",activity,FINDING," in (out / "claims.csv").read_text()


def test_aftc_run_rejects_a_malformed_claim_or_a_coarse_record(tmp_path, capsys):
    out = tmp_path / "o"
    bad = _user_file(tmp_path, '\n[[claims]]\nkind = "activity"\ntext = "x"\nmax_fast_rm = 1\n')
    assert main(["run", bad, "--out", str(out), "--quiet", "--no-baselines"]) == 2
    err = capsys.readouterr().err
    assert "Unknown key 'max_fast_rm'" in err and "max_fast_rms" in err
    assert not (out / "metrics.json").exists()
    coarse = _user_file(tmp_path, CHATTER_CLAIM, "coarse", record_dt=0.01)
    assert main(["run", coarse, "--out", str(out), "--quiet", "--no-baselines"]) == 2
    assert "record_dt = 0.001" in capsys.readouterr().err


# ---------------------------------------------------------------------------- rows
def test_campaign_rows_carry_the_activity_of_each_run(tmp_path):
    from adaptive_ftc.campaigns import load_campaign, read_results, run_campaign

    spec = {
        "name": "act",
        "base": "hypersonic-direct-s1-digital",
        "designs": ["adaptive"],
        "runs": 2,
        "seed": 1,
        "chunk_size": 2,
        "duration": 3.0,
        "success": {"rms_error_final": 0.01, "final_window": 1.0},
        "failures": {"count": 0},
    }
    run_campaign(load_campaign(spec), tmp_path / "c", jobs=1, progress=False, summary=False)
    df = read_results(tmp_path / "c")
    assert df["activity_record_ok"].all()  # the digital scenario records at 1 ms
    assert (df["fast_rms_max"] > 0.0).all() and (df["peak_rate_max"] > 0.0).all()
    # the same number as the run's own metrics
    sc = load_scenario("hypersonic-direct-s1-digital")
    r = simulate(dataclasses.replace(sc.loop, t_final=3.0), sc.solver)
    expected = r.metrics(final_window=1.0)["fast_rms_max"]
    assert_close(df["fast_rms_max"].to_numpy(), expected, atol=1e-12 + 1e-9 * expected)


def test_robustness_rows_carry_the_activity_and_flag_a_coarse_record():
    from adaptive_ftc.studies import robustness_sweep

    fine = robustness_sweep(
        "hypersonic-direct-s1", "lag", [0.05], duration=6.0, window=3.0, record_dt=1e-3
    )
    coarse = robustness_sweep("hypersonic-direct-s1", "lag", [0.05], duration=6.0, window=3.0)
    assert bool(fine["activity_record_ok"][0]) and not bool(coarse["activity_record_ok"][0])
    # a 50 ms lag: the thesis law's command chatters (issue 25: several 0.1 rad RMS)
    assert fine["fast_rms"][0] > 0.05 and fine["tv_per_s"][0] > 1.0
    assert math.isnan(fine["rate_limited_fraction"][0])  # no rate limit in a lag sweep


def test_reproduce_counts_findings_apart_from_failures(tmp_path):
    from adaptive_ftc.reproduce import run_reproduction

    s = run_reproduction(
        tmp_path / "r",
        names=["hypersonic-direct-s1-digital"],
        jobs=1,
        progress=False,
        fair_baselines=False,
        formats=("png",),
    )
    # the scenario's design (constraint-aware) passes every claim; the thesis law beside it
    # chatters: its fast-content claim is a finding, counted apart, never a FAIL
    assert s["n_finding"] == 0 and s["n_fail"] == 0 and s["n_pass"] == 4
    assert s["n_claims"] == 4 and s["n_thesis_law_finding"] == 1
    with (tmp_path / "r" / "claims.csv").open() as fh:
        claims = list(csv.DictReader(fh))
    assert [c["run"] for c in claims] == ["adaptive"] * 4 + ["thesis_law"] * 4
    thesis = [c for c in claims if c["run"] == "thesis_law" and c["verdict"] == "FINDING"]
    assert len(thesis) == 1 and "the thesis law chatters at 16 Hz" in thesis[0]["finding"]
    with (tmp_path / "r" / "metrics.csv").open() as fh:
        rows = {r["variant"]: r for r in csv.DictReader(fh)}
    assert float(rows["thesis_law"]["fast_rms_max"]) > 0.3
    assert float(rows["adaptive"]["fast_rms_max"]) < 0.03 * 0.577
    assert rows["adaptive"]["activity_record_ok"] == "True"
    assert (tmp_path / "r" / "data" / "hypersonic-direct-s1-digital_thesis_law.nc").is_file()
    page = (tmp_path / "r" / "report.html").read_text(encoding="utf-8")
    assert 'badge finding">FINDING' in page


def test_a_rate_limited_failure_on_ideal_actuators_is_measured_in_its_window(tmp_path):
    src = tmp_path / "rl.toml"
    src.write_text(
        'extends = "hypersonic-direct-s1"\nname = "rl"\nduration = 6.0\n'
        "[solver]\nrecord_dt = 0.001\n"
        '[[failures]]\nactuator = 1\nmodel = "rate_limited"\nonset = 2.0\nrecovery = 4.0\n'
        "rate = 0.001\n"
    )
    r = load_scenario(src).run()
    assert r.meta["actuator_limits"]["declared"]["rate"] == ["inf", "inf"]
    during = r.activity(2.0, 4.0)["delta_e1"].rate_limited_fraction
    after = r.activity(4.5, 6.0)["delta_e1"].rate_limited_fraction
    whole = r.activity(0.0, 6.0)["delta_e1"].rate_limited_fraction
    # the command drifts at about 2e-3 rad/s: it moves at the 1e-3 rad/s limit about half of
    # the failure's window; no limit in effect after the recovery: nan (nothing to be at)
    assert during > 0.4 and math.isnan(after)
    # the fraction is of the whole window: no limit elsewhere counts as not at the limit
    assert_close(whole, during * 2.0 / 6.0, atol=2e-3)
    assert math.isnan(r.activity(2.0, 4.0)["delta_e2"].rate_limited_fraction)


@pytest.mark.parametrize(
    "key, value",
    [
        ("max_fast_rms", "a"),
        ("max_fast_rms", [0.1, -1.0]),
        ("reference_peak_to_peak", []),
        ("max_peak_command", True),
        ("within_travel", "yes"),
    ],
)
def test_activity_claim_thresholds_of_the_wrong_type_are_refused_at_validation(key, value):
    # regression: `max_fast_rms = "a"` passed `aftc validate` (the per-actuator keys were not
    # type-checked) and failed only when the claim was judged after the run
    from adaptive_ftc.claims import ClaimError, _params

    with pytest.raises(ClaimError, match=key):
        _params({"kind": "activity", "text": "t", key: value})
    assert _params({"kind": "activity", "text": "t", "max_fast_rms": [0.1, 0.2]})
