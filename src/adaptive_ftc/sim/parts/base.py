"""The interface of a part of a generated closed loop, and the state allocator they share.

A part (plant, design law, approximator, allocation, actuator, sensor, sampler, s' filter,
failures, reference...) is one small class: :meth:`Part.build` emits its code through the
:class:`~adaptive_ftc.sim.compose.Generator` and claims its states from the one
:class:`StateAllocator`; :meth:`Part.rhs` and :meth:`Part.jump` give the lines it puts at the
named hooks of the skeleton (``sim/parts/skeleton.py``); :meth:`Part.tables` the module-level
helpers that read its numbers from ``D``; :meth:`Part.params` its named blocks of ``D.c``
(:data:`~adaptive_ftc.sim.layout.PARAMS`). Parts learn about the loop from :class:`Build` and
about each other's states only through the allocator's names.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["Build", "Part", "StateAllocator"]


@dataclass
class StateAllocator:
    """Hands out the places of the loop's states ``Y``, in the order the parts claim them."""

    blocks: dict[str, slice] = field(default_factory=dict)
    labels: dict[str, tuple[str, ...]] = field(default_factory=dict)
    controller: list[str] = field(default_factory=list)
    size: int = 0

    def claim(self, name: str, n: int, labels=(), *, controller: bool = False) -> int:
        """Claim ``n`` states named ``name`` (``labels``: one name per state, for the states
        after the controller's); returns where they start. ``controller``: states of the
        control law (integrated, held by a digital controller)."""
        if name in self.blocks:
            raise ValueError(f"The states '{name}' are claimed twice.")
        start = self.size
        self.blocks[name] = slice(start, start + n)
        self.labels[name] = tuple(labels)
        if controller:
            self.controller.append(name)
        self.size += n
        return start

    def __getitem__(self, name: str) -> slice:
        return self.blocks[name]

    @property
    def controller_stop(self) -> int:
        """Where the states of the control law end (plant and controller states before)."""
        return max((self.blocks[n].stop for n in self.controller), default=0)

    def labels_after(self, stop: int) -> tuple[str, ...]:
        """The labels of the blocks from ``stop`` on, in order."""
        return tuple(
            lab for name, sl in self.blocks.items() if sl.start >= stop for lab in self.labels[name]
        )


@dataclass
class Build:
    """What the parts of one loop share while they emit: the generator, the loop, the bound
    design, the s' mode, the state allocator and which optional parts the loop has."""

    g: Any  # sim.compose.Generator
    loop: Any  # sim.system.ClosedLoop
    ctrl: Any  # the design, bound to the loop
    sdot: str
    states: StateAllocator = field(default_factory=StateAllocator)
    #: the regressors' parameter blocks (phi offset, state index, size), set by the
    #: approximator, used by the design law
    blocks: list = field(default_factory=list)
    #: work buffers of parts beyond ``layout.WORK`` (name -> size), after those
    work: dict[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        loop = self.loop
        self.has_act = bool(loop.has_actuator_dynamics)
        self.sampled = loop.sample_time > 0
        self.has_meas = loop.sensors is not None
        self.has_act2 = (
            self.has_act
            and loop.actuators is not None
            and any(v > 0 for v in np.ravel(loop.actuators.omega))
        )
        self.has_delay = loop.actuators is not None and loop.actuators.has_delay
        #: sensor readings a digital controller's decimation filter averages per sample (the
        #: design's model asks for it: ConstraintAware.readings); 1 = none
        self.readings = decimation_readings(loop, self.ctrl) if self.sampled else 1
        #: what the controller reads of state ``i`` (generated code)
        self.measured = "measured(x, Y, ph, i, D)" if self.readings > 1 else "x[i] + meas(ph, i, D)"
        self.g.measured = self.measured

    @property
    def nx(self) -> int:
        return self.g.nx

    @property
    def p(self) -> int:
        return self.g.p

    @property
    def m(self) -> int:
        return self.g.m


def decimation_readings(loop, ctrl) -> int:
    """The number ``N`` of sensor readings per sample that the digital controller ``ctrl``
    (bound to ``loop``) averages (its model's
    :attr:`~adaptive_ftc.controllers.constraints.ConstraintAware.readings`); 1 = none. The
    loop's sensors must give those ``N`` readings per sample."""
    import math

    from adaptive_ftc.errors import ConfigurationError

    ca = getattr(ctrl, "constraint_aware", None)
    if ca is None or ca.is_ideal or not loop.sample_time > 0:
        return 1
    n = ca.readings
    if n > 1:
        have = loop.sample_time * loop.sensors.rate if loop.sensors is not None else 0.0
        if not math.isclose(have, n, rel_tol=1e-9):
            got = (
                f"the loop's sensors give {have:g} (rate {loop.sensors.rate:g} Hz)"
                if loop.sensors is not None
                else "the loop declares no sensors"
            )
            raise ConfigurationError(
                f"The design's decimation filter averages {n} sensor readings per sample "
                f"(its model: noise_rate {ca.noise_rate:g} Hz, sample_time "
                f"{ca.sample_time:g} s), but {got} every {loop.sample_time:g} s: declare the "
                "loop's sensor rate in the model (`noise_rate`) or set `decimation = false`."
            )
    return n


class Part:
    """One part of a generated loop (see the module docstring). Every method has a default
    that contributes nothing, so a part implements only what it has."""

    #: the recorded signals it owns (names of :data:`~adaptive_ftc.sim.layout.RECORDS`; the
    #: shared ``signals`` computes them, in the columns of ``RecordLayout``)
    records: tuple[str, ...] = ()

    def build(self, b: Build) -> None:
        """Emit through ``b.g`` and claim states from ``b.states`` (parts build in order)."""

    def functions(self, b: Build) -> list[str]:
        """Module-level functions placed before the parts' generated definitions."""
        return []

    def helpers(self, b: Build) -> list[str]:
        """Module-level functions placed after the parts' generated definitions."""
        return []

    def rhs(self, b: Build) -> dict[str, list[str]]:
        """Lines of the right-hand side per hook (``skeleton.RHS_HOOKS``)."""
        return {}

    def jump(self, b: Build) -> dict[str, list[str]]:
        """Lines of ``jump`` (the state update at an interval's start) per hook."""
        return {}

    def jump_uses_scratch(self, b: Build) -> bool:
        """Whether its ``jump`` lines use the ``scratch`` and ``misc`` views."""
        return False

    def tables(self, b: Build) -> list[str]:
        """Module-level helpers that read the part's numbers from ``D`` (after ``jump``)."""
        return []

    def params(self, b: Build) -> dict[str, tuple[float, ...]]:
        """Its named blocks of ``D.c`` (:data:`~adaptive_ftc.sim.layout.PARAMS`)."""
        return {}
