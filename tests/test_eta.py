"""The progress bars' ETA (issue 28): time left from the measured rate of the work done so far,
tasks weighted by their expected cost. Driven by a fake clock: no real time is measured."""

from __future__ import annotations

import pytest

from adaptive_ftc import _feedback
from adaptive_ftc._feedback import BAR_FORMAT, Eta, EtaBar
from adaptive_ftc.errors import ConfigurationError


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0  # any origin: only differences count

    def __call__(self) -> float:
        return self.now


# tasks of very different costs (a 120 s run at 1 ms records, a 10 s run, figures...)
COSTS = [5.0, 0.2, 0.2, 3.0, 0.5, 0.5, 0.5, 8.0, 0.1, 1.0]


@pytest.mark.parametrize("startup", [0.0, 8.0, 600.0])
@pytest.mark.parametrize("throughput", [0.5, 2.0, 7.0])
def test_eta_equals_the_true_time_left_at_a_steady_rate(throughput, startup):
    # the machine completes `throughput` units of cost per second once it has started (imports,
    # workers, a cold run's compiles: `startup` seconds before the first task starts); each
    # task takes its cost over that: the true time left after task k is the cost still to do
    # over the throughput, whatever the start-up took
    clock = FakeClock()
    eta = Eta(sum(COSTS), clock=clock)
    clock.now += startup
    for k, cost in enumerate(COSTS):
        clock.now += cost / throughput
        eta.done(cost)
        truth = sum(COSTS[k + 1 :]) / throughput
        if k == 0:  # one completion is no rate yet
            assert eta.seconds_left() is None and eta.text() == ""
            continue
        assert eta.seconds_left() == pytest.approx(truth, rel=1e-9, abs=1e-9)
    assert eta.seconds_left() == 0.0


def test_two_workers_are_measured_together():
    # two workers of 1 task/s, the second started half a second late: 2 tasks/s in all
    clock = FakeClock()
    n = 20
    eta = Eta(float(n), clock=clock)
    ends = sorted([1.0 + i for i in range(n // 2)] + [1.5 + i for i in range(n // 2)])
    for k, end in enumerate(ends):
        clock.now = 100.0 + end
        eta.done(1.0)
        if k:
            assert eta.seconds_left() == pytest.approx((n - k - 1) / 2.0)


def test_counting_tasks_alike_would_be_wrong_by_minutes():
    # the reason for the weights: after tasks of 5 and 0.2 units, 8 of 10 tasks are left but
    # only 13.8 of 19 units; counted alike the ETA would be 8 x 0.4 s x 5.2 / 0.2 ... = 16 s
    # instead of 13.8 / 0.5 = 27.6 s, and it swings with every long task
    clock = FakeClock()
    eta, counts = Eta(sum(COSTS), clock=clock), Eta(len(COSTS), clock=clock)
    for cost in COSTS[:2]:
        clock.now += cost / 0.5
        eta.done(cost)
        counts.done(1.0)
    assert eta.seconds_left() == pytest.approx((sum(COSTS) - 5.2) / 0.5)
    assert counts.seconds_left() == pytest.approx(8 * 0.4)
    assert eta.seconds_left() - counts.seconds_left() > 20


def test_eta_is_never_negative_nor_infinite():
    clock = FakeClock()
    eta = Eta(2.0, clock=clock)
    eta.done(1.0)
    eta.done(1.0)  # a second completion at the same instant: no elapsed time, no rate yet
    assert eta.seconds_left() == 0.0  # ... but nothing is left
    eta.add(3.0)
    assert eta.seconds_left() is None
    clock.now += 1.0
    eta.done(9.0)  # more work than expected was done
    assert eta.seconds_left() == 0.0
    eta.add(-20.0)  # work dropped below nothing
    assert eta.total == 0.0 and eta.seconds_left() == 0.0
    eta.done(-3.0)  # a negative cost counts as nothing
    assert eta.completed == 11.0
    with pytest.raises(ConfigurationError, match="finite cost"):
        Eta(float("inf"))
    with pytest.raises(ConfigurationError, match="finite cost"):
        Eta(float("nan"))


def test_the_total_can_change_while_it_runs():
    # a scenario whose run failed draws none of its 3 figures (2 units each)
    clock = FakeClock()
    eta = Eta(10.0, clock=clock)
    clock.now += 30.0
    eta.done(1.0)
    clock.now += 2.0
    eta.done(1.0)  # 1 unit in 2 s
    eta.add(-6.0)
    assert eta.seconds_left() == pytest.approx((4.0 - 2.0) / 0.5)


@pytest.mark.parametrize(
    ("seconds", "text"), [(0.4, "ETA 0:00"), (83, "ETA 1:23"), (3725, "ETA 1:02:05")]
)
def test_eta_text(seconds, text):
    clock = FakeClock()
    eta = Eta(3.0, clock=clock)
    eta.done(1.0)
    clock.now += seconds
    eta.done(1.0)  # one in `seconds`, one left: as long
    assert eta.text() == text


def test_bar_shows_the_measured_eta_not_tqdms(capsys):
    clock = FakeClock()
    assert "{remaining}" not in BAR_FORMAT
    with EtaBar(4, cost=10.0, desc="work", clock=clock) as bar:
        clock.now += 30.0  # start-up
        bar.tick(2.0)
        assert not bar.bar.postfix  # no rate yet: no ETA
        clock.now += 4.0
        bar.tick(4.0)  # 4 units in 4 s: 4 left, 4 s
        assert bar.bar.postfix == "ETA 0:04"
        bar.note("data/x.nc")
        assert bar.bar.postfix == "ETA 0:04, data/x.nc"
        bar.grow(1, 4.0)  # one more task: 8 units left, 8 s
        assert bar.bar.total == 5 and bar.bar.postfix.startswith("ETA 0:08")
        clock.now += 1.0
        bar.tick(1.0)
        assert bar.bar.n == 3
    err = capsys.readouterr().err
    assert "ETA 0:04" in err and "<?" not in err


def test_a_resumed_bar_rates_only_this_sessions_work():
    # a campaign resumed at 90 of 100 runs: the rate is that of the runs done now
    clock = FakeClock()
    bar = EtaBar(100, initial=90, disable=True, clock=clock)
    assert bar.eta.total == 10.0
    clock.now += 30.0
    bar.tick(1.0)
    clock.now += 10.0
    bar.tick(1.0)  # one run in 10 s: 8 left, 80 s
    assert bar.eta.seconds_left() == pytest.approx(80.0)
    bar.close()


def test_reproduce_weighs_its_tasks_and_ends_at_zero(tmp_path, monkeypatch):
    from adaptive_ftc.reproduce import run_reproduction

    bars: list[EtaBar] = []
    ticks: list[float] = []

    class Recording(EtaBar):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            bars.append(self)

        def tick(self, cost=1.0, n=1):
            ticks.append(cost)
            super().tick(cost, n)

    monkeypatch.setattr(_feedback, "EtaBar", Recording)
    run_reproduction(
        tmp_path / "r",
        quick=True,
        names=["wingrock-free-1deg"],
        jobs=1,
        progress=False,
        formats=("png",),
        dpi=40,
        figure_limit=1,
        data=False,
    )
    (bar,) = bars
    assert len(ticks) == bar.bar.total  # one tick a task (a disabled bar does not count)
    # every task's cost is counted once: the ETA ends at zero, not below
    assert bar.eta.completed == pytest.approx(bar.eta.total)
    assert bar.eta.seconds_left() == 0.0
    # the tasks are weighted: a figure (0.5 s) against a short run not written to a file
    assert max(ticks) > 5 * min(ticks)


def test_a_resumed_campaign_rates_only_the_runs_of_this_call(tmp_path, monkeypatch):
    from adaptive_ftc.campaigns import load_campaign, run_campaign

    spec = {
        "name": "eta",
        "base": "hypersonic-direct-s1",
        "designs": ["adaptive", "frozen"],
        "runs": 4,
        "seed": 3,
        "chunk_size": 2,
        "duration": 1.0,
        "success": {"rms_error_final": 0.01, "final_window": 0.5},
        "failures": {"count": 1, "models": {"loss_of_effectiveness": {}}},
    }
    bars: list[EtaBar] = []

    class Recording(EtaBar):
        def __init__(self, total, **k):
            super().__init__(total, **k)
            self.initial = k.get("initial", 0)
            bars.append(self)

    monkeypatch.setattr(_feedback, "EtaBar", Recording)
    out = tmp_path / "c"
    run_campaign(load_campaign(spec), out, jobs=1, progress=False, max_chunks=1, summary=False)
    run_campaign(load_campaign(spec), out, jobs=1, progress=False, summary=False)
    first, second = bars
    # 8 runs (4 members x 2 designs) in chunks of 4: the first call runs one chunk, the second
    # resumes at 4 and its ETA is measured on its own 4 runs
    assert (first.bar.total, first.initial, first.eta.total) == (8, 0, 4.0)
    assert (second.bar.total, second.initial, second.eta.total) == (8, 4, 4.0)
    assert first.eta.completed == second.eta.completed == 4.0
