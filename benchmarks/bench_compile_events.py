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
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

DEFAULT_COMMAND = ["run", "hypersonic-direct-s1", "--no-figures", "--quiet"]


@dataclass
class CompileTimes:
    """A ``numba.core.event.Listener`` body: CPU seconds per compiled function, self and
    inclusive (nested compiles are subtracted from their caller's self time)."""

    clock: object = time.process_time
    #: name -> [compiles, self seconds, inclusive seconds]
    table: dict[str, list] = field(default_factory=dict)
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
        row = self.table.setdefault(name, [0, 0.0, 0.0])
        row[0] += 1
        row[1] += total - nested
        row[2] += total
        if self._stack:
            self._stack[-1][2] += total

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


def main(argv: list[str]) -> int:
    command = argv or DEFAULT_COMMAND
    with tempfile.TemporaryDirectory(prefix="aftc-bench-compile-") as tmp:
        # before numba is imported: it reads NUMBA_CACHE_DIR once
        os.environ["ADAPTIVE_FTC_CACHE_DIR"] = str(Path(tmp) / "loops")
        os.environ["NUMBA_CACHE_DIR"] = str(Path(tmp) / "numba")
        if command[0] in ("run", "reproduce") and "--out" not in command:
            command = [*command, "--out", str(Path(tmp) / "out")]
        from numba.core import event

        times = CompileTimes()
        event.register("numba:compile", listener(times))
        from adaptive_ftc import cli

        t0, w0 = time.process_time(), time.perf_counter()
        try:
            code = cli.main(command)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
        cpu, wall = time.process_time() - t0, time.perf_counter() - w0
    compiled = times.total_self()
    print(
        f"\naftc {' '.join(command[:2])}: {cpu:.2f} s CPU ({wall:.2f} s wall, load "
        f"{os.getloadavg()[0]:.1f}); compiling {compiled:.2f} s CPU ({compiled / cpu:.0%})"
    )
    print(f"{'function':<34} {'compiles':>8} {'self s':>8} {'incl. s':>8}")
    for name, n, own, incl in times.rows():
        print(f"{name:<34} {n:>8} {own:>8.2f} {incl:>8.2f}")
    return int(code or 0)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
