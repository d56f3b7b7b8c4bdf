"""The parts of a generated closed loop, one module each (see :mod:`.base` for the interface
and :mod:`.skeleton` for the hooks they fill).

:func:`parts` lists them in build order: the order in which they emit code (their numbers'
places in ``D.c`` follow it) and claim states (plant, theta, the design's states, the
allocator's, the constraint-aware option's, the s' filter, then actuators, held values,
delay states and a decimating controller's sums), and the order of their helpers
(``tables``) in the module. A new part is a new module here and one entry in :func:`parts`.
"""

from __future__ import annotations

from adaptive_ftc.sim.parts.actuator import Actuator
from adaptive_ftc.sim.parts.allocation import Allocation
from adaptive_ftc.sim.parts.approximator import Approximator
from adaptive_ftc.sim.parts.base import Build, Part, StateAllocator
from adaptive_ftc.sim.parts.constraint_aware import ConstraintAware
from adaptive_ftc.sim.parts.decimation import Decimation
from adaptive_ftc.sim.parts.delay import Delay
from adaptive_ftc.sim.parts.design import Design
from adaptive_ftc.sim.parts.failures import Failures
from adaptive_ftc.sim.parts.plant import Plant
from adaptive_ftc.sim.parts.reference import Reference
from adaptive_ftc.sim.parts.sampler import Sampler
from adaptive_ftc.sim.parts.sdot import SDot
from adaptive_ftc.sim.parts.sensor import Sensor

__all__ = ["Build", "Part", "StateAllocator", "parts"]


def parts() -> tuple[Part, ...]:
    """Fresh parts of one loop, in build order (each keeps what it emitted for this loop)."""
    return (
        Reference(),
        Plant(),
        Approximator(),
        Design(),
        Allocation(),
        ConstraintAware(),
        SDot(),
        Failures(),
        Actuator(),
        Sensor(),
        Sampler(),
        Delay(),
        Decimation(),
    )
