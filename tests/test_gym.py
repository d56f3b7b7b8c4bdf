"""The Gymnasium environment (issue 30): any scenario as a ``gymnasium.Env``, stepped sample by
sample on the simulator's own digital-control loop (``adaptive_ftc.sim.stepper``)."""

from __future__ import annotations

import math
import re
import subprocess
import sys
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

gymnasium = pytest.importorskip(
    "gymnasium", reason="the Gymnasium environment needs the gym extra: pip install -e '.[gym]'"
)

from gymnasium.utils.env_checker import check_env  # noqa: E402

import adaptive_ftc.gym as aftc_gym  # noqa: E402
from adaptive_ftc import ConfigurationError, RunStatus, SolverOptions, simulate  # noqa: E402
from adaptive_ftc.campaigns import draw_member, load_campaign  # noqa: E402
from adaptive_ftc.gym import CATALOGUE_IDS, ScenarioEnv  # noqa: E402
from adaptive_ftc.scenarios import list_scenarios, load_scenario  # noqa: E402
from adaptive_ftc.sim.stepper import DigitalStepper  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def _episode(env: ScenarioEnv, policy, *, seed: int = 0, options=None):
    """Run one episode; returns the sample times, the loop's states at them, the commands
    applied and the infos (states at ``times[k]``: before that sample's update)."""
    obs, info = env.reset(seed=seed, options=options)
    times, states, commands, infos = [info["time"]], [env.state], [], []
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        times.append(info["time"])
        states.append(env.state)
        commands.append(info["command"])
        infos.append((reward, info))
        done = terminated or truncated
    return np.array(times), np.array(states), np.array(commands), infos


def _assert_same_as_simulator(env: ScenarioEnv, times, states, commands) -> None:
    """The simulator's digital run of the episode's loop, recorded at the sample instants,
    has the same plant and controller states and the same held commands, bit for bit."""
    result = simulate(env.loop, env.solver, t_eval=times)
    assert result.status == "completed"
    nx, n_ad = result.states.shape[1], result.adaptive.shape[1]
    np.testing.assert_array_equal(states[:, :nx], result.states)
    np.testing.assert_array_equal(states[:, nx : nx + n_ad], result.adaptive)
    np.testing.assert_array_equal(commands, result.u_cmd[:-1])  # held over [t_k, t_k+1)


# ----------------------------------------------------------------------------- conformance
def test_env_passes_gymnasium_env_checker_in_both_modes():
    for mode in ("residual", "direct"):
        env = ScenarioEnv("hypersonic-direct-s1-actuators", dt=0.005, mode=mode, t_final=0.1)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # advice on unbounded spaces, not failures
            check_env(env)


def test_every_registered_id_makes_resets_and_steps():
    for env_id, (name, _) in CATALOGUE_IDS.items():
        assert name in list_scenarios()
        env = gymnasium.make(env_id, t_final=0.05)
        obs, info = env.reset(seed=0)
        assert env.observation_space.contains(obs), env_id
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample() * 0)
        assert env.observation_space.contains(obs) and math.isfinite(reward), env_id
        assert info["status"] == "completed", (env_id, info.get("message"))
        env.close()


def test_ids_are_registered_by_the_gym_module_not_by_the_package():
    code = (
        "import gymnasium, adaptive_ftc\n"
        "ours = lambda: sorted(k for k in gymnasium.registry if k.startswith('adaptive_ftc/'))\n"
        "print(len(ours()))\n"
        "import adaptive_ftc.gym\n"
        "print(len(ours()))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    ).stdout.split()
    assert out == ["0", str(len(CATALOGUE_IDS))]
    assert set(CATALOGUE_IDS) <= set(gymnasium.registry)
    assert "adaptive_ftc/HypersonicDirect-v0" in CATALOGUE_IDS
    aftc_gym.register_catalogue()  # again: no error, nothing overridden


# ----------------------------------------------------------------- the simulator's digital run
def test_zero_residual_reproduces_the_digital_run_bit_for_bit_across_failures():
    # dopri5, the catalogue's digital scenario, past its first failure (t = 40 s)
    env = ScenarioEnv("hypersonic-direct-s1-digital", mode="residual", t_final=41.0)
    times, states, commands, infos = _episode(env, lambda obs: np.zeros(2))
    assert times[-1] == 41.0 and len(times) == 41.0 / 0.005 + 1
    _assert_same_as_simulator(env, times, states, commands)
    for _, info in infos:
        np.testing.assert_array_equal(info["command"], info["design_command"])


def test_zero_residual_reproduces_noisy_mimo_and_rosenbrock_digital_runs_bit_for_bit():
    # rk4 with seeded sensor noise; a MIMO plant with four actuators (rk4); the wing rock with
    # rodas5p (recorded at the samples only); 2 ms and 5 ms periods
    for name, dt in (
        ("hypersonic-direct-s1-noise", 0.002),
        ("twomass-mimo", 0.005),
        ("wingrock-direct-s1", 0.002),
    ):
        env = ScenarioEnv(name, mode="residual", dt=dt, t_final=2.0)
        m = env.action_space.shape[0]
        times, states, commands, _ = _episode(env, lambda obs, m=m: np.zeros(m), seed=3)
        assert env.loop.sample_time == dt
        _assert_same_as_simulator(env, times, states, commands)


def test_campaign_member_with_a_failure_between_samples_reproduces_the_simulator():
    spec = load_campaign("hypersonic-loe")

    # a member whose first failure starts early and off the 5 ms sample grid
    def first_onset(i: int) -> float:
        member = draw_member(spec, i)
        return (
            min((f.onset for f in member.failures), default=math.inf) if member.loop else math.inf
        )

    index = next(
        i
        for i in range(500)
        if first_onset(i) < 14.0
        and abs(first_onset(i) / 0.005 - round(first_onset(i) / 0.005)) > 0.01
    )
    onset = first_onset(index)
    env = ScenarioEnv(campaign=spec, mode="residual", dt=0.005, t_final=onset + 1.0)
    times, states, commands, infos = _episode(
        env, lambda obs: np.zeros(2), options={"member": index}
    )
    assert env.member == index and infos[-1][1]["member"] == index
    assert env.loop.failures.failures == draw_member(spec, index).loop.failures.failures
    _assert_same_as_simulator(env, times, states, commands)


def test_campaign_members_are_drawn_from_the_seed():
    env = ScenarioEnv(campaign="hypersonic-loe", mode="residual", dt=0.005, t_final=0.1)
    env.reset(seed=7)
    first = env.member, env.loop.failures.failures
    env.reset(seed=7)
    assert (env.member, env.loop.failures.failures) == first
    members = set()
    for seed in range(5):
        env.reset(seed=seed)
        members.add(env.member)
    assert len(members) == 5


# ----------------------------------------------------------------------------- direct mode
def test_direct_mode_holds_each_action_on_the_plant_like_an_exact_integration():
    from scipy.integrate import solve_ivp

    env = ScenarioEnv(
        "hypersonic-direct-s1", dt=0.01, t_final=0.5, solver=SolverOptions(method="rk4", dt=1e-4)
    )
    plant = env.scenario.loop.plant
    obs, _ = env.reset(seed=0)
    x = np.array(env.scenario.loop.initial_state, dtype=float)
    t = 0.0
    for k in range(50):
        u = np.array([0.02 * math.sin(k / 5), 0.01 * math.cos(k / 7)])
        obs, reward, terminated, truncated, info = env.step(u)
        np.testing.assert_array_equal(info["command"], u)
        sol = solve_ivp(
            lambda s, y, u=u: plant.derivative(s, y, u), (t, t + 0.01), x, rtol=1e-12, atol=1e-14
        )
        x, t = sol.y[:, -1], t + 0.01
        np.testing.assert_allclose(env.state[:2], x, rtol=1e-9, atol=1e-12)
    assert truncated and not terminated and info["time"] == pytest.approx(0.5)


def test_direct_mode_action_space_is_the_declared_travel():
    env = ScenarioEnv("hypersonic-direct-s1-actuators", dt=0.005)
    np.testing.assert_array_equal(env.action_space.low, [-1.0, -1.0])
    np.testing.assert_array_equal(env.action_space.high, [1.0, 1.0])
    env = ScenarioEnv("hypersonic-direct-s1-actuators", dt=0.005, mode="residual")
    assert np.all(np.isinf(env.action_space.high))
    env = ScenarioEnv("hypersonic-direct-s1", dt=0.005, action_bounds=(-0.5, [0.5, 1.0]))
    np.testing.assert_array_equal(env.action_space.high, [0.5, 1.0])


# ----------------------------------------------------------------------- observation, reward
def test_observation_is_the_noisy_measurement_and_the_reference():
    sc = load_scenario("hypersonic-direct-s1-noise")
    env = ScenarioEnv(sc, mode="residual", dt=0.001, t_final=2.0)
    assert env.observation_names == ("alpha", "q", "y_d[alpha]", "y_d'[alpha]")
    obs, info = env.reset(seed=0)
    noise, ref = [], []
    done = False
    while not done:
        noise.append(obs[:2] - env.state[:2])
        ref.append((info["time"], obs[2]))
        obs, _, terminated, truncated, info = env.step(np.zeros(2))
        done = terminated or truncated
    noise = np.array(noise)
    # the catalogue's noise: 1e-3 rad on alpha, 1e-2 rad/s on q (2000 samples: within 5 %)
    np.testing.assert_allclose(noise.std(axis=0), [1e-3, 1e-2], rtol=0.05)
    # the reference of the scenario, (pi/36) sin(t)... evaluated as the loop does
    from adaptive_ftc.scenarios.expressions import Expression

    yd = Expression(sc.loop.reference[0], ("t",))
    for t, value in ref[::200]:
        assert value == pytest.approx(yd(t=t), rel=1e-12, abs=1e-15)
    # another seed, other noise; the same seed, the same
    a, _ = env.reset(seed=1)
    b, _ = env.reset(seed=1)
    c, _ = env.reset(seed=2)
    assert np.array_equal(a, b) and not np.array_equal(a, c)


def test_reward_is_the_weighted_tracking_effort_and_rate_cost():
    weights = {"tracking_weight": 2.0, "effort_weight": 0.3, "rate_weight": 5.0}
    env = ScenarioEnv("hypersonic-direct-s1-digital", mode="residual", t_final=0.2, **weights)
    rng = np.random.default_rng(0)
    times, states, commands, infos = _episode(env, lambda obs: rng.normal(0, 0.01, 2))
    result = simulate(env.loop, env.solver, t_eval=times)  # its y_d at the sample instants
    for k, (reward, info) in enumerate(infos):
        e = result.yd[k + 1] - states[k + 1, :1]
        u = commands[k]
        du = u - commands[k - 1] if k else np.zeros(2)
        expect = -(2.0 * e @ e + 0.3 * u @ u + 5.0 * du @ du)
        assert reward == pytest.approx(expect, rel=1e-12)
        np.testing.assert_allclose(info["tracking_error"], e, rtol=1e-12)


def test_divergence_terminates_with_the_run_status_and_reason():
    env = ScenarioEnv("hypersonic-direct-s1", dt=0.01, divergence_penalty=50.0)
    env.reset(seed=0)
    for _ in range(10_000):
        obs, reward, terminated, truncated, info = env.step(np.array([40.0, 40.0]))
        if terminated or truncated:
            break
    assert terminated and not truncated
    assert info["status"] == RunStatus.DIVERGED and reward == -50.0
    assert info["reason"].signal in ("alpha", "q") and "diverged" in info["message"]
    assert np.all(np.isfinite(obs))
    with pytest.raises(ConfigurationError, match="reset"):
        env.step(np.zeros(2))


# ----------------------------------------------------------------------------- clear errors
def test_errors_name_the_culprit_and_the_fix():
    with pytest.raises(ConfigurationError, match=r"continuous controller.*`dt`"):
        ScenarioEnv("hypersonic-direct-s1")
    with pytest.raises(ConfigurationError, match="Did you mean 'residual'"):
        ScenarioEnv("hypersonic-direct-s1-digital", mode="residul")
    with pytest.raises(ConfigurationError, match="Did you mean 'frozen'"):
        ScenarioEnv("hypersonic-direct-s1-digital", mode="residual", design="frozn")
    with pytest.raises(ConfigurationError, match="mode='residual'"):
        ScenarioEnv("hypersonic-direct-s1-digital", design="frozen")
    with pytest.raises(ConfigurationError, match="scipy"):
        ScenarioEnv("hypersonic-direct-s1-digital", solver=SolverOptions(method="LSODA"))
    with pytest.raises(ConfigurationError, match="rate_weight"):
        ScenarioEnv("hypersonic-direct-s1-digital", rate_weight=-1.0)
    with pytest.raises(ConfigurationError, match="not 'wingrock-direct-s1'"):
        ScenarioEnv("wingrock-direct-s1", campaign="hypersonic-loe", dt=0.005)
    env = ScenarioEnv("hypersonic-direct-s1-digital", t_final=0.1)
    with pytest.raises(ConfigurationError, match="reset"):
        env.step(np.zeros(2))
    env.reset(seed=0)
    with pytest.raises(ConfigurationError, match="2 finite numbers"):
        env.step(np.zeros(3))
    with pytest.raises(ConfigurationError, match="no campaign"):
        env.reset(options={"member": 1})


def test_stepper_refuses_a_continuous_loop_and_out_of_order_calls():
    sc = load_scenario("hypersonic-direct-s1")
    with pytest.raises(ConfigurationError, match="sample_time"):
        DigitalStepper(sc.loop)
    st = DigitalStepper(replace(sc.loop, sample_time=0.01, t_final=0.02))
    with pytest.raises(ConfigurationError, match="call sample"):
        st.advance()
    st.sample()
    with pytest.raises(ConfigurationError, match="advance"):
        st.sample()
    with pytest.raises(ConfigurationError, match="one value per actuator"):
        st.advance([1.0])


# ------------------------------------------------------------------------------- the docs page
def test_deploying_page_examples_print_what_the_page_says(capsys):
    page = (ROOT / "docs" / "deploying.md").read_text(encoding="utf-8")
    parts = re.split(r"```python\n(.*?)```", page, flags=re.S)
    assert len(parts) >= 9  # four examples
    namespace = {"__name__": "deploying"}
    for code, after in zip(parts[1::2], parts[2::2], strict=True):
        exec(compile(code, "docs/deploying.md", "exec"), namespace)  # noqa: S102
        said = re.match(r"\s*prints `([^`]*)`", after)
        assert said, f"no 'prints `...`' after the example:\n{code}"
        assert capsys.readouterr().out.strip() == said.group(1)


@pytest.mark.parametrize("module", ["adaptive_ftc.gym", "adaptive_ftc.sim.stepper"])
def test_docstring_examples(module):
    import doctest
    import importlib

    failures, tried = doctest.testmod(importlib.import_module(module))
    assert tried and failures == 0
