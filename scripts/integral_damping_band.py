"""Issue 25, combination 2: does round 11b's damping of the integral's zero pair widen the band of
``C_INTEGRAL`` (docs/hardware.md, "Round 12 (session 15)")?

Runs combination 2 (lag 50 ms + rate 2 + travel ±0.5 + 50 Hz + noise 1e-4; the 120 s case,
final window 100-120 s, recorded at 1 ms; ``scripts/combo2_sign_study.py``'s loop) for each
``C_INTEGRAL`` and noise seed, with and without the damping
(:func:`adaptive_ftc.controllers.constraints.integral_damping`: ``lam >= 2 C_INTEGRAL_ZETA
sqrt(k_I)``, at most ``C_INTEGRAL_LAM_MAX`` times the thesis's ``lam``), and prints the
final-window error and fast content per run and the band (every seed under the threshold):

    PYTHONPATH=src python scripts/integral_damping_band.py [--law direct|sign]
        [--c 0.15,0.2,...] [--seeds 0,1,2] [--damping on|off|both]

``--law direct``: §2.3 (hypersonic-direct-s1), whose rule takes no damping: ``on`` applies
§4.4's to it; ``--law sign``: §4.4 (hypersonic-sign-s1-rho0pos), whose rule takes it: ``off``
sets ``C_INTEGRAL_ZETA`` to 0. About 0.5 s a run on two shared cores (the first compiles).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import combo2_sign_study as study  # noqa: E402

from adaptive_ftc.controllers import constraints  # noqa: E402
from adaptive_ftc.controllers.direct import DirectAdaptive  # noqa: E402

THRESHOLDS = {"direct": (8.7e-4, 1.73e-2), "sign": (8.7e-4, 8.67e-3)}  # error, fast (rad)
C_DEFAULT = "0.15,0.2,0.22,0.235,0.24,0.25,0.26,0.27,0.28,0.30,0.32,0.35,0.40"


def damp_direct(on: bool) -> None:
    """§2.3's configuration with (``on``) or without §4.4's damping of the integral."""
    plain = DirectAdaptive.__dict__.get("_plain_configuration")
    if plain is None:
        plain = DirectAdaptive.configuration
        DirectAdaptive._plain_configuration = plain  # type: ignore[attr-defined]
    if not on:
        DirectAdaptive.configuration = plain  # type: ignore[method-assign]
        return

    def damped(self, b_max=1.0, input_gain=0.0):
        cfg = plain(self, b_max, input_gain)
        ca = self.constraint_aware
        lam = self.lam if isinstance(self.lam, (int, float)) else min(self.lam)
        least = ca.min_loop_gain if ca is not None else None
        return constraints.integral_damping(cfg, float(lam), least)

    DirectAdaptive.configuration = damped  # type: ignore[method-assign]


def run(law: str, c: float, seed: int, damping: bool) -> tuple[float, float, float]:
    """(error, fast content, lam factor) of one run; error ``inf`` where it diverged."""
    zeta = constraints.C_INTEGRAL_ZETA
    if law == "direct":
        damp_direct(damping)
    elif not damping:
        constraints.C_INTEGRAL_ZETA = 0.0
    try:
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            study.main(["--law", law, "--c-integral", str(c), "--seed", str(seed)])
    finally:
        constraints.C_INTEGRAL_ZETA = zeta
        damp_direct(False)
    lines = buf.getvalue().splitlines()
    lam_x = float(lines[0].split("lam x")[1].split(",")[0])
    if lines[1].startswith("DIVERGED"):
        return float("inf"), float("inf"), lam_x
    words = lines[1].split()
    return float(words[1]), float(words[3]), lam_x


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--law", choices=("direct", "sign"), default="direct")
    ap.add_argument("--c", default=C_DEFAULT, help="C_INTEGRAL values, comma-separated")
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--damping", choices=("on", "off", "both"), default="both")
    args = ap.parse_args(argv)
    thr, fast_max = THRESHOLDS[args.law]
    modes = {"on": (True,), "off": (False,), "both": (False, True)}[args.damping]
    seeds = [int(s) for s in args.seeds.split(",")]
    band: dict[bool, list[float]] = {m: [] for m in modes}
    for c in (float(x) for x in args.c.split(",")):
        cells = []
        for m in modes:
            res = [run(args.law, c, s, m) for s in seeds]
            ok = all(e <= thr and f <= fast_max for e, f, _ in res)
            if ok:
                band[m].append(c)
            text = " / ".join(f"{e:.2e}" if e < float("inf") else "diverged" for e, _, _ in res)
            fast = max(f for _, f, _ in res)
            cells.append(
                f"{'damped' if m else 'rule  '} lam x{res[0][2]:.2f}: {text} (fast <= "
                f"{fast:.1e}){' ok' if ok else ''}"
            )
        print(f"C_INTEGRAL {c:<6g} | " + " | ".join(cells), flush=True)
    for m in modes:
        b = band[m]
        span = f"{min(b):g}-{max(b):g}" if b else "none"
        print(f"band {'damped' if m else 'rule'}: {span} ({', '.join(f'{c:g}' for c in b)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
