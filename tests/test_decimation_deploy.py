"""The constraint-aware law's decimation filter beyond the simulator (issue 25, session 15):
its C form (``<prefix>_read`` per sensor reading, ``<prefix>_step`` on their mean), checked
in the loop against the simulator's own run of the decimating loop; the DigitalStepper and
the Gymnasium environment stepping a decimating design as the simulator runs it; the FMU's
refusal, naming the fix.

Truths: the simulator's digital run (RK4; the loop breaks at every sensor reading and the
design reads the mean of the period's readings, ``sim/parts/decimation.py``), and, for the
C's filter alone, the mean of the readings given to it.

The case is issue 25's combination 1 on hypersonic-direct-s1 (``scripts/hardware_cases.py``
"lag 20 ms + 200 Hz + noise 1e-3": a 1 kHz sensor, 1e-3 rad on alpha and 1e-2 rad/s on q, a
200 Hz controller, 20 ms actuator lag), where the rule takes the filter (5 readings a sample).
"""

from __future__ import annotations

import shutil
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from adaptive_ftc import simulate
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.scenarios import load_scenario

ROOT = Path(__file__).resolve().parents[1]
TOL = 1e-12  # the closed-loop tolerance of tests/test_export_c.py
needs_cc = pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler (cc)")

SCENARIO = """
extends = "hypersonic-direct-s1"
name = "hypersonic-decimated"
[sensors]
noise = {alpha = 1e-3, q = 1e-2}
rate = 1000.0
[digital]
sample_time = 0.005
[actuators]
tau = 0.02
[controller.constraint_aware]
from_hardware = true
"""


def _combination_1(duration: float):
    """Combination 1's loop with the constraint-aware design (the rule's configuration) and
    its solver (RK4 at 1 ms)."""
    sys.path.insert(0, str(ROOT / "scripts"))
    from hardware_cases import HYPERSONIC_CASES, case_loop, constraint_aware

    case = next(c for c in HYPERSONIC_CASES if c.name.startswith("lag 20 ms + 200 Hz"))
    loop, solver = case_loop(load_scenario("hypersonic-direct-s1"), case, duration=duration)
    loop = constraint_aware(loop, solver)
    aware = loop.controller.bound(loop).constraint_aware
    assert aware.readings == 5  # the rule's filter
    assert aware.regressor_prefilter  # and its low-passed regressor (session 15): both exported
    return loop, solver


# ----------------------------------------------------------------------------- C export
@needs_cc
def test_the_exported_filter_in_the_loop_equals_the_simulators_decimating_run(tmp_path):
    from adaptive_ftc.export import export_c
    from adaptive_ftc.export.sil import replay, verify

    loop, _ = _combination_1(2.0)
    out = export_c(loop, tmp_path / "c")
    assert out.readings == 5
    h = out.header.read_text()
    assert "#define AFTC_READINGS 5" in h
    assert "void aftc_read(aftc_state *state, const double y[]);" in h
    assert "const double r[]," in h and "aftc_step(&state, &params, r, t, u);" in h
    assert "The sensor reads every 0.001 s (1000 Hz)" in h and "every 0.005 s" in h
    # the C in the loop: each sensor reading to aftc_read (the true state at the reading plus
    # its own noise draw), aftc_step at each sample; the project's plant between samples
    report = verify(loop, workdir=tmp_path / "loop")
    assert report.samples == 400  # 2 s at 200 Hz
    assert report.worst <= TOL, report
    # the simulator's own states at every reading and sample, fed to the C
    again = replay(loop, workdir=tmp_path / "replay")
    assert again.samples == 400
    assert again.worst <= TOL, again


@needs_cc
def test_the_exported_filter_steps_on_the_mean_of_the_readings_since_the_last_step(tmp_path):
    from adaptive_ftc.export import export_c
    from adaptive_ftc.export.sil import CompiledController, compile_library
    from adaptive_ftc.sim.compose import generate

    loop, _ = _combination_1(0.1)
    out = export_c(loop, tmp_path)
    lib = compile_library(out.source, tmp_path / "lib.so")
    n_work = generate(loop, sdot="filtered")[3]["w:size"].stop

    def controller() -> CompiledController:
        return CompiledController(lib, out.n_y, out.n_states, out.n_u, n_work, readings=5)

    readings = np.array([[0.010, 0.001], [0.012, -0.002], [0.009, 0.003], [0.011, 0.0]])
    mean = readings.mean(axis=0)
    r = np.array([0.02, 0.01, 0.0])
    five, one, latest = controller(), controller(), controller()
    for y in readings:
        five.read(y)
    one.read(mean)
    latest.read(readings[-1])
    u = [c.step(None, r, 0.0) for c in (five, one, latest)]
    np.testing.assert_allclose(u[0], u[1], rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(five.states, one.states, rtol=1e-12, atol=1e-300)
    assert np.max(np.abs(five.states - latest.states)) > 1e-6  # not the latest reading alone
    # no reading since the previous step: the previous mean again
    one.read(mean)
    np.testing.assert_allclose(
        five.step(None, r, 0.005), one.step(None, r, 0.005), rtol=1e-12, atol=1e-300
    )
    np.testing.assert_allclose(five.states, one.states, rtol=1e-12, atol=1e-300)
    # the Python side names the misuse
    with pytest.raises(ConfigurationError, match="read"):
        five.step(mean, r, 0.01)


def test_the_cli_export_names_the_readings(tmp_path, capsys):
    from adaptive_ftc.cli import main

    path = tmp_path / "d.toml"
    path.write_text(SCENARIO)
    assert main(["export", "c", str(path), "--out", str(tmp_path / "c"), "--prefix", "p"]) == 0
    said = capsys.readouterr().out
    assert "every 0.005 s (the mean of 5 sensor readings: p_read at each)" in said
    assert "void p_read(p_state *state" in (tmp_path / "c" / "p.h").read_text()


def test_the_fmu_export_refuses_the_decimation_filter_naming_the_fix(tmp_path):
    from adaptive_ftc.export.fmu import export_fmu

    loop, _ = _combination_1(0.1)
    for part in ("controller", "loop"):
        with pytest.raises(
            ConfigurationError,
            match=r"averages the 5 sensor readings .*`aftc export c`.*`decimation = false`",
        ):
            export_fmu(loop, tmp_path, part=part)


# ----------------------------------------------------------------------- stepping
def test_a_decimating_loop_steps_like_the_simulator_and_hands_out_the_mean():
    from adaptive_ftc.sim.stepper import DigitalStepper

    loop, solver = _combination_1(1.0)
    st = DigitalStepper(loop, solver)
    assert st.readings == 5
    times, states, commands, seen = [st.time], [st.state], [], []
    while not st.done:
        sample = st.sample()
        np.testing.assert_array_equal(st.measured(), sample.measured)  # kept after the update
        seen.append(sample.measured)
        st.advance(sample.command)
        commands.append(sample.command)
        times.append(st.time)
        states.append(st.state)
    times, states = np.array(times), np.array(states)
    assert times.size == 201 and times[-1] == pytest.approx(1.0)
    run = simulate(loop, solver, t_eval=times)
    nx, n_ad = run.states.shape[1], run.adaptive.shape[1]
    np.testing.assert_array_equal(states[:, :nx], run.states)  # bit for bit (RK4)
    np.testing.assert_array_equal(states[:, nx : nx + n_ad], run.adaptive)
    np.testing.assert_array_equal(np.array(commands), run.u_cmd[:-1])
    # what each sample read: the mean of the loop's states at the period's five reading
    # instants (the first sample: t0 alone) plus the simulator's offset of that sample
    asm = st.asm
    bps, samp = np.asarray(asm.breakpoints), asm.data.samp
    rows = [k for k in range(bps.size - 1) if samp[k] > 0]
    at = simulate(loop, solver, t_eval=bps[rows])
    truth = []
    for i, k in enumerate(rows):
        if samp[k] == 1:
            truth.append(at.states[max(i - 4, 0) : i + 1].mean(axis=0) + asm.data.meas[k])
    np.testing.assert_allclose(np.array(seen), np.array(truth), rtol=0, atol=1e-15)
    assert np.max(np.abs(np.array(seen) - states[:-1, :nx])) > 1e-3  # not the latest state


def test_the_gymnasium_env_steps_a_decimating_design_like_the_simulator(tmp_path):
    pytest.importorskip("gymnasium", reason="the Gymnasium environment needs the gym extra")
    from adaptive_ftc.gym import ScenarioEnv

    path = tmp_path / "d.toml"
    path.write_text(SCENARIO)
    env = ScenarioEnv(str(path), mode="residual", t_final=0.5)
    obs, info = env.reset(seed=0)
    assert env.loop.controller.bound(env.loop).constraint_aware.readings == 5
    times, states, commands, observed = [info["time"]], [env.state], [], [obs]
    done = False
    while not done:
        stepper = env.unwrapped._stepper
        obs, _, terminated, truncated, info = env.step(np.zeros(2))
        done = terminated or truncated
        assert info["status"] == "completed"
        times.append(info["time"])
        states.append(env.state)
        commands.append(info["command"])
        observed.append(obs)
        if not done:  # the observation is what the next sample reads (the mean)
            np.testing.assert_array_equal(obs[:2], stepper.measured())
    times, states = np.array(times), np.array(states)
    run = simulate(env.loop, env.solver, t_eval=times)
    assert run.status == "completed" and times.size == 101
    nx, n_ad = run.states.shape[1], run.adaptive.shape[1]
    np.testing.assert_array_equal(states[:, :nx], run.states)
    np.testing.assert_array_equal(states[:, nx : nx + n_ad], run.adaptive)
    np.testing.assert_array_equal(np.array(commands), run.u_cmd[:-1])
    # the averaged noise: the observation's offset is smaller than the sensor's per reading
    offsets = np.array(observed)[1:-1, 0] - states[1:-1, 0]
    assert offsets.std() < 1e-3 / np.sqrt(5) * 1.5


def test_a_loop_whose_sensors_do_not_give_the_readings_is_refused_by_the_stepper():
    """The filter needs the loop's sensors to give its N readings a sample: a mismatch is the
    simulator's own refusal (naming the fix), not a silent latest reading."""
    from adaptive_ftc.sim.stepper import DigitalStepper

    loop, solver = _combination_1(0.1)
    ca = replace(loop.controller.constraint_aware, decimation=True)
    wrong = replace(
        loop,
        controller=replace(loop.controller, constraint_aware=ca),
        sensors=replace(loop.sensors, rate=2000.0),
    )
    with pytest.raises(ConfigurationError, match="`noise_rate`.*`decimation = false`"):
        DigitalStepper(wrong, solver)
