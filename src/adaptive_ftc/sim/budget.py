"""Run-size budget: refuse, before anything is allocated, runs that cannot finish.

A run with ``duration = 1e9`` s, ``record_dt = 1e-12`` s or ``dt = 1e-12`` s would try to
allocate hundreds of GiB or spin for days in compiled code. :func:`check_run_size` estimates
the integration steps, the recorded samples and the memory of the recorded data
(plant states + adaptive states + recomputed signals, times the samples, times 8 bytes) and
raises :class:`~adaptive_ftc.errors.ConfigurationError` with the estimate and the fix when a
limit below is exceeded. The scenario loader (and so ``aftc validate``/``aftc run``) calls it;
the engine's ``simulate()`` calls it too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim.layout import RecordLayout

if TYPE_CHECKING:  # pragma: no cover
    from adaptive_ftc.sim.engine import SolverOptions
    from adaptive_ftc.sim.system import ClosedLoop

__all__ = [
    "MAX_RECORDED_BYTES",
    "MAX_INTERVALS",
    "MAX_SAMPLES",
    "MAX_STEPS",
    "RunSize",
    "check_run_size",
    "estimate_run_size",
]

#: Largest recorded data of one run (states + signals x samples x 8 bytes): 2 GiB.
MAX_RECORDED_BYTES: int = 2 * 1024**3
#: Most integration steps of one run (fixed-step RK4 or the variable-step ``max_step`` bound).
MAX_STEPS: float = 5e8
#: Most recorded samples of one run.
MAX_SAMPLES: float = 5e7
#: Most controller (or sensor-noise) sample intervals of one run: each is an integration
#: restart with its own row of the failure, actuator and measurement tables.
MAX_INTERVALS: float = 2e7


@dataclass(frozen=True)
class RunSize:
    """Estimated size of one run (see :func:`estimate_run_size`).

    Attributes
    ----------
    steps
        Integration steps (``nan`` for a variable-step method without ``max_step``: unknown).
    samples
        Recorded samples.
    columns
        Recorded numbers per sample (plant states, adaptive states, signals).
    nbytes
        Memory of the recorded data in bytes.
    """

    steps: float
    samples: float
    columns: int
    nbytes: float

    def describe(self) -> str:
        """One line, e.g. ``"1.2e+05 steps, 1.2e+04 samples x 48 numbers = 4.4 MiB"``."""
        steps = "unknown steps" if math.isnan(self.steps) else f"{self.steps:.3g} steps"
        return (
            f"{steps}, {self.samples:.3g} recorded samples x {self.columns} numbers = "
            f"{_human(self.nbytes)}"
        )


def _human(nbytes: float) -> str:
    for unit, scale in (("TiB", 1024**4), ("GiB", 1024**3), ("MiB", 1024**2), ("KiB", 1024)):
        if nbytes >= scale:
            return f"{nbytes / scale:.3g} {unit}"
    return f"{nbytes:.0f} B"


def _adaptive_count(loop: Any) -> int:
    """Upper estimate of the adaptive states: every regressor parameter plus the per-actuator
    and per-output extras of the designs (kappa, tau, rho, filters)."""
    ctrl = loop.controller
    try:
        regs = ctrl.regressors()
        n_reg = sum(int(r.size) for r in regs)
    except Exception:  # noqa: BLE001 - an estimate: fall back to a generous guess
        n_reg = 64
    p, m = loop.plant.n_outputs, loop.plant.n_actuators
    return n_reg * max(1, p) + 4 * m + 4 * p + 4


def estimate_run_size(loop: ClosedLoop, solver: SolverOptions) -> RunSize:
    """Estimate steps, recorded samples and recorded bytes of ``simulate(loop, solver)``.

    Steps: ``(t_final - t0) / dt`` for the fixed-step ``"rk4"`` method, ``/ max_step`` for the
    variable-step methods when ``max_step`` is finite (an upper bound of the step count's lower
    bound), else unknown. Samples: ``(t_final - t0) / record_dt + 1`` plus one per failure time.
    Bytes: ``samples x (n_states + n_adaptive + recorded signals) x 8`` (the recorded
    signals: :class:`~adaptive_ftc.sim.layout.RecordLayout`, ``9 p + 2 m + 4`` columns).
    """
    span = float(loop.t_final) - float(loop.t0)
    n_events = len(getattr(loop.failures, "failures", ())) * 2
    if solver.method == "rk4":
        steps = span / float(solver.dt) + n_events
    elif math.isfinite(float(solver.max_step)):
        steps = span / float(solver.max_step) + n_events
    else:
        steps = math.nan
    samples = span / float(solver.record_dt) + 1 + n_events
    p, m, n = loop.plant.n_outputs, loop.plant.n_actuators, loop.plant.n_states
    columns = n + _adaptive_count(loop) + RecordLayout(p=p, m=m).width
    return RunSize(steps=steps, samples=samples, columns=columns, nbytes=samples * columns * 8.0)


def check_run_size(loop: ClosedLoop, solver: SolverOptions) -> RunSize:
    """Raise when a run would exceed :data:`MAX_STEPS`, :data:`MAX_SAMPLES` or
    :data:`MAX_RECORDED_BYTES`; return the estimate otherwise.

    Raises
    ------
    ConfigurationError
        Naming the estimate, the limit and the setting to change (``duration``,
        ``solver.dt``, ``solver.record_dt``).

    Examples
    --------
    >>> from adaptive_ftc import load_scenario
    >>> sc = load_scenario("hypersonic-direct-s1")
    >>> check_run_size(sc.loop, sc.solver).samples
    12005.0
    """
    size = estimate_run_size(loop, solver)
    span = float(loop.t_final) - float(loop.t0)
    what = f"The run of {span:g} s ({size.describe()})"
    if size.steps > MAX_STEPS:
        raise ConfigurationError(
            f"{what} needs more than {MAX_STEPS:.3g} integration steps. Increase `solver.dt` "
            f"(now {solver.dt:g} s; >= {span / MAX_STEPS:.3g} s fits) or shorten `duration`."
        )
    period = float(getattr(loop, "sample_time", 0.0) or 0.0)
    sensors = getattr(loop, "sensors", None)
    by_sensor = False
    if (
        sensors is not None
        and sensors.has_noise
        and (not period or 1.0 / float(sensors.rate) < period)
    ):  # a noise draw per reading, a digital controller's faster sensor too
        period, by_sensor = 1.0 / float(sensors.rate), True
    if period and span / period > MAX_INTERVALS:
        what_t = "the sensors' noise `rate`" if by_sensor else "`sample_time`"
        raise ConfigurationError(
            f"{what} has {span / period:.3g} controller/sensor samples, more than the limit of "
            f"{MAX_INTERVALS:.3g}. Make {what_t} coarser (a period >= {span / MAX_INTERVALS:.3g} "
            "s fits) or shorten `duration`."
        )
    if size.samples > MAX_SAMPLES or size.nbytes > MAX_RECORDED_BYTES:
        fit = span * size.columns * 8.0 / MAX_RECORDED_BYTES
        fit = max(fit, span / MAX_SAMPLES)
        raise ConfigurationError(
            f"{what} would record more than the limit of {_human(MAX_RECORDED_BYTES)} / "
            f"{MAX_SAMPLES:.3g} samples. Increase `solver.record_dt` (now "
            f"{solver.record_dt:g} s; >= {fit:.3g} s fits) or shorten `duration`."
        )
    return size
