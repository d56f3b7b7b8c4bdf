"""Issue 25, combination 2 on §4.4 (hypersonic-sign-s1-rho0pos): which difference between the
§4.4 and §2.3 constraint-aware laws costs the error (docs/hardware.md, "Round 11b").

One run of combination 2 (lag 50 ms + rate 2 + travel ±0.5 + 50 Hz + noise 1e-4; the final
window 100-120 s, recorded at 1 ms) with levers that swap one difference at a time:

    PYTHONPATH=src python scripts/combo2_sign_study.py [--law sign|direct]
        [--failures sign|direct] [--growth G] [--alpha1 X] [--seed N] [...]

``--law``: the design (§4.4 sign estimation or §2.3 direct, each with its catalogue gains);
``--failures``: whose failure scenario (hypersonic-sign-s1-rho0pos: elevator 2 at (0.5 + 0.5
sin^2 t) with a 0.08 sin 0.5t bias from 60 s, elevator 1 0.5 u^3 + 0.2 u from 80 s;
hypersonic-direct-s1: elevator 2 stuck from 40 s, elevator 1 at 75 % with a -0.2 bias from
80 s). §4.4 levers: ``--growth`` (``ConstraintAware.gain_growth``: the loop sized for a loop
gain that may grow by that factor), ``--scale-x`` / ``--slope-x`` (factors on the compiled
scale ``r`` and slope scale ``r_K``), ``--alpha0`` / ``--alpha1`` (factors on the compiled
adaptation gains; ``--alpha1 0`` freezes ``rho``), ``--rho-factor``, ``--rho-factor-integral``,
``--zeta`` (``RHO_FACTOR``, ``RHO_FACTOR_INTEGRAL``, ``C_INTEGRAL_ZETA``); both laws:
``--c-integral``, ``--seed`` (the sensor noise's), ``--noise-off`` (the designer's model keeps
the declared noise). Session 14's §4.4 law: ``--rho-factor-integral 1.25 --zeta 0``. Printed:
the configuration, the final-window error, fast content, peak, the error's RMS over 85-100,
100-110 and 110-120 s, its RMS by band of angular frequency, and ``rho`` over 30-120 s.
"""

from __future__ import annotations

import argparse
import math
import sys
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import hardware_cases as hc  # noqa: E402

from adaptive_ftc.controllers import constraints  # noqa: E402
from adaptive_ftc.controllers.sign_estimation import SignEstimation, SignGains  # noqa: E402
from adaptive_ftc.errors import DivergenceWarning  # noqa: E402
from adaptive_ftc.scenarios.loader import load_scenario  # noqa: E402
from adaptive_ftc.sim.engine import simulate  # noqa: E402

SCENARIOS = {"sign": "hypersonic-sign-s1-rho0pos", "direct": "hypersonic-direct-s1"}
CASE = hc.HYPERSONIC_CASES[-1]
BANDS = ((0.0, 1.5), (1.5, 6.0), (6.0, 30.0), (30.0, math.inf))  # rad/s


def build(args):
    """The combination's loop and solver with the levers applied."""
    base = load_scenario(SCENARIOS[args.law])
    fail = load_scenario(SCENARIOS[args.failures])
    loop, solver = hc.case_loop(base, CASE, args.duration)
    loop = replace(loop, failures=fail.loop.failures)
    if args.seed != 0 and loop.sensors is not None:
        loop = replace(loop, sensors=replace(loop.sensors, seed=args.seed))
    if args.noise_off and loop.sensors is not None:
        loop = replace(loop, sensors=None)
    loop = hc.constraint_aware(loop, solver)
    if args.noise_off:
        # the designer's model keeps the declared noise (the same configuration)
        ca = replace(loop.controller.constraint_aware, noise=CASE.noise)
        loop = replace(loop, controller=replace(loop.controller, constraint_aware=ca))
    over = {}
    if args.growth is not None:
        over["gain_growth"] = args.growth
    if over:
        ca = replace(loop.controller.constraint_aware, **over)
        loop = replace(loop, controller=replace(loop.controller, constraint_aware=ca))
    return loop, solver


def patch(args):
    """Module-level levers (restored by nothing: one run per process)."""
    if args.c_integral is not None:
        constraints.C_INTEGRAL = args.c_integral
    if args.rho_factor is not None:
        constraints.RHO_FACTOR = args.rho_factor
    if args.zeta is not None:
        constraints.C_INTEGRAL_ZETA = args.zeta
    if args.rho_factor_integral is not None:
        constraints.RHO_FACTOR_INTEGRAL = args.rho_factor_integral
    if args.scale_x is not None or args.slope_x is not None:
        configuration = SignEstimation.configuration

        def moved(self, *a, **k):
            cfg = configuration(self, *a, **k)
            if cfg == constraints.IDENTITY:
                return cfg
            return cfg._replace(
                scale=cfg.scale * (args.scale_x or 1.0),
                slope_scale=cfg.slope_scale * (args.slope_x or 1.0),
            )

        SignEstimation.configuration = moved  # type: ignore[method-assign]
    if args.alpha1 is not None or args.alpha0 is not None:
        gains = SignEstimation.gains

        def scaled(self):
            g = gains(self)
            a0 = g.alpha0 * (args.alpha0 if args.alpha0 is not None else 1.0)
            a1 = g.alpha1 * (args.alpha1 if args.alpha1 is not None else 1.0)
            return SignGains(a0, g.sigma0, a1, g.sigma1)

        SignEstimation.gains = scaled  # type: ignore[method-assign]


def band_power(t, e, bands=BANDS):
    """RMS of ``e`` (detrended) per band of angular frequency (rad/s)."""
    e = e - np.mean(e)
    n = e.size
    spec = np.fft.rfft(e * np.hanning(n))
    w = 2 * math.pi * np.fft.rfftfreq(n, d=float(np.median(np.diff(t))))
    p = np.abs(spec) ** 2
    tot = float(np.sum(p)) or 1.0
    rms = float(np.sqrt(np.mean(e**2)))
    return [rms * math.sqrt(float(np.sum(p[(w >= lo) & (w < hi)])) / tot) for lo, hi in bands]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--law", choices=SCENARIOS, default="sign")
    ap.add_argument("--failures", choices=SCENARIOS, default=None)
    ap.add_argument("--duration", type=float, default=None)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--noise-off", action="store_true")
    ap.add_argument("--growth", type=float, default=None, help="ConstraintAware.gain_growth")
    ap.add_argument("--alpha1", type=float, default=None, help="factor on the compiled alpha1")
    ap.add_argument("--alpha0", type=float, default=None, help="factor on the compiled alpha0")
    ap.add_argument("--scale-x", type=float, default=None, help="factor on the scale r")
    ap.add_argument("--slope-x", type=float, default=None, help="factor on the slope scale")
    ap.add_argument("--zeta", type=float, default=None, help="C_INTEGRAL_ZETA (§4.4)")
    ap.add_argument("--rho-factor-integral", type=float, default=None, help="RHO_FACTOR_INTEGRAL")
    ap.add_argument("--c-integral", type=float, default=None)
    ap.add_argument("--rho-factor", type=float, default=None)
    args = ap.parse_args(argv)
    args.failures = args.failures or args.law
    patch(args)
    loop, solver = build(args)
    bound = loop.controller.bound(loop)
    cfg = bound.configuration(2.0, bound.constraint_aware.input_gain)
    print(
        f"law {args.law}, failures {args.failures}: scale {cfg.scale:.4g}, slope "
        f"{cfg.slope_scale:.4g}, lam x{cfg.lam_factor:.3g}, k_I {cfg.error_integral:.3g}, "
        f"robust {tuple(round(float(v), 4) for v in bound.robust_settings())}, "
        f"gains {tuple(round(float(v), 5) for v in bound.gains())}"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        r = simulate(loop, solver)
    t_end = loop.t_final
    m = hc.metrics(r, loop, (t_end - 20.0, t_end))
    if not math.isfinite(m["err"]):
        print(f"DIVERGED at {m['t_end']:.2f} s")
        return 0
    e = r.e[:, 0]
    spans = [(t_end - 35, t_end - 20), (t_end - 20, t_end - 10), (t_end - 10, t_end)]
    parts = [float(np.sqrt(np.mean(e[(r.time >= a) & (r.time < b)] ** 2))) for a, b in spans]
    sel = r.time >= t_end - 20
    bp = band_power(r.time[sel], e[sel])
    print(
        f"error {m['err']:.3e}  fast {m['fast']:.2e}  peak {m['peak_u']:.3f}  at_rate "
        f"{m['at_rate']:.3f} | RMS 85-100 {parts[0]:.2e}, 100-110 {parts[1]:.2e}, 110-120 "
        f"{parts[2]:.2e} | bands <1.5 {bp[0]:.2e} 1.5-6 {bp[1]:.2e} 6-30 {bp[2]:.2e} "
        f">30 {bp[3]:.2e} rad/s"
    )
    if "rho" in r.adaptive_names:
        rho = r.adaptive_state("rho")
        bnd = bound.rho_bound()
        for a, b in ((30, 60), (60, 80), (80, 100), (100, 120)):
            s = (r.time >= a) & (r.time < b)
            print(
                f"  rho {a}-{b} s: min {rho[s].min():.3f} mean {rho[s].mean():.3f} max "
                f"{rho[s].max():.3f}, at bound {np.mean(rho[s] >= bnd * (1 - 1e-6)):.2f}"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
