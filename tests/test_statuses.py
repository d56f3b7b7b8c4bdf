"""Run statuses that say what happened (issue 26): a RunStatus with a StatusReason, the message
built from the reason, Ctrl-C raised from simulate(), and `aftc run` reporting a run with no
samples. Each case is a run whose cause is known by construction (the expression that goes
non-finite, the time it does, the bound that is crossed)."""

from __future__ import annotations

import _thread
import math
import threading
import warnings
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc import (
    DivergenceWarning,
    RunStatus,
    SimulationInterrupted,
    SolverOptions,
    StatusReason,
    load_scenario,
    simulate,
)
from adaptive_ftc.cli import main

BASE = 'extends = "hypersonic-direct-s1"\nname = "{name}"\nduration = {duration}\nclaims = []\n'


def _scenario(tmp_path, name, body, duration=6.0):
    path = tmp_path / f"{name}.toml"
    path.write_text(BASE.format(name=name, duration=duration) + body)
    return load_scenario(path)


def _stuck(value, onset=0.5):
    return f'[[failures]]\nactuator = 2\nmodel = "stuck"\nonset = {onset}\nvalue = "{value}"\n'


def _run(sc, solver=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        return simulate(sc.loop, solver or sc.solver)


def test_run_status_is_a_str_enum_exported_with_its_reason():
    import adaptive_ftc

    assert {"RunStatus", "StatusReason", "SimulationInterrupted"} <= set(adaptive_ftc.__all__)
    assert RunStatus.DIVERGED == "diverged" and f"{RunStatus.NONFINITE}" == "nonfinite"
    assert repr(RunStatus.COMPLETED) == "'completed'"  # printed as before the enum
    assert {s.value for s in RunStatus} == {
        "completed",
        "diverged",
        "nonfinite",
        "step_underflow",
        "singular",
        "interrupted",
        "invalid",
    }
    with pytest.raises(AttributeError):  # frozen
        StatusReason(time=1.0).time = 2.0  # type: ignore[misc]


@pytest.mark.parametrize(
    ("value", "t_bad"),
    [("sqrt(5-t)", 5.0), ("log(t-1)", 0.5), ("1/(t-3)", 3.0)],
)
def test_a_non_finite_failure_pattern_is_nonfinite_naming_it_without_stiffness_advice(
    tmp_path, value, t_bad
):
    """Regression: dopri5 rejects every step once the pattern is NaN/inf and used to report a
    step-size underflow with "too stiff: try rodasp"."""
    sc = _scenario(tmp_path, "bad-pattern", _stuck(value))
    r = _run(sc)
    assert r.status == RunStatus.NONFINITE, r.message
    assert r.reason.expression == value
    assert "actuator 2" in r.reason.source
    assert r.reason.time == pytest.approx(t_bad, abs=1e-6)  # when it first went non-finite
    assert r.reason.advice == "" and "rodasp" not in r.message and "stiff" not in r.message
    assert value in r.message and f"t = {t_bad:g} s" in r.message
    assert r.time[-1] <= t_bad + 1e-9


def test_a_fixed_step_run_names_the_pattern_too(tmp_path):
    sc = _scenario(tmp_path, "bad-pattern-rk4", _stuck("sqrt(5-t)"))
    r = _run(sc, SolverOptions(method="rk4", dt=1e-3))
    assert r.status == RunStatus.NONFINITE and r.reason.expression == "sqrt(5-t)"
    assert r.reason.time == pytest.approx(5.0, abs=1e-3)


def test_a_non_finite_reference_derivative_is_named(tmp_path):
    sc = _scenario(tmp_path, "bad-ref", '[reference]\noutputs = ["0.05*sqrt(abs(t-2))"]\n')
    r = _run(sc)
    assert r.status == RunStatus.NONFINITE, r.message
    assert r.reason.expression == "0.05*sqrt(abs(t-2))"
    assert "reference of output 'alpha'" in r.reason.source and "derivative" in r.reason.source
    assert r.reason.time == pytest.approx(2.0, abs=1e-6)
    assert "rodasp" not in r.message


def test_a_blow_up_is_diverged_with_signal_bound_and_time_and_no_stiffness_advice(tmp_path):
    """gamma = 1e9 under fixed-step RK4: theta explodes past the divergence bound at once."""
    sc = _scenario(tmp_path, "gamma", "[controller]\ngamma = 1e9\n")
    solver = SolverOptions(method="rk4", dt=1e-3)
    r = _run(sc, solver)
    assert r.status == RunStatus.DIVERGED
    assert r.reason.signal.startswith("theta") and r.reason.bound == solver.divergence_bound
    assert abs(r.reason.value) >= solver.divergence_bound and not r.reason.envelope
    assert r.reason.time == pytest.approx(1e-3)
    assert "rodasp" not in r.message and "divergence bound" in r.message


def test_a_real_step_underflow_keeps_the_stiffness_advice():
    """The diagnosis finds no non-finite expression or derivative at a healthy state: the
    integrator's step-size underflow (code 2) stands, with the advice (and only there)."""
    from adaptive_ftc.sim.compose import assemble
    from adaptive_ftc.sim.diagnose import STIFF_ADVICE, stop_outcome

    sc = load_scenario("hypersonic-direct-s1")
    asm = assemble(sc.loop, sdot="exact")
    y = asm.y0.copy()
    status, reason = stop_outcome(
        sc.loop, asm, sc.solver, code=2, t_stop=1.5, bad=-1, y_stop=y, t_prev=1.49, y_prev=y
    )
    assert status == RunStatus.STEP_UNDERFLOW
    assert reason.advice == STIFF_ADVICE and reason.time == 1.5 and reason.method == "dopri5"
    # the same integrator code with a NaN state and no culprit expression: a non-finite signal
    bad = y.copy()
    bad[3] = math.nan
    status, reason = stop_outcome(
        sc.loop, asm, sc.solver, code=1, t_stop=1.5, bad=3, y_stop=bad, t_prev=1.49, y_prev=y
    )
    assert status == RunStatus.NONFINITE and reason.advice == ""
    assert reason.signal == asm.adaptive_names[1]


def test_a_plant_equation_dividing_by_zero_mid_run_is_singular_naming_equation_and_state(
    tmp_path,
):
    path = tmp_path / "sing.toml"
    path.write_text(
        'name = "sing"\nduration = 4.0\n[plant]\nmodel = "equations"\nname = "clocked"\n'
        'states = ["z", "w", "p"]\noutputs = { z = "w" }\nactuators = ["T1", "T2"]\n'
        "initial_state = [0.0, 0.0, 0.0]\n[plant.dynamics]\n"
        'z = "w"\nw = "T1 + T2 - w + 0.01/(p - 2)"\np = "1"\n'
        '[reference]\noutputs = ["0.1*sin(t)"]\n[controller]\ndesign = "direct"\n'
        "allocation = [1.0, 1.0]\nlam = 2.0\nk = 3.0\nk0 = 0.5\neps0 = 0.01\ngamma = 20.0\n"
        'sigma = 0.001\n[controller.regressor]\ntype = "linear"\ninputs = ["e", "edot"]\n'
        '[solver]\nmethod = "dopri5"\nrtol = 1e-6\natol = 1e-9\n'
    )
    r = _run(load_scenario(path))
    assert r.status == RunStatus.SINGULAR, r.message
    assert r.reason.signal == "w" and r.reason.expression == "T1 + T2 - w + 0.01/(p - 2)"
    assert "p = 2" in r.reason.states
    assert r.reason.time == pytest.approx(2.0, abs=1e-6)
    assert "rodasp" not in r.message and "equation of w'" in r.message


def test_divergence_bound_crossed_at_t0_is_reported_not_plotted(tmp_path, capsys, monkeypatch):
    """Regression: alpha(0) = 0.03 over a bound of 1e-6 was called 'left the plant's envelope
    |alpha| <= 1.571' and `aftc run` died with an internal error plotting no samples. The
    loader now refuses such a bound in a file, so the run gets it from a patched simulate():
    a run with no samples must still be reported (exit 3), not plotted."""
    from adaptive_ftc.sim import engine

    sc = load_scenario("hypersonic-direct-s1")
    r = _run(replace(sc, solver=replace(sc.solver, divergence_bound=1e-6)))
    assert r.status == RunStatus.DIVERGED and r.time.size == 0
    assert r.reason.signal == "alpha" and r.reason.bound == 1e-6 and r.reason.time == 0.0
    assert r.reason.value == pytest.approx(0.03) and not r.reason.envelope
    assert "envelope" not in r.message and "1e-06" in r.message
    real = engine.simulate
    monkeypatch.setattr(
        engine, "simulate", lambda loop, solver: real(loop, replace(solver, divergence_bound=1e-6))
    )
    src = tmp_path / "short.toml"
    src.write_text(BASE.format(name="short", duration=2.0))
    out = tmp_path / "out"
    code = main(["run", str(src), "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert code == 3, err
    assert "internal error" not in err and "before the first sample" in err
    assert "divergence bound 1e-06" in err
    assert not list(out.glob("figures/*")) and not list(out.glob("data/*"))


def test_the_envelope_still_reports_diverged_with_its_bound(tmp_path):
    sc = _scenario(tmp_path, "wrong-sign", "[controller]\nallocation = [-1.0, -2.0]\n", 20.0)
    r = _run(sc)
    assert r.status == RunStatus.DIVERGED and r.reason.envelope
    assert r.reason.signal == "alpha" and r.reason.bound == pytest.approx(math.pi / 2)
    assert "envelope" in r.message


@pytest.mark.parametrize("output", ["sqrt(u**2)", "abs(u)**0.5"])
def test_a_kinked_pattern_at_u_0_records_a_finite_control_gain(tmp_path, output):
    """Regression: an actuator with no allocation (u = 0 throughout) under a pattern whose
    derivative is undefined at 0 recorded NaN as the control gain on every sample. The slope
    there is the central difference (0 for these symmetric kinks), so the gain is the healthy
    actuator's alone: the same as with actuator 1 healthy."""
    body = (
        "[controller]\nallocation = [0.0, 1.0]\n[[failures]]\nactuator = 1\n"
        f'model = "nonaffine"\nonset = 0.0\noutput = "{output}"\n'
    )
    sc = _scenario(tmp_path, "kink", body, 2.0)
    r = _run(sc)
    assert r.status == RunStatus.COMPLETED
    assert np.all(np.isfinite(r.control_gain))
    healthy = _run(replace(sc, loop=sc.loop.without_failures()))
    np.testing.assert_allclose(r.control_gain, healthy.control_gain, rtol=1e-12)


def test_status_and_reason_round_trip_through_netcdf(tmp_path):
    from adaptive_ftc import SimResult

    sc = _scenario(tmp_path, "nc", _stuck("sqrt(5-t)"))
    r = _run(sc)
    back = SimResult.from_netcdf(r.to_netcdf(tmp_path / "r.nc"))
    assert back.status is RunStatus.NONFINITE
    assert repr(back.reason) == repr(r.reason)  # repr: the value is nan (nan != nan)
    assert back.message == r.message


def test_campaign_row_takes_time_and_culprit_from_the_reason(tmp_path):
    from adaptive_ftc.campaigns.runner import outcome

    sc = _scenario(tmp_path, "row", _stuck("log(t-1)"))
    r = _run(sc)
    spec = type(
        "Spec",
        (),
        {"final_window": 1.0, "recovery_tolerance": 0.1, "success_rms": 1, "activity": None},
    )  # activity None: the spec does not judge control activity
    row = outcome(r, spec())
    assert row["status"] == "nonfinite" and type(row["status"]) is str
    assert row["divergence_time"] == pytest.approx(0.5, abs=1e-6)
    assert row["divergence_signal"] == "log(t-1)"


def _interrupt_after(seconds):
    timer = threading.Timer(seconds, _thread.interrupt_main)
    timer.start()
    return timer


def test_ctrl_c_in_simulate_raises_with_the_partial_result():
    """Regression: simulate() swallowed Ctrl-C and returned status 'interrupted' with a
    DivergenceWarning (hidden by a warnings filter): a loop over simulate() could not be
    stopped."""
    sc = load_scenario("wingrock-estimation-s1")
    opts = SolverOptions(dt=2e-5, record_dt=1.0)
    simulate(replace(sc.loop, t_final=0.01), opts)  # compile outside the timed part
    timer = _interrupt_after(1.0)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", DivergenceWarning)  # no warning instead of raising
            with pytest.raises(SimulationInterrupted) as info:
                simulate(replace(sc.loop, t_final=5000.0), opts)
    finally:
        timer.cancel()
    assert isinstance(info.value, KeyboardInterrupt)
    partial = info.value.result
    assert partial.status == RunStatus.INTERRUPTED and 0 < partial.time[-1] < 5000.0
    assert partial.reason.time is not None and "Interrupted" in partial.message


def test_ctrl_c_during_aftc_run_exits_130(tmp_path, capsys):
    src = tmp_path / "long.toml"
    src.write_text(BASE.format(name="long", duration=1e4))
    load_scenario(src).run(solver=SolverOptions(method="dopri5", rtol=1e-6, atol=1e-9))
    out = tmp_path / "out"
    # warm, this 1e4 s run takes about 2 s end to end since session 11's lean paths (the timer
    # at 2 s raced it): the interrupt comes at 0.5 s, inside the run or its setup (both 130)
    timer = _interrupt_after(0.5)
    try:
        code = main(["run", str(src), "--out", str(out), "--quiet", "--no-baselines"])
    finally:
        timer.cancel()
    assert code == 130
    assert "interrupted" in capsys.readouterr().err
    assert not list(out.glob("data/*"))


def test_report_cell_says_where_and_what_stopped_the_run(tmp_path):
    from adaptive_ftc.reproduce import _short_status

    r = _run(_scenario(tmp_path, "cell", _stuck("sqrt(5-t)")))
    assert _short_status(r) == "nonfinite at t = 5 s ('sqrt(5-t)')"
    ok = _run(_scenario(tmp_path, "ok", "", 1.0))
    assert _short_status(ok) == "completed"


def test_simulation_interrupted_pickles_with_its_result_and_message():
    import pickle

    exc = pickle.loads(
        pickle.dumps(SimulationInterrupted({"partial": 1}, "Interrupted at t = 2 s"))
    )
    assert isinstance(exc, KeyboardInterrupt)
    assert exc.result == {"partial": 1} and str(exc) == "Interrupted at t = 2 s"


def test_ctrl_c_while_a_data_file_is_written_waits_for_the_write(tmp_path, monkeypatch):
    """Regression: Ctrl-C arriving while ``to_netcdf`` wrote (``aftc run``'s writing phase)
    raised inside HDF5 with xarray's file lock held, and closing the file then hung forever.
    The interrupt now waits for the write and is raised right after it: the file is whole and
    the next write does not block."""
    from adaptive_ftc.sim import ncwrite  # the writer (xarray's file, without xarray: issue 29)

    r = _run(_scenario(tmp_path, "w", "", 1.0))
    write = ncwrite.write

    def interrupted_write(*args, **kwargs):
        _thread.interrupt_main()  # Ctrl-C in the middle of the write
        return write(*args, **kwargs)

    monkeypatch.setattr(ncwrite, "write", interrupted_write)
    with pytest.raises(KeyboardInterrupt):
        r.to_netcdf(tmp_path / "a.nc")
    monkeypatch.setattr(ncwrite, "write", write)
    from adaptive_ftc import SimResult

    back = SimResult.from_netcdf(tmp_path / "a.nc")  # complete, and the lock was released
    assert back.time.size == r.time.size
    r.to_netcdf(tmp_path / "b.nc")
