"""The open engine: parts carry their equations, users bring their own plant, a structure
compiles once whatever its numbers, and nothing a user writes can crash the interpreter."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import warnings
from dataclasses import replace
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

from adaptive_ftc import (
    Bias,
    ClosedLoop,
    DirectAdaptive,
    FuzzyBasis,
    LinearRegressor,
    LossOfEffectiveness,
    SignEstimation,
    SolverOptions,
    Stuck,
    load_scenario,
    simulate,
    simulate_many,
)
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.plants import CustomPlant, ExpressionPlant, Pendulum, Plant, check_plant, plant
from adaptive_ftc.sim import codegen
from adaptive_ftc.sim.compose import assemble, generate, source_of

ROOT = Path(__file__).resolve().parents[1]


class PendulumNumbers(NamedTuple):
    g_over_l: float
    damping: float
    inertia: float


def pendulum_equations(t, x, u, p, xdot):
    """The built-in Pendulum's equations, written again by a user."""
    xdot[0] = x[1]
    xdot[1] = -p.g_over_l * math.sin(x[0]) + (u[0] + u[1] + u[2] - p.damping * x[1]) / p.inertia


def _pendulum_loop(plant_obj, *, t_final=6.0, design=None):
    fls = FuzzyBasis(
        inputs=("theta", "omega"), centers=(-1.0, 0.0, 1.0), width=(0.5, 1.0), normalised=False
    )
    ctrl = design or DirectAdaptive(regressor=fls, lam=2, k=5, k0=1, gamma=10, sigma=0.01)
    return ClosedLoop(
        plant=plant_obj,
        controller=ctrl,
        allocation=(1.0, 1.0, 1.0),
        reference=("0.5*sin(0.5*t)",),
        initial_state=(0.1, 0.0),
        failures=(LossOfEffectiveness(actuator=2, onset=2.0, effectiveness=0.3),),
        t_final=t_final,
    )


USER_PENDULUM = CustomPlant(
    name="user-pendulum",
    states=("theta", "omega"),
    outputs={"theta": "omega"},
    actuators=("m1", "m2", "m3"),
    equations=pendulum_equations,
    params=PendulumNumbers(9.81, 0.05, 0.1),
)
FILE_PENDULUM = ExpressionPlant(
    name="file-pendulum",
    states=("theta", "omega"),
    outputs={"theta": "omega"},
    actuators=("m1", "m2", "m3"),
    parameters={"g_over_l": 9.81, "damping": 0.05, "inertia": 0.1},
    dynamics={
        "theta": "omega",
        "omega": "-g_over_l*sin(theta) + (m1 + m2 + m3 - damping*omega)/inertia",
    },
)


def test_a_plant_written_three_ways_gives_the_same_closed_loop():
    """Built-in class, user Python function and scenario-file equations: three independent
    routes to the same plant agree to rounding."""
    runs = [simulate(_pendulum_loop(p)) for p in (Pendulum(), USER_PENDULUM, FILE_PENDULUM)]
    for r in runs:
        assert r.status == "completed"
    for r in runs[1:]:
        np.testing.assert_allclose(r.states, runs[0].states, rtol=0, atol=1e-12)
        np.testing.assert_allclose(r.adaptive, runs[0].adaptive, rtol=0, atol=1e-10)


def test_user_plant_open_loop_matches_the_analytic_oscillator():
    class K(NamedTuple):
        w2: float

    @plant(states=("q", "v"), outputs={"q": "v"}, actuators=("a", "b"), params=K(4.0))
    def oscillator(t, x, u, p, xdot):
        xdot[0] = x[1]
        xdot[1] = -p.w2 * x[0] + u[0] + u[1]

    loop = _unforced_loop(oscillator)
    r = simulate(loop)
    np.testing.assert_allclose(r.states[:, 0], np.cos(2.0 * r.time), atol=1e-9)


def _unforced_loop(plant_):
    """``plant_`` from (1, 0) with both actuators allocated zero: its free response."""
    ctrl = DirectAdaptive(regressor=LinearRegressor(inputs=(), bias=True), theta0=0.0)
    return ClosedLoop(
        plant=plant_, controller=ctrl, allocation=(0.0, 0.0), initial_state=(1.0, 0.0), t_final=3.0
    )


class _Spring(NamedTuple):
    """Module level: its numbers can live in the loop's flat data array."""

    index: int  # an integer field: rebuilt as an int in the compiled code
    soft: float
    stiff: float


def _local_spring_class():
    class Spring(NamedTuple):  # defined in a function: not importable, passed whole
        index: int
        soft: float
        stiff: float

    return Spring


@pytest.mark.parametrize("where", ["module", "function"])
def test_plant_parameters_reach_the_equations_flattened_or_whole(where):
    """Parameters of an importable class are flattened into the data array (an int field
    comes back an int); those of a class defined in a function travel whole. Both give the
    analytic oscillator x = cos(2 t)."""
    cls = _Spring if where == "module" else _local_spring_class()

    @plant(states=("q", "v"), outputs={"q": "v"}, actuators=("a", "b"), params=cls(1, 9.0, 4.0))
    def spring(t, x, u, p, xdot):
        k = p.stiff if p.index == 1 else p.soft
        xdot[0] = x[1]
        xdot[1] = -k * x[0] + u[0] + u[1]

    loop = _unforced_loop(spring)
    asm = assemble(loop)
    assert (asm.data.p == ()) == (where == "module")
    r = simulate(loop)
    np.testing.assert_allclose(r.states[:, 0], np.cos(2.0 * r.time), atol=1e-9)


def test_two_hundred_members_that_differ_only_in_numbers_compile_once():
    """Gains, failure values and times, initial states are data, not code."""
    sc = load_scenario("hypersonic-direct-s1")
    base = replace(sc.loop, t_final=0.2)
    rng = np.random.default_rng(0)
    loops = []
    for _ in range(200):
        ctrl = replace(base.controller, gamma=float(rng.uniform(1, 10)), k=float(rng.uniform(1, 9)))
        fails = (
            Stuck(
                actuator=2,
                onset=float(rng.uniform(0.01, 0.1)),
                value=f"{rng.uniform(-0.2, 0.2)!r} + {rng.uniform(0, 0.1)!r}*cos(0.5*t) - "
                f"{rng.uniform(0, 0.1)!r}*sin(0.5*t)",
            ),
            LossOfEffectiveness(
                actuator=1,
                onset=float(rng.uniform(0.1, 0.15)),
                effectiveness=float(rng.uniform(0.2, 0.9)),
            ),
        )
        loops.append(
            replace(
                base,
                controller=ctrl,
                failures=fails,
                initial_state=(float(rng.uniform(-0.05, 0.05)), 0.0),
            )
        )
    simulate(loops[0], sc.solver)  # compile (or load) the structure once
    before = codegen.stats()
    results = simulate_many(loops[1:], sc.solver, jobs=2)
    assert all(r.status == "completed" for r in results)
    after = codegen.stats()
    assert after["generated"] == before["generated"]
    assert after["loaded"] == before["loaded"]  # no new module for any member
    integrator = assemble(loops[0]).integrator(sc.solver.compiled_method)
    assert len(integrator.signatures) == 1


def test_loops_of_different_structures_share_one_compiled_integrator():
    """The integrators call each loop's own rhs and jump through addresses in its data: a new
    structure compiles its rhs and signals, never another RK4 or DOPRI5."""
    from adaptive_ftc.sim.compose import integrators

    solver = SolverOptions(method="rk4", dt=1e-3)
    direct = replace(load_scenario("hypersonic-direct-s1").loop, t_final=0.3)
    nussbaum = replace(load_scenario("hypersonic-nussbaum-s1-pos").loop, t_final=0.3)
    assert source_of(direct) != source_of(nussbaum)
    import numba

    a, b = assemble(direct), assemble(nussbaum)
    assert a.module is not b.module and a.integrator("rk4") is b.integrator("rk4")
    assert numba.typeof(a.data) == numba.typeof(b.data)  # one signature serves both
    before = set(integrators().integrate_rk4.signatures)
    ra, rb = simulate(direct, solver), simulate(nussbaum, solver)
    assert ra.status == rb.status == "completed"
    assert len(set(integrators().integrate_rk4.signatures) - before) <= 1  # at most 1 compile
    # each loop ran its own equations: the same numbers as its rhs evaluated from Python
    for asm, r in ((a, ra), (b, rb)):
        y = np.concatenate([r.states[-1], r.adaptive[-1]])
        y = np.concatenate([y, np.zeros(asm.y0.size - y.size)])
        assert np.all(np.isfinite(asm.derivative(r.time[-1], y, 0)))
    assert not np.allclose(ra.states, rb.states)


def test_data_without_compiled_addresses_is_refused_not_called():
    asm = assemble(replace(load_scenario("hypersonic-direct-s1").loop, t_final=0.1))
    asm.integrator("rk4")  # assemble() wrote the addresses
    bare = replace(asm, data=asm.data._replace(i=asm.data.i.copy()))
    bare.data.i[:] = 0  # e.g. a LoopData built by hand
    with pytest.raises(ConfigurationError, match="call assemble"):
        bare.integrator("rk4")


def test_an_address_call_refuses_other_argument_types_at_compile_time():
    # the integrators call rhs through its address: arguments of other types than those it
    # was compiled for would be read as garbage, so the call refuses them when it compiles
    import numba

    from adaptive_ftc.sim.fptr import call_rhs

    data = assemble(replace(load_scenario("hypersonic-direct-s1").loop, t_final=0.1)).data

    @numba.njit
    def strided(ptr, Y, D):
        call_rhs(ptr, 0.0, Y[::2], 0, D, Y, Y)

    with pytest.raises(numba.core.errors.TypingError, match="through an address needs"):
        strided(0, np.zeros(10), data)


def test_the_generated_module_reads_like_the_thesis():
    text = source_of(load_scenario("hypersonic-nussbaum-s1-pos").loop)
    for needle in (
        "(4.25)-(4.27)",
        "def rhs(t, Y, ph, D, W, dY)",
        "plant_dynamics(",
        "theta_law(",
        "nussbaum(",
    ):
        assert needle in text
    # shared by every loop (compose.integrators()): they call rhs and control_gain by address;
    # control_gain is the plant's (one module per plant, any design)
    assert "def integrate_rk4(" not in text and "def signals(" not in text
    assert "def control_gain(" not in text
    failures = text[text.index("def failure(") : text.index("def rhs(")]
    assert "c[o + " in failures and "0.75" not in failures  # failure numbers are data


def test_the_cache_survives_a_new_process_and_is_keyed_by_content(tmp_path):
    env = {**os.environ, "ADAPTIVE_FTC_CACHE_DIR": str(tmp_path)}
    code = (
        "from dataclasses import replace\n"
        "from adaptive_ftc import load_scenario, simulate\n"
        "from adaptive_ftc.sim import codegen\n"
        "sc = load_scenario('hypersonic-direct-s2')\n"
        "simulate(replace(sc.loop, t_final=0.1), sc.solver)\n"
        "print(codegen.stats()['compiled'])\n"
    )
    runs = [
        subprocess.run(
            [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300
        )
        for _ in range(2)
    ]
    assert [r.returncode for r in runs] == [0, 0], runs[0].stderr + runs[1].stderr
    assert int(runs[0].stdout.split()[-1]) > 0  # first process compiles
    assert int(runs[1].stdout.split()[-1]) == 0  # second process loads from the disk cache
    assert len(list((tmp_path / "loops").glob("loop_*.py"))) == 1
    assert len(list((tmp_path / "loops").glob("integrators_*.py"))) == 1  # shared by all loops


_DECORATED = """
from adaptive_ftc.plants import plant


@plant(states=("theta", "omega"), outputs={"theta": "omega"}, actuators=("m1", "m2", "m3"))
def decorated_pendulum(t, x, u, p, xdot):
    xdot[0] = x[1]
    xdot[1] = -{g} * x[0] + (u[0] + u[1] + u[2]) / 0.1
"""


def _fresh_loop(plant_obj):
    """A two-second loop of a structure no other test compiles (a distinctive reference)."""
    loop = replace(_pendulum_loop(plant_obj, t_final=2.0), reference=("0.25*sin(0.75*t)",))
    return replace(loop, controller=DirectAdaptive(regressor=LinearRegressor(inputs=("e",))))


def test_a_decorated_plant_compiles_once_per_process_and_disk_caches(monkeypatch, tmp_path):
    # ``@plant`` rebinds the function's name to the plant: the loop imports the function
    # through it, so the loop is a disk-cached module like a built-in plant's
    (tmp_path / "user_plants_a.py").write_text(_DECORATED.replace("{g}", "9.0"))
    monkeypatch.syspath_prepend(str(tmp_path))
    from user_plants_a import decorated_pendulum

    loop = _fresh_loop(decorated_pendulum)
    assert "from user_plants_a import decorated_pendulum" in source_of(loop)
    from adaptive_ftc.sim.compose import integrators

    integrators()  # loaded once per process: not counted below
    before = codegen.stats()
    first = simulate(loop)
    mid = codegen.stats()
    second = simulate(replace(loop, initial_state=(0.2, 0.0)))
    after = codegen.stats()
    assert first.status == second.status == "completed"
    assert mid["in_memory"] == before["in_memory"]  # on disk, not in memory
    assert mid["loaded"] == before["loaded"] + 2  # the loop and its plant's control gain
    assert after["loaded"] == mid["loaded"] and after["compiled"] == mid["compiled"]


def test_a_plant_of_a_script_compiles_once_per_process(tmp_path):
    # a plant defined where it cannot be imported (a script's __main__, a notebook, a
    # function) is compiled in memory: once per plant object, again when it is redefined
    def make(g):
        ns: dict = {}
        exec(_DECORATED.replace("{g}", str(g)), ns)  # as a notebook cell would define it
        return ns["decorated_pendulum"]

    ship = make(8.0)
    before = codegen.stats()["in_memory"]
    a = simulate(_fresh_loop(ship))
    b = simulate(replace(_fresh_loop(ship), initial_state=(0.3, 0.0)))
    assert codegen.stats()["in_memory"] == before + 2  # the loop and its plant's control gain
    c = simulate(_fresh_loop(make(8.0)))  # redefined: compiled again
    assert codegen.stats()["in_memory"] == before + 4
    assert a.status == b.status == c.status == "completed"
    np.testing.assert_array_equal(a.states, c.states)  # same equations, same numbers


def test_no_writable_cache_directory_compiles_in_memory(monkeypatch, tmp_path):
    loop = replace(_pendulum_loop(Pendulum()), t_final=0.5, name="in-memory")
    loop = replace(loop, controller=replace(loop.controller, k=4.5))
    simulate(loop)  # its structure, control gain and the integrators: loaded in this process
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    monkeypatch.setenv("ADAPTIVE_FTC_CACHE_DIR", str(blocker / "x"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocker / "y"))
    monkeypatch.setattr(codegen.tempfile, "gettempdir", lambda: str(blocker / "z"))
    assert codegen.cache_dir() is None
    before = codegen.stats()["in_memory"]
    # a structure not seen in this process: an extra failure shape
    loop = replace(loop, failures=(Bias(actuator=3, onset=0.1, bias="0.01*t*t"),))
    assert simulate(loop).status == "completed"
    assert codegen.stats()["in_memory"] == before + 1


def test_import_does_not_load_numba_or_scipy():
    code = "import sys, adaptive_ftc; print('numba' in sys.modules, 'scipy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.stdout.split() == ["False", "False"], out.stderr


# ----------------------------------------------------------------------------- refusals
def _custom(equations, **kw):
    class P(NamedTuple):
        k: float

    args = dict(
        name="m",
        states=("p", "v"),
        outputs={"p": "v"},
        actuators=("a", "b"),
        equations=equations,
        params=P(1.0),
    )
    args.update(kw)
    return CustomPlant(**args)


def _ok(t, x, u, p, xdot):
    xdot[0] = x[1]
    xdot[1] = -p.k * x[0] + u[0] + u[1]


@pytest.mark.parametrize(
    ("equations", "kw", "message"),
    [
        (lambda t, x, u, p, xdot: _set(xdot, x[1] + u[0], u[0]), {}, "acts directly on output"),
        (lambda t, x, u, p, xdot: _set(xdot, x[1], x[0]), {}, "No actuator"),
        (lambda t, x, u, p, xdot: _set(xdot, x[1], u[2]), {}, "index outside"),
        (lambda t, x, u, p, xdot: _set(xdot, 2 * x[1], u[0]), {}, "relative degree 2"),
        (lambda t, x, u, p, xdot: None, {}, "finite dx/dt"),
        (lambda t, x, u, p: None, {}, "takes 4 argument"),
        (_ok, {"outputs": {"p": "p"}}, "its own rate"),
        (_ok, {"outputs": {"p": "speed"}}, "is not a state"),
        (_ok, {"params": {"k": 1.0}}, "NamedTuple"),
        (_ok, {"states": ("p", "p")}, "repeats"),
    ],
)
def test_a_plant_that_breaks_the_designs_assumptions_is_refused(equations, kw, message):
    with pytest.raises(ConfigurationError, match=message):
        _custom(equations, **kw)


def _late_index(t, x, u, p, xdot):
    j = 0 if t < 0.05 else 5  # u has two entries: out of bounds once the run is under way
    xdot[0] = x[1]
    xdot[1] = -p.k * x[0] + u[0] + u[1] + 0.0 * u[j]


@pytest.mark.parametrize("method", ["rk4", "dopri5"])
def test_a_user_plants_index_error_inside_the_integrator_is_a_clear_error(method):
    # the shared integrators call the loop's rhs by address: the bounds-checked index of the
    # user's equations must still come back as a clear error, not a crash
    plant_obj = _custom(_late_index)
    loop = ClosedLoop(
        plant=plant_obj,
        controller=DirectAdaptive(regressor=LinearRegressor(inputs=("e",))),
        allocation=(1.0, 1.0),
        reference=("0.1*sin(t)",),
        initial_state=(0.0, 0.0),
        t_final=0.2,
    )
    with pytest.raises(ConfigurationError, match="index outside an array"):
        simulate(loop, SolverOptions(method=method))


def _set(xdot, a, b):
    xdot[0] = a
    xdot[1] = b


def _uses_python_objects(t, x, u, p, xdot):
    import time

    xdot[0] = x[1]
    xdot[1] = u[0] + u[1] + 0.0 * time.time()


def test_equations_numba_cannot_compile_give_a_clear_error_not_a_crash():
    loop = ClosedLoop(
        plant=_custom(_uses_python_objects),
        controller=DirectAdaptive(regressor=LinearRegressor(inputs=("e", "edot"))),
        allocation=(1.0, 1.0),
        reference=("sin(t)",),
        t_final=0.5,
    )
    with pytest.raises(ConfigurationError, match="cannot be compiled"):
        simulate(loop)


def test_a_plant_subclass_without_equations_is_refused_not_silently_replaced():
    from dataclasses import dataclass
    from typing import ClassVar

    @dataclass(frozen=True, kw_only=True)
    class Incomplete(Plant):
        name: ClassVar[str] = "incomplete"
        state_names: ClassVar[tuple[str, ...]] = ("a", "b")
        output_names: ClassVar[tuple[str, ...]] = ("a",)
        position_index: ClassVar[tuple[int, ...]] = (0,)
        velocity_index: ClassVar[tuple[int, ...]] = (1,)

        @property
        def n_actuators(self) -> int:
            return 2

        def parameter_values(self):
            return ()

    with pytest.raises(ConfigurationError, match="equations"):
        ClosedLoop(
            plant=Incomplete(),
            controller=DirectAdaptive(regressor=LinearRegressor(inputs=("e",))),
            allocation=(1.0, 1.0),
        )


def test_expression_plant_errors_name_the_state_and_the_fix():
    with pytest.raises(ConfigurationError, match="no equation for omega"):
        ExpressionPlant(
            states=("theta", "omega"),
            outputs={"theta": "omega"},
            actuators=("m",),
            dynamics={"theta": "omega"},
        )
    with pytest.raises(ConfigurationError, match="unknown name 'thetta'"):
        ExpressionPlant(
            states=("theta", "omega"),
            outputs={"theta": "omega"},
            actuators=("m",),
            dynamics={"theta": "omega", "omega": "-thetta + m"},
        )


def test_check_plant_accepts_every_registered_plant():
    from adaptive_ftc.plants import PLANTS

    for name, cls in PLANTS.items():
        if cls is not ExpressionPlant:
            check_plant(cls()), name


def test_fuzzy_widths_per_input_scale_each_input():
    fls = FuzzyBasis(
        inputs=("a", "b"), centers=((0.0,), (0.0,)), width=(1.0, 10.0), normalised=False
    )
    np.testing.assert_allclose(fls([1.0, 10.0]), [math.exp(-0.5) * math.exp(-0.5)])
    with pytest.raises(ConfigurationError, match="one per input"):
        FuzzyBasis(inputs=("a", "b"), centers=(0.0,), width=(1.0, 2.0, 3.0))


def test_sign_estimation_on_the_reversed_pendulum_finds_the_direction():
    fls = FuzzyBasis(
        inputs=("theta", "omega"), centers=(-1.0, 0.0, 1.0), width=(0.5, 1.0), normalised=False
    )
    ctrl = SignEstimation(
        regressor=fls, lam=2, k=5, k0=1, alpha0=10, alpha1=10, sigma0=0.01, sigma1=1e-4, rho0=1.0
    )
    r = simulate(_pendulum_loop(Pendulum(gains=(-1.0, -1.0, -1.0)), design=ctrl, t_final=10.0))
    assert r.adaptive_state("rho")[-1] < 0  # true direction negative
    assert float(r.rms_error(8, 10)[0]) < 1e-3


@pytest.mark.parametrize("script", ["own_plant_python.py", "own_plant_file.py"])
def test_examples_run(script):
    with warnings.catch_warnings():
        out = subprocess.run(
            [sys.executable, str(ROOT / "examples" / script)],
            capture_output=True,
            text=True,
            timeout=600,
            cwd=ROOT,
        )
    assert out.returncode == 0, out.stdout + out.stderr
    assert "completed" in out.stdout


# ----------------------------------------------------------------------------- solvers, interrupts
def test_compiled_adaptive_methods_agree_with_fine_rk4():
    """The adaptive-step paths through simulate(): same trajectory as RK4 at a tiny step."""
    from adaptive_ftc import SolverOptions

    loop = replace(_pendulum_loop(Pendulum()), t_final=4.0)
    ref = simulate(loop, SolverOptions(method="rk4", dt=2e-4))
    for method in ("dopri5", "rodasp", "auto", "accurate"):
        r = simulate(loop, SolverOptions(method=method, rtol=1e-10, atol=1e-12))
        assert r.status == "completed"
        assert r.meta["steps"] > 0 and r.meta["rhs_evaluations"] > r.meta["steps"]
        np.testing.assert_allclose(r.states, ref.states, atol=2e-8, err_msg=method)
        np.testing.assert_allclose(r.adaptive, ref.adaptive, atol=2e-7, err_msg=method)


def test_ctrl_c_returns_the_partial_result_quickly():
    import signal
    import time

    code = (
        "import time, warnings\n"
        "from dataclasses import replace\n"
        "from adaptive_ftc import load_scenario, simulate, SolverOptions\n"
        "sc = load_scenario('wingrock-estimation-s1')\n"
        "opts = SolverOptions(dt=2e-5, record_dt=1.0)\n"
        # compile first, with the options of the interrupted run: the compiler runs inside the
        # interruptible call, so a Ctrl-C during compilation waits for it (seconds)
        "simulate(replace(sc.loop, t_final=0.01), opts)\n"
        "print('ready', flush=True)\n"
        "warnings.simplefilter('ignore')\n"
        "t = time.perf_counter()\n"
        "from adaptive_ftc import SimulationInterrupted\n"
        "try:\n"
        "    simulate(replace(sc.loop, t_final=5000.0), opts)\n"
        "except SimulationInterrupted as exc:\n"  # raised, with the partial result
        "    r = exc.result\n"
        "print(r.status, r.time[-1] < 5000, round(time.perf_counter() - t, 1), flush=True)\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "ready"
    time.sleep(1.0)
    sent = time.perf_counter()
    proc.send_signal(signal.SIGINT)
    out = proc.stdout.readline()  # the partial result is back (the interpreter exit is not timed)
    assert time.perf_counter() - sent < 5.0
    proc.communicate(timeout=60)
    status, partial, _ = out.split()
    assert (status, partial) == ("interrupted", "True")


def test_a_wrong_control_direction_is_reported_as_divergence_not_completed():
    """Regression (issue 11): a wrong sign used to end 'completed' with alpha at 3.18 rad."""
    from adaptive_ftc import DivergenceWarning

    sc = load_scenario("hypersonic-direct-s1")
    with pytest.warns(DivergenceWarning, match="envelope"):
        r = simulate(replace(sc.loop, allocation=(-1.0, -2.0)), sc.solver)
    assert r.status == "diverged"
    assert np.all(np.abs(r.states[:, 0]) <= math.pi / 2)


def test_simulate_refuses_a_run_that_cannot_fit_before_allocating():
    from adaptive_ftc import SolverOptions

    sc = load_scenario("hypersonic-direct-s1")
    with pytest.raises(ConfigurationError, match="steps"):
        simulate(replace(sc.loop, t_final=1e9), SolverOptions(dt=1e-3))


def test_failure_free_and_oracle_runs_share_the_compiled_code_of_their_loop():
    """The variants a reproduction runs per scenario cost no compilation of their own: the
    failure-free run keeps the failures' code (never acting), the oracle is the nominal
    inverse with one number changed."""
    from adaptive_ftc.baselines import baseline_loop

    sc = load_scenario("hypersonic-direct-s2")  # non-affine failures: shapes of their own
    loop = sc.loop
    assert any(
        type(f).__name__ not in ("LossOfEffectiveness", "Stuck") for f in loop.failures.failures
    )
    assert any(pt is not None for pt in generate(loop)[3]["patterns"])  # beyond a*u + b
    healthy = loop.without_failures()
    assert not healthy.failures.failures and healthy.dormant_failures
    assert source_of(healthy) == source_of(loop)
    nominal, oracle = (baseline_loop(loop, v) for v in ("nominal-inverse", "oracle"))
    assert source_of(oracle) == source_of(nominal)
    # ... and they still behave differently: a failure-free run is healthy throughout
    r = simulate(replace(healthy, t_final=1.0))
    assert r.failures == () and np.allclose(r.u_applied, r.u_cmd)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the rebinding is Linux-only")
def test_generated_code_calls_the_c_librarys_math_functions():
    # numba binds exp, sin, tanh... to wrappers of its helper library, which its Linux wheels
    # link to glibc's compatibility entry points; the loops call libm's own symbols instead
    import ctypes
    import ctypes.util

    import llvmlite.binding as ll

    simulate(replace(_pendulum_loop(Pendulum()), t_final=0.1))
    libm = ctypes.CDLL(ctypes.util.find_library("m"))
    for name in ("exp", "sin", "cos", "tanh", "pow"):
        assert ll.address_of_symbol(name) == ctypes.cast(getattr(libm, name), ctypes.c_void_p).value


def test_loops_compile_with_numba_profiling_on(tmp_path):
    # NUMBA_ENABLE_PROFILING (perf maps) turns on debug info, whose first-line finder failed
    # on the generated no-op ``jump`` (a docstring alone), reported as a plant index error
    code = "print(simulate(replace(sc.loop, t_final=0.1), sc.solver).status)\n"
    out = _in_a_new_process(code, tmp_path, NUMBA_ENABLE_PROFILING="1")
    assert out.split()[-1] == "completed"


def test_loops_compile_at_their_own_llvm_level_and_leave_numbas_setting_alone(tmp_path):
    # the generated loops compile at -O2 (as fast or faster on them, same numbers); numba's
    # process-wide setting is untouched for any other numba code
    code = (
        "import numba\n"
        "from numba.core import config, event\n"
        "seen = []\n"
        "class Spy(event.Listener):\n"
        "    def on_start(self, e):\n"
        "        seen.append((e.data['dispatcher'].py_func.__module__, int(config.OPT)))\n"
        "    def on_end(self, e):\n"
        "        pass\n"
        "with event.install_listener('numba:compile', Spy()):\n"
        "    simulate(replace(sc.loop, t_final=0.1), sc.solver)\n"
        "    numba.njit(lambda x: x + 1)(1.0)\n"
        "loops = {o for m, o in seen if m.startswith('adaptive_ftc_loop_')}\n"
        "user = {o for m, o in seen if m == '__main__'}\n"
        "print(sorted(loops), sorted(user), int(config.OPT))\n"
    )
    out = _in_a_new_process(code, tmp_path, NUMBA_OPT=None)
    assert out.split("\n")[-2] == "[2] [3] 3"


def _in_a_new_process(code: str, cache, **env) -> str:
    """Run ``code`` in a fresh interpreter with the free wing-rock scenario loaded as ``sc``
    (a small loop), an empty loop cache and ``env`` (``None``: variable unset); its stdout."""
    full = {**os.environ, "ADAPTIVE_FTC_CACHE_DIR": str(cache)}
    for key, value in env.items():
        if value is None:
            full.pop(key, None)
        else:
            full[key] = value
    head = (
        "from dataclasses import replace\n"
        "from adaptive_ftc import load_scenario, simulate\n"
        "sc = load_scenario('wingrock-free-1deg')\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", head + code], env=full, capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout


def test_is_compiled_needs_the_loop_and_the_shared_integrators(tmp_path):
    # `aftc simulate` says "compiling" when is_compiled() is False: a cached loop whose shared
    # integrators are not (yet, or any more) cached still compiles
    code = (
        "from adaptive_ftc.sim.compose import is_compiled\n"
        "print(is_compiled(sc.loop))\n"
        "simulate(replace(sc.loop, t_final=0.1), sc.solver)\n"
    )
    assert _in_a_new_process(code, tmp_path).split()[-1] == "False"
    check = "from adaptive_ftc.sim.compose import is_compiled\nprint(is_compiled(sc.loop))\n"
    assert _in_a_new_process(check, tmp_path).split()[-1] == "True"
    for index in (tmp_path / "loops" / "__pycache__").glob("integrators_*.nbi"):
        index.unlink()
    assert _in_a_new_process(check, tmp_path).split()[-1] == "False"


def test_the_generated_code_runs_in_python_with_numba_disabled(tmp_path):
    # NUMBA_DISABLE_JIT=1 steps through the generated modules in Python (a debugging aid): the
    # shared integrators then call the loop's Python functions for its addresses
    sc = load_scenario("hypersonic-direct-s1")
    loop = replace(sc.loop, t_final=0.05)
    ref = simulate(loop, sc.solver)
    code = (
        "sc = load_scenario('hypersonic-direct-s1')\n"
        "r = simulate(replace(sc.loop, t_final=0.05), sc.solver)\n"
        "print(r.status, repr(float(r.states[-1, 0])), repr(float(r.control_gain[-1])))\n"
    )
    status, alpha, gain = _in_a_new_process(code, tmp_path, NUMBA_DISABLE_JIT="1").split()[-3:]
    assert status == "completed"
    assert math.isclose(float(alpha), ref.states[-1, 0], rel_tol=1e-9, abs_tol=1e-15)
    assert ref.control_gain[-1] != 0.0
    assert math.isclose(float(gain), ref.control_gain[-1], rel_tol=1e-9)


def test_failure_patterns_compile_on_their_own_and_never_change_the_loops_structure():
    """A failure pattern that is not affine (of t alone, of the state, of u) is a small module
    of its own called through its address: loops that differ only in their failures share
    one compiled structure, and the patterns compute what they say."""
    from adaptive_ftc import NonAffine

    base = replace(load_scenario("hypersonic-direct-s1").loop, t_final=1.0)
    solver = SolverOptions(method="rk4", dt=1e-3, record_dt=0.01)
    affine = replace(
        base, failures=(LossOfEffectiveness(actuator=2, onset=0.2, effectiveness=0.5),)
    )
    of_time = replace(base, failures=(Stuck(actuator=2, onset=0.2, value="0.01 + 0.02*cos(3*t)"),))
    of_state = replace(
        base,
        failures=(NonAffine(actuator=1, onset=0.3, output="0.5*u - 0.25*u**3 + 0.1*alpha"),),
    )
    assert source_of(affine) == source_of(of_time) == source_of(of_state)
    simulate(affine, solver)  # the structure compiles (or loads) here
    before = codegen.stats()["compiled"]
    r_time, r_state = simulate(of_time, solver), simulate(of_state, solver)
    assert codegen.stats()["compiled"] == before  # only the patterns' own small modules
    # the applied outputs are the patterns evaluated independently at the recorded times
    t = r_time.time
    after = t > 0.2 - 1e-9  # the sample at the onset is failed
    np.testing.assert_allclose(
        r_time.u_applied[after, 1], 0.01 + 0.02 * np.cos(3 * t[after]), rtol=0, atol=1e-15
    )
    u, alpha = r_state.u_cmd[:, 0], r_state.states[:, 0]
    after = r_state.time > 0.3 - 1e-9
    expected = 0.5 * u - 0.25 * u**3 + 0.1 * alpha
    np.testing.assert_allclose(r_state.u_applied[after, 0], expected[after], rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(r_state.u_applied[~after, 0], u[~after], rtol=0, atol=0)
    # the slope enters the recorded control gain: 0.5 - 0.75 u^2 times the healthy gain
    healthy = simulate(replace(of_state, failures=()), solver)
    assert not np.allclose(r_state.control_gain[after], healthy.control_gain[after])


def test_a_failure_pattern_call_refuses_other_argument_types_at_compile_time():
    import numba

    from adaptive_ftc.sim.fptr import call_pattern

    @numba.njit
    def strided(ptr, x):
        return call_pattern(ptr, 0.0, x[::2], 0.0, x, 0)

    with pytest.raises(numba.core.errors.TypingError, match="failure pattern through an address"):
        strided(0, np.zeros(10))


def test_designs_on_one_plant_share_the_plants_compiled_control_gain():
    """The recorded control gain needs the plant's equations, not the design's: it is compiled
    once per plant, whatever the design, and gives the gain of each loop's own allocation."""
    from adaptive_ftc.sim.compose import generate

    direct = replace(load_scenario("hypersonic-direct-s1").loop, t_final=0.5)
    nussbaum = replace(load_scenario("hypersonic-nussbaum-s1-pos").loop, t_final=0.5)
    assert generate(direct)[3]["gain"][0] == generate(nussbaum)[3]["gain"][0]
    a, b = assemble(direct), assemble(nussbaum)
    assert a.data.i[12] == b.data.i[12]  # I_GAIN: one compiled function
    # against an independent computation: sum_j b_j R_j df_j/du from the plant's own input
    # gains (numpy) along each loop's allocation, at the recorded states (healthy here)
    for loop in (direct, nussbaum):
        r = simulate(loop, SolverOptions(method="rk4", dt=1e-3, record_dt=0.1))
        for n in (0, 3):
            x = r.states[n]
            g = loop.plant.input_gains(float(r.time[n]), x)[0]
            expected = float(np.dot(g, np.asarray(loop.R)[0]))
            assert math.isclose(r.control_gain[n], expected, rel_tol=1e-9, abs_tol=1e-12)
