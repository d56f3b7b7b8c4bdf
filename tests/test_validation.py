"""Issue 26, validation before cost: problems a scenario file can have are found by the loader
and `aftc validate`, before anything is compiled or simulated, and all of them at once."""

from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path

import pytest

from adaptive_ftc import load_scenario
from adaptive_ftc.cli import EXIT_INVALID, EXIT_NOT_COMPENSABLE, EXIT_OK, main
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim.system import ClosedLoop


def _file(tmp_path: Path, text: str, name: str = "s.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _validate(path: Path, capsys) -> tuple[int, str]:
    rc = main(["validate", str(path)])
    captured = capsys.readouterr()
    return rc, captured.out + captured.err


# ------------------------------------------------------------------ healthy-plant sign (1)
@pytest.mark.parametrize(
    ("base", "allocation", "expected"),
    [
        ("hypersonic-direct-s1", "[-1.0, -2.0]", EXIT_NOT_COMPENSABLE),  # known sign, wrong
        ("hypersonic-estimation-s1", "[-1.0, -2.0]", EXIT_NOT_COMPENSABLE),
        ("wingrock-direct-s1", "[2.0, 2.0, 1.0]", EXIT_NOT_COMPENSABLE),  # the printed signs
        ("hypersonic-direct-s1", "[1.0, 2.0]", EXIT_OK),
        ("hypersonic-nussbaum-s1-pos", "[-1.0, -2.0]", EXIT_OK),  # needs no known sign
    ],
)
def test_a_known_sign_design_on_a_healthy_plant_with_the_wrong_direction_is_not_compensable(
    tmp_path, capsys, base, allocation, expected
):
    f = _file(
        tmp_path, f'extends = "{base}"\nduration = 10.0\n[controller]\nallocation = {allocation}\n'
    )
    rc, out = _validate(f, capsys)
    assert rc == expected, out
    assert ("healthy plant: NOT compensable" in out) == (expected != EXIT_OK)


def test_a_mimo_output_whose_healthy_gain_is_negative_is_named(tmp_path, capsys):
    # spacecraft: roll is driven by wheels 1 and 4; negating that row reverses roll only
    sc = load_scenario("spacecraft-mimo-s1")
    rows = [[float(v) for v in r] for r in sc.loop.R]
    rows[0] = [-v for v in rows[0]]
    f = _file(
        tmp_path,
        f'extends = "spacecraft-mimo-s1"\nduration = 10.0\n[controller]\nallocation = {rows}\n',
    )
    rc, out = _validate(f, capsys)
    assert rc == EXIT_NOT_COMPENSABLE
    names = sc.loop.plant.output_names
    assert f"control gain of {names[0]} with healthy actuators" in out
    assert f"control gain of {names[1]} with healthy" not in out


def test_every_catalogue_scenario_keeps_its_validate_verdict(capsys):
    from adaptive_ftc.scenarios.loader import list_scenarios

    for name in list_scenarios():
        rc = main(["validate", name])
        capsys.readouterr()
        assert rc == (EXIT_NOT_COMPENSABLE if "free" in name else EXIT_OK), name


# ------------------------------------------------------------------ dead actuators (4)
def test_an_actuator_dead_from_the_start_is_a_warning(tmp_path, capsys):
    stuck = (
        'extends = "hypersonic-direct-s1"\nduration = 10.0\n'
        "[[failures]]\nactuator = 1\nmodel = 'stuck'\nonset = 0.0\nvalue = 0.1\n"
    )
    rc, out = _validate(_file(tmp_path, stuck), capsys)
    assert rc == EXIT_OK  # elevator 2 still compensates
    assert "warning: actuator 1 (delta_e1) is never effective" in out
    later = stuck.replace("onset = 0.0", "onset = 5.0")
    rc, out = _validate(_file(tmp_path, later), capsys)
    assert rc == EXIT_OK and "warning" not in out


# ------------------------------------------------------------------ messages (5)
def test_the_allocation_shape_message_names_the_number_of_gains():
    sc = load_scenario("hypersonic-direct-s1")
    with pytest.raises(ConfigurationError) as info:
        ClosedLoop(plant=sc.loop.plant, controller=sc.loop.controller, allocation=(1.0, 2.0, 3.0))
    assert "a list of 2 proportional gains" in str(info.value)
    assert "{" not in str(info.value)


# ------------------------------------------------------------------ initial state (2)
def _hypersonic(tmp_path: Path, extra: str) -> Path:
    return _file(tmp_path, f'extends = "hypersonic-direct-s1"\nduration = 10.0\n{extra}\n')


def test_an_initial_state_outside_the_envelope_is_refused_at_validation(tmp_path, capsys):
    f = _hypersonic(tmp_path, "[plant]\ninitial_state = [2.0, 0.0]")
    rc, out = _validate(f, capsys)
    assert rc == EXIT_INVALID
    assert "[plant] `initial_state`: alpha = 2 is outside the plant's envelope" in out
    inside = _hypersonic(tmp_path, "[plant]\ninitial_state = [1.5, 0.0]")
    assert _validate(inside, capsys)[0] == EXIT_OK


def test_a_divergence_bound_below_the_initial_state_is_refused(tmp_path, capsys):
    rc, out = _validate(_hypersonic(tmp_path, "[solver]\ndivergence_bound = 1e-6"), capsys)
    assert rc == EXIT_INVALID
    assert "`divergence_bound` = 1e-06: the initial value alpha = 0.03" in out
    rc, out = _validate(_hypersonic(tmp_path, "[solver]\ndivergence_bound = 0.04"), capsys)
    assert rc == EXIT_OK, out


# ------------------------------------------------------------------ sampled s' filter (3)
def test_an_unstable_sampled_filter_is_refused_with_its_stable_range(tmp_path, capsys):
    f = _hypersonic(tmp_path, "[digital]\nsample_time = 0.05\n[solver]\nfilter_tau = 0.02")
    rc, out = _validate(f, capsys)
    assert rc == EXIT_INVALID
    assert "Stable range: filter_tau > 0.025 s" in out


def test_the_default_filter_tau_follows_a_slow_sample_time():
    from adaptive_ftc.sim.engine import SolverOptions

    f = load_scenario("hypersonic-direct-s1-digital")
    assert f.solver.filter_tau is None
    assert f.solver.filter_tau_for(f.loop) == 0.01  # 200 Hz: the catalogue's setting
    slow = replace(f.loop, sample_time=0.05)
    assert SolverOptions().filter_tau_for(slow) == pytest.approx(0.1)
    assert SolverOptions(filter_tau=0.03).filter_tau_for(slow) == 0.03
    assert SolverOptions().filter_tau_for(load_scenario("hypersonic-direct-s1").loop) == 0.01


def test_a_40_hz_controller_without_filter_tau_validates_and_runs(tmp_path, capsys):
    f = _hypersonic(tmp_path, "duration = 1.0\n[digital]\nsample_time = 0.025").read_text()
    f = _file(tmp_path, f.replace("duration = 10.0\n", ""))
    rc, out = _validate(f, capsys)
    assert rc == EXIT_OK, out
    with warnings.catch_warnings():  # 40 Hz is too slow for these gains: it may diverge
        warnings.simplefilter("ignore")
        result = load_scenario(f).run()  # the old default (0.01 s) refused to assemble
    assert result.time[-1] > 0.2
