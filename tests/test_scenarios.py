"""Scenario files: catalogue, clear errors for bad files, nothing half-runs."""

from __future__ import annotations

from pathlib import Path

import pytest

from adaptive_ftc import ScenarioError, list_scenarios, load_scenario

GOOD = """
name = "mine"
duration = 5.0
[plant]
model = "hypersonic"
initial_state = [0.03, 0.0]
[reference]
outputs = ["pi/36*sin(0.2*t)"]
[controller]
design = "direct"
allocation = [1.0, 2.0]
[controller.regressor]
type = "linear"
inputs = ["e", "edot"]
[[failures]]
actuator = 2
model = "stuck"
onset = 2.0
value = 0.1
"""


def write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "scenario.toml"
    p.write_text(text)
    return p


THESIS = {  # SPEC §7: every thesis simulation and its figures
    "hypersonic-direct-s1": ("2.1", "2.2"),
    "hypersonic-direct-s2": ("2.3", "2.4"),
    "hypersonic-nussbaum-s1-pos": ("4.1", "4.2"),
    "hypersonic-nussbaum-s1-neg": ("4.3", "4.4"),
    "hypersonic-nussbaum-s2-pos": ("4.5", "4.6"),
    "hypersonic-nussbaum-s2-neg": ("4.7", "4.8"),
    "hypersonic-sign-s1-rho0pos": ("4.9", "4.10"),
    "hypersonic-sign-s1-rho0neg": ("4.11", "4.12"),
    "hypersonic-sign-s2-rho0pos": ("4.13", "4.14"),
    "hypersonic-sign-s2-rho0neg": ("4.15", "4.16"),
    "wingrock-estimation-s1": ("2.6", "2.7", "2.8"),
    "wingrock-estimation-s2": ("2.9", "2.10", "2.11"),
    "manipulator-mimo-s1": ("3.2", "3.3", "3.4"),
    "manipulator-mimo-s2": ("3.5", "3.6", "3.7"),
    "spacecraft-mimo-s1": ("3.9", "3.10", "3.11", "3.12", "3.13"),
    "spacecraft-mimo-s2": ("3.14", "3.15", "3.16", "3.17", "3.18"),
}


def test_every_catalogue_scenario_loads_and_thesis_ones_name_their_figures():
    names = list_scenarios()
    for name in names:
        sc = load_scenario(name)
        assert sc.name == name and sc.title and sc.loop.t_final > 0
        if name in THESIS:
            assert sc.figures == THESIS[name], name
    assert {"hypersonic-direct-s1", "hypersonic-direct-s2"} <= set(names)


def test_a_user_file_loads_and_runs(tmp_path):
    sc = load_scenario(write(tmp_path, GOOD))
    res = sc.run()
    assert res.status == "completed" and res.time[-1] == pytest.approx(5.0)


@pytest.mark.parametrize(
    ("old", "new", "match"),
    [
        (
            'model = "hypersonic"',
            'model = "hypersonc"',
            r"\[plant\] unknown plant model "
            r"'hypersonc'\. Did you mean 'hypersonic'\?",
        ),
        ("duration = 5.0", "", r"missing key 'duration'"),
        ('design = "direct"', 'design = "direkt"', r"Did you mean 'direct'\?"),
        (
            "value = 0.1",
            "valeu = 0.1",
            r"\[failures\.1\] unknown key 'valeu'\. Did you mean "
            r"'value'\?",
        ),
        ("value = 0.1", 'value = "0.1*sinn(t)"', r"\[failures\.1\].*unknown function 'sinn'"),
        (
            "value = 0.1",
            "value = \"__import__('os').system('touch /tmp/pwned')\"",
            r"\[failures\.1\].*(not allowed|unknown function|only calls of plain function)",
        ),
        ("actuator = 2", "actuator = 3", r"only 2 actuators"),
        ('model = "stuck"', 'model = "stuk"', r"Did you mean 'stuck'\?"),
        (
            'inputs = ["e", "edot"]',
            'inputs = ["e", "edott"]',
            r"Unknown regressor input 'edott'.*Did you mean 'edot'\?",
        ),
        ('outputs = ["pi/36*sin(0.2*t)"]', 'outputs = ["x1"]', r"unknown name 'x1'"),
        ("allocation = [1.0, 2.0]", "allocation = [1.0]", r"allocation"),
        ("duration = 5.0", 'duration = 5.0\nsolver = { method = "rk5" }', r"Did you mean 'rk4'"),
        ("duration = 5.0", "duration = 5.0\nfoo = 1", r"unknown key 'foo'"),
        ("duration = 5.0", "duration = [", r"not valid TOML"),
    ],
)
def test_bad_files_give_one_clear_error_naming_file_table_and_key(tmp_path, old, new, match):
    assert old in GOOD
    path = write(tmp_path, GOOD.replace(old, new, 1))
    with pytest.raises(ScenarioError, match=match) as info:
        load_scenario(path)
    assert str(path) in str(info.value)
    assert not Path("/tmp/pwned").exists()


def test_unknown_names_and_missing_files_are_reported():
    with pytest.raises(ScenarioError, match=r"Did you mean 'hypersonic-direct-s1'\?"):
        load_scenario("hypersonc-direct-s1")
    with pytest.raises(ScenarioError, match="does not exist"):
        load_scenario("no/such/file.toml")


def test_extends_inherits_and_overrides_but_not_metadata(tmp_path):
    p = tmp_path / "child.toml"
    p.write_text(
        'extends = "hypersonic-direct-s1"\nname = "child"\nfigures = ["x"]\n'
        "duration = 30.0\n[controller]\nk = 7.0\n"
    )
    sc = load_scenario(p)
    assert sc.loop.t_final == 30.0 and sc.loop.controller.k == 7.0
    assert sc.loop.controller.lam == 2.0 and len(sc.loop.failures.failures) == 2
    assert sc.figures == ("x",)
