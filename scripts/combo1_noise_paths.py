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
the failures. ``--gain-estimate BAND`` (round 8, session 13) adds an online estimate of the
loop's input gain ``b = d y''/d u0`` and normalises the command by it, ``u0 -> (b_nom /
b_hat) u0`` (:func:`emit_with_gain_estimate`; ``--gain-forget`` its forgetting rate, 1/s):
the input-gain lever of docs/hardware.md ("Round 8: the input-gain lever, built");
``--gain-low-band WC`` normalises only the command's content below ``WC`` rad/s.

Round 11 (session 15): ``--noise-seed N`` draws the sensors' noise with seed ``N``;
``--no-regressor-prefilter`` runs the law without the regressor's prefilter that the rule takes
since session 15 (``ConstraintAware.regressor_prefilter``: session 14's law),
``--regressor-filter M`` with it taken (§4.4 too) at ``M w`` instead of ``C_REGRESSOR_NOISE w``;
``--desired-regressor`` evaluates the regressor on the desired trajectory instead (the
desired-compensation adaptive law, Sadegh & Horowitz, IJRR 9(3) 1990: ``u0 = Pi(x_d)^T theta``,
``theta' = gamma Pi(x_d) q``, with ``x_d = (y_d, y_d')`` for the hypersonic basis of (alpha,
q), the rule's prefilter off), and ``--rate-feedback KQ`` adds its extra feedback term on the
measured rate error, ``u0 += KQ e'`` (:func:`desired_regressor_rhs`).

    PYTHONPATH=src python scripts/combo1_noise_paths.py hypersonic-direct-s1
    PYTHONPATH=src python scripts/combo1_noise_paths.py hypersonic-direct-s1 --command-filter 4
    PYTHONPATH=src python scripts/combo1_noise_paths.py hypersonic-direct-s1 --gain-estimate 10 \
        --scale-g 0.5 --scale-k 0.5 --command-filter 4
    PYTHONPATH=src python scripts/combo1_noise_paths.py hypersonic-direct-s1 --noise-seed 1 \
        --no-regressor-prefilter
    PYTHONPATH=src python scripts/combo1_noise_paths.py hypersonic-direct-s1 --desired-regressor \
        --rate-feedback 1.75
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
from adaptive_ftc.sim.parts import approximator  # noqa: E402

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


#: the input-gain estimate's states: four low-passes of the measured output, the actuator's
#: lag model, four low-passes of the delivered command, and the two forgetting sums
GAIN_STATES = 11
#: the estimate's sums start at this prior (``S_pp``; ``S_zp = b_nom`` times it) and keep it
#: as a regulariser: ``b_hat = (S_zp + P0 b_nom) / (S_pp + P0)``
GAIN_PRIOR = 1e-10
#: the least estimate, a fraction of the nominal gain (the projection's lower end)
GAIN_FLOOR = 0.1


def nominal_gain(loop) -> float:
    """The healthy loop's signed ``d y''/d u0 = sum_j G_j R_j`` at ``t0`` (``G``: the plant's
    input gains of its single output, the designer's nominal model); 0 where not defined."""
    G = np.asarray(loop.plant.input_gains(loop.t0, np.asarray(loop.initial_state, float)))
    R = np.atleast_2d(np.asarray(loop.R, dtype=float))
    if G.shape != R.shape or G.shape[0] != 1 or not np.all(np.isfinite(G)):
        return 0.0
    return float(np.sum(G[0] * R[0]))


def gain_lines(
    band, forget, lag, b_nom, pos, at, consts, low_band=0.0
) -> tuple[list[str], list[str]]:
    """The input-gain estimate's generated lines, its states from ``at`` on: ``(the command
    normalised by the estimate, before the command filter; the estimator's derivatives)``.

    The estimator regresses the band-passed acceleration of the measured output, ``z = s^2
    B(s) y_m``, on the band-passed delivered command through the actuator's lag model, ``phi
    = B(s) u0 / (lag s + 1)``, ``B(s) = band^2 s^2 / (s + band)^4`` (the double zero removes
    the reference and the failures' slow patterns, which the loop cancels and which would bias
    the estimate down; the plant's state terms are ``M / band^2`` of the input's there), by
    least squares with exponential forgetting (Ioannou & Sun, *Robust Adaptive Control*,
    1996, ch. 4: least squares with forgetting factor): ``b_hat = S_zp / S_pp``, ``S_zp' =
    forget (z phi - S_zp)``, ``S_pp' = forget (phi^2 - S_pp)``, projected on ``[GAIN_FLOOR
    b_nom, b_nom]``; the command is normalised as with an input-gain estimate in adaptive
    control, ``u0 -> (b_nom / b_hat) u0``. The output's position, not its measured rate:
    the command carries the rate's noise through the learnt rate feedback, and a regression
    on the measured rate's derivative takes that correlation for input gain (measured: 1.5-2x
    the true gain in the noise-driven stretches).

    ``low_band`` > 0 (rad/s): the normalisation only below it, on a first-order low-pass of
    the command (one state more, after the estimate's), ``u0 -> u0 + (b_nom / b_hat - 1)
    u0_lp``: the failed loop's gain restored where the stuck elevator's pattern is rejected,
    not in the band where the command carries the noise (a lag compensator whose boost is the
    estimate)."""
    k0 = len(consts)
    consts.extend([band, forget, GAIN_FLOOR * b_nom, b_nom, lag, GAIN_PRIOR])
    a, lf, bmin, bn, lg, p0 = (f"c[{k0 + k}]" for k in range(6))
    x1, x2, x3, x4, ln, y1, y2, y3, y4, sz, sp = (at + k for k in range(GAIN_STATES))
    clip = f"min(max(bh, {bmin}), {bn})" if b_nom > 0 else f"max(min(bh, {bmin}), {bn})"
    control = [
        "    # study lever: the command normalised by the estimated input gain",
        f"    bh = (Y[{sz}] + {p0} * {bn}) / (Y[{sp}] + {p0})",
        f"    bh = {clip}",
    ]
    if low_band > 0:
        consts.append(float(low_band))
        wc = f"c[{len(consts) - 1}]"
        control += [
            f"    dY[{at + GAIN_STATES}] = {wc} * (u0[0] - Y[{at + GAIN_STATES}])",
            f"    u0[0] += ({bn} / bh - 1.0) * Y[{at + GAIN_STATES}]",
        ]
    else:
        control += [f"    u0[0] *= {bn} / bh"]
    pre = [
        "    # study lever: least-squares estimate of the input gain (forgetting)",
        f"    ym = sig[{pos}]",
        f"    dY[{x1}] = {a} * (ym - Y[{x1}])",
        f"    dY[{x2}] = {a} * (Y[{x1}] - Y[{x2}])",
        f"    dY[{x3}] = {a} * (Y[{x2}] - Y[{x3}])",
        f"    dY[{x4}] = {a} * (Y[{x3}] - Y[{x4}])",
        f"    zb = {a} * {a} * (ym - 4.0 * Y[{x1}] + 6.0 * Y[{x2}] - 4.0 * Y[{x3}] + Y[{x4}])",
    ]
    if lag > 0:
        pre += [f"    dY[{ln}] = (u0[0] - Y[{ln}]) / {lg}", f"    ul = Y[{ln}]"]
    else:
        pre += [f"    dY[{ln}] = 0.0", "    ul = u0[0]"]
    pre += [
        f"    dY[{y1}] = {a} * (ul - Y[{y1}])",
        f"    dY[{y2}] = {a} * (Y[{y1}] - Y[{y2}])",
        f"    dY[{y3}] = {a} * (Y[{y2}] - Y[{y3}])",
        f"    dY[{y4}] = {a} * (Y[{y3}] - Y[{y4}])",
        f"    pb = Y[{y2}] - 2.0 * Y[{y3}] + Y[{y4}]",
        f"    dY[{sz}] = {lf} * (zb * pb - Y[{sz}])",
        f"    dY[{sp}] = {lf} * (pb * pb - Y[{sp}])",
    ]
    return control, pre


def emit_with_gain_estimate(band: float, forget: float, low_band: float = 0.0):
    """A replacement of ``constraints.emit`` that adds the input-gain estimate (:func:`gain_
    lines`, its states before the rule's, adaptive: frozen with the adaptation) to a
    single-output loop without an allocator whose position output is measured; the lag of
    its actuator model is the designer's ``lag + T/2`` (half a sample of hold)."""
    emit = constraints.emit

    def patched(cfg, g, blocks, at, single_output, direction=""):
        loop = g.loop
        pos = tuple(getattr(loop.plant, "position_index", ()))
        b_nom = nominal_gain(loop)
        ca = loop.controller.constraint_aware
        if g.p != 1 or loop.allocator is not None or not pos or not abs(b_nom) > 0 or ca is None:
            return emit(cfg, g, blocks, at, single_output, direction)
        g.adaptive_names += [f"gain_estimate{k + 1}" for k in range(GAIN_STATES)]
        g.y0_extra.extend([0.0] * (GAIN_STATES - 2) + [GAIN_PRIOR * b_nom, GAIN_PRIOR])
        extra = 1 if low_band > 0 else 0
        if extra:
            g.adaptive_names += ["gain_low_pass"]
            g.y0_extra.append(0.0)
        lag = ca.lag + 0.5 * ca.sample_time
        control0, pre0 = gain_lines(band, forget, lag, b_nom, int(pos[0]), at, g.consts, low_band)
        control, pre, post, measure = emit(
            cfg, g, blocks, at + GAIN_STATES + extra, single_output, direction
        )
        return control0 + control, pre + pre0, post, measure

    return patched


def desired_regressor_rhs(rate_feedback: float = 0.0):
    """A replacement of the approximator's ``rhs`` whose regressor reads the desired
    trajectory where it reads a measured output's position or velocity (``ref[3 i]``,
    ``ref[3 i + 1]``), so that the command ``u0 = Pi(x_d)^T theta`` and the adaptation
    (``phi``) carry no measurement noise (Sadegh & Horowitz 1990, the desired-compensation
    adaptive law), plus ``u0_i += rate_feedback e_i'`` (the measured rate error; their extra
    feedback term, which the Lyapunov argument needs for ``Pi(x) - Pi(x_d)``)."""
    rhs = approximator.Approximator.rhs

    def patched(self, b):
        out = rhs(self, b)
        plant = b.loop.plant
        nx, p = int(plant.n_states), int(plant.n_outputs)
        lines = []
        for ln in out["regressors"]:
            for i in range(p):
                ln = ln.replace(f"sig[{plant.position_index[i]}]", f"ref[{3 * i}]")
                ln = ln.replace(f"sig[{plant.velocity_index[i]}]", f"ref[{3 * i + 1}]")
            lines.append(ln)
        if rate_feedback:
            lines += ["    # study lever: the desired-compensation law's rate feedback"]
            lines += [
                f"    u0[{i}] += {float(rate_feedback)!r} * sig[{nx + p + i}]" for i in range(p)
            ]
        return {**out, "regressors": lines}

    return patched


def gain_estimate(r, loop) -> np.ndarray:
    """The input-gain estimate ``b_hat`` along a run with ``--gain-estimate`` (projected)."""
    b_nom = nominal_gain(loop)
    sz = r.adaptive_state(f"gain_estimate{GAIN_STATES - 1}")
    sp = r.adaptive_state(f"gain_estimate{GAIN_STATES}")
    bh = (sz + GAIN_PRIOR * b_nom) / (sp + GAIN_PRIOR)
    lo, hi = sorted((GAIN_FLOOR * b_nom, b_nom))
    return np.clip(bh, lo, hi)


def run(
    scenario: str,
    *,
    noise_off=False,
    failures_off=False,
    levers=None,
    duration=None,
    gain_estimate=None,
    decimation=None,
    noise_seed=0,
    regressor_prefilter=None,
    regressor_filter=None,
    desired_regressor=None,
):
    """The combination's run of ``scenario`` with the constraint-aware law, ``levers`` (the
    keywords of :func:`with_levers`) applied to its configuration, and ``gain_estimate =
    (band, forget[, low_band])`` the input-gain estimate (:func:`emit_with_gain_estimate`);
    ``decimation``: the model's (``ConstraintAware.decimation``; ``None``: the rule's, the
    filter since session 14; ``False``: the latest reading, session 13's law);
    ``noise_seed``: the sensors' seed; ``regressor_prefilter``: the model's (``None``: the
    rule's, since session 15), ``regressor_filter`` its bandwidth in multiples of ``w``
    (``None``: ``C_REGRESSOR_NOISE``); ``desired_regressor``: the rate feedback of the
    desired-compensation lever (:func:`desired_regressor_rhs`; ``None``: off; the rule's
    prefilter then off): ``(result, loop)``."""
    sc = load_scenario(scenario)
    loop, solver = case_loop(sc, COMBO1, duration, noise_seed)
    loop = constraint_aware(loop, solver)
    if desired_regressor is not None:
        regressor_prefilter = False
    model = {}
    if decimation is not None:
        model["decimation"] = decimation
    if regressor_prefilter is not None:
        model["regressor_prefilter"] = regressor_prefilter
    if model:
        ca = replace(loop.controller.constraint_aware, **model)
        loop = replace(loop, controller=replace(loop.controller, constraint_aware=ca))
    if noise_off:
        loop = replace(loop, sensors=None)
    if failures_off:
        loop = replace(loop, failures=())
    saved, saved_emit = constraints.ConstraintAware.configure, constraints.emit
    saved_c, saved_rhs = constraints.C_REGRESSOR_NOISE, approximator.Approximator.rhs
    if levers:
        constraints.ConstraintAware.configure = with_levers(**levers)
    if gain_estimate is not None:
        constraints.emit = emit_with_gain_estimate(*gain_estimate)
    if regressor_filter is not None:
        constraints.C_REGRESSOR_NOISE = float(regressor_filter)
    if desired_regressor is not None:
        approximator.Approximator.rhs = desired_regressor_rhs(desired_regressor)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = simulate(loop, solver)
    finally:
        constraints.ConstraintAware.configure = saved
        constraints.emit = saved_emit
        constraints.C_REGRESSOR_NOISE = saved_c
        approximator.Approximator.rhs = saved_rhs
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
    ap.add_argument("--gain-estimate", type=float, default=None, metavar="BAND")
    ap.add_argument("--gain-forget", type=float, default=0.2, metavar="RATE")
    ap.add_argument("--gain-low-band", type=float, default=0.0, metavar="RAD_PER_S")
    ap.add_argument("--no-split", action="store_true", help="skip the regressor/theta split")
    ap.add_argument(
        "--no-decimation",
        action="store_true",
        help="the latest sensor reading at each sample (session 13's law), not the mean",
    )
    ap.add_argument("--noise-seed", type=int, default=0, help="the sensors' seed (default 0)")
    ap.add_argument(
        "--no-regressor-prefilter",
        action="store_true",
        help="without the regressor's prefilter the rule takes (session 14's law)",
    )
    ap.add_argument(
        "--regressor-filter",
        type=float,
        default=None,
        metavar="M",
        help="the regressor's prefilter (taken) at M w instead of C_REGRESSOR_NOISE w",
    )
    ap.add_argument(
        "--desired-regressor",
        action="store_true",
        help="the regressor on the desired trajectory (desired-compensation lever)",
    )
    ap.add_argument(
        "--rate-feedback",
        type=float,
        default=0.0,
        metavar="KQ",
        help="with --desired-regressor: u0 += KQ e' (the measured rate error)",
    )
    args = ap.parse_args(argv)
    levers = {
        "lam_factor": args.lam_factor,
        "scale_g": args.scale_g,
        "scale_k": args.scale_k,
        "command_filter": args.command_filter,
        "q_prefilter": args.q_prefilter,
        "measure_prefilter": args.measure_prefilter,
    }
    ge = None
    if args.gain_estimate is not None:
        ge = (args.gain_estimate, args.gain_forget, args.gain_low_band)
    r, loop = run(
        args.scenario,
        noise_off=args.noise_off,
        failures_off=args.failures_off,
        levers=levers,
        gain_estimate=ge,
        decimation=False if args.no_decimation else None,
        noise_seed=args.noise_seed,
        regressor_prefilter=(
            False
            if args.no_regressor_prefilter
            else (True if args.regressor_filter is not None else None)
        ),
        regressor_filter=args.regressor_filter,
        desired_regressor=args.rate_feedback if args.desired_regressor else None,
    )
    m = metrics(r, loop, WINDOW)
    if not math.isfinite(m["err"]):
        print(f"{args.scenario}: {m['status']} at {m['t_end']:.2f} s")
        return 0
    print(f"{args.scenario}, {COMBO1.name}: error {m['err']:.3e} rad, fast {m['fast']:.3e} rad")
    u = np.asarray(r.u_cmd, dtype=float)
    per = ", ".join(f"{fast_rms(u[:, j], r.time):.2e}" for j in range(u.shape[1]))
    print(f"fast content per actuator: {per}")
    if ge is not None:
        bh = gain_estimate(r, loop)
        sel = (r.time >= WINDOW[0]) & (r.time <= WINDOW[1])
        print(
            f"input-gain estimate (nominal {nominal_gain(loop):.3g}): final window "
            f"{bh[sel].min():.3g} to {bh[sel].max():.3g}, mean {bh[sel].mean():.3g}"
        )
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
