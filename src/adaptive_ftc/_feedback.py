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
    from adaptive_ftc.sim import codegen
    from adaptive_ftc.sim.compose import _INTEGRATORS_IMPORTS, _integrators_source, is_compiled

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
    shared = not codegen.is_cached(_integrators_source(), _INTEGRATORS_IMPORTS, kind="integrators")
    seconds = n * SECONDS_PER_STRUCTURE + (SECONDS_SHARED if n and shared else 0.0)
    return n, seconds


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
