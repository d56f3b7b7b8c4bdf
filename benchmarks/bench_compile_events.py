"""What a first run compiles: numba's compile events of one `aftc` command with empty caches.

Run: ``python benchmarks/bench_compile_events.py [run hypersonic-direct-s1 --no-figures]``
(the arguments after the script are the ``aftc`` command; that one by default).

Runs the command in this process with new, empty temporary caches (``ADAPTIVE_FTC_CACHE_DIR``,
``NUMBA_CACHE_DIR``) and a listener on numba's ``numba:compile`` events, then prints, per
compiled Python function, how many times it compiled and the CPU seconds of its own compiles
("self": the time of the functions it compiled on the way, e.g. a non-inlined callee, is
counted there, not twice) beside the inclusive time, and the share of the command's CPU time
that compiling took. CPU time, not wall: on a shared machine a process waiting for a core uses
none. This is the profile behind the "what a cold run compiles" rows of docs/performance.md.

``aftc run`` compiles the shared integrators in a forked child while it compiles the loops'
structures itself (sim/precompile.py): the child's compiles are listed in a table of their own
(the listener is inherited by the fork and writes the child's rows to a file), with each
process's CPU time and the critical path they imply on an idle 2-core machine: the parent's
CPU up to its wait for the child, or the child's (started when the parent had used its CPU
up to the fork) if longer, plus the parent's CPU after the wait. ``--serial`` compiles
everything in one process, as before the overlap (for a before/after in one session).
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

DEFAULT_COMMAND = ["run", "hypersonic-direct-s1", "--no-figures", "--quiet"]


@dataclass
class CompileTimes:
    """A ``numba.core.event.Listener`` body: CPU seconds per compiled function, self and
    inclusive (nested compiles are subtracted from their caller's self time)."""

    clock: Any = time.process_time
    #: name -> [compiles, self seconds, inclusive seconds]
    table: dict[str, list] = field(default_factory=dict)
    #: where a forked child (another process id than ``pid``) appends its rows, one a compile
    #: (``name<TAB>self<TAB>inclusive``): its own table dies with it
    log: Path | None = None
    pid: int = field(default_factory=os.getpid)
    _stack: list[list] = field(default_factory=list)

    def start(self, name: str) -> None:
        self._stack.append([name, self.clock(), 0.0])

    def end(self, name: str) -> None:
        if not self._stack or self._stack[-1][0] != name:
            raise RuntimeError(
                f"numba compile event for {name!r} ended out of order "
                f"(open: {[s[0] for s in self._stack]}); the listener was installed mid-compile."
            )
        _, t0, nested = self._stack.pop()
        total = self.clock() - t0
        if self._stack:
            self._stack[-1][2] += total
        if self.log is not None and os.getpid() != self.pid:
            with open(self.log, "a", encoding="utf-8") as f:
                f.write(f"{name}\t{total - nested}\t{total}\n")
            return
        self.add(name, total - nested, total)

    def add(self, name: str, own: float, total: float) -> None:
        row = self.table.setdefault(name, [0, 0.0, 0.0])
        row[0] += 1
        row[1] += own
        row[2] += total

    @classmethod
    def read(cls, log: Path) -> CompileTimes:
        """The table of the rows a child appended to ``log``."""
        times = cls()
        if log.is_file():
            for line in log.read_text(encoding="utf-8").splitlines():
                name, own, total = line.split("\t")
                times.add(name, float(own), float(total))
        return times

    def rows(self) -> list[tuple[str, int, float, float]]:
        """(name, compiles, self s, inclusive s), the costliest (self) first."""
        return sorted(((k, *v) for k, v in self.table.items()), key=lambda r: -r[2])

    def total_self(self) -> float:
        return sum(v[1] for v in self.table.values())


def listener(times: CompileTimes):
    """A numba event listener feeding ``times`` (register with
    ``numba.core.event.register("numba:compile", ...)``)."""
    from numba.core import event

    class _Listener(event.Listener):
        def on_start(self, ev):
            times.start(ev.data["dispatcher"].py_func.__qualname__)

        def on_end(self, ev):
            times.end(ev.data["dispatcher"].py_func.__qualname__)

    return _Listener()


def _table(times: CompileTimes) -> None:
    print(f"{'function':<34} {'compiles':>8} {'self s':>8} {'incl. s':>8}")
    for name, n, own, incl in times.rows():
        print(f"{name:<34} {n:>8} {own:>8.2f} {incl:>8.2f}")


def main(argv: list[str]) -> int:
    serial = "--serial" in argv
    command = [a for a in argv if a != "--serial"] or DEFAULT_COMMAND
    with tempfile.TemporaryDirectory(prefix="aftc-bench-compile-") as tmp:
        # before numba is imported: it reads NUMBA_CACHE_DIR once
        os.environ["ADAPTIVE_FTC_CACHE_DIR"] = str(Path(tmp) / "loops")
        os.environ["NUMBA_CACHE_DIR"] = str(Path(tmp) / "numba")
        if command[0] in ("run", "reproduce") and "--out" not in command:
            command = [*command, "--out", str(Path(tmp) / "out")]
        from numba.core import event

        from adaptive_ftc.sim import precompile

        times = CompileTimes(log=Path(tmp) / "child.log")
        event.register("numba:compile", listener(times))
        marks: dict[str, float] = {}
        start, wait = precompile.SharedCompile.start, precompile.SharedCompile.wait
        if serial:
            precompile.SharedCompile.start = classmethod(lambda cls, jobs: None)  # type: ignore
        else:

            def timed_start(cls, jobs):
                try:
                    return start.__func__(cls, jobs)
                finally:  # the child is forked at the end of start()
                    marks["fork"] = time.process_time() - t0

            def timed_wait(self):
                marks["wait"] = time.process_time() - t0
                w = time.perf_counter()
                try:
                    return wait(self)
                finally:
                    marks["waited"] = time.perf_counter() - w

            precompile.SharedCompile.start = classmethod(timed_start)  # type: ignore
            precompile.SharedCompile.wait = timed_wait  # type: ignore
        from adaptive_ftc import cli

        t0, w0, c0 = time.process_time(), time.perf_counter(), os.times()
        try:
            code = cli.main(command)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
        cpu, wall, c1 = time.process_time() - t0, time.perf_counter() - w0, os.times()
        children = (c1.children_user - c0.children_user) + (c1.children_system - c0.children_system)
        child = CompileTimes.read(Path(tmp) / "child.log")
    compiled = times.total_self()
    print(
        f"\naftc {' '.join(command[:2])}{' (--serial)' if serial else ''}: {cpu:.2f} s CPU "
        f"here, {children:.2f} s in child processes ({wall:.2f} s wall, load "
        f"{os.getloadavg()[0]:.1f}); compiling {compiled:.2f} s CPU here ({compiled / cpu:.0%})"
        + (f", {child.total_self():.2f} s in the compile child" if child.table else "")
    )
    _table(times)
    if child.table:
        print("\nthe compile child (sim/precompile.py):")
        _table(child)
    if "wait" in marks:
        post = cpu - marks["wait"]
        path = max(marks["wait"], marks["fork"] + child.total_self()) + post
        print(
            f"\nforked at {marks['fork']:.2f} s CPU; waited for the child from "
            f"{marks['wait']:.2f} s CPU ({marks['waited']:.2f} s wall); {post:.2f} s CPU after; "
            f"critical path on an idle 2-core machine about {path:.2f} s of CPU (the parent's "
            f"{cpu:.2f} s and the child's compiles, each on a core of its own)"
        )
    return int(code or 0)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
