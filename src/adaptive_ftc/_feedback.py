"""What the command-line tools say before they compile: how many loop structures and how long.

A loop structure is the generated module of a closed loop (``sim.compose.generate``):
runs that differ only in numbers share one. The first run of a structure compiles it with numba;
later runs, in this process or any other, load it from the disk cache.

The cost per structure is measured, not guessed: on a cold cache (``ADAPTIVE_FTC_CACHE_DIR`` and
``NUMBA_CACHE_DIR`` empty), the first run of ``hypersonic-direct-s1`` took 10.4 s of CPU (its
loop and the integrators every loop shares), the next new structures (``hypersonic-sign-s1-
rho0pos``, ``manipulator-mimo-s1``) 2.1 s and 4.5 s (numba compile events of a cold ``aftc
reproduce``, README's first-run row: 22 ``rhs`` modules, 0.5-1.8 s each, and the integrators
4.8 s once). Hence :data:`SECONDS_PER_STRUCTURE` and :data:`SECONDS_SHARED`; wall time is
longer on a busy machine.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from adaptive_ftc.sim.system import ClosedLoop

#: CPU seconds to compile one new loop structure (its ``rhs``, gain and signals modules).
SECONDS_PER_STRUCTURE = 2.5
#: CPU seconds to compile the integrators every loop shares (once per installation).
SECONDS_SHARED = 8.0


def compile_plan(loops: Iterable[tuple[ClosedLoop, str]]) -> tuple[int, float]:
    """``(n, seconds)``: the distinct structures among ``(loop, sdot)`` pairs that are not
    compiled yet, and the CPU seconds their compilation is expected to take."""
    from adaptive_ftc.sim.compose import is_compiled

    seen: set[tuple[int, str]] = set()
    texts: set[str] = set()
    n = 0
    from adaptive_ftc.sim.compose import generate

    for loop, sdot in loops:
        if (id(loop), sdot) in seen:
            continue
        seen.add((id(loop), sdot))
        try:
            text = generate(loop, sdot=sdot)[0]
        except Exception:  # noqa: BLE001 - the run itself reports a loop that cannot be built
            continue
        if text in texts:
            continue
        texts.add(text)
        if not is_compiled(loop, sdot=sdot):
            n += 1
    shared = not shared_compiled()
    seconds = n * SECONDS_PER_STRUCTURE + (SECONDS_SHARED if n and shared else 0.0)
    return n, seconds


def shared_compiled() -> bool:
    """Whether the integrators every loop shares are compiled (in this process or the disk
    cache)."""
    from adaptive_ftc.sim import codegen
    from adaptive_ftc.sim.compose import _INTEGRATORS_IMPORTS, _integrators_source

    return codegen.is_cached(_integrators_source(), _INTEGRATORS_IMPORTS, kind="integrators")


def compile_line(n: int, seconds: float, jobs: int = 1) -> str:
    """The line printed before the first compile (``jobs``: processes compiling at once)."""
    wall = seconds / max(1, min(jobs, n))
    word = "structure" if n == 1 else "structures"
    shared = seconds > n * SECONDS_PER_STRUCTURE
    how = f"{SECONDS_PER_STRUCTURE:g} s of CPU a structure" + (
        f" + {SECONDS_SHARED:g} s once for the shared integrators" if shared else ""
    )
    return (
        f"compiling {n} loop {word} (first run only, ~{wall:.0f} s: {how}; longer on a busy "
        "machine)..."
    )


# ---------------------------------------------------------------------------- ETA of the bars
#: The bars' layout: tqdm's own ``<{remaining}`` (a smoothed rate of task *counts*, which
#: swings by minutes when a figure follows a long run) is replaced by :class:`Eta`'s text,
#: carried in the postfix.
BAR_FORMAT = "{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} {unit} [{elapsed}{postfix}]"


#: Expected CPU seconds of the tasks behind the bars, used as the ETA's weights (measured on
#: warm ``aftc reproduce`` runs of the shared 2-core machine: a run costs about 0.05 s + 0.06 s
#: per million recorded values, writing its data file 0.35 s per million more, a figure 0.5 s
#: and 0.3 s for each format beyond the first). Only their ratios matter: the ETA's rate is
#: measured, these only say how much of the work a task is.
SECONDS_RUN = 0.05
SECONDS_PER_VALUE_RUN = 0.06e-6
SECONDS_PER_VALUE_WRITE = 0.35e-6
SECONDS_FIGURE = 0.5
SECONDS_FORMAT = 0.3


def run_cost(values: float, *, write: bool = True) -> float:
    """Expected seconds of a run that records ``values`` numbers (and writes them)."""
    per = SECONDS_PER_VALUE_RUN + (SECONDS_PER_VALUE_WRITE if write else 0.0)
    return SECONDS_RUN + max(0.0, float(values)) * per


def write_cost(values: float) -> float:
    """Expected seconds of writing a data file of ``values`` numbers."""
    return SECONDS_RUN + max(0.0, float(values)) * SECONDS_PER_VALUE_WRITE


def figure_cost(n_formats: int = 1) -> float:
    """Expected seconds of one figure saved in ``n_formats`` formats."""
    return SECONDS_FIGURE + SECONDS_FORMAT * max(0, n_formats - 1)


class Eta:
    """Time left from the measured rate of the work done so far.

    Each task has an expected cost (any unit: expected CPU seconds, recorded values, or 1 for
    tasks alike). The rate is the cost completed per second of wall time, measured from the
    first completion on: the time until then holds what happens once (imports, worker start,
    numba compiles on a first run: a cold ``aftc reproduce`` used to open on a 23-minute
    estimate) and would make the rate look slow for the whole run. Parallel workers and the
    machine's load are in the measured rate. The time left is the cost still to do over that
    rate; nothing is estimated before a second task completes (there is no rate yet), and the
    time left is never negative and never infinite.

    Parameters
    ----------
    total
        The expected cost of all the work this clock measures (work finished before it
        started, e.g. a resumed campaign's, is not in it).
    clock
        Seconds, monotonic (tests pass a fake one).

    Examples
    --------
    >>> t = [0.0]
    >>> eta = Eta(10.0, clock=lambda: t[0])
    >>> t[0] = 9.0; eta.done(1.0)   # the first task, after 8 s of start-up
    >>> eta.seconds_left() is None  # no rate yet
    True
    >>> t[0] = 13.0; eta.done(2.0)  # 2 more in 4 s: 0.5 a second, 7 to do
    >>> eta.seconds_left()
    14.0
    """

    def __init__(self, total: float, *, clock=None) -> None:
        import time

        total = float(total)
        if not total >= 0 or total == float("inf"):
            from adaptive_ftc.errors import ConfigurationError

            raise ConfigurationError(f"`total` of Eta must be a finite cost >= 0; got {total!r}.")
        self.total = total
        self._clock = clock or time.monotonic
        self.completed = 0.0
        self._first: tuple[float, float] | None = None  # (time, cost) of the first completion

    def done(self, cost: float = 1.0) -> None:
        """Record a completed task of expected ``cost``."""
        self.completed += max(0.0, float(cost))
        if self._first is None:
            self._first = (self._clock(), self.completed)

    def add(self, cost: float) -> None:
        """Change the expected total by ``cost`` (negative: work dropped, e.g. the figures of
        a run that failed)."""
        self.total = max(0.0, self.total + float(cost))

    def seconds_left(self) -> float | None:
        """Seconds left at the measured rate, or ``None`` while there is no rate."""
        if self._first is None:
            return None
        t_first, c_first = self._first
        elapsed, work = self._clock() - t_first, self.completed - c_first
        if work <= 0 or elapsed <= 0:
            return 0.0 if self.completed >= self.total else None
        return max(0.0, self.total - self.completed) / (work / elapsed)

    def text(self) -> str:
        """``"ETA 1:23"`` (``""`` while there is no rate)."""
        left = self.seconds_left()
        if left is None:
            return ""
        s = int(round(left))
        h, rest = divmod(s, 3600)
        m, s = divmod(rest, 60)
        return f"ETA {h:d}:{m:02d}:{s:02d}" if h else f"ETA {m:d}:{s:02d}"


class EtaBar:
    """A tqdm bar counting tasks, its ETA from :class:`Eta` (tasks weighted by their cost).

    ``bar.tick(cost)`` counts one task; ``bar.note(text)`` shows what is being done after the
    ETA; ``bar.grow(n, cost)`` changes the total (e.g. ``-3`` figures a failed run will not
    draw). The bar itself is ``bar.bar`` (tqdm.auto, looked up when the bar is made).
    """

    def __init__(
        self,
        total: int,
        *,
        cost: float | None = None,
        desc: str = "",
        unit: str = "task",
        disable: bool = False,
        initial: int = 0,
        clock=None,
    ) -> None:
        from tqdm.auto import tqdm

        self.eta = Eta(float(total - initial) if cost is None else cost, clock=clock)
        self._note = ""
        self.bar = tqdm(
            total=total,
            initial=initial,
            desc=desc,
            unit=unit,
            disable=disable,
            bar_format=BAR_FORMAT,
        )

    def _show(self) -> None:
        text = ", ".join(t for t in (self.eta.text(), self._note) if t)
        self.bar.set_postfix_str(text, refresh=False)

    def tick(self, cost: float = 1.0, n: int = 1) -> None:
        """``n`` tasks done, of expected ``cost`` together."""
        self.eta.done(cost)
        self._show()
        self.bar.update(n)

    def note(self, text: str) -> None:
        """Show ``text`` (e.g. the file being written) after the ETA."""
        self._note = text
        self._show()
        self.bar.refresh()

    def grow(self, n: int, cost: float | None = None) -> None:
        """Change the total by ``n`` tasks of expected ``cost`` (default: ``n``)."""
        self.bar.total += n
        self.eta.add(float(n) if cost is None else cost)
        self._show()
        self.bar.refresh()

    def close(self) -> None:
        self.bar.close()

    def __enter__(self) -> EtaBar:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
