"""Where the constraint-aware law's fast command content comes from in issue 25's first
hardware combination (lag 20 ms + digital 200 Hz + noise 1e-3 rad on alpha, 1e-2 rad/s on q),
and what each lever of the rule does to it (docs/hardware.md, "Round 7: combination 1").

Runs the case of ``scripts/hardware_cases.py`` with the constraint-aware law and prints, over
the final window (100-120 s, recorded at 1 ms): the RMS tracking error, the fast content (RMS
of the command minus its zero-phase 1 Hz low-pass, largest over the actuators) and its split
into frequency bands per actuator, and the split of the common command ``u0 = Pi(x_m)^T
theta`` into the **regressor path** (``Pi(x_m)^T theta - Pi(x)^T theta``: the measured states
in the fuzzy basis times the learnt ``theta``, a rate feedback the law has learnt) and the
**theta path** (``Pi(x)^T theta``: what ``theta`` itself carries, the proportional path
``(g/b) s`` through the ``s'`` filter and the integral path).

The levers change the configuration the rule derives (``ConstraintAware.configure``) for
this run only: ``--lam-factor F`` (``lam = F lam_thesis``), ``--scale-g X`` and ``--scale-k X``
(the adaptation gain and the robust term's slope times X, i.e. the loop gain and the integral
path), ``--command-filter M`` (a first-order low-pass ``M w`` on ``u0``, at most ``1/lag`` and
``1/T``: the command filter without limits), ``--q-prefilter M`` and ``--measure-prefilter M``
(the adaptation signal ``q`` and every measurement the law sees through first-order filters at
``M w``). ``--noise-off`` removes the sensors (the same designer's model), ``--failures-off``
the failures.

    PYTHONPATH=src python scripts/combo1_noise_paths.py hypersonic-direct-s1
    PYTHONPATH=src python scripts/combo1_noise_paths.py hypersonic-direct-s1 --command-filter 4
"""

from __future__ import annotations

import argparse
import math
import sys
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.signal import butter, sosfiltfilt

sys.path.insert(0, str(Path(__file__).resolve().parent))

from hardware_cases import HYPERSONIC_CASES, case_loop, constraint_aware, metrics  # noqa: E402

from adaptive_ftc.controllers import constraints  # noqa: E402
from adaptive_ftc.scenarios.loader import load_scenario  # noqa: E402
from adaptive_ftc.sim.engine import simulate  # noqa: E402

#: the first combination of issue 25
COMBO1 = next(c for c in HYPERSONIC_CASES if c.name.startswith("lag 20 ms + 200 Hz"))
#: the frequency bands (Hz) of the split
BANDS = ((1, 3), (3, 10), (10, 30), (30, 100), (100, 500))
WINDOW = (100.0, 120.0)


def with_levers(
    *,
    lam_factor=None,
    scale_g=1.0,
    scale_k=1.0,
    command_filter=None,
    q_prefilter=None,
    measure_prefilter=None,
):
    """A replacement of ``ConstraintAware.configure`` that applies the levers to the rule's
    configuration (``w`` = the rule's loop rate)."""
    configure = constraints.ConstraintAware.configure

    def patched(self, **kw):
        cfg = configure(self, **kw)
        if cfg == constraints.IDENTITY:
            return cfg
        w, _ = self.omega_max(kw["w0"], kw["b_max"])
        cap = math.inf
        if self.sample_time > 0:
            cap = constraints.C_EULER / self.sample_time
        upd = {"scale": cfg.scale * scale_g, "slope_scale": cfg.slope_scale * scale_k}
        if lam_factor is not None:
            upd["lam_factor"] = float(lam_factor)
        if command_filter is not None:
            wf = min(command_filter * w, cap)
            if self.lag > 0:
                wf = min(wf, 1.0 / self.lag)
            upd["omega_f"] = wf
        if q_prefilter is not None:
            upd["omega_q"] = min(q_prefilter * w, cap)
        if measure_prefilter is not None:
            upd["omega_m"] = min(measure_prefilter * w, cap)
        return cfg._replace(**upd)

    return patched


def run(scenario: str, *, noise_off=False, failures_off=False, levers=None, duration=None):
    """The combination's run of ``scenario`` with the constraint-aware law, ``levers`` (the
    keywords of :func:`with_levers`) applied to its configuration: ``(result, loop)``."""
    sc = load_scenario(scenario)
    loop, solver = case_loop(sc, COMBO1, duration)
    loop = constraint_aware(loop, solver)
    if noise_off:
        loop = replace(loop, sensors=None)
    if failures_off:
        loop = replace(loop, failures=())
    saved = constraints.ConstraintAware.configure
    if levers:
        constraints.ConstraintAware.configure = with_levers(**levers)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = simulate(loop, solver)
    finally:
        constraints.ConstraintAware.configure = saved
    return r, loop


def band_rms(r, window=WINDOW) -> np.ndarray:
    """RMS of each actuator's command in each band of ``BANDS`` (rows: actuators) over
    ``window`` (zero-phase fourth-order band-passes of the whole record)."""
    u = np.asarray(r.u_cmd, dtype=float)
    sel = (r.time >= window[0]) & (r.time <= window[1])
    fs = 1.0 / float(np.median(np.diff(r.time)))
    out = np.zeros((u.shape[1], len(BANDS)))
    for k, (lo, hi) in enumerate(BANDS):
        sos = butter(4, [lo, min(hi, 0.99 * fs / 2)], btype="band", fs=fs, output="sos")
        for j in range(u.shape[1]):
            out[j, k] = np.sqrt(np.mean(sosfiltfilt(sos, u[:, j])[sel] ** 2))
    return out


def fast_rms(x, t, window=WINDOW) -> float:
    """The fast content of one signal: RMS of ``x`` minus its zero-phase 1 Hz low-pass."""
    fs = 1.0 / float(np.median(np.diff(t)))
    sos = butter(2, 1.0, fs=fs, output="sos")
    sel = (t >= window[0]) & (t <= window[1])
    hi = x - sosfiltfilt(sos, x)
    return float(np.sqrt(np.mean(hi[sel] ** 2)))


def regressor_split(r, loop, window=WINDOW) -> tuple[float, float, float]:
    """Fast content of ``u0`` (single output), of the theta path ``Pi(x)^T theta`` and of the
    regressor path ``u0 - Pi(x)^T theta`` (``Pi`` of the true states: the thesis law's
    regressor on the same plant, evaluated at the recorded states) over ``window``."""
    a = loop.controller.thesis_assembled(loop)
    y = np.array(a.y0, dtype=float)
    nx = loop.plant.n_states
    rows = r.time >= window[0] - 10.0  # 10 s before the window: the filters' edges decay
    t = r.time[rows]
    X = np.asarray(r.states, dtype=float)[rows]
    th = np.asarray(r.theta, dtype=float)[rows]
    u0 = np.asarray(r.u0, dtype=float)[rows, 0]
    sl = a.theta_slices[0]
    true = np.empty_like(u0)
    for n in range(u0.size):
        y[:nx] = X[n]
        true[n] = float(np.dot(a.regressor_values(float(t[n]), y)[sl], th[n]))
    return fast_rms(u0, t, window), fast_rms(true, t, window), fast_rms(u0 - true, t, window)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenario", nargs="?", default="hypersonic-direct-s1")
    ap.add_argument("--noise-off", action="store_true")
    ap.add_argument("--failures-off", action="store_true")
    ap.add_argument("--lam-factor", type=float, default=None)
    ap.add_argument("--scale-g", type=float, default=1.0)
    ap.add_argument("--scale-k", type=float, default=1.0)
    ap.add_argument("--command-filter", type=float, default=None)
    ap.add_argument("--q-prefilter", type=float, default=None)
    ap.add_argument("--measure-prefilter", type=float, default=None)
    ap.add_argument("--no-split", action="store_true", help="skip the regressor/theta split")
    args = ap.parse_args(argv)
    levers = {
        "lam_factor": args.lam_factor,
        "scale_g": args.scale_g,
        "scale_k": args.scale_k,
        "command_filter": args.command_filter,
        "q_prefilter": args.q_prefilter,
        "measure_prefilter": args.measure_prefilter,
    }
    r, loop = run(
        args.scenario, noise_off=args.noise_off, failures_off=args.failures_off, levers=levers
    )
    m = metrics(r, loop, WINDOW)
    if not math.isfinite(m["err"]):
        print(f"{args.scenario}: {m['status']} at {m['t_end']:.2f} s")
        return 0
    print(f"{args.scenario}, {COMBO1.name}: error {m['err']:.3e} rad, fast {m['fast']:.3e} rad")
    names = loop.plant.actuator_names
    head = " | ".join(f"{lo}-{hi} Hz" for lo, hi in BANDS)
    print(f"| actuator | {head} |")
    for j, row in enumerate(band_rms(r)):
        print(f"| {names[j]} | " + " | ".join(f"{v:.1e}" for v in row) + " |")
    if not args.no_split and loop.plant.n_outputs == 1:
        total, theta_path, reg_path = regressor_split(r, loop)
        print(
            f"u0 fast {total:.2e}: theta path Pi(x)^T theta {theta_path:.2e}, "
            f"regressor path Pi(x_m)^T theta - Pi(x)^T theta {reg_path:.2e}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
