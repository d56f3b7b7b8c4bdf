"""Simulation results: labelled arrays with xarray/pandas/netCDF/CSV export and metrics."""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import subprocess
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from adaptive_ftc._units import cf_unit_attrs, per_second, udunits
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim.status import RunStatus, StatusReason

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    import xarray as xr

    from adaptive_ftc.sim.compose import Assembled
    from adaptive_ftc.sim.engine import SolverOptions
    from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["SimResult"]

#: Units of the time coordinate of the files: simulation time in seconds, with t = 0 put at a
#: conventional epoch (CF wants a reference time; a simulation has none).
TIME_UNITS = "seconds since 1970-01-01 00:00:00"
#: A run's times of at least this many bytes are held over a block of the pool of
#: :mod:`adaptive_ftc.sim.blocks` (``SimResult.from_run``).
TIME_POOL_BYTES = 1 << 19


@dataclass
class SimResult:
    """Recorded run of a closed loop. Shapes are fixed (never squeezed): ``(time, output)``,
    ``(time, actuator)``, ``(time, state)``, ``(time, param)``.

    Attributes
    ----------
    time
        Sample times (s).
    states
        Plant states.
    adaptive
        Adaptive states (theta, kappa, tau, rho, filter states).
    y, yd, yd_dot, e, edot, s, sdot, u0
        Outputs, references, errors ``e = y_d - y``, filtered errors ``s = e' + lambda e``,
        ``s'`` and the design's control signal(s) ``u0``.
    u_cmd, u_applied
        Actuator commands ``u = R^T u0`` and the (possibly failed) actuator outputs.
    u_f
        §2.4 compensation term ``-sum_j kappa_j^T varpi_j`` (zero for the other designs).
    gain
        ``N(tau)`` (Nussbaum design), ``rho`` (sign estimation), else 1.
    control_gain
        True control gain of output 1 along the allocation, ``sum_j g_j R_1j d u^f_j / d u_j``:
        its sign is the true control direction (4.6).
    status, reason, message
        How the run ended (a :class:`~adaptive_ftc.RunStatus`: ``"completed"``,
        ``"diverged"``, ``"nonfinite"``, ``"step_underflow"``, ``"singular"``, ...), why (a
        :class:`~adaptive_ftc.StatusReason`, ``None`` when completed) and the message built
        from both.
    state_units, output_units, actuator_units
        UDUNITS strings declared by the plant class (``state_units``, ``output_units``,
        ``actuator_units`` class attributes); empty when the plant declares none, and the
        exported file then says ``"1"`` with a comment.
    actuator_position
        Actuator positions (time, actuator) when the actuators have states (declared
        :class:`~adaptive_ftc.hardware.Actuators` or a dynamics failure): the position state
        of an actuator with dynamics, else its command clipped to its travel; ``None`` for
        ideal actuators. The limits are in ``meta["actuator_limits"]``
        (:mod:`adaptive_ftc.sim.activity`).
    """

    time: np.ndarray
    states: np.ndarray
    adaptive: np.ndarray
    y: np.ndarray
    yd: np.ndarray
    yd_dot: np.ndarray
    e: np.ndarray
    edot: np.ndarray
    s: np.ndarray
    sdot: np.ndarray
    u0: np.ndarray
    u_cmd: np.ndarray
    u_applied: np.ndarray
    u_f: np.ndarray
    gain: np.ndarray
    control_gain: np.ndarray
    state_names: tuple[str, ...]
    output_names: tuple[str, ...]
    actuator_names: tuple[str, ...]
    adaptive_names: tuple[str, ...]
    theta_slices: tuple[slice, ...]
    failure_times: tuple[float, ...]
    failures: tuple[str, ...]
    status: RunStatus = RunStatus.COMPLETED
    message: str = ""
    meta: dict[str, Any] = field(default_factory=dict)
    state_units: tuple[str, ...] = ()
    output_units: tuple[str, ...] = ()
    actuator_units: tuple[str, ...] = ()
    actuator_position: np.ndarray | None = None
    reason: StatusReason | None = None

    def __post_init__(self) -> None:
        self.status = RunStatus(self.status)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_run(
        cls,
        loop: ClosedLoop,
        asm: Assembled,
        T: np.ndarray,
        Y: np.ndarray,
        phases: np.ndarray,
        *,
        signals: np.ndarray | None = None,
        solver: SolverOptions,
        message: str,
        wall_time: float,
        status: RunStatus | str = RunStatus.COMPLETED,
        reason: StatusReason | None = None,
        lean: bool = False,
    ) -> SimResult:
        """Build a result from recorded closed-loop states; ``signals``: their block from
        ``asm.signals`` (:func:`signal_block`), else recomputed here. ``status`` and
        ``reason`` say how the run ended; ``message`` is the text built from them. ``lean``:
        ``signals`` is the narrow block of :func:`lean_signal_block` (``e``, ``u_cmd``,
        ``u_applied``); every other signal is a read-only ``nan`` array (no memory)."""
        p, m, n = loop.plant.n_outputs, loop.plant.n_actuators, loop.plant.n_states
        out = signals
        if lean and out is None:
            raise ConfigurationError(
                "SimResult.from_run(lean=True) needs the lean signals block "
                "(lean_signal_block, filled by asm.signals(..., lean=True)); pass signals=."
            )
        if out is None:
            out = signal_block(loop, T.size)
            if T.size:
                asm.signals(
                    np.ascontiguousarray(T),
                    np.ascontiguousarray(Y),
                    np.ascontiguousarray(phases),
                    out,
                )
        if lean:
            nan = np.full(1, np.nan)
            col = {
                name: np.lib.stride_tricks.as_strided(
                    nan, (T.size, where.stop - where.start), (0, 0), writeable=False
                )
                for name, where, _ in asm.layout.records
            }
            col.update(e=out[:, :p], u_cmd=out[:, p : p + m], u_applied=out[:, p + m : p + 2 * m])
        else:
            col = {name: out[:, where] for name, where, _ in asm.layout.records}
        times = sorted(
            {t for f in loop.failures.failures for t in f.jump_times if loop.t0 < t < loop.t_final}
        )
        plant = loop.plant
        from adaptive_ftc.sim.activity import actuator_positions

        u_cmd = col["u_cmd"]
        where = asm.layout.states
        from adaptive_ftc.sim import blocks

        # the result's own times (not a view of the record grid): over a block from the pool
        # (0.96 MB at 1 ms records over 120 s; fresh pages for it cost 0.5 ms of a campaign run)
        time = blocks.empty(T.shape, min_bytes=TIME_POOL_BYTES)
        time[...] = T
        return cls(
            # views of the recorded block, like the signals below: copying them cost ~1 ms
            # of a 60 ms run
            time=time,
            states=Y[:, where["plant"]],
            adaptive=Y[:, asm.layout.adaptive],
            **{k: col[k] for k in ("y", "yd", "yd_dot", "e", "edot", "s", "sdot", "u0")},
            u_cmd=u_cmd,
            u_applied=col["u_applied"],
            # the columns of one value (not per output or actuator): 1-d
            **{k: col[k][:, 0] for k in ("u_f", "gain", "control_gain")},
            state_names=tuple(loop.plant.state_names),
            output_names=tuple(loop.plant.output_names),
            actuator_names=tuple(loop.plant.actuator_names),
            adaptive_names=asm.adaptive_names,
            theta_slices=asm.theta_slices,
            failure_times=tuple(times),
            failures=tuple(loop.describe_failures()),
            status=RunStatus(status),
            reason=reason,
            message=message,
            meta=_run_meta(loop, asm, solver, wall_time),
            state_units=(su := _declared_units(plant, ("state_units", "units"), n)),
            output_units=_declared_units(plant, ("output_units",), p)
            or _output_units(loop.plant.state_names, loop.plant.output_names, su),
            actuator_units=_declared_units(plant, ("actuator_units",), m),
            actuator_position=actuator_positions(loop, asm, Y, phases, u_cmd),
        )

    def __repr__(self) -> str:
        """A one-line summary (the arrays are in the fields; ``.to_xarray()`` shows them all)."""
        name = self.meta.get("scenario") or self.meta.get("name") or "run"
        span = f"{self.time[0]:g}-{self.time[-1]:g} s" if self.time.size else "no samples"
        return (
            f"<SimResult {name!r}: {self.status}, {span}, {self.time.size} samples, "
            f"{len(self.state_names)} states, {len(self.adaptive_names)} adaptive states, "
            f"outputs {', '.join(self.output_names)}; actuators "
            f"{', '.join(self.actuator_names)}>"
        )

    # ------------------------------------------------------------------ access
    @property
    def theta(self) -> np.ndarray:
        """All regressor parameters ``theta`` (time, param)."""
        stop = self.theta_slices[-1].stop if self.theta_slices else 0
        return self.adaptive[:, :stop]

    def adaptive_state(self, name: str) -> np.ndarray:
        """One adaptive state by name (e.g. ``"tau"``, ``"rho"``, ``"kappa3_1"``)."""
        if name not in self.adaptive_names:
            from adaptive_ftc.errors import did_you_mean

            raise KeyError(f"No adaptive state '{name}'.{did_you_mean(name, self.adaptive_names)}")
        return self.adaptive[:, self.adaptive_names.index(name)]

    def window(self, start: float | None = None, end: float | None = None) -> np.ndarray:
        """Boolean mask of samples with ``start <= t <= end``."""
        lo = self.time[0] if start is None else start
        hi = self.time[-1] if end is None else end
        if self.time.size == 0:
            return np.zeros(0, dtype=bool)
        return (self.time >= lo - 1e-9) & (self.time <= hi + 1e-9)

    # ------------------------------------------------------------------ metrics
    def rms_error(self, start: float | None = None, end: float | None = None) -> np.ndarray:
        """RMS tracking error per output over ``[start, end]``."""
        mask = self.window(start, end)
        if not mask.any():
            raise ConfigurationError(
                f"No samples in the window [{start}, {end}] (run covers "
                f"{self.time[0] if self.time.size else 'nothing'} to "
                f"{self.time[-1] if self.time.size else ''} s)."
            )
        return np.sqrt(np.mean(self.e[mask] ** 2, axis=0))

    def max_error(self, start: float | None = None, end: float | None = None) -> np.ndarray:
        """Largest absolute tracking error per output over ``[start, end]``."""
        mask = self.window(start, end)
        if not mask.any():
            raise ConfigurationError(f"No samples in the window [{start}, {end}].")
        return np.max(np.abs(self.e[mask]), axis=0)

    def recovery(self, window: float = 5.0, *, fast: bool | None = None) -> list[dict[str, Any]]:
        """Per failure time: RMS error just after it (``window`` s) and just before the next.

        ``fast``: reduce with the compiled kernels of :mod:`adaptive_ftc.sim.reduce` (the same
        numbers bit for bit; they compile once per machine, about 4 s, so a campaign asks for
        them); ``None`` (default): only where this process has already loaded them."""
        rows: list[dict[str, Any]] = []
        if self.time.size == 0:
            return rows
        t_last = float(self.time[-1])
        # only failures that happened inside the recorded run (none: no rows, no crash)
        times = [float(t) for t in self.failure_times if float(t) <= t_last]
        if not times:
            return rows
        t_end = min(float(self.meta.get("t_final", t_last)), t_last)
        ends = times[1:] + [t_end]
        if _compiled(fast) and _monotone(self.time):  # spans of rows: compiled sums
            from adaptive_ftc.sim.reduce import rms_rows, row_span

            for t, nxt in zip(times, ends, strict=True):
                after_rows = row_span(self.time, t, min(t + window, nxt))
                settle_rows = row_span(self.time, max(t, nxt - window), nxt)
                rows.append(
                    {
                        "time": t,
                        "rms_after": rms_rows(self.e, *after_rows),
                        "rms_before_next": rms_rows(self.e, *settle_rows),
                    }
                )
            return rows
        for t, nxt in zip(times, ends, strict=True):
            after = self.window(t, min(t + window, nxt))
            settle = self.window(max(t, nxt - window), nxt)
            row = {
                "time": t,
                "rms_after": float(np.sqrt(np.mean(self.e[after] ** 2)))
                if after.any()
                else math.nan,
                "rms_before_next": float(np.sqrt(np.mean(self.e[settle] ** 2)))
                if settle.any()
                else math.nan,
            }
            rows.append(row)
        return rows

    def metrics(
        self, final_window: float | None = None, *, fast: bool | None = None
    ) -> dict[str, float]:
        """Headline numbers: RMS/max error overall and in the final window, peak control.

        ``fast``: as in :meth:`recovery` (compiled one-pass reductions, the same numbers)."""
        if self.time.size == 0:
            return {"status": self.status}  # type: ignore[dict-item]
        t_end = float(self.time[-1])
        fw = final_window if final_window is not None else max(0.1 * (t_end - self.time[0]), 1e-9)
        if (
            _compiled(fast)
            and _monotone(self.time)
            and self.e.size
            and self.u_cmd.size
            and self.u_applied.size
        ):
            # one compiled pass over the records (sim/reduce.py), the same numbers bit for bit
            from adaptive_ftc.sim.reduce import error_stats, row_span

            i0, i1 = row_span(self.time, t_end - fw, t_end)
            if i1 == self.time.size and i1 > i0:
                ss, emax, ss_f, emax_f, peak_cmd, peak_app = error_stats(
                    self.e, self.u_cmd, self.u_applied, i0
                )
                p = self.e.shape[1] if self.e.ndim == 2 else 1
                one_pass: dict[str, Any] = {
                    "rms_error": math.sqrt(ss / self.e.size),
                    "max_error": emax,
                    "final_window_s": fw,
                    "rms_error_final": math.sqrt(ss_f / ((i1 - i0) * p)),
                    "max_error_final": emax_f,
                    "peak_command": peak_cmd,
                    "peak_applied": peak_app,
                    "t_end": t_end,
                    "status": self.status,
                }
                one_pass.update(self._activity_metrics(t_end - fw, t_end))
                return one_pass
        out: dict[str, Any] = {
            "rms_error": float(np.sqrt(np.mean(self.e**2))),
            "max_error": float(np.max(np.abs(self.e))),
            "final_window_s": fw,
            "rms_error_final": float(np.sqrt(np.mean(self.e[self.window(t_end - fw)] ** 2))),
            "max_error_final": float(np.max(np.abs(self.e[self.window(t_end - fw)]))),
            "peak_command": float(np.max(np.abs(self.u_cmd))),
            "peak_applied": float(np.max(np.abs(self.u_applied))),
            "t_end": t_end,
            "status": self.status,
        }
        out.update(self._activity_metrics(t_end - fw, t_end))
        return out

    def activity(
        self, start: float | None = None, end: float | None = None, f_c: float = 1.0
    ) -> dict[str, Any]:
        """Control activity per actuator over ``[start, end]`` (default: the whole run):
        fast command content above ``f_c`` Hz, total variation per second, peak rate,
        fractions of time at a rate or travel limit, peak command against the declared travel,
        peak to peak. Actuator name -> :class:`~adaptive_ftc.sim.activity.ActuatorActivity`
        (see :mod:`adaptive_ftc.sim.activity` for the definitions and the aliasing rule)."""
        from adaptive_ftc.sim.activity import activity

        return activity(self, start, end, f_c=f_c)

    def _activity_metrics(self, start: float, end: float) -> dict[str, Any]:
        """The final window's activity for :meth:`metrics`: per actuator
        ``<metric>_<actuator>``, the worst actuator's ``<metric>_max`` and the record check."""
        from adaptive_ftc.sim.activity import ACTIVITY_FIELDS, DEFAULT_F_C

        acts = self.activity(start, end, f_c=DEFAULT_F_C)
        out: dict[str, Any] = {}
        for name, a in acts.items():
            for key in ACTIVITY_FIELDS:
                out[f"{key}_{name}"] = getattr(a, key)
        for key in ACTIVITY_FIELDS:
            vals = [getattr(a, key) for a in acts.values() if not math.isnan(getattr(a, key))]
            out[f"{key}_max"] = max(vals) if vals else math.nan
        first = next(iter(acts.values()), None)
        out["activity_f_c"] = DEFAULT_F_C
        out["activity_record_dt"] = first.record_dt if first else math.nan
        out["activity_record_ok"] = bool(first.record_ok) if first else False
        return out

    # ------------------------------------------------------------------ export
    def to_xarray(
        self, *, timing: bool = False, decimate: int = 1, float32: bool = False
    ) -> xr.Dataset:
        """All recorded signals as a self-describing :class:`xarray.Dataset`.

        Every variable carries CF attributes (``long_name``, ``units`` in UDUNITS style, see
        :mod:`adaptive_ftc._units`; the spacecraft's modal coordinates, in √kg·m, which UDUNITS
        cannot write, state it in ``units_note`` instead); plant states are one variable each
        (``state_<name>``) because their units differ. The dimensions ``output``, ``actuator``,
        ``param`` and ``state`` are plain integer dimensions labelled by the auxiliary
        coordinates ``output_name``, ``actuator_name``, ``param_name`` and ``state_name``
        (select by name with ``ds.swap_dims(output="output_name").sel(output_name="alpha")``).
        ``time`` is the simulation time in :data:`TIME_UNITS` (``"seconds since 1970-01-01
        00:00:00"``: the epoch is a convention, ``t = 0`` of the run's clock; xarray decodes it
        to dates unless the file is opened with ``decode_times=False``).
        The global attributes hold the provenance: ``Conventions = "CF-1.10"``, ``history``,
        the package version, the git commit when the package runs from a checkout, the
        scenario name and file text, the solver settings and the controller (its gains).

        Parameters
        ----------
        timing
            Also store the wall time of the run (``wall_time_s``); off by default so that
            identical inputs give identical files.
        decimate
            Keep every ``decimate``-th sample (the last sample is always kept), for long runs.
        float32
            Only recorded in the attributes (``precision``, ``history``): :meth:`to_netcdf`
            stores the signals in single precision.
        """
        import xarray as xr

        data, coords = self._layout(decimate)
        ds = xr.Dataset(data, coords=coords)
        ds.attrs.update(self._global_attrs(timing=timing, decimate=decimate, float32=float32))
        return ds

    def _layout(self, decimate: int) -> tuple[dict[str, Any], dict[str, Any]]:
        """The variables of :meth:`to_xarray`, ``name -> (dims, values, attributes)``: the
        data variables and the coordinates, in the order of the file."""
        if isinstance(decimate, bool) or not isinstance(decimate, int) or decimate < 1:
            raise ConfigurationError(
                f"`decimate` must be a whole number >= 1 (keep every k-th sample); got "
                f"{decimate!r}."
            )
        idx = _decimation_index(self.time.size, decimate)
        out_u = [_unit(self.output_units, i) for i in range(len(self.output_names))]
        y_units = _common(out_u)
        rate = per_second(y_units)
        act_units = _common(
            [_unit(self.actuator_units, j) for j in range(len(self.actuator_names))]
        )
        data: dict[str, Any] = {}
        for i, name in enumerate(self.state_names):
            unit = _unit(self.state_units, i)
            data[f"state_{name}"] = (
                ("time",),
                self.states[idx, i],
                _attrs(f"plant state {name}", unit, declared=bool(self.state_units)),
            )
        declared_y = bool(self.output_units)
        declared_u = bool(self.actuator_units)
        for key, long_name, unit, declared in (
            ("y", "plant output y", y_units, declared_y),
            ("yd", "reference y_d", y_units, declared_y),
            ("yd_dot", "reference rate dy_d/dt", rate, declared_y),
            ("e", "tracking error e = y_d - y", y_units, declared_y),
            ("edot", "tracking error rate de/dt", rate, declared_y),
            ("s", "filtered error s = de/dt + lambda e", rate, declared_y),
            ("sdot", "filtered error rate ds/dt", per_second(rate), declared_y),
            ("u0", "design control signal u0", act_units, declared_u),
        ):
            data[key] = (
                ("time", "output"),
                getattr(self, key)[idx],
                _attrs(long_name, unit, declared=declared),
            )
        data["u_cmd"] = (
            ("time", "actuator"),
            self.u_cmd[idx],
            _attrs("actuator command u = R^T u0", act_units, declared=declared_u),
        )
        data["u_applied"] = (
            ("time", "actuator"),
            self.u_applied[idx],
            _attrs("actuator output after failures u^f", act_units, declared=declared_u),
        )
        if self.actuator_position is not None:
            data["u_position"] = (
                ("time", "actuator"),
                self.actuator_position[idx],
                _attrs("actuator position (declared actuators)", act_units, declared=declared_u),
            )
        data["u_f"] = (
            ("time",),
            self.u_f[idx],
            _attrs(
                "failure compensation term -sum_j kappa_j^T varpi_j (2.4)",
                act_units,
                declared=declared_u,
            ),
        )
        data["adaptive_gain"] = (
            ("time",),
            self.gain[idx],
            _attrs(
                "adaptive gain: Nussbaum gain N(tau) (4.3), sign estimate rho (4.4), else 1",
                "1",
            ),
        )
        data["true_control_gain"] = (
            ("time",),
            self.control_gain[idx],
            _attrs(
                "true control gain of output 1 along the allocation, sum_j g_j R_1j du^f_j/du_j;"
                " its sign is the control direction (4.6)",
                "1",
            ),
        )
        data["adaptive"] = (
            ("time", "param"),
            self.adaptive[idx],
            {
                "long_name": "adaptive parameters (theta, kappa, tau, rho, filter states)",
                "units": "1",
                "comment": "units differ per parameter and are not declared",
            },
        )
        # numeric dimensions, labelled by string auxiliary coordinates (CF 5: no string-valued
        # dimension coordinates); the state labels ride on a variable of the state dimension
        data["state_index"] = (
            ("state",),
            np.arange(len(self.state_names), dtype=np.int32),
            {"long_name": "position of each plant state in the state vector", "units": "1"},
        )
        coords = {
            "time": (
                "time",
                self.time[idx],
                {
                    "standard_name": "time",
                    "long_name": "simulation time t",
                    "units": TIME_UNITS,
                    "calendar": "standard",
                    "axis": "T",
                    "comment": "t in seconds of the run's own clock; the epoch is a "
                    "convention (t = 0 at 1970-01-01 00:00:00 UTC): open the file with "
                    "xarray.open_dataset(..., decode_times=False) for t as float seconds",
                },
            ),
            "state_name": ("state", list(self.state_names), {"long_name": "plant state name"}),
            "output_name": (
                "output",
                list(self.output_names),
                {"long_name": "controlled output name"},
            ),
            "actuator_name": (
                "actuator",
                list(self.actuator_names),
                {"long_name": "actuator name"},
            ),
            "param_name": (
                "param",
                list(self.adaptive_names),
                {"long_name": "adaptive parameter name"},
            ),
        }
        return data, coords

    def _global_attrs(self, *, timing: bool, decimate: int, float32: bool) -> dict[str, Any]:
        from adaptive_ftc._version import __version__

        meta = {k: v for k, v in self.meta.items() if timing or k != "wall_time_s"}
        attrs: dict[str, Any] = {
            "Conventions": "CF-1.10",
            "title": f"adaptive-ftc run of {meta.get('scenario', meta.get('name', ''))}".strip(),
            "source": f"adaptive-ftc {__version__}",
            "package_version": __version__,
            # no date: identical inputs give byte-identical files
            "history": (
                f"written by adaptive-ftc {__version__} SimResult.to_netcdf("
                f"float32={bool(float32)}, decimate={int(decimate)})"
            ),
        }
        commit = _git_commit()
        if commit:
            attrs["git_commit"] = commit
        for k, v in meta.items():
            if isinstance(v, bool):
                attrs[k] = int(v)
            elif isinstance(v, (int, float, str)):
                attrs[k] = v
            else:
                attrs[k] = str(v)
        attrs.update(
            status=str(self.status),
            message=self.message,
            failure_times=np.asarray(self.failure_times, dtype=float),
            failures="; ".join(self.failures),
            decimation=int(decimate),
            precision="float32" if float32 else "float64",
            # what from_netcdf needs to rebuild the result exactly
            aftc_result_json=json.dumps(
                {
                    "failures": list(self.failures),
                    "theta_slices": [[sl.start, sl.stop] for sl in self.theta_slices],
                    "meta": _jsonable(meta),
                    "state_units": list(self.state_units),
                    "output_units": list(self.output_units),
                    "actuator_units": list(self.actuator_units),
                    "reason": _jsonable(dataclasses.asdict(self.reason))
                    if self.reason is not None
                    else None,
                },
                sort_keys=True,
            ),
        )
        return attrs

    @classmethod
    def from_netcdf(cls, path: str | Path) -> SimResult:
        """Read a file written by :meth:`to_netcdf` back into a :class:`SimResult`.

        Raises
        ------
        ConfigurationError
            When the file does not exist or was not written by ``SimResult.to_netcdf``.
        """
        import xarray as xr

        path = Path(path)
        if not path.is_file():
            raise ConfigurationError(f"No netCDF file at '{path}'; give the path of a .nc file.")
        try:
            with xr.open_dataset(path, engine="netcdf4", decode_times=False) as handle:
                ds = handle.load()
        except Exception as exc:  # noqa: BLE001 - any reader failure is the same user error
            raise ConfigurationError(
                f"'{path}' is not a readable netCDF4 file ({type(exc).__name__}: {exc}); "
                "write it with SimResult.to_netcdf."
            ) from None
        if "aftc_result_json" not in ds.attrs:
            raise ConfigurationError(
                f"'{path}' was not written by SimResult.to_netcdf (no 'aftc_result_json' "
                "attribute); open it with xarray.open_dataset instead."
            )
        info = json.loads(ds.attrs["aftc_result_json"])

        # older files have string dimension coordinates "state", "output", ... instead
        def labels(dim: str) -> list[str]:
            var = ds[f"{dim}_name"] if f"{dim}_name" in ds.variables else ds[dim]
            return [str(v) for v in var.values]

        states = labels("state")
        n_t = ds.sizes["time"]

        def arr(name: str) -> np.ndarray:
            return np.asarray(ds[name].values, dtype=float)

        return cls(
            time=arr("time"),
            states=np.stack([arr(f"state_{s}") for s in states], axis=1)
            if states
            else np.zeros((n_t, 0)),
            adaptive=arr("adaptive"),
            y=arr("y"),
            yd=arr("yd"),
            yd_dot=arr("yd_dot"),
            e=arr("e"),
            edot=arr("edot"),
            s=arr("s"),
            sdot=arr("sdot"),
            u0=arr("u0"),
            u_cmd=arr("u_cmd"),
            u_applied=arr("u_applied"),
            u_f=arr("u_f"),
            gain=arr("adaptive_gain"),
            control_gain=arr("true_control_gain"),
            state_names=tuple(states),
            output_names=tuple(labels("output")),
            actuator_names=tuple(labels("actuator")),
            adaptive_names=tuple(labels("param")),
            theta_slices=tuple(slice(a, b) for a, b in info["theta_slices"]),
            failure_times=tuple(float(t) for t in np.atleast_1d(ds.attrs.get("failure_times", []))),
            failures=tuple(info["failures"]),
            status=RunStatus(str(ds.attrs.get("status", "completed"))),
            reason=_reason_from_json(info.get("reason")),
            message=str(ds.attrs.get("message", "")),
            meta=dict(info["meta"]),
            state_units=tuple(info.get("state_units", ())),
            output_units=tuple(info.get("output_units", ())),
            actuator_units=tuple(info.get("actuator_units", ())),
            actuator_position=arr("u_position") if "u_position" in ds else None,
        )

    def to_pandas(self) -> pd.DataFrame:
        """A wide table, one column per signal component, indexed by time."""
        import pandas as pd

        cols: dict[str, np.ndarray] = {}
        for i, name in enumerate(self.state_names):
            cols[name] = self.states[:, i]
        for i, name in enumerate(self.output_names):
            for key in ("yd", "e", "s", "u0"):
                cols[f"{key}_{name}"] = getattr(self, key)[:, i]
        for j, name in enumerate(self.actuator_names):
            cols[f"cmd_{name}"] = self.u_cmd[:, j]
            cols[f"applied_{name}"] = self.u_applied[:, j]
        cols["u_f"] = self.u_f
        cols["gain"] = self.gain
        cols["control_gain"] = self.control_gain
        for i, name in enumerate(self.adaptive_names):
            cols[name] = self.adaptive[:, i]
        return pd.DataFrame(cols, index=pd.Index(self.time, name="time"))

    def to_netcdf(
        self,
        path: str | Path,
        *,
        float32: bool = False,
        decimate: int = 1,
        complevel: int = 4,
        timing: bool = False,
    ) -> Path:
        """Write a compressed, self-describing netCDF4 file (netCDF4-python), atomically.

        The file is written to a temporary name in the same folder and renamed, so an
        interrupted write never leaves a truncated file where a good one was. Identical
        results give byte-identical files (the wall time is left out unless ``timing``).

        Parameters
        ----------
        path
            Target file (``.nc``).
        float32
            Store the signals in single precision (half the size; about 7 digits).
        decimate
            Keep every ``decimate``-th sample, for long runs.
        complevel
            zlib level 0-9 (0: no compression).
        timing
            Also store the wall time of the run.
        """
        from adaptive_ftc._atomic import atomic_path

        if isinstance(complevel, bool) or not isinstance(complevel, int) or not 0 <= complevel <= 9:
            raise ConfigurationError(f"`complevel` must be a whole number 0..9; got {complevel!r}.")
        data, coords = self._layout(decimate)
        attrs = self._global_attrs(timing=timing, decimate=decimate, float32=float32)
        path = Path(path)
        from adaptive_ftc._signals import sigint_deferred
        from adaptive_ftc.sim import ncwrite

        # the file of xarray's Dataset.to_netcdf, without importing xarray (sim/ncwrite.py);
        # Ctrl-C waits for the write (raised inside HDF5 it left the file open)
        with sigint_deferred(), atomic_path(path) as tmp:
            ncwrite.write(tmp, data, coords, attrs, float32=float32, complevel=complevel)
        return path

    def to_csv(self, path: str | Path) -> Path:
        """Write the wide table to CSV."""
        from adaptive_ftc._atomic import atomic_path

        path = Path(path)
        with atomic_path(path) as tmp:
            self.to_pandas().to_csv(tmp)
        return path

    def plot(self, kind: str = "tracking", **kwargs):
        """Thesis-style figure; see :mod:`adaptive_ftc.plots`."""
        from adaptive_ftc import plots

        return plots.plot(self, kind, **kwargs)


def _compiled(fast: bool | None) -> bool:
    """Whether to reduce with :mod:`adaptive_ftc.sim.reduce`'s kernels: as asked, else only
    where this process has loaded them already (a first ``aftc run`` would otherwise compile
    them, about 4 s, to save milliseconds)."""
    if fast is not None:
        return bool(fast)
    from adaptive_ftc.sim.activity import reductions_loaded

    return reductions_loaded()


def _monotone(time: np.ndarray) -> bool:
    """Whether the record times never decrease (windows are then spans of rows)."""
    from adaptive_ftc.sim.reduce import nondecreasing

    return nondecreasing(time)


def _run_meta(loop: ClosedLoop, asm: Assembled, solver: Any, wall_time: float) -> dict:
    """The provenance of one run (``SimResult.meta``)."""
    ctrl = loop.controller
    meta = {
        "name": loop.name,
        "plant": loop.plant.name,
        "design": ctrl.design,
        "equations": ctrl.equation,
        "adapt": loop.adapt,
        "solver": solver.method,
        "dt": solver.dt,
        "sdot": solver.sdot_for(loop),
        "t_final": loop.t_final,
        "wall_time_s": wall_time,
        "solver_settings": _solver_settings(solver),
        "controller": repr(ctrl),
        "actuators": repr(loop.actuators) if loop.actuators is not None else "ideal",
        "sensors": repr(loop.sensors) if loop.sensors is not None else "exact",
        "sample_time": loop.sample_time,
    }
    if loop.has_actuator_dynamics:
        from adaptive_ftc.sim.activity import actuator_limits_meta

        meta["actuator_limits"] = actuator_limits_meta(loop, asm)
    return meta


# ---------------------------------------------------------------------- export helpers
def lean_signal_block(loop: ClosedLoop, rows: int) -> np.ndarray:
    """An uninitialised block for the lean signals of ``rows`` records of ``loop``: ``e``,
    ``u_cmd`` and ``u_applied`` (``p + 2 m`` columns; ``simulate``'s ``lean_signals``)."""
    from adaptive_ftc.sim import blocks

    return blocks.empty((rows, loop.plant.n_outputs + 2 * loop.plant.n_actuators))


def signal_block(loop: ClosedLoop, rows: int) -> np.ndarray:
    """An uninitialised block for the recorded signals of ``rows`` records of ``loop``
    (``Assembled.signals`` writes every column of every row)."""
    from adaptive_ftc.sim import blocks
    from adaptive_ftc.sim.layout import RecordLayout

    width = RecordLayout(p=loop.plant.n_outputs, m=loop.plant.n_actuators).width
    return blocks.empty((rows, width))  # an earlier run's block when one is free


def _solver_settings(solver: Any) -> str:
    """The solver options as sorted JSON (stable text for provenance attributes); remembered
    per (frozen, hashable) options object: a batch shares one."""
    try:
        return _settings_text(solver)
    except TypeError:  # unhashable
        return _settings_text.__wrapped__(solver)


@functools.lru_cache(maxsize=64)
def _settings_text(solver: Any) -> str:

    try:
        fields = dataclasses.asdict(solver)
    except TypeError:
        return repr(solver)
    return json.dumps(_jsonable(fields), sort_keys=True)


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return repr(value)
    if isinstance(value, (str, int, float, bool)) or value is None:
        return value
    if isinstance(value, np.generic):
        return value.item()
    return str(value)


def _reason_from_json(data: dict[str, Any] | None) -> StatusReason | None:
    """The :class:`StatusReason` written by :meth:`SimResult.to_netcdf` (non-finite numbers are
    stored as their text)."""
    if not data:
        return None
    known = {f.name: f for f in dataclasses.fields(StatusReason)}
    values: dict[str, Any] = {}
    for k, v in data.items():
        if k not in known:
            continue
        if k in ("time", "value", "bound") and v is not None:
            v = float(v)
        values[k] = v
    return StatusReason(**values)


def _declared_units(plant: Any, attrs: tuple[str, ...], size: int) -> tuple[str, ...]:
    """Units from the first plant class attribute of ``attrs`` that exists (a string or one
    string per item), else ``()``."""
    units = next((getattr(plant, a) for a in attrs if getattr(plant, a, None) is not None), None)
    if units is None:
        return ()
    if isinstance(units, str):
        return (units,) * size
    units = tuple(str(u) for u in units)
    return units if len(units) == size else ()


def _output_units(
    state_names: tuple[str, ...], output_names: tuple[str, ...], state_units: tuple[str, ...]
) -> tuple[str, ...]:
    """Output units taken from the states of the same name, when every output is a state."""
    if not state_units or not all(o in state_names for o in output_names):
        return ()
    return tuple(state_units[state_names.index(o)] for o in output_names)


def _unit(units: tuple[str, ...], i: int) -> str:
    return udunits(units[i]) if i < len(units) and units[i] else "1"


def _common(units: list[str]) -> str:
    return units[0] if units and all(u == units[0] for u in units) else "1"


def _attrs(long_name: str, unit: str, *, declared: bool = True) -> dict[str, str]:
    out = {"long_name": long_name, **cf_unit_attrs(unit)}
    if not declared:
        out["comment"] = "units not declared by the plant class; '1' is a placeholder"
    return out


def _decimation_index(n: int, k: int) -> np.ndarray:
    idx = np.arange(0, n, k)
    if n and idx[-1] != n - 1:
        idx = np.append(idx, n - 1)
    return idx


@functools.lru_cache(maxsize=1)
def _git_commit() -> str:
    """The git commit of the package's checkout, or ``""`` (installed from a wheel, no git)."""
    here = Path(__file__).resolve().parent
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            cwd=here,
            capture_output=True,
            text=True,
            timeout=5,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return ""
    commit = out.stdout.strip()
    return commit if out.returncode == 0 and len(commit) == 40 else ""
