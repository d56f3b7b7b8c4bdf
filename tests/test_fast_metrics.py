"""The cheap per-run reduction (issue 29, campaign throughput): ``SimResult.metrics``,
``recovery``, the activity metrics and a campaign's recovery times, computed by compiled
passes over the records (sim/reduce.py) and on the judged window only, against plain numpy /
scipy computations written out here; and a campaign's rows computed in the thread that
simulated the run (``iter_simulate(reduce=...)``)."""

from __future__ import annotations

import dataclasses
import math
import threading

import numpy as np
import pytest
from scipy.signal import butter, sosfiltfilt

from adaptive_ftc import iter_simulate, simulate_many
from adaptive_ftc.campaigns import draw_member, load_campaign, run_chunk
from adaptive_ftc.campaigns.runner import outcome, recovery_times
from adaptive_ftc.sim import reduce
from adaptive_ftc.sim.activity import activity
from adaptive_ftc.sim.zerophase import lowpass_design, sosfiltfilt_odd

pytestmark = pytest.mark.filterwarnings("ignore::adaptive_ftc.errors.DivergenceWarning")

SPEC = {
    "name": "fast-metrics",
    "base": "hypersonic-direct-s1",
    "designs": ["adaptive"],
    "runs": 4,
    "seed": 29,
    "chunk_size": 4,
    "duration": 40.0,
    "success": {"rms_error_final": 8.7e-4, "final_window": 10.0},
    "failures": {
        "count": {"integers": [1, 2]},
        "onset": {"uniform": [5.0, 30.0]},
        "recovery_probability": 0.5,
        "duration": {"uniform": [2.0, 8.0]},
        "models": {
            "loss_of_effectiveness": {"effectiveness": {"uniform": [0.1, 0.9]}},
            "stuck": {"value": {"uniform": [-0.2, 0.2]}},
        },
    },
}


@pytest.fixture(scope="module")
def spec():
    return load_campaign(SPEC)


@pytest.fixture(scope="module")
def results(spec):
    """Four 40 s runs with one or two failures each, recorded every millisecond."""
    loops = [draw_member(spec, i).design_loop("adaptive") for i in range(spec.runs)]
    return simulate_many(loops, spec.solver, jobs=2)


def _variants(result):
    """The run itself, and copies with three tracking errors (a MIMO layout: strided columns
    of a wider block) and with a non-finite error (a diverging run's records)."""
    rng = np.random.default_rng(7)
    n = result.time.size
    block = rng.standard_normal((n, 11)) * 1e-3
    block[:, 4:7] = result.e[:, [0]] * np.array([1.0, -0.5, 2.0]) + block[:, 4:7]
    wide = dataclasses.replace(result, e=block[:, 4:7])
    bad_e = result.e.copy()
    bad_e[n // 2, 0] = math.nan
    bad_u = result.u_cmd.copy()
    bad_u[n // 3, 1] = math.inf
    return [result, wide, dataclasses.replace(result, e=bad_e, u_cmd=bad_u)]


def _truth_metrics(r, fw):
    """The headline numbers, as a reader would compute them with numpy."""
    t, e = r.time, r.e
    final = (t >= t[-1] - fw - 1e-9) & (t <= t[-1] + 1e-9)
    return {
        "rms_error": float(np.sqrt(np.mean(e**2))),
        "max_error": float(np.max(np.abs(e))),
        "rms_error_final": float(np.sqrt(np.mean(e[final] ** 2))),
        "max_error_final": float(np.max(np.abs(e[final]))),
        "peak_command": float(np.max(np.abs(r.u_cmd))),
        "peak_applied": float(np.max(np.abs(r.u_applied))),
    }


def _close(a, b, rel=1e-12):
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return a == b or abs(a - b) <= rel * max(abs(a), abs(b))


@pytest.mark.parametrize("fast", [True, False])
def test_the_headline_metrics_equal_plain_numpy(results, spec, fast):
    for result in results:
        for r in _variants(result):
            got = r.metrics(final_window=spec.final_window, fast=fast)
            for key, want in _truth_metrics(r, spec.final_window).items():
                assert _close(got[key], want), (key, got[key], want)


def test_the_activity_metrics_equal_a_filter_of_the_window_written_out(results):
    """fast content, total variation, peak rate, peak and peak to peak of the final window,
    against scipy's sosfiltfilt over the window and 10 s on each side, by hand."""
    for r in results:
        t_end = float(r.time[-1])
        start = t_end - 10.0
        dt = float(np.median(np.diff(r.time)))
        part = (r.time >= start - 10.0 - 1e-9) & (r.time <= t_end + 10.0 + 1e-9)
        win = (r.time >= start - 1e-9) & (r.time <= t_end + 1e-9)
        sos = butter(4, 1.0, btype="low", fs=1.0 / dt, output="sos")
        pad = min(int(part.sum()) - 1, math.ceil(3.0 / dt))
        low = sosfiltfilt(sos, r.u_cmd[part], axis=0, padtype="odd", padlen=pad)
        low_win = low[win[part]]
        acts = activity(r, start, t_end)
        for j, name in enumerate(r.actuator_names):
            u = r.u_cmd[win, j]
            want = {
                "fast_rms": np.sqrt(np.mean((u - low_win[:, j]) ** 2)),
                "tv_per_s": np.sum(np.abs(np.diff(u))) / (t_end - start),
                "peak_rate": np.max(np.abs(np.diff(u))) / dt,
                "peak_command": np.max(np.abs(u)),
                "peak_to_peak": np.max(u) - np.min(u),
            }
            for key, value in want.items():
                got = getattr(acts[name], key)
                assert _close(got, float(value)), (name, key, got, value)


@pytest.mark.parametrize("fast", [True, False])
def test_recovery_and_recovery_times_equal_plain_numpy(results, spec, fast):
    tol = spec.recovery_tolerance
    for result in results:
        for r in _variants(result)[:2]:
            times = [float(t) for t in r.failure_times]
            assert times, "every member fails at least once"
            t_last = float(r.time[-1])
            err = np.max(np.abs(r.e), axis=1)
            want_rec = []  # recovery_times: every failure, to the next one or the end
            for t, nxt in zip(times, [*times[1:], t_last], strict=True):
                seg = np.flatnonzero((r.time >= t - 1e-9) & (r.time <= nxt + 1e-9))
                if seg.size == 0:  # after the records end (a diverged run)
                    continue
                bad = np.flatnonzero(err[seg] > tol)
                if bad.size == 0:
                    want_rec.append(0.0)
                elif bad[-1] == seg.size - 1:
                    want_rec.append(math.inf)
                else:
                    want_rec.append(float(r.time[seg[bad[-1] + 1]] - t))
            # recovery: the failures inside the records, 5 s after each and before the next
            inside = [t for t in times if t <= t_last]
            ends = [*inside[1:], min(float(r.meta["t_final"]), t_last)]
            rows = r.recovery(fast=fast)
            assert [row["time"] for row in rows] == inside
            for row, t, nxt in zip(rows, inside, ends, strict=True):
                after = (r.time >= t - 1e-9) & (r.time <= min(t + 5.0, nxt) + 1e-9)
                settle = (r.time >= max(t, nxt - 5.0) - 1e-9) & (r.time <= nxt + 1e-9)
                assert _close(row["rms_after"], float(np.sqrt(np.mean(r.e[after] ** 2))))
                assert _close(row["rms_before_next"], float(np.sqrt(np.mean(r.e[settle] ** 2))))
            assert recovery_times(r, tol) == want_rec


def test_a_result_with_unsorted_times_takes_the_mask_path(results, spec):
    """Records that go back in time (cut and joined by hand) have no row spans: the masks of
    the plain path, same numbers as numpy's over the same masks."""
    r = results[0]
    n = r.time.size
    order = np.r_[np.arange(n // 2, n), np.arange(0, n // 2)]
    shuffled = dataclasses.replace(r, time=r.time[order], e=r.e[order])
    got = shuffled.metrics(final_window=spec.final_window, fast=True)
    t, e = shuffled.time, shuffled.e
    final = t >= t.max() - spec.final_window - 1e-9
    final &= t <= t[-1] + 1e-9
    assert got["rms_error"] == pytest.approx(float(np.sqrt(np.mean(e**2))), rel=1e-12)
    assert got["max_error"] == float(np.max(np.abs(e)))


@pytest.mark.parametrize("n", [1, 7, 8, 9, 128, 129, 1000, 8193, 40001])
@pytest.mark.parametrize("p", [1, 3])
def test_the_compiled_sums_are_numpys_bit_for_bit(n, p):
    """numpy's pairwise order, reproduced: the same float, not merely a close one."""
    rng = np.random.default_rng(n + p)
    block = rng.standard_normal((n, 9)) * 10.0 ** rng.uniform(-6, 3, (n, 9))
    a = block[:, 2 : 2 + p]  # strided, like a column of the signal block
    lo = n // 3
    stats = reduce.error_stats(a, block[:, 5:7], block[:, 7:9], lo)
    assert stats == (
        float(np.sum(a**2)),
        float(np.max(np.abs(a))),
        float(np.sum(a[lo:] ** 2)),
        float(np.max(np.abs(a[lo:]))),
        float(np.max(np.abs(block[:, 5:7]))),
        float(np.max(np.abs(block[:, 7:9]))),
    )


def test_the_filter_with_its_state_designed_once_is_sosfiltfilt_bit_for_bit():
    rng = np.random.default_rng(3)
    x = np.cumsum(rng.standard_normal((5000, 2)), axis=0)[::1]
    sos, zi = lowpass_design(4, 1.0, 1000.0)
    for pad in (9, 300, 3000, 4999):
        want = sosfiltfilt(sos.copy(), x, axis=0, padtype="odd", padlen=pad)
        got = sosfiltfilt_odd(sos, zi, x, pad)
        assert np.array_equal(got, want)


def test_iter_simulate_reduces_each_result_in_the_thread_that_ran_it(spec, results):
    main = threading.get_ident()
    seen = []

    def rms(r):
        seen.append(threading.get_ident())
        return float(r.rms_error()[0])

    loops = [draw_member(spec, i).design_loop("adaptive") for i in range(spec.runs)]
    got = list(iter_simulate(loops, spec.solver, jobs=2, reduce=rms))
    assert got == [float(r.rms_error()[0]) for r in results]
    assert len(seen) == spec.runs and main not in seen


def test_iter_simulate_raises_what_the_reducer_raises(spec):
    def boom(r):
        raise ZeroDivisionError("reducer")

    loops = [draw_member(spec, 0).design_loop("adaptive")]
    with pytest.raises(ZeroDivisionError, match="reducer"):
        list(iter_simulate(loops, spec.solver, jobs=1, reduce=boom))


def test_a_chunks_rows_are_the_outcomes_of_its_runs(spec, results):
    """Drawn lazily and reduced in the workers, the rows are those of the runs reduced one by
    one afterwards."""
    rows = run_chunk(spec, 0, jobs=2)
    assert len(rows) == spec.runs
    for row, r in zip(rows, results, strict=True):
        want = outcome(r, spec)
        for key, value in want.items():
            got = row[key]
            if isinstance(value, float) and math.isnan(value):
                assert math.isnan(got), key
            else:
                assert got == value, key


@pytest.mark.parametrize(
    "t",
    [
        np.arange(0, 120.0005, 1e-3),  # an engine's record: ~16 distinct float spacings
        np.arange(0, 20.0, 1e-3) * 1.0 + 3.7,  # an even number of spacings
        np.r_[np.arange(0, 10.0, 1e-3), 10.0 - 1e-3 + 4e-4],  # a closer last record
        np.linspace(0.0, 7.0, 7001),
        np.r_[0.0, 0.5, 0.51, 1.0],  # uneven: numpy's median and the resampling path
    ],
)
def test_the_grid_spacing_is_numpys_median_bit_for_bit(t):
    d = np.diff(t)
    kind, dt = reduce.grid_spacing(t)
    assert dt == float(np.median(d))
    uniform = bool(np.all(np.abs(d - dt) <= 1e-6 * dt))
    closer_last = bool(np.all(np.abs(d[:-1] - dt) <= 1e-6 * dt) and d[-1] < dt)
    assert kind == (0 if uniform else 1 if closer_last else 2)


def test_many_distinct_spacings_fall_back_to_numpy():
    t = np.cumsum(np.random.default_rng(5).uniform(0.9e-3, 1.1e-3, 500))
    kind, dt = reduce.grid_spacing(t)
    assert kind == 2 and math.isnan(dt)


def test_a_record_block_is_used_again_only_when_nothing_reads_it():
    """sim/blocks.py: a big block comes back from the pool once every view of it is gone, and
    never while a view (a result's signal) still reads it."""
    from adaptive_ftc.sim import blocks

    shape = (blocks.MIN_BYTES // 8 // 4 + 3, 4)
    a = blocks.empty(shape)
    a[:] = 1.0
    view = a[:, 2:3]  # as SimResult.e is a column of the signal block
    address = view.__array_interface__["data"][0] - 16
    del a
    b = blocks.empty(shape)  # the first block is still read through `view`
    assert b.__array_interface__["data"][0] != address
    b[:] = 2.0
    assert np.all(view == 1.0)
    del view
    c = blocks.empty(shape)
    assert c.__array_interface__["data"][0] == address  # given back, taken again
    assert blocks.empty((10, 3)).base is None  # small: a plain np.empty


def test_a_single_result_does_not_compile_the_kernels_unless_asked(tmp_path):
    """``metrics()`` and ``recovery()`` of one result (``aftc run``) reduce with numpy unless
    the process has loaded the compiled kernels (a campaign asks for them with ``fast=True``):
    on an empty cache they would compile for about 4 s to save milliseconds."""
    import subprocess
    import sys

    code = (
        "import sys, warnings; warnings.simplefilter('ignore')\n"
        "from dataclasses import replace\n"
        "from adaptive_ftc import load_scenario, simulate\n"
        "sc = load_scenario('hypersonic-direct-s1')\n"
        "r = simulate(replace(sc.loop, t_final=2.0), sc.solver)\n"
        "r.metrics(); r.recovery()\n"
        "print('adaptive_ftc.sim.reduce' in sys.modules)\n"
        "r.metrics(fast=True)\n"
        "print('adaptive_ftc.sim.reduce' in sys.modules)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=600, check=True
    ).stdout.split()
    assert out == ["False", "True"]
