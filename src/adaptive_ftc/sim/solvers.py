"""The registry of solver methods: every name :class:`~adaptive_ftc.SolverOptions` accepts.

One place lists the methods; what validates a method, picks its compiled entry point, lists the
CLI's ``--method`` choices, orders the shared integrators' compiles and renders the methods
table of docs/solvers.md reads it. Adding a compiled adaptive method is one entry here, its
step functions and an entry in ``_CORES`` of ``sim/templates/adaptive.py`` (a test checks that
the two agree).

Examples
--------
>>> method("dopri5").entry
'integrate_dopri5'
>>> method("accurate").compiled
'auto'
>>> "LSODA" in names(kind="scipy")
True
"""

from __future__ import annotations

from dataclasses import dataclass

from adaptive_ftc.errors import ConfigurationError, did_you_mean

__all__ = ["METHODS", "SolverMethod", "compiled_entries", "method", "methods_table", "names"]

#: what a method is: a compiled fixed-step or adaptive-step integrator, an alias of another
#: method, or a method of :func:`scipy.integrate.solve_ivp`
KINDS = ("fixed", "adaptive", "alias", "scipy")


@dataclass(frozen=True, kw_only=True)
class SolverMethod:
    """One solver method.

    Parameters
    ----------
    name
        The name ``SolverOptions(method=...)`` and ``aftc run --method`` take.
    kind
        One of :data:`KINDS`.
    summary
        One line for the docs' table.
    alias_of
        For an alias: the method it runs.
    compile_cost
        Rank of the compile time of its shared integrator (larger compiles longer; cold cache):
        a batch of runs compiles the costliest first.
    """

    name: str
    kind: str
    summary: str
    alias_of: str | None = None
    compile_cost: int = 0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ConfigurationError(
                f"`kind` of SolverMethod {self.name!r} must be one of {', '.join(KINDS)}; "
                f"got {self.kind!r}."
            )
        if (self.kind == "alias") != (self.alias_of is not None):
            raise ConfigurationError(
                f"SolverMethod {self.name!r}: give `alias_of` exactly when `kind` is 'alias'."
            )

    @property
    def compiled(self) -> str | None:
        """The compiled method this one runs (``None``: scipy)."""
        if self.kind == "alias":
            return method(str(self.alias_of)).compiled
        return self.name if self.kind in ("fixed", "adaptive") else None

    @property
    def entry(self) -> str | None:
        """The name of its compiled entry point in the shared integrators module."""
        compiled = self.compiled
        return None if compiled is None else f"integrate_{compiled}"


_SCIPY = "scipy.integrate.solve_ivp's {} (slow; a cross-check)"

#: every method, in the order the docs and the CLI list them
METHODS: tuple[SolverMethod, ...] = (
    SolverMethod(
        name="rk4",
        kind="fixed",
        summary="classical RK4, fixed step `dt`, steps land on every break (default)",
        compile_cost=1,
    ),
    SolverMethod(
        name="dopri5",
        kind="adaptive",
        summary="Dormand-Prince 5(4), PI step control, 4th-order dense output (non-stiff)",
        compile_cost=2,
    ),
    SolverMethod(
        name="rodasp",
        kind="adaptive",
        summary="RODASP (Rodas4P) Rosenbrock 4(3), L-stable, finite-difference Jacobian (stiff)",
        compile_cost=3,
    ),
    SolverMethod(
        name="rodas5p",
        kind="adaptive",
        summary="Rodas5P Rosenbrock 5(4), 4th-order dense output (stiff, tight tolerances)",
        compile_cost=3,
    ),
    SolverMethod(
        name="auto",
        kind="adaptive",
        summary="DOPRI5 switching to RODASP while the loop is stiff, and back",
        compile_cost=4,
    ),
    SolverMethod(
        name="accurate",
        kind="alias",
        alias_of="auto",
        summary='`"auto"` (kept for old scenario files)',
    ),
    *(
        SolverMethod(name=n, kind="scipy", summary=_SCIPY.format(n))
        for n in ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")
    ),
)

_BY_NAME = {m.name: m for m in METHODS}


def names(kind: str | None = None) -> tuple[str, ...]:
    """The names of the registered methods (of one ``kind`` of :data:`KINDS`)."""
    return tuple(m.name for m in METHODS if kind is None or m.kind == kind)


def method(name: str) -> SolverMethod:
    """The registered method ``name``; a :class:`ConfigurationError` naming the choices if
    there is none."""
    found = _BY_NAME.get(name) if isinstance(name, str) else None
    if found is None:
        every = names()
        raise ConfigurationError(
            f"Unknown solver method {name!r}.{did_you_mean(str(name), every)} "
            f"Use one of {', '.join(every)}."
        )
    return found


def compiled_entries() -> tuple[str, ...]:
    """The compiled entry points of the shared integrators module, one per compiled method."""
    return tuple(dict.fromkeys(m.entry for m in METHODS if m.entry is not None))


def methods_table() -> str:
    """The Markdown table of every method (docs/solvers.md holds it between markers)."""
    lines = ["| method | kind | what it is |", "|---|---|---|"]
    for m in METHODS:
        lines.append(f"| `{m.name}` | {m.kind} | {m.summary} |")
    return "\n".join(lines)
