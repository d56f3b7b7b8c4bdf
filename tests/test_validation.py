"""Issue 26, validation before cost: problems a scenario file can have are found by the loader
and `aftc validate`, before anything is compiled or simulated, and all of them at once."""

from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path

import pytest

from adaptive_ftc import load_scenario
from adaptive_ftc.cli import EXIT_INVALID, EXIT_NOT_COMPENSABLE, EXIT_OK, main
from adaptive_ftc.errors import ConfigurationError, ExpressionError, ScenarioError
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


# ------------------------------------------------------------------ constant expressions (8)
@pytest.mark.parametrize(
    ("text", "named"),
    [
        ("10**1000000", "10**1000000"),
        ("9**9**9", "9**9**9"),
        ("0.1 + 1/0", "1/0"),
        ("t*log(0)", "log(0)"),
        ("sqrt(-1) + t", "sqrt(-1)"),
        ("(-8)**(1/3)*t", "(-8)**(1/3)"),  # was a raw TypeError (a complex power)
        ("acos(2)", "acos(2)"),
        ("u/0", "u/0"),
        ("1e60*1e60*t", "1e60*1e60"),
    ],
)
def test_a_non_finite_constant_sub_expression_is_refused_naming_it(text, named):
    from adaptive_ftc.scenarios.expressions import Expression

    with pytest.raises(ExpressionError) as info:
        Expression(text, ("t", "u"))
    assert f"'{named}'" in str(info.value)


def test_finite_constants_are_folded_to_numbers():
    from adaptive_ftc.scenarios.expressions import Expression

    assert Expression("2**10 - 24", ("t",)).node == ("const", 1000.0)
    assert Expression("(-8)**2*t", ("t",)).node == ("bin", "*", ("const", 64.0), ("var", "t"))
    assert Expression("pi/36*sin(0.2*t)", ("t",))(t=0.0) == 0.0


def test_non_finite_constants_in_a_scenario_are_refused_at_validation(tmp_path, capsys):
    f = _hypersonic(
        tmp_path,
        '[reference]\noutputs = ["log(0)*sin(t)"]\n'
        "[[failures]]\nactuator = 2\nmodel = 'stuck'\nonset = 5.0\nvalue = '9**9**9'\n",
    )
    rc, out = _validate(f, capsys)
    assert rc == EXIT_INVALID
    assert "'log(0)'" in out and "'9**9**9'" in out


# ------------------------------------------------------------------ every problem at once (7)
MANY = """extends = "hypersonic-direct-s1"
name = "many"
duration = 10.0
colour = "red"

[plant]
initial_state = [2.0, 0.0]

[controller]
allocation = [-1.0, -2.0]

[controller.regressor]
inputs = ["alpha", "qq"]

[sensors]
nois = {alpha = 0.1}

[solver]
divergence_bound = 1e-6
methd = "rk4"

[[figure]]
kind = "trackin"
outputs = [2]

[[claims]]
kind = "trackng"
text = "x"
"""


def test_independent_mistakes_of_every_stage_are_reported_in_one_run(tmp_path, capsys):
    rc, out = _validate(_file(tmp_path, MANY), capsys)
    assert rc == EXIT_INVALID
    expected = [
        "unknown key 'colour'",  # top-level keys
        "[sensors] unknown key 'nois'",  # a table that fails: the loop is built without it
        "[solver] unknown key 'methd'",
        "[claims.1] Unknown claim kind 'trackng'",
        "[figure.1] unknown figure kind 'trackin'",
        "[figure.1] `outputs`: expected a list of output numbers from 1 to 1 (alpha), got [2]",
        "[plant] `initial_state`: alpha = 2 is outside the plant's envelope",
        "[solver] `divergence_bound` = 1e-06",  # checked with the solver table's good keys
        "Unknown regressor input 'qq'",  # the loop's expressions and inputs
        "[failures] not compensable: healthy plant: NOT compensable",  # the design's conditions
    ]
    missing = [line for line in expected if line not in out]
    assert not missing, out
    assert "10 problems:" in out


def test_a_figure_naming_an_unknown_output_is_refused_before_simulating(tmp_path, capsys):
    f = _hypersonic(tmp_path, '[[figure]]\nkind = "tracking"\noutputs = ["x"]')
    rc, out = _validate(f, capsys)
    assert rc == EXIT_INVALID and "`outputs`: expected a list of output numbers" in out
    ok = _hypersonic(tmp_path, '[[figure]]\nkind = "tracking"\noutputs = [1]\nzoom = [0, 1]')
    assert _validate(ok, capsys)[0] == EXIT_OK


def test_the_loader_knows_every_figure_kind_plots_draws():
    from adaptive_ftc import plots
    from adaptive_ftc.scenarios import loader

    assert loader._FIGURE_KINDS == plots.KINDS  # kept apart so loading imports no matplotlib


def test_a_claim_with_an_unknown_key_is_refused_at_validation(tmp_path, capsys):
    claim = '[[claims]]\nkind = "bounded"\ntext = "x"\nbound = 10.0\n'
    rc, out = _validate(_hypersonic(tmp_path, claim + "colour = 1\n"), capsys)
    assert rc == EXIT_INVALID and "[claims.1] Unknown key 'colour'" in out
    assert _validate(_hypersonic(tmp_path, claim), capsys)[0] == EXIT_OK


# ------------------------------------------------------------------ extends / unset (6)
def test_unset_removes_inherited_tables_and_keys(tmp_path):
    base = load_scenario("hypersonic-direct-s1-actuators")
    assert base.loop.actuators is not None
    f = _file(
        tmp_path,
        'extends = "hypersonic-direct-s1-actuators"\nunset = ["actuators", "solver.rtol"]\n',
    )
    sc = load_scenario(f)
    assert sc.loop.actuators is None
    assert sc.solver.rtol == 1e-8  # the SolverOptions default, not the inherited 1e-7
    assert sc.loop.R.tolist() == base.loop.R.tolist()  # everything else still inherited


def test_unset_of_a_key_the_base_lacks_or_without_extends_is_an_error(tmp_path):
    typo = _file(tmp_path, 'extends = "hypersonic-direct-s1"\nunset = ["actuator"]\n')
    with pytest.raises(ScenarioError, match="`unset` names 'actuator'"):
        load_scenario(typo)
    alone = _file(tmp_path, 'unset = ["actuators"]\nduration = 1.0\n', name="alone.toml")
    with pytest.raises(ScenarioError, match="extends nothing"):
        load_scenario(alone)
    wrong = _file(tmp_path, 'extends = "hypersonic-direct-s1"\nunset = "actuators"\n', "w.toml")
    with pytest.raises(ScenarioError, match="`unset`: expected a list"):
        load_scenario(wrong)


def test_regressor_inputs_are_checked_when_the_controller_has_other_problems(tmp_path, capsys):
    f = _hypersonic(
        tmp_path, '[controller]\ngamma = "fast"\n[controller.regressor]\ninputs = ["qq"]'
    )
    rc, out = _validate(f, capsys)
    assert rc == EXIT_INVALID
    assert "[controller] `gamma`: expected a number" in out
    assert "[controller.regressor] unknown regressor input 'qq'. Did you mean 'q'?" in out


MANY_WITH_A_BAD_CONTROLLER = """extends = "hypersonic-direct-s1"
duration = 10.0
colour = "red"

[plant]
initial_state = [2.0, 0.0]

[reference]
outputs = ["log(0)*sin(t)"]

[controller]
gamma = "fast"

[[failures]]
actuator = 2
model = "stuck"
onset = 5.0
value = "9**9**9"

[solver]
divergence_bound = 1e-6
methd = "rk4"

[[figure]]
kind = "tracking"
outputs = ["x"]

[[claims]]
kind = "tracking"
text = "x"
window = 1.0
threshold = 1.0
colour = 1
"""


def test_nine_mistakes_with_no_loop_to_build_are_still_reported_in_one_run(tmp_path, capsys):
    rc, out = _validate(_file(tmp_path, MANY_WITH_A_BAD_CONTROLLER), capsys)
    assert rc == EXIT_INVALID
    assert "9 problems:" in out, out
    for line in (
        "unknown key 'colour'",
        "'log(0)'",
        "`gamma`: expected a number",
        "'9**9**9'",
        "unknown key 'methd'",
        "[claims.1] Unknown key 'colour'",
        "[figure.1] `outputs`",
        "outside the plant's envelope",
        "`divergence_bound` = 1e-06",
    ):
        assert line in out, line
