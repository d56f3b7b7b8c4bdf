"""The allocation study at a reduced size (issue 31): paired draws, the fixed allocation's
runs shared across detection settings, success judged by the scenario's tracking claim."""

from __future__ import annotations

import numpy as np
import pytest

from adaptive_ftc.allocation import AdaptiveAllocation, PseudoInverse
from adaptive_ftc.allocation_study import (
    allocation_study,
    draw_failures,
    plot_allocation_study,
    summarize,
)
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.faults import LossOfEffectiveness, Stuck


def test_draws_fail_distinct_actuators_within_the_ranges():
    rng = np.random.default_rng(0)
    for _ in range(20):
        fails = draw_failures(6, 3, rng, onset=(10.0, 20.0), stuck=5.0)
        assert len({f.actuator for f in fails}) == 3
        for f in fails:
            assert 10.0 <= f.onset <= 20.0
            if isinstance(f, Stuck):
                assert abs(f.value) <= 5.0
            else:
                assert isinstance(f, LossOfEffectiveness) and 0.1 <= f.effectiveness <= 0.5
    with pytest.raises(ConfigurationError, match="between 0 and the 6 actuators"):
        draw_failures(6, 7, rng, onset=(0.0, 1.0), stuck=1.0)


def test_a_reduced_study_compares_allocators_on_the_same_draws():
    allocators = {"fixed": None, "pinv": PseudoInverse(), "adaptive": AdaptiveAllocation(gain=5.0)}
    table = allocation_study(
        "spacecraft-mimo-s1",
        failed=(1,),
        draws=2,
        delays=(None, 1.0),
        allocators=allocators,
        duration=40.0,
        onset=(5.0, 15.0),
        window=10.0,
        threshold=0.0025,
        seed=3,
    )
    assert len(table) == 2 * 2 * 3
    for _, rows in table.groupby("draw"):
        assert rows["failures"].nunique() == 1  # every allocator sees the same failures
        fixed = rows[rows["allocator"] == "fixed"]
        assert fixed["rms"].nunique() == 1  # the fixed allocation ignores annunciations
        silent = rows[rows["detection"] == "silent"]
        # silently, pinv (no knowledge, healthy demand) is the fixed allocation itself
        assert silent.set_index("allocator").loc["pinv", "rms"] == pytest.approx(
            silent.set_index("allocator").loc["fixed", "rms"], rel=1e-6
        )
    assert (table["success"] == (table["rms"] <= 0.0025)).all()
    summary = summarize(table)
    assert set(summary["runs"]) == {2}
    assert plot_allocation_study(table).axes


def test_a_study_without_a_success_criterion_says_what_to_give():
    with pytest.raises(ConfigurationError, match="give `window` and `threshold`"):
        allocation_study("wingrock-free-1deg", failed=(1,), draws=1)
