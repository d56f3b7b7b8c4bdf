"""A first run compiles on two cores: the shared integrators in a forked child, the structures
in the parent (sim/precompile.py), and the runs then compile nothing and compute what a serial
first run computes.

Checked in a fresh process with empty caches (the code must compile there, not load from
disk): numba's compile events of the parent and of the child, one function a line, and the
runs' numbers against the same runs in this process (compiled the usual way, one after
another).
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"

_CHILD = """
import hashlib, json, os, sys
from dataclasses import replace
from numba.core import event

LOG = sys.argv[1]

class _Log(event.Listener):
    def on_start(self, ev):
        pass

    def on_end(self, ev):
        fn = ev.data["dispatcher"].py_func
        where = fn.__module__  # a generated module: adaptive_ftc_<kind>_<key>; keep the kind
        if where.startswith("adaptive_ftc_"):
            where = where.rsplit("_", 1)[0]
        with open(LOG, "a") as f:
            f.write(f"{os.getpid()} {where}.{fn.__qualname__}\\n")

event.register("numba:compile", _Log())
from adaptive_ftc.baselines import nominal_inverse
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim import precompile
from adaptive_ftc.sim.engine import simulate

sc = load_scenario("hypersonic-direct-s1")
loop = replace(sc.loop, t_final=2.0)
jobs = [
    (loop, sc.solver),
    (nominal_inverse(loop), sc.solver),
    (loop.frozen(), replace(sc.solver, method="rk4", dt=1e-3)),
]
used = precompile.overlapped(jobs)
with open(LOG, "a") as f:
    f.write(f"{os.getpid()} --runs--\\n")
digests = []
for lp, solver in jobs:
    res = simulate(lp, solver)
    h = hashlib.sha256(res.states.tobytes())
    h.update(res.u_applied.tobytes())
    h.update(json.dumps(res.metrics(), sort_keys=True, default=float).encode())
    digests.append(h.hexdigest())
print("RESULT " + json.dumps({"used": used, "pid": os.getpid(), "digests": digests}))
"""


def _jobs():
    from adaptive_ftc.baselines import nominal_inverse
    from adaptive_ftc.scenarios.loader import load_scenario

    sc = load_scenario("hypersonic-direct-s1")
    loop = replace(sc.loop, t_final=2.0)
    return [
        (loop, sc.solver),
        (nominal_inverse(loop), sc.solver),
        (loop.frozen(), replace(sc.solver, method="rk4", dt=1e-3)),
    ]


def _digest(res) -> str:
    h = hashlib.sha256(res.states.tobytes())
    h.update(res.u_applied.tobytes())
    h.update(json.dumps(res.metrics(), sort_keys=True, default=float).encode())
    return h.hexdigest()


@pytest.fixture(scope="module")
def cold(tmp_path_factory) -> tuple[dict, list[tuple[int, str]]]:
    """The child's result and its compile log ``(pid, function)``: one fresh process with
    empty caches (compiling takes a while)."""
    from adaptive_ftc._figure_process import _usable_cpus

    if not sys.platform.startswith("linux") or _usable_cpus() < 2:
        pytest.skip("no second process here (not Linux, or a single usable CPU)")
    tmp = tmp_path_factory.mktemp("precompile")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(SRC), env.get("PYTHONPATH", "")])
    env["ADAPTIVE_FTC_CACHE_DIR"] = str(tmp / "loops")
    env["NUMBA_CACHE_DIR"] = str(tmp / "numba")
    env.pop("NUMBA_DISABLE_JIT", None)
    log = tmp / "compiles.log"
    done = subprocess.run(
        [sys.executable, "-c", _CHILD, str(log)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    line = next(ln for ln in done.stdout.splitlines() if ln.startswith("RESULT "))
    events = []
    for row in log.read_text().splitlines():
        pid, name = row.split(" ", 1)
        events.append((int(pid), name))
    return json.loads(line[len("RESULT ") :]), events


def test_the_integrators_compile_in_a_second_process_beside_the_structures(cold):
    result, events = cold
    assert result["used"]
    parent = result["pid"]
    child = {pid for pid, _ in events} - {parent}
    assert len(child) == 1, events  # one forked child
    (child_pid,) = child
    by: dict[str, set[int]] = {}
    for pid, where in events:
        by.setdefault(where, set()).add(pid)
    shared = "adaptive_ftc_integrators."
    # the integrators of both methods and the low-pass filter in the child...
    for name in ("integrate_dopri5", "_steps_dopri5", "integrate_rk4"):
        assert by.get(shared + name) == {child_pid}, (name, events)
    assert by.get("adaptive_ftc_lowpass.filtfilt_odd") == {child_pid}, events
    # ...the loops' own code (both structures), the plant's gain and the record pass here
    assert by.get("adaptive_ftc_loop.rhs") == {parent}, events
    assert by.get("adaptive_ftc_gain.control_gain") == {parent}, events
    assert by.get(shared + "signals") == {parent}, events


def test_after_the_overlap_the_runs_compile_nothing(cold):
    result, events = cold
    parent = result["pid"]
    mark = events.index((parent, "--runs--"))
    assert [e for e in events[mark + 1 :] if e[0] == parent] == [], events[mark:]


def test_nothing_compiles_twice(cold):
    """Each of the package's functions compiles once in all (numba's own overloads, such as
    ``np.empty``'s implementation, compile once per library that calls them), but a loop's
    ``rhs``: once per structure (the scenario's loop, shared with its frozen copy, and the
    nominal inverse)."""
    _, events = cold
    counts: dict[str, int] = {}
    for _, where in events:
        if where.startswith("adaptive_ftc"):
            counts[where] = counts.get(where, 0) + 1
    assert counts.pop("adaptive_ftc_loop.rhs") == 2, counts
    assert {k: v for k, v in counts.items() if v > 1} == {}, counts


def test_the_runs_compute_what_a_serial_first_run_computes(cold):
    """The same runs in this process, their code compiled the usual way (on first use, one
    after another), give the same numbers bit for bit."""
    from adaptive_ftc.sim.engine import simulate

    result, _ = cold
    here = [_digest(simulate(loop, solver)) for loop, solver in _jobs()]
    assert result["digests"] == here


def test_the_signatures_are_those_the_runs_compile(tmp_path):
    """:func:`shared_signatures` gives the argument types of the integrators and of
    ``signals`` as ``simulate`` passes them (else the child's work would be for nothing):
    checked on the compiled functions' own signatures in this process."""
    from adaptive_ftc.sim.compose import integrators
    from adaptive_ftc.sim.engine import simulate
    from adaptive_ftc.sim.precompile import shared_signatures

    module = integrators()
    for loop, solver in _jobs():
        simulate(loop, solver)
        for name, sig in shared_signatures(loop, solver):
            assert sig in getattr(module, name).signatures, (name, sig)


def test_the_lowpass_signature_is_the_one_the_metrics_compile():
    from adaptive_ftc.sim.engine import simulate
    from adaptive_ftc.sim.precompile import compile_lowpass
    from adaptive_ftc.sim.zerophase import _kernel

    loop, solver = _jobs()[0]
    simulate(loop, solver)  # a run's activity metrics filter its commands' columns
    assert _kernel().signatures
    before = set(_kernel().signatures)
    assert compile_lowpass() == 0  # found compiled: the same types
    assert set(_kernel().signatures) == before


def test_aftc_run_compiles_first_only_when_something_is_new(tmp_path, monkeypatch):
    """``aftc run`` hands every run's loop (the fair baselines' exact inverses included) to
    the overlap before its first run, and skips it when everything is compiled."""
    from adaptive_ftc import cli
    from adaptive_ftc.sim import compose, precompile

    calls: list[list] = []
    monkeypatch.setattr(precompile, "overlapped", lambda jobs: calls.append(list(jobs)))
    src = tmp_path / "short.toml"
    src.write_text('extends = "hypersonic-direct-s1"\nname = "short"\nduration = 2.0\n')
    base = ["run", str(src), "--no-figures", "--quiet"]
    assert cli.main([*base, "--out", str(tmp_path / "a")]) == 0  # compiles, or finds it all
    calls.clear()
    assert cli.main([*base, "--out", str(tmp_path / "b")]) == 0
    assert calls == []  # everything compiled: nothing to overlap
    monkeypatch.setattr(compose, "is_compiled", lambda loop, sdot="exact": False)
    assert cli.main([*base, "--out", str(tmp_path / "c")]) == 0
    (jobs,) = calls
    designs = {loop.controller.design for loop, _ in jobs}
    assert {"nominal-inverse", "oracle"} <= designs and len(designs) >= 3, designs
    assert {loop.name for loop, _ in jobs} >= {"short"}


def test_numba_writes_its_typing_messages_without_colorama():
    """numba writes a message for every overload it rejects while typing (15,091 on a first
    ``aftc run hypersonic-direct-s1``); with colorama installed each piece went through
    colorama's terminal set-up (0.6-0.8 s of CPU): after the first loop loads, plain text."""
    pytest.importorskip("colorama")
    import numba
    from numba.core import errors

    from adaptive_ftc.sim import codegen

    if numba.config.COLOR_SCHEME != "no_color":
        pytest.skip("a colour scheme was chosen (NUMBA_COLOR_SCHEME): left as it is")
    codegen._plain_typing_errors()
    scheme = errors.termcolor()
    assert scheme.errmsg("no match") == "no match"
    assert scheme.filename("f.py") == "f.py"


def test_is_cached_sees_a_module_compiled_after_it_last_looked(tmp_path, monkeypatch):
    """``is_cached`` lists a cache folder once and again only when the folder changed (a
    glob per question cost 17 ms in a folder of 22,675 files): a file numba writes later is
    seen."""
    from adaptive_ftc.sim import codegen

    monkeypatch.setenv("ADAPTIVE_FTC_CACHE_DIR", str(tmp_path / "cache"))
    folder = codegen.cache_dir()
    assert folder is not None and folder.parent == tmp_path / "cache"
    (folder / "__pycache__").mkdir()
    source = "# a module nobody compiled\nx = 1\n"
    assert not codegen.is_cached(source, [])
    assert not codegen.is_cached(source, [])  # the listing kept
    key = codegen._key(source, [])
    (folder / "__pycache__" / f"loop_{key}.f-2.py311.nbi").write_bytes(b"")
    assert codegen.is_cached(source, [])
    assert not codegen.is_cached(source, [], kind="gain")


def test_a_loop_that_cannot_be_built_is_left_to_its_run():
    """The compiles before the runs skip what cannot be built or compiled: the run itself then
    reports it, with the loop's name (sim/compile_errors.py), not the overlap."""
    from adaptive_ftc.sim.engine import SolverOptions
    from adaptive_ftc.sim.precompile import compile_shared, compile_structures

    broken = object()  # no closed loop at all
    compile_structures([(broken, SolverOptions())])
    assert compile_shared([(broken, SolverOptions())]) == 0
