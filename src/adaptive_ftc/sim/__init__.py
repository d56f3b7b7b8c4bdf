"""Simulation: closed loop, engine, results and metrics.

The public names and the submodules are imported on first use (PEP 562 ``__getattr__``), so
that importing a light submodule (``adaptive_ftc.sim.solvers``, the solver registry that
``aftc run --help`` lists) does not import the engine, numpy and the compiler with it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from adaptive_ftc._lazy import lazy_attributes

if TYPE_CHECKING:
    from adaptive_ftc.sim.engine import SolverOptions, simulate
    from adaptive_ftc.sim.result import SimResult
    from adaptive_ftc.sim.stepper import ControllerSample, DigitalStepper
    from adaptive_ftc.sim.system import ClosedLoop

__all__ = [
    "ClosedLoop",
    "ControllerSample",
    "DigitalStepper",
    "SimResult",
    "SolverOptions",
    "simulate",
]

#: public name -> the module that defines it
_LAZY = {
    "ClosedLoop": "adaptive_ftc.sim.system",
    "ControllerSample": "adaptive_ftc.sim.stepper",
    "DigitalStepper": "adaptive_ftc.sim.stepper",
    "SimResult": "adaptive_ftc.sim.result",
    "SolverOptions": "adaptive_ftc.sim.engine",
    "simulate": "adaptive_ftc.sim.engine",
}

__getattr__, __dir__ = lazy_attributes(globals(), _LAZY, submodules=True)
