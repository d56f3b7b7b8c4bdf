"""A first run compiles each integrator helper once: no second copy for a literal argument.

numba types a variable assigned a literal ``0`` as ``Literal[int](0)`` where it is first
passed to a compiled (not inlined) function, and compiles that function for it as well as for
``int64``: the adaptive integrators' step loop (``_steps_dopri5``) was compiled twice on every
first run, about 2 s of CPU (benchmarks/bench_compile_events.py). Checked in a fresh process
with empty caches (the code must compile here, not load from disk).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"

_CHILD = """
import collections, json
from dataclasses import replace
from numba.core import event

counts = collections.Counter()

class _Count(event.Listener):
    def on_start(self, ev):
        counts[ev.data["dispatcher"].py_func.__name__] += 1

    def on_end(self, ev):
        pass

event.register("numba:compile", _Count())
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim.engine import simulate

sc = load_scenario("hypersonic-direct-s1")
res = simulate(replace(sc.loop, t_final=1.0), replace(sc.solver, method="dopri5"))
assert res.status == "completed", res.status
print("COUNTS " + json.dumps(counts))
"""


def test_adaptive_step_loop_compiles_once(tmp_path: Path) -> None:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(SRC), env.get("PYTHONPATH", "")])
    env["ADAPTIVE_FTC_CACHE_DIR"] = str(tmp_path / "loops")
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "numba")
    env.pop("NUMBA_DISABLE_JIT", None)
    out = subprocess.run(
        [sys.executable, "-c", _CHILD], env=env, capture_output=True, text=True, check=True
    ).stdout
    counts = json.loads(out.split("COUNTS ", 1)[1])
    assert counts["_steps_dopri5"] == 1, counts
    assert counts["_records_at"] == 1, counts
