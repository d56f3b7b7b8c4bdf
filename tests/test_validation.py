"""Issue 26, validation before cost: problems a scenario file can have are found by the loader
and `aftc validate`, before anything is compiled or simulated, and all of them at once."""

from __future__ import annotations

from pathlib import Path

import pytest

from adaptive_ftc import load_scenario
from adaptive_ftc.cli import EXIT_NOT_COMPENSABLE, EXIT_OK, main
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
