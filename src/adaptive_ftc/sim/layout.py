"""The memory of a compiled closed loop, named once: :class:`LoopLayout`.

Inside compiled code a loop's numbers, integers, states and scratch buffers are flat arrays
(``D.c``, ``D.i``, ``Y``, ``W``: see :class:`~adaptive_ftc.sim.compose.LoopData`). This module
is the one place that says what lives where; the generator (``sim/compose.py`` and the parts of
``sim/parts/``) writes the places into the generated text, and everything that reads a loop's
arrays from Python (results, the run-size budget, the recorded signals) asks a
:class:`LoopLayout` or the tables below instead of counting offsets of its own.

- :class:`Header`: the header of ``D.i`` (sizes, then where each table starts).
- :data:`WORK`: the buffers of the work array ``W`` in their order.
- :class:`Misc`: the slots of the work buffer ``misc``.
- :class:`SignalTable`: the table the shared ``signals`` reads at ``D.i[I_SIGT]``.
- :data:`PARAMS`: the named blocks of ``D.c`` after the expressions' constants, in order.
- :class:`RecordLayout`: the columns of the recorded signals (names, sizes, units).
"""

from __future__ import annotations

import enum
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field

__all__ = [
    "HEADER",
    "PARAMS",
    "RECORDS",
    "SIGNAL_WORK",
    "WORK",
    "Header",
    "LoopLayout",
    "Misc",
    "RecordLayout",
    "SignalTable",
]


class Header(enum.IntEnum):
    """The header of ``LoopData.i``: sizes, then where each table starts (in ``i`` or ``c``),
    then the envelope (its start in ``c``, its length), the addresses of the compiled ``rhs``,
    ``jump`` (0 for a continuous loop: none) and the plant's ``control_gain`` that the shared
    integrators and ``signals`` call (``sim/fptr.py``; set by ``assemble``), where the
    :class:`SignalTable` starts and the interval a call of the integrators starts at. The
    failure instance per (interval, actuator) follows the header (from :meth:`head` on)."""

    NPH = 0  # intervals of the integration
    M = 1  # actuators
    NX = 2  # plant states
    NINST = 3  # failure instances
    INST = 4  # the instance table (in i)
    SAMP = 5  # the sample flags (in i)
    ACT = 6  # the actuator table (in c)
    MEAS = 7  # the measurement table (in c)
    ENV = 8  # the envelope (in c)
    NENV = 9  # its length
    RHS = 10  # address of the compiled rhs
    JUMP = 11  # address of the compiled jump (0: none)
    GAIN = 12  # address of the plant's control_gain
    SIGT = 13  # the signal table (in i)
    #: the loop's interval where a call of the shared integrators starts (0 for a whole run;
    #: :class:`~adaptive_ftc.sim.stepper.DigitalStepper` integrates one interval at a time)
    PH0 = 14

    @classmethod
    def head(cls) -> int:
        """Where the failure instance per (interval, actuator) starts in ``i``."""
        return len(cls)


#: the names of :class:`Header` in order (the generated modules' ``I_<name>`` constants)
HEADER: tuple[str, ...] = tuple(h.name for h in Header)

#: The work array of one run, as named buffers in this order: controller signals
#: [x, e, e', s], regressor values, memberships, u0, commands, applied outputs, plant
#: derivative, reference (y_d, y_d', y_d'' per output), q, misc (:class:`Misc`), design basis
#: values, scratch derivative (for ``jump``), the failure values remembered per actuator.
WORK: tuple[str, ...] = (
    *("sig", "phi", "mu", "u0", "u", "uf", "xdot", "ref", "q", "misc", "wb", "scr", "fc"),
)
#: the work buffers whose places the shared ``signals`` reads (:class:`SignalTable`)
SIGNAL_WORK: tuple[str, ...] = ("sig", "ref", "xdot", "q", "u0", "u", "uf", "misc")


class Misc(enum.IntEnum):
    """The slots of the work buffer ``misc`` (8 long)."""

    UF_COMP = 0  # the design's compensation of the failures (recorded as ``u_f``)
    GAIN = 1  # the design's adaptive gain N(tau) or rho (recorded as ``gain``)
    SDOT_USED = 2  # the s' of output 1 the robust term used
    REF_VALID = 3  # 1 while ``ref`` holds the reference at REF_TIME
    REF_TIME = 4  # the time of the reference in ``ref``
    SAMPLING = 5  # 1 while ``jump`` computes a controller sample

    @classmethod
    def size(cls) -> int:
        return 8


class SignalTable(enum.IntEnum):
    """The table of the shared ``signals`` at ``D.i[I_SIGT]``: the number of outputs, the
    places of the :data:`SIGNAL_WORK` buffers in ``W``, of ``lam`` and ``R`` in ``D.c``, then
    the outputs' position states (``P``), their rate states (``P``) and where the plant's
    numbers start in ``D.c``."""

    P = 0
    SIG = 1
    REF = 2
    XDOT = 3
    Q = 4
    U0 = 5
    U = 6
    UF = 7
    MISC = 8
    LAM = 9
    RMAT = 10
    POS = 11  # P entries, then the P rate indices, then the plant's start in D.c


#: the named blocks of ``D.c`` after the expressions' constants, in order: name -> the
#: generated module's constant for its start. A part fills the blocks it owns; ``delay`` is
#: present only when an actuator has an input delay, ``alloc`` only with an allocator.
PARAMS: Mapping[str, str] = {
    "lam": "LAM",
    "k": "K",
    "k0": "K0",
    "R": "RMAT",
    "eps0": "EPS0",
    "filter_tau": "FTAU",
    "adapt": "ADAPT",
    "centers": "CEN",
    "spread": "SPREAD",
    "act0": "ACT0",
    "envelope": "ENV",
    "gains": "GAINS",
    "plant": "PLANT",
    "delay": "DELAY",
    "alloc": "ALLOC",
}


#: the recorded signals in column order: (name, per, unit). ``per``: "output" (one column
#: per output), "actuator" (one per actuator) or "one"; ``unit``: "output" (the output's
#: unit), "rate" (the output's unit per second), "command" (the actuators' command unit) or
#: "" (none or mixed)
RECORDS: tuple[tuple[str, str, str], ...] = (
    ("y", "output", "output"),
    ("yd", "output", "output"),
    ("yd_dot", "output", "rate"),
    ("e", "output", "output"),
    ("edot", "output", "rate"),
    ("s", "output", "rate"),
    ("sdot", "output", ""),
    ("q", "output", ""),
    ("u0", "output", "command"),
    ("u_cmd", "actuator", "command"),
    ("u_applied", "actuator", "command"),
    ("u_f", "one", "command"),
    ("gain", "one", ""),
    ("control_gain", "one", ""),
    ("sdot_used", "one", ""),
)


@dataclass(frozen=True)
class RecordLayout:
    """The columns of the recorded signals of a loop with ``p`` outputs and ``m`` actuators
    (what the shared ``signals`` writes, one row per recorded time).

    >>> r = RecordLayout(p=2, m=3)
    >>> r.width, r["u_cmd"], r["gain"]
    (28, slice(18, 21, None), slice(25, 26, None))
    """

    p: int
    m: int

    def __iter__(self) -> Iterator[tuple[str, slice, str]]:
        at = 0
        for name, per, unit in RECORDS:
            n = {"output": self.p, "actuator": self.m, "one": 1}[per]
            yield name, slice(at, at + n), unit
            at += n

    def __getitem__(self, name: str) -> slice:
        for key, where, _ in self:
            if key == name:
                return where
        raise KeyError(f"No recorded signal '{name}'; the signals are {self.names}.")

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(name for name, _, _ in RECORDS)

    @property
    def width(self) -> int:
        """Columns of one recorded row."""
        return 9 * self.p + 2 * self.m + 4


@dataclass(frozen=True)
class LoopLayout:
    """Where everything of one compiled loop lives: named slices of its state vector ``Y``,
    of ``D.c`` (parameters) and of the work array ``W``, and its recorded columns.

    Made by the generator (:func:`~adaptive_ftc.sim.compose.generate`); read through
    ``Assembled.layout``. ``layout["y:held_command"]``, ``layout["c:lam"]`` and
    ``layout["w:ref"]`` are the same places as ``layout.states["held_command"]``,
    ``layout.params["lam"]`` and ``layout.work["ref"]`` (a ``"y:"`` name only for states the
    loop has).
    """

    states: Mapping[str, slice]
    params: Mapping[str, slice]
    work: Mapping[str, slice]
    records: RecordLayout
    #: labels of the states after the controller's (actuators, held values, delay states)
    extra_names: tuple[str, ...] = ()
    n_states: int = 0
    #: the adaptive (controller) states in ``Y``: after the plant's, before the hardware's
    adaptive: slice = field(default_factory=lambda: slice(0, 0))
    _flat: Mapping[str, slice] = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        flat = {f"y:{k}": v for k, v in self.states.items() if v.stop > v.start}
        flat.update({f"c:{k}": v for k, v in self.params.items()})
        flat.update({f"w:{k}": v for k, v in self.work.items()})
        flat["w:size"] = slice(0, self.work_size)
        object.__setattr__(self, "_flat", flat)

    @property
    def work_size(self) -> int:
        """Length of the work array ``W``."""
        return max((s.stop for s in self.work.values()), default=0)

    def signal_table(self, pos, vel) -> tuple[int, ...]:
        """The :class:`SignalTable` of this loop (``pos``, ``vel``: the outputs' position
        and rate states), as the shared ``signals`` reads it from ``D.i``."""
        places = {
            SignalTable.P: len(pos),
            **{SignalTable[w.upper()]: self.work[w].start for w in SIGNAL_WORK},
            SignalTable.LAM: self.params["lam"].start,
            SignalTable.RMAT: self.params["R"].start,
        }
        head = [places[k] for k in SignalTable if k != SignalTable.POS]
        return (*head, *pos, *vel, self.params["plant"].start)

    def misc(self, slot: Misc) -> int:
        """Index of ``slot`` of the ``misc`` buffer in ``W``."""
        return self.work["misc"].start + int(slot)

    # the mapping of "c:<param>" / "w:<buffer>" names (the generator's flat names)
    def __getitem__(self, key: str) -> slice:
        try:
            return self._flat[key]
        except KeyError:
            known = sorted(self._flat)
            raise KeyError(f"No place '{key}' in the loop layout; known: {known}.") from None

    def __contains__(self, key: object) -> bool:
        return key in self._flat

    def keys(self):
        return self._flat.keys()

    def items(self):
        return self._flat.items()
