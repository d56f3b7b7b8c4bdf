"""Simulation results: labelled arrays with xarray/pandas/netCDF/CSV export and metrics."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim import kernel as K

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    import xarray as xr

    from adaptive_ftc.sim.assemble import Assembled
    from adaptive_ftc.sim.engine import SolverOptions
    from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["SimResult"]


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
    status, message
        ``"completed"`` or ``"diverged"`` and the divergence message.
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
    status: str = "completed"
    message: str = ""
    meta: dict[str, Any] = field(default_factory=dict)

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
        solver: SolverOptions,
        message: str,
        wall_time: float,
    ) -> SimResult:
        """Build a result from recorded closed-loop states (signals are recomputed)."""
        p, m, n = loop.plant.n_outputs, loop.plant.n_actuators, loop.plant.n_states
        ncol = 9 * p + 2 * m + 4
        out = np.zeros((T.size, ncol))
        if T.size:
            K.signals(
                asm.model,
                np.ascontiguousarray(T),
                np.ascontiguousarray(Y),
                np.ascontiguousarray(phases),
                out,
            )
        cols = [out[:, i * p : (i + 1) * p] for i in range(9)]
        c = 9 * p
        times = sorted(
            {t for f in loop.failures.failures for t in f.jump_times if loop.t0 < t < loop.t_final}
        )
        ctrl = loop.controller
        meta = {
            "name": loop.name,
            "plant": loop.plant.name,
            "design": ctrl.design,
            "equations": ctrl.equation,
            "adapt": loop.adapt,
            "solver": solver.method,
            "dt": solver.dt,
            "sdot": solver.sdot,
            "t_final": loop.t_final,
            "wall_time_s": wall_time,
        }
        return cls(
            time=T.copy(),
            states=Y[:, :n].copy(),
            adaptive=Y[:, n:].copy(),
            y=cols[0],
            yd=cols[1],
            yd_dot=cols[2],
            e=cols[3],
            edot=cols[4],
            s=cols[5],
            sdot=cols[6],
            u0=cols[8],
            u_cmd=out[:, c : c + m],
            u_applied=out[:, c + m : c + 2 * m],
            u_f=out[:, c + 2 * m],
            gain=out[:, c + 2 * m + 1],
            control_gain=out[:, c + 2 * m + 2],
            state_names=tuple(loop.plant.state_names),
            output_names=tuple(loop.plant.output_names),
            actuator_names=tuple(loop.plant.actuator_names),
            adaptive_names=asm.adaptive_names,
            theta_slices=asm.theta_slices,
            failure_times=tuple(times),
            failures=tuple(loop.describe_failures()),
            status="diverged" if message else "completed",
            message=message,
            meta=meta,
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

    def recovery(self, window: float = 5.0) -> list[dict[str, Any]]:
        """Per failure time: RMS error just after it (``window`` s) and just before the next."""
        rows = []
        times = list(self.failure_times)
        ends = times[1:] + [float(self.meta.get("t_final", self.time[-1]))]
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

    def metrics(self, final_window: float | None = None) -> dict[str, float]:
        """Headline numbers: RMS/max error overall and in the final window, peak control."""
        if self.time.size == 0:
            return {"status": self.status}  # type: ignore[dict-item]
        t_end = float(self.time[-1])
        fw = final_window if final_window is not None else max(0.1 * (t_end - self.time[0]), 1e-9)
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
        return out

    # ------------------------------------------------------------------ export
    def to_xarray(self) -> xr.Dataset:
        """All recorded signals as an :class:`xarray.Dataset` with labelled dimensions."""
        import xarray as xr

        t = ("time",)
        ds = xr.Dataset(
            {
                "states": (("time", "state"), self.states),
                "adaptive": (("time", "param"), self.adaptive),
                "y": (("time", "output"), self.y),
                "yd": (("time", "output"), self.yd),
                "yd_dot": (("time", "output"), self.yd_dot),
                "e": (("time", "output"), self.e),
                "edot": (("time", "output"), self.edot),
                "s": (("time", "output"), self.s),
                "sdot": (("time", "output"), self.sdot),
                "u0": (("time", "output"), self.u0),
                "u_cmd": (("time", "actuator"), self.u_cmd),
                "u_applied": (("time", "actuator"), self.u_applied),
                "u_f": (t, self.u_f),
                "gain": (t, self.gain),
                "control_gain": (t, self.control_gain),
            },
            coords={
                "time": self.time,
                "state": list(self.state_names),
                "output": list(self.output_names),
                "actuator": list(self.actuator_names),
                "param": list(self.adaptive_names),
            },
        )
        ds["time"].attrs["units"] = "s"
        attrs = {
            k: (v if isinstance(v, (int, float, str)) and not isinstance(v, bool) else str(v))
            for k, v in self.meta.items()
        }
        attrs.update(
            status=self.status,
            message=self.message,
            failure_times=np.asarray(self.failure_times, dtype=float),
            failures="; ".join(self.failures),
        )
        ds.attrs.update(attrs)
        return ds

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

    def to_netcdf(self, path: str | Path) -> Path:
        """Write the dataset to netCDF (scipy engine, no extra dependency)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        self.to_xarray().to_netcdf(path, engine="scipy")
        return path

    def to_csv(self, path: str | Path) -> Path:
        """Write the wide table to CSV."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        self.to_pandas().to_csv(path)
        return path

    def plot(self, kind: str = "tracking", **kwargs):
        """Thesis-style figure; see :mod:`adaptive_ftc.plots`."""
        from adaptive_ftc import plots

        return plots.plot(self, kind, **kwargs)
