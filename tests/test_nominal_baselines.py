"""Nominal-inverse and oracle baselines (issue 14): the closed loop obeys the designed linear
error dynamics, the oracle keeps them through failures, zero-adaptive-state loops run
everywhere, and scenario files and campaigns accept the designs."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from adaptive_ftc import ConfigurationError, SolverOptions, load_scenario, simulate
from adaptive_ftc.baselines import (
    BASELINES,
    FAIR_BASELINES,
    baseline_loop,
    baseline_solver,
    fixed_gain,
    nominal_inverse,
    oracle,
    run_baselines,
)
from adaptive_ftc.campaigns import DESIGN_VARIANTS, draw_member, load_campaign
from adaptive_ftc.controllers import DESIGNS, NominalInverse, OracleInverse
from adaptive_ftc.controllers.nominal import solve_guarded
from adaptive_ftc.faults import LossOfEffectiveness

SOLVER = SolverOptions(method="dopri5", rtol=1e-9, atol=1e-12, record_dt=0.01)
LAM, K = 2.0, 5.0


@pytest.fixture(scope="module")
def hyper():
    """The §2.3 hypersonic loop, 10 s, failures removed, controlled by the nominal inverse
    with ``k0 = 0`` (linear error dynamics)."""
    sc = load_scenario("hypersonic-direct-s1")
    loop = replace(sc.loop.without_failures(), t_final=10.0)
    return replace(loop, controller=NominalInverse(lam=LAM, k=K, k0=0.0, eps0=0.01))


def _analytic_error(t, e0, s0, lam=LAM, k=K):
    """Solution of ``s' = -k s``, ``e' = -lam e + s`` (the designed error dynamics, k0 = 0)."""
    return e0 * np.exp(-lam * t) + s0 * (np.exp(-k * t) - np.exp(-lam * t)) / (lam - k)


def _initial_errors(loop):
    """``e(0)`` and ``s(0)`` of the hypersonic loop (reference pi/36 sin(0.2 t))."""
    alpha0, q0 = loop.initial_state
    e0 = 0.0 - alpha0
    ed0 = math.pi / 36 * 0.2 - q0
    return e0, ed0 + LAM * e0


def _run(loop, solver=SOLVER):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(loop, solver)


def test_nominal_inverse_follows_the_designed_error_dynamics(hyper):
    r = _run(hyper)
    assert r.status == "completed"
    assert r.adaptive.shape == (r.time.size, 0) and r.adaptive_names == ()
    e0, s0 = _initial_errors(hyper)
    expected = _analytic_error(r.time, e0, s0)
    np.testing.assert_allclose(r.e[:, 0], expected, rtol=0, atol=1e-8)
    # q = s' + k s (+ k0 tanh) is what the inverse cancels: zero along the run
    assert np.max(np.abs(r.sdot[:, 0] + K * r.s[:, 0])) < 1e-6
    assert abs(r.e[-1, 0]) < 1e-7  # converged: e decays like exp(-2 t)


def test_robust_term_gives_the_nonlinear_s_dynamics(hyper):
    """With ``k0 > 0`` the filtered error obeys ``s' = -k s - k0 tanh(s/eps0)``: compare with
    an independent integration of that scalar ODE (and ``e' = -lam e + s``)."""
    k0, eps0 = 0.5, 0.05
    loop = replace(hyper, controller=NominalInverse(lam=LAM, k=K, k0=k0, eps0=eps0))
    r = _run(replace(loop, t_final=3.0))
    e0, s0 = _initial_errors(loop)

    def rhs(t, z):
        e, s = z
        return [-LAM * e + s, -K * s - k0 * math.tanh(s / eps0)]

    ref = solve_ivp(rhs, (0.0, 3.0), [e0, s0], t_eval=r.time, rtol=1e-11, atol=1e-13)
    np.testing.assert_allclose(r.e[:, 0], ref.y[0], rtol=0, atol=1e-7)
    np.testing.assert_allclose(r.s[:, 0], ref.y[1], rtol=0, atol=1e-6)


def test_stiff_inverse_loops_run_with_a_stiff_method_at_the_same_accuracy(hyper):
    """With a small eps0 the exact inverse gives s' = -k s - k0 tanh(s/eps0), stiff near
    s = 0 (slope k0/eps0 = 2e4): the baselines of a DOPRI5 scenario run with Rodas5P, agree
    with an independent stiff integration and take far fewer steps."""
    k0, eps0 = 20.0, 1e-3
    loop = replace(hyper, controller=NominalInverse(lam=LAM, k=K, k0=k0, eps0=eps0), t_final=2.0)
    solver = SolverOptions(method="dopri5", rtol=1e-8, atol=1e-11, record_dt=0.01)
    assert baseline_solver("fixed-gain", solver) == solver  # the adaptive structure, unchanged
    chosen = baseline_solver("oracle", solver)
    assert chosen == baseline_solver("nominal-inverse", solver)
    assert chosen == replace(solver, method="rodas5p", rtol=1e-6, atol=1e-9)  # yardsticks
    loose = replace(solver, rtol=1e-4, atol=1e-6)
    assert baseline_solver("oracle", loose) == replace(loose, method="rodas5p")  # not tightened
    # a per-state atol of the adaptive loop (its states, not the baseline's): the smallest
    per_state = replace(solver, atol=(1e-8, 1e-6, 1e-7))
    assert baseline_solver("oracle", per_state).atol == 1e-8
    explicit, switching = _run(loop, solver), _run(loop, chosen)
    e0, s0 = _initial_errors(loop)

    def rhs(t, z):
        e, s = z
        return [-LAM * e + s, -K * s - k0 * math.tanh(s / eps0)]

    ref = solve_ivp(rhs, (0.0, 2.0), [e0, s0], t_eval=explicit.time, method="Radau", rtol=1e-11,
                    atol=1e-14)  # fmt: skip
    for r in (explicit, switching):
        np.testing.assert_allclose(r.e[:, 0], ref.y[0], rtol=0, atol=1e-7)
    assert switching.meta["steps"] < 0.5 * explicit.meta["steps"]


def test_oracle_keeps_the_error_dynamics_through_a_loss_of_effectiveness(hyper):
    """Truth: the oracle inverts the failed plant exactly, so e(t) is the failure-free analytic
    solution even after actuator 1 keeps 20 % of its effectiveness and actuator 2 30 %; the
    nominal inverse, blind to the loss, does not."""
    failures = (
        LossOfEffectiveness(actuator=1, onset=2.0, effectiveness=0.2),
        LossOfEffectiveness(actuator=2, onset=2.0, effectiveness=0.3),
    )
    healthy = replace(hyper, reference=("pi/36*sin(2*t)",))
    failed = replace(healthy, failures=failures)
    ro = _run(replace(failed, controller=OracleInverse(lam=LAM, k=K, k0=0.0, eps0=0.01)))
    rn = _run(failed)
    rh = _run(healthy)
    assert ro.status == rn.status == rh.status == "completed"
    np.testing.assert_allclose(ro.e[:, 0], rh.e[:, 0], rtol=0, atol=1e-8)
    window = (5.0, 10.0)  # the analytic error is below 4e-7 rad there
    oracle_rms = ro.rms_error(*window)[0]
    nominal_rms = rn.rms_error(*window)[0]
    assert oracle_rms < 4e-7, (oracle_rms, nominal_rms)
    assert nominal_rms > 100 * oracle_rms  # the blind inverse lags the 2 rad/s reference
    # the applied control gain the oracle inverts is the true one: 0.2*1 + 0.3*2 of healthy
    t = ro.time > 2.5
    np.testing.assert_allclose(
        ro.control_gain[t] / rh.control_gain[t], (0.2 * 1 + 0.3 * 2) / 3.0, rtol=1e-6
    )


def test_mimo_inverse_solves_the_coupled_outputs():
    """A 2-output plant: G is 2x2; the error of each output obeys its own linear dynamics."""
    sc = load_scenario("twomass-mimo")
    loop = replace(sc.loop.without_failures(), t_final=4.0)
    c = sc.loop.controller
    lam = c.lam if isinstance(c.lam, float) else c.lam[0]
    k = c.k if isinstance(c.k, float) else c.k[0]
    ctrl = NominalInverse(lam=lam, k=k, k0=0.0, eps0=c.eps0)
    r = _run(replace(loop, controller=ctrl))
    assert r.status == "completed" and r.e.shape[1] == 2
    for i in range(2):
        expected = _analytic_error(r.time, r.e[0, i], r.s[0, i], lam=lam, k=k)
        np.testing.assert_allclose(r.e[:, i], expected, rtol=0, atol=1e-7)


def test_solve_guarded_matches_numpy_and_floors_small_pivots():
    rng = np.random.default_rng(4)
    G = rng.normal(size=(3, 3)) + 3 * np.eye(3)
    v = rng.normal(size=3)
    buf = np.concatenate([G.ravel(), v])
    out = np.zeros(3)
    solve_guarded(buf, 0, 3, 1e-9, out)
    np.testing.assert_allclose(out, np.linalg.solve(G, v), rtol=1e-12)
    # single output: g below gmin is replaced by copysign(gmin, g); g = 0 by +gmin
    for g, expected in ((1e-12, 2.0 / 1e-3), (-1e-12, -2.0 / 1e-3), (0.0, 2.0 / 1e-3)):
        buf = np.array([g, 2.0])
        solve_guarded(buf, 0, 1, 1e-3, out)
        assert out[0] == pytest.approx(expected)
    # a singular 2x2 (second pivot 0 after elimination): bounded by the floor
    buf = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 2.0])
    solve_guarded(buf, 0, 2, 1e-6, out)
    assert np.all(np.isfinite(out[:2])) and abs(out[1]) == pytest.approx(1.0 / 1e-6)


def test_settings_are_validated():
    with pytest.raises(ConfigurationError, match="gmin"):
        NominalInverse(gmin=0.0)
    with pytest.raises(ConfigurationError, match="probe"):
        OracleInverse(probe=-1.0)
    with pytest.raises(ConfigurationError, match="Unknown baseline"):
        baseline_loop(load_scenario("hypersonic-direct-s1").loop, "orakle")
    with pytest.raises(ConfigurationError, match="needs a ClosedLoop"):
        nominal_inverse("hypersonic-direct-s1")


def test_zero_adaptive_state_loops_run_everywhere(hyper):
    """Frozen, fixed-gain, metrics and figures of a loop without adaptive states."""
    from adaptive_ftc.plots import default_figure_specs, plot

    short = replace(hyper, t_final=1.0)
    r = _run(short.frozen())
    assert r.status == "completed"
    assert fixed_gain(short, SOLVER).adaptive_initial == ()
    m = r.metrics()
    assert math.isfinite(m["rms_error"])
    import matplotlib

    matplotlib.use("Agg")
    for spec in default_figure_specs(r):
        plot(r, spec["kind"])


def test_baselines_keep_the_loop_and_take_the_designs_gains():
    sc = load_scenario("hypersonic-direct-s1")
    for make, cls in ((nominal_inverse, NominalInverse), (oracle, OracleInverse)):
        b = make(sc.loop)
        assert type(b.controller) is cls
        assert (b.controller.lam, b.controller.k, b.controller.k0) == (2.0, 5.0, 2.0)
        assert b.failures == sc.loop.failures and b.allocation == sc.loop.allocation
        assert b.adaptive_initial == () and b.name.endswith(f"({cls.design})")
    assert set(FAIR_BASELINES) == set(BASELINES) - {"oracle"}


def test_run_baselines_returns_every_baseline():
    sc = load_scenario("hypersonic-direct-s1")
    loss = LossOfEffectiveness(actuator=2, onset=5.0, effectiveness=0.1)
    sc = replace(sc, loop=replace(sc.loop, t_final=15.0, failures=(loss,)))
    runs = run_baselines(sc, ("nominal-inverse", "oracle"))
    assert list(runs) == ["nominal-inverse", "oracle"]
    assert runs["oracle"].meta["variant"] == "oracle"
    assert runs["oracle"].meta["scenario"] == "hypersonic-direct-s1"
    # after the elevator loses 90 % (t = 5 s) the oracle still tracks, the nominal inverse not
    oracle_rms = runs["oracle"].rms_error(10, 15)[0]
    assert oracle_rms < 1e-6 and runs["nominal-inverse"].rms_error(10, 15)[0] > 10 * oracle_rms


SCENARIO = """
name = "ni"
duration = 2.0
[plant]
model = "hypersonic"
initial_state = [0.03, 0.0]
[reference]
outputs = ["pi/36*sin(0.2*t)"]
[controller]
design = "{design}"
allocation = [1.0, 2.0]
lam = 2.0
k = 5.0
k0 = 0.0
{extra}
[solver]
method = "dopri5"
rtol = 1e-9
atol = 1e-12
"""


def load_scenario_text(text, tmp_path):
    path = tmp_path / "ni.toml"
    path.write_text(text)
    return load_scenario(path)


@pytest.mark.parametrize("design", ["nominal-inverse", "oracle"])
def test_scenario_files_select_the_designs(design, tmp_path):
    assert DESIGNS[design].design == design
    sc = load_scenario_text(SCENARIO.format(design=design, extra="gmin = 1e-4"), tmp_path)
    assert sc.loop.controller.design == design and sc.loop.controller.gmin == 1e-4
    r = sc.run()
    e0, s0 = _initial_errors(sc.loop)
    np.testing.assert_allclose(r.e[:, 0], _analytic_error(r.time, e0, s0), atol=1e-8)


def test_scenario_file_rejects_a_regressor_for_the_inverse(tmp_path):
    from adaptive_ftc.errors import ScenarioError

    bad = SCENARIO.format(design="nominal-inverse", extra='[controller.regressor]\ntype = "linear"')
    with pytest.raises(ScenarioError, match="regressor"):
        load_scenario_text(bad, tmp_path)


def test_campaigns_accept_the_names():
    assert {"fixed-gain", "nominal-inverse", "oracle"} <= set(DESIGN_VARIANTS)
    spec = load_campaign(
        {
            "name": "ni",
            "base": "hypersonic-direct-s1",
            "designs": ["adaptive", "nominal-inverse", "oracle"],
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
    for name, cls in (("nominal-inverse", NominalInverse), ("oracle", OracleInverse)):
        loop = member.design_loop(name)
        assert type(loop.controller) is cls and loop.failures == member.loop.failures


def test_report_shows_every_baseline_and_marks_the_oracle():
    from adaptive_ftc.claims import ClaimResult
    from adaptive_ftc.report import ScenarioEntry, render_report

    claim = ClaimResult(
        kind="tracking",
        text="tracking kept",
        passed=False,
        measured=1e-3,
        threshold=2.5e-3,
        detail="...",
        unit="rad",
        baselines=(
            ("nominal-inverse", 1e-5, 0.01),
            ("oracle", 1e-14, 1e-11),
            ("frozen", math.inf, math.inf),
        ),
    )
    entry = ScenarioEntry(
        name="sc",
        title="Sc",
        claims=[claim],
        error_ratio=math.inf,
        baseline_ratios={"fixed-gain": math.inf, "nominal-inverse": 0.0125, "oracle": 1e-11},
    )
    assert entry.best_fair_ratio == ("nominal-inverse", 0.0125)
    page = render_report([entry])
    assert "<td>0.0125 (nominal-inverse)</td>" in page  # summary: best fair baseline
    assert "oracle (knows the failure; not compared with)" in page  # scenario table
    assert "oracle (knows the failure: shown, not compared with): RMS 1e-14 rad" in page
    assert "nominal-inverse: RMS 1e-05 rad = <b>0.01</b> × adaptive" in page
