"""Campaign throughput (issue 29, session 13): what a campaign's members share is found or
allocated once, with the same numbers as computed afresh for each member.

- the facts of a record grid (``reduce.grid_spacing``, ``reduce.nondecreasing``) are
  remembered per grid, bit for bit, and follow an array whose times change;
- the record times are the same numbers as ``t0 + dt * np.arange(n + 1)``, found once per
  grid and copied into a block of the pool, as are a run's phases and its result's times;
- the activity's low-pass builds scipy's odd extension itself: scipy's numbers bit for bit;
- a campaign chunk's rows equal, every column, the rows computed without any of it.
"""

from __future__ import annotations

import gc

import numpy as np
import pytest

from adaptive_ftc.sim import reduce
from adaptive_ftc.sim.engine import _record_times


@pytest.fixture
def fresh_memo():
    with reduce._memo_lock:
        saved_memo, saved_seen = list(reduce._memo), dict(reduce._seen)
        reduce._memo.clear()
        reduce._seen.clear()
    yield
    with reduce._memo_lock:
        reduce._memo[:] = saved_memo
        reduce._seen.clear()
        reduce._seen.update(saved_seen)


def _counting(monkeypatch, name):
    calls = []
    kernel = getattr(reduce, name)

    def counted(t):
        calls.append(t.size)
        return kernel(t)

    monkeypatch.setattr(reduce, name, counted)
    return calls


def test_a_shared_grid_is_reduced_once_with_the_same_facts(fresh_memo, monkeypatch):
    grid = _record_times(0.0, 120.0, 1e-3)  # a campaign member's record times
    truth = reduce._grid_spacing(grid.copy())
    assert truth[0] == 0  # uniform: the common case
    spacing = _counting(monkeypatch, "_grid_spacing")
    order = _counting(monkeypatch, "_nondecreasing")
    for _ in range(5):  # five members: each result holds its own copy of the times
        t = grid.copy()
        kind, dt = reduce.grid_spacing(t)
        assert (kind, dt) == (int(truth[0]), float(truth[1]))
        assert np.float64(dt).tobytes() == np.float64(truth[1]).tobytes()
        assert reduce.nondecreasing(t) is True
    # found at most on the first two sightings (the second remembers the grid), then never
    assert 1 <= len(spacing) <= 2
    assert 1 <= len(order) <= 2


def test_the_facts_follow_the_times_not_the_array(fresh_memo):
    grid = _record_times(0.0, 60.0, 1e-3)
    for _ in range(3):
        assert reduce.grid_spacing(grid) == (0, reduce.grid_spacing(grid.copy())[1])
    # the same array changed in place: its facts are found again, not the remembered ones
    grid[100] += 0.5e-3
    kind, dt = reduce._grid_spacing(grid.copy())
    assert kind == 2
    assert reduce.grid_spacing(grid) == (2, float(dt))
    grid[200] = grid[199] - 1.0  # decreasing
    assert reduce.nondecreasing(grid) is False
    assert reduce.nondecreasing(grid.copy()) is False


def test_a_diverged_members_shorter_grid_is_not_kept(fresh_memo, monkeypatch):
    grid = _record_times(0.0, 120.0, 1e-3)
    kernel = reduce._grid_spacing
    spacing = _counting(monkeypatch, "_grid_spacing")
    for cut in (50_000, 61_234, 99_999):  # runs that stopped at different records
        t = grid[:cut].copy()
        kind, dt = kernel(t.copy())
        assert reduce.grid_spacing(t) == (int(kind), float(dt))
    assert len(spacing) == 3
    assert not reduce._memo  # each seen once: nothing remembered
    short = grid[:100].copy()  # below MEMO_MIN_ROWS: never remembered
    for _ in range(3):
        reduce.grid_spacing(short)
    assert not reduce._memo


@pytest.mark.parametrize(
    ("t0", "t1", "dt"),
    [(0.0, 120.0, 1e-3), (0.0, 120.0, 0.01), (-3.7, 41.3, 1e-3), (2.5, 7.0, 0.3), (0.0, 1.0, 0.1)],
)
def test_record_times_are_the_grid_t0_plus_k_dt(t0, t1, dt):
    import math

    t = _record_times(t0, t1, dt)
    n = int(math.floor((t1 - t0) / dt + 1e-9))
    grid = t0 + dt * np.arange(n + 1)  # the formula the engine always used
    if t1 - grid[-1] > 1e-9 * max(1.0, abs(t1)):
        grid = np.append(grid, t1)
    assert t.dtype == np.float64 and t.flags.c_contiguous and t.flags.writeable
    assert t.tobytes() == grid.tobytes()


@pytest.mark.parametrize(("n", "pad"), [(30_001, 10_000), (5000, 3000), (400, 399), (100, 27)])
def test_the_lowpass_of_strided_command_columns_is_scipys_bit_for_bit(n, pad):
    """The activity's low-pass reads the commands as strided columns of a lean signal block
    (``e``, ``u_cmd``, ``u_applied`` side by side) and builds the odd extension itself: scipy's
    ``sosfiltfilt`` of the same columns, bit for bit."""
    from scipy.signal import sosfiltfilt

    from adaptive_ftc.sim import zerophase

    rng = np.random.default_rng(n + pad)
    block = np.cumsum(rng.standard_normal((n, 5)), axis=0) * 1e-3
    block += 1e-2 * rng.standard_normal((n, 5))
    sos, zi = zerophase.lowpass_design(4, 1.0, 1000.0)
    for u in (block[:, 1:3], block[:, 3:5], block[::-1, 1:4], block[:, :1]):
        assert not u.flags.c_contiguous or u.shape[1] == 1
        expected = sosfiltfilt(sos.copy(), u, axis=0, padtype="odd", padlen=pad)
        got = zerophase.sosfiltfilt_odd(sos, zi, u, pad)
        assert got.shape == expected.shape
        assert got.tobytes() == np.ascontiguousarray(expected).tobytes()


#: members of 12 s recorded every millisecond (the campaign's activity records): failures at
#: different times, recoveries, two members that diverge at different times (an elevator
#: stuck far out), so rows over full and cut grids
ROWS_SPEC = {
    "name": "reuse-rows",
    "base": "hypersonic-direct-s1",
    "designs": ["adaptive"],
    "runs": 8,
    "seed": 3,
    "chunk_size": 8,
    "duration": 12.0,
    "success": {"rms_error_final": 8.7e-4, "final_window": 4.0},
    "failures": {
        "count": {"integers": [1, 2]},
        "onset": {"uniform": [1.0, 8.0]},
        "recovery_probability": 0.3,
        "duration": {"uniform": [0.5, 3.0]},
        "models": {
            "loss_of_effectiveness": {"effectiveness": {"uniform": [0.1, 0.9]}},
            "bias": {"bias": {"uniform": [-0.3, 0.3]}},
            "stuck": {"value": {"uniform": [-60.0, 60.0]}},
        },
    },
}


def _same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return np.float64(a).tobytes() == np.float64(b).tobytes()
    return type(a) is type(b) and a == b


def test_results_rows_equal_the_rows_without_the_reuse(monkeypatch, fresh_memo):
    """Every column of a campaign chunk's rows, with the remembered grid facts and the compiled
    low-pass, equals the rows computed with neither (no memo; scipy's own sosfiltfilt)."""
    import warnings

    from scipy.signal import sosfiltfilt

    from adaptive_ftc.campaigns import load_campaign, run_chunk
    from adaptive_ftc.errors import DivergenceWarning
    from adaptive_ftc.sim import zerophase

    spec = load_campaign(ROWS_SPEC)
    assert spec.solver.record_dt == 1e-3
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        rows = run_chunk(spec, 0, jobs=1, lanes=False)
        assert reduce._memo  # the members' shared grid was remembered
        scipy_calls = []

        def scipys(sos, zi, u, pad):
            scipy_calls.append(pad)
            return sosfiltfilt(np.array(sos), u, axis=0, padtype="odd", padlen=pad)

        monkeypatch.setattr(zerophase, "sosfiltfilt_odd", scipys)
        monkeypatch.setattr(reduce, "MEMO_MIN_ROWS", 10**12)
        with reduce._memo_lock:
            reduce._memo.clear()
            reduce._seen.clear()
        truth = run_chunk(spec, 0, jobs=1, lanes=False)
    assert len(scipy_calls) >= len(truth)
    assert not reduce._memo
    statuses = [r["status"] for r in rows]
    assert statuses.count("diverged") >= 2 and statuses.count("completed") >= 4
    ends = {r["t_end"] for r in rows if r["status"] == "diverged"}
    assert len(ends) >= 2  # cut at different records
    assert len(rows) == len(truth)
    for got, want in zip(rows, truth, strict=True):
        assert got.keys() == want.keys()
        for key in want:
            assert _same(got[key], want[key]), (key, got[key], want[key])


def _pooled(a: np.ndarray) -> bool:
    """Whether ``a`` lies over a buffer of the pool of sim/blocks.py (a bytearray)."""
    while isinstance(a, np.ndarray) and a.base is not None:
        a = a.base
    return isinstance(a, memoryview) and isinstance(a.obj, bytearray)


def test_a_long_runs_times_come_from_the_pool_and_are_its_own():
    """A run's record grid, its phases and its result's times (0.56 MB each at 70,001
    records) are blocks of the pool; each result's times are its own array, the grid
    t0 + dt * k bit for bit."""
    import dataclasses
    import math

    from adaptive_ftc.scenarios import load_scenario
    from adaptive_ftc.sim.engine import CompiledLoop, simulate
    from adaptive_ftc.sim.result import TIME_POOL_BYTES

    sc = load_scenario("hypersonic-direct-s1")
    loop = dataclasses.replace(sc.loop, t_final=70.0)
    solver = dataclasses.replace(sc.solver, record_dt=1e-3)
    n = int(math.floor(70.0 / 1e-3 + 1e-9))
    grid = 0.0 + 1e-3 * np.arange(n + 1)
    cl = CompiledLoop.build(loop, solver)
    run = cl.integrate()
    assert cl.t_rec.tobytes() == grid.tobytes() and _pooled(cl.t_rec)
    assert _pooled(run.phases) and _pooled(run.Y)
    first = simulate(loop, solver, lean_signals=True)
    assert first.time.nbytes >= TIME_POOL_BYTES
    assert first.time.tobytes() == grid.tobytes() and _pooled(first.time)
    second = simulate(loop, solver, lean_signals=True)
    first.time[:] = -1.0  # its own array: not the other result's times, not the next grid
    assert second.time.tobytes() == grid.tobytes()
    del first
    gc.collect()
    third = simulate(loop, solver, lean_signals=True)  # may take first's block: overwritten
    assert third.time.tobytes() == grid.tobytes()
    assert CompiledLoop.build(loop, solver).t_rec.tobytes() == grid.tobytes()
