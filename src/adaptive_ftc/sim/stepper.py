"""Advance a digital closed loop one controller sample at a time, its command set from outside.

A digital controller (``ClosedLoop(sample_time=T)``, :mod:`adaptive_ftc.hardware`) computes its
command at the instants ``t0 + k T`` and holds it; :func:`~adaptive_ftc.simulate` runs the
whole loop in one compiled call. :class:`DigitalStepper` runs the *same* compiled loop (the
same generated module, the same shared integrators, the same intervals and tables) interval
by interval, and between :meth:`~DigitalStepper.sample` (the controller's sample: the
design's command computed and held) and :meth:`~DigitalStepper.advance` (the plant and every
state integrated to the next sample) the held command may be replaced: by a learned policy's
command, a residual added to the design's, or the output of an exported controller.

A design with the decimation filter (``ConstraintAware.decimation``: the mean of the ``N``
sensor readings of each sample) steps too: :meth:`~DigitalStepper.advance` runs the loop's
update at each reading instant between two samples (the reading added to the filter's sum,
as the simulator's loop does there) and stops at the next sample only; the measurement
handed out is the mean the design reads.

With the design's own command kept, the states at every sample are the simulator's: bit for
bit with ``rk4`` and ``dopri5``, whose steps do not depend on the recorded times, and with the
Rosenbrock methods when the simulator records only at sample instants (a record inside an
interval adds a dense-output check there that can change their steps). ``auto`` restarts its
stiffness detection at each sample: it agrees to the tolerances only. The scipy methods are
refused (no compiled integrator).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim.compose import assemble, integrators
from adaptive_ftc.sim.engine import SolverOptions
from adaptive_ftc.sim.layout import Header
from adaptive_ftc.sim.parts.decimation import SAMPLE
from adaptive_ftc.sim.status import RunStatus, StatusReason
from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["ControllerSample", "DigitalStepper"]


@dataclass(frozen=True)
class ControllerSample:
    """What a digital controller sees at one sample instant, and what the design commands.

    Attributes
    ----------
    time
        The sample instant (s).
    state
        The true plant state.
    measured
        The measured plant state: ``state`` plus the sensors' bias and noise of this sample
        (with the design's decimation filter: the mean of the period's sensor readings).
    reference
        ``y_d, y_d', y_d''`` per output (``3 p`` values, output by output).
    command
        The design's command ``u = R^T u0`` (one per actuator), held unless replaced.
    """

    time: float
    state: np.ndarray
    measured: np.ndarray
    reference: np.ndarray
    command: np.ndarray


class DigitalStepper:
    """A digital closed loop advanced sample by sample, with its held command settable.

    Parameters
    ----------
    loop
        A closed loop with a digital controller (``sample_time > 0``).
    solver
        How the plant is integrated between samples (default: compiled RK4, ``dt = 1e-3``);
        a compiled method (``rk4``, ``dopri5``, ``rodasp``, ``rodas5p``, ``auto``).

    Examples
    --------
    >>> from dataclasses import replace
    >>> from adaptive_ftc import load_scenario
    >>> sc = load_scenario("hypersonic-direct-s1-digital")
    >>> st = DigitalStepper(replace(sc.loop, t_final=0.02), sc.solver)
    >>> while not st.done:
    ...     s = st.sample()
    ...     status, reason = st.advance(s.command)  # the design's own command
    >>> round(st.time, 3), status
    (0.02, 'completed')
    """

    def __init__(self, loop: ClosedLoop, solver: SolverOptions | None = None) -> None:
        if not isinstance(loop, ClosedLoop):
            raise ConfigurationError(f"DigitalStepper needs a ClosedLoop; got {loop!r}.")
        if not loop.sample_time > 0:
            raise ConfigurationError(
                f"DigitalStepper needs a digital controller: loop {loop.name!r} has "
                "sample_time = 0 (continuous); set `sample_time` (s) on the ClosedLoop."
            )
        from adaptive_ftc.sim.parts.base import decimation_readings

        bind = getattr(loop.controller, "bound", None)
        #: sensor readings per sample the design averages (its decimation filter; 1: none)
        self.readings = decimation_readings(
            loop, bind(loop) if bind is not None else loop.controller
        )
        solver = solver or SolverOptions()
        method = solver.compiled_method
        if method is None:
            raise ConfigurationError(
                f"DigitalStepper integrates with the compiled methods; the solver's method "
                f"{solver.method!r} is scipy's. Use method 'rk4', 'dopri5', 'rodasp', "
                "'rodas5p' or 'auto'."
            )
        self.loop = loop
        self.solver = solver
        self.method = method
        self.asm = asm = assemble(
            loop, sdot=solver.sdot_for(loop), filter_tau=solver.filter_tau_for(loop)
        )
        self.breakpoints = np.asarray(asm.breakpoints, dtype=float)
        self._samp = asm.data.samp.copy()
        self._meas = asm.data.meas.copy()
        self._held = asm.layout["y:held_command"]
        # the decimation filter's running sum of the period's readings and their count
        self._sum = asm.layout["y:decimation"] if self.readings > 1 else None
        # the integrators run without the loop's jumps (this class runs them, so that the
        # held command can change in between) and from the interval set in PH0
        self._D = asm.data._replace(i=asm.data.i.copy())
        self._D.i[Header.JUMP] = 0
        n = asm.y0.size
        self._atol = solver.atol_for(n)
        self._stop = np.zeros(1, dtype=np.int64)
        self._stats = np.zeros(5, dtype=np.int64)
        self._out_Y = np.empty((1, n))
        self._out_phase = np.empty(1, dtype=np.int64)
        self._scratch = np.empty((8, n))
        self._ref = np.zeros(3 * loop.plant.n_outputs)
        self.reset()

    def reset(self) -> None:
        """Back to the loop's initial state at ``t0`` (before its first sample)."""
        self.Y = self.asm.y0.copy()
        self.W = self.asm.work()
        self.phase = 0
        self._sampled = False
        self._seen: np.ndarray | None = None  # what the sample read (the decimation filter)
        self.status: RunStatus = RunStatus.COMPLETED
        self.reason: StatusReason | None = None

    @property
    def time(self) -> float:
        """The current time (s): the start of the current interval."""
        return float(self.breakpoints[self.phase])

    @property
    def done(self) -> bool:
        """Whether the run reached ``t_final`` or stopped."""
        return self.phase >= self.breakpoints.size - 1 or self.status is not RunStatus.COMPLETED

    @property
    def state(self) -> np.ndarray:
        """The whole state vector of the loop (plant, controller, held values), a copy."""
        return self.Y.copy()

    def measured(self) -> np.ndarray:
        """The measured plant state now: the true state plus the sensors' bias and noise of
        the current sample (at ``t_final``: of the last one). With the design's decimation
        filter (:attr:`readings` > 1), what the design reads: the mean of the sample
        period's sensor readings, each the true state at its instant, with the mean of their
        bias and noise (the simulator's ``measured``, :mod:`adaptive_ftc.sim.parts.decimation`;
        at ``t_final``: the readings since the last sample with that sample's noise)."""
        nx = self.asm.n_x
        ph = min(self.phase, self.breakpoints.size - 2)
        if self._sum is None:
            return self.Y[:nx] + self._meas[ph]
        if self._sampled and self._seen is not None:  # the sample has emptied the sum
            return self._seen.copy()
        at = self._sum.start
        total = self.Y[at : at + nx] + self.Y[:nx]
        return total / (self.Y[at + nx] + 1.0) + self._meas[ph]

    def reference(self) -> np.ndarray:
        """``y_d, y_d', y_d''`` per output now (``3 p`` values, output by output)."""
        self.asm.module.reference_at(self.time, self.asm.data.c, self._ref)
        return self._ref.copy()

    @property
    def held_command(self) -> np.ndarray:
        """The command held until the next sample (a copy)."""
        return self.Y[self._held].copy()

    def sample(self) -> ControllerSample:
        """The controller's sample at the current time: the design's command computed and
        held (the loop's own update at this instant); returns what the controller sees."""
        if self.done:
            raise ConfigurationError(
                "The run has ended (t_final reached or stopped); call reset() to start again."
            )
        if self._sampled:
            raise ConfigurationError(
                f"sample() was already called at t = {self.time:g} s; call advance() next."
            )
        asm, ph = self.asm, self.phase
        seen = self.measured()  # before the update (it empties the decimation filter's sum)
        asm.module.jump(self.time, self.Y, ph, asm.data, self.W)
        self._sampled, self._seen = True, seen
        return ControllerSample(
            time=self.time,
            state=self.Y[: asm.n_x].copy(),
            measured=seen.copy(),
            reference=self.reference(),
            command=self.Y[self._held].copy(),
        )

    def advance(self, command=None) -> tuple[RunStatus, StatusReason | None]:
        """Hold ``command`` (one value per actuator; ``None``: the design's) and integrate the
        loop to the next sample instant (or ``t_final``).

        Returns
        -------
        (RunStatus, StatusReason | None)
            ``completed`` while the run goes on (or reached ``t_final``); else why it stopped
            (a state over the divergence bound or outside the plant's envelope...), as
            :func:`~adaptive_ftc.simulate` reports it.
        """
        if not self._sampled:
            raise ConfigurationError(
                f"advance() needs the sample at t = {self.time:g} s first: call sample()."
            )
        if command is not None:
            u = np.asarray(command, dtype=float).reshape(-1)
            m = self._held.stop - self._held.start
            if u.size != m:
                raise ConfigurationError(
                    f"The command needs one value per actuator ({m}); got {u.size}."
                )
            self.Y[self._held] = u
        self._sampled, self._seen = False, None
        nph = self.breakpoints.size - 1
        first = True
        while self.phase < nph and (first or self._samp[self.phase] != SAMPLE):
            # an interval that starts between samples (a failure time; a sensor reading, which
            # the update adds to the decimation filter's sum)
            if not first:
                self.asm.module.jump(self.time, self.Y, self.phase, self.asm.data, self.W)
            first = False
            self._interval(self.phase)
            if self.status is not RunStatus.COMPLETED:
                break
            self.phase += 1
        return self.status, self.reason

    def _interval(self, ph: int) -> None:
        a, b = float(self.breakpoints[ph]), float(self.breakpoints[ph + 1])
        D, solver = self._D, self.solver
        D.i[Header.PH0] = ph
        bound = float(solver.divergence_bound)
        t_rec = np.array([b])
        if self.method == "rk4":
            k = self._scratch
            _, code, t_stop, bad = integrators().integrate_rk4(
                self.Y, np.array([a, b]), float(solver.dt), t_rec, D, self.W, bound,
                self._stop, self._out_Y, self._out_phase, self._stats, *k,
            )  # fmt: skip
        else:
            # [a, b, b]: the end state is the record at the start of an empty interval, so
            # it adds no dense-output check to the last step (as in a whole run)
            _, code, t_stop, bad = getattr(integrators(), f"integrate_{self.method}")(
                self.Y, np.array([a, b, b]), t_rec, D, self.W, float(solver.rtol),
                self._atol, float(min(solver.max_step, 1e300)), bound, self._stop,
                self._out_Y, self._out_phase, self._stats,
            )  # fmt: skip
        if int(code) == 0:
            self.Y[:] = self._out_Y[0]
            return
        from adaptive_ftc.sim.diagnose import stop_outcome

        y_stop = self._out_Y[0].copy() if int(code) in (1, 2) else None
        self.status, self.reason = stop_outcome(
            self.loop, self.asm, solver, code=int(code), t_stop=float(t_stop), bad=int(bad),
            y_stop=y_stop, t_prev=a, y_prev=self.Y.copy(),
        )  # fmt: skip
        if y_stop is not None and np.all(np.isfinite(y_stop)):
            self.Y[:] = y_stop
