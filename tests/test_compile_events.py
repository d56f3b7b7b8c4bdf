"""benchmarks/bench_compile_events.py: per-function compile times, nested compiles counted once."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from bench_compile_events import CompileTimes, listener  # noqa: E402


class _Clock:
    """A clock the test advances by hand (no timing in the test)."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_nested_compile_is_subtracted_from_its_caller() -> None:
    clock = _Clock()
    times = CompileTimes(clock=clock)
    times.start("outer")
    clock.now = 1.0
    times.start("inner")
    clock.now = 3.0
    times.end("inner")
    clock.now = 3.5
    times.end("outer")
    rows = {name: (n, own, incl) for name, n, own, incl in times.rows()}
    assert rows["inner"] == (1, 2.0, 2.0)
    assert rows["outer"] == (1, 1.5, 3.5)
    assert times.total_self() == pytest.approx(3.5)  # the wall of the outermost compile
    assert [r[0] for r in times.rows()] == ["inner", "outer"]  # costliest self time first


def test_out_of_order_end_names_the_open_compiles() -> None:
    times = CompileTimes(clock=_Clock())
    times.start("outer")
    with pytest.raises(RuntimeError, match="'inner'.*open: \\['outer'\\]"):
        times.end("inner")


def test_listener_records_a_real_numba_compile() -> None:
    numba = pytest.importorskip("numba")
    from numba.core import event

    @numba.njit(inline="never")
    def _callee(x):
        return x + 1.0

    @numba.njit
    def _caller(x):
        return _callee(x) * 2.0

    times = CompileTimes()
    with event.install_listener("numba:compile", listener(times)):
        assert _caller(1.0) == 4.0
    names = {name.rsplit(".", 1)[-1]: n for name, n, _, _ in times.rows()}
    assert names == {"_caller": 1, "_callee": 1}
    assert times.total_self() <= sum(incl for *_, incl in times.rows())
