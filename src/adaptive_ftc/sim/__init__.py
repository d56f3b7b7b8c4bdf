"""Simulation: closed loop, engine, results and metrics."""

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
