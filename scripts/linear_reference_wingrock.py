"""A linear reference for the wing-rock recovery at 8 s under issue 25's hardware cases.

The wing-rock cases (``scripts/hardware_cases.py wingrock-direct-s1 --ideal-cases``, and
``wingrock-estimation-s1``) are judged over 8.5-10 s, 0.5 s after aileron 3 recovers from
stuck at 10 (8 s): the recovered aileron adds a torque step of 1461 rad/s^2 (its own share,
342, on top of the 1119 the other two held against it) that a failure-blind controller
learns only from the roll. This script asks how well *any* linear controller that knows the
plant can settle that step behind each case's declared hardware: a state feedback on the
integral of the roll, the roll, its rate and (behind a lag) the modelled actuator output,
with every closed-loop pole at ``-wn`` (Ackermann on the plant linearised at 0; at 50 Hz on
the exact zero-order-hold model, poles at ``exp(-wn T)``), swept over ``wn``. It knows the
plant after the recovery (``beta`` = 477.4 / 634.0 of the healthy input gain) or, failure-
blind, assumes the healthy gain (``beta`` = 1).

Forward Euler at 0.1 ms on the nonlinear plant (eq. (2.101)), from the steady state before
the recovery (roll 0, the integral holding the stuck torque), the actuators as
:class:`adaptive_ftc.hardware.Actuators` models them (``a' = clip((u - a)/tau, -r, r)``,
``tau`` = the lag or the rate limiter's 5 ms band; the stuck aileron starts from 10), the
controller held at its sample rate, seeded noise; RMS roll over 8.5-10 s (the cases' window),
the largest fast command content (RMS above 1 Hz, zero-phase, over the window) and the peak
command.

    PYTHONPATH=src python scripts/linear_reference_wingrock.py
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import expm
from scipy.signal import butter, sosfiltfilt

from adaptive_ftc.plants.wingrock import WingRock

P = WingRock()
A0, A1, A2, A3, A4 = P.a0, P.a1, P.a2, P.a3, P.a4
GAINS = np.array(P.b)
R = np.array([-2.0, -2.0, -1.0])  # the scenario's allocation
EFF = np.array([1.0, 0.3, 1.0])  # after 6 s: aileron 2 at 30 %
B_HEALTHY = float(GAINS @ R)  # 634.0 per unit u0
B_AFTER = float(GAINS @ (EFF * R))  # 477.4 after the recovery
STUCK = 10.0
T_RECOVER = 8.0
WINDOW = (8.5, 10.0)


def _ackermann(a: np.ndarray, b: np.ndarray, coeffs: np.ndarray) -> np.ndarray:
    n = a.shape[0]
    ctrb = np.column_stack([np.linalg.matrix_power(a, k) @ b for k in range(n)])
    pa = sum(c * np.linalg.matrix_power(a, n - k) for k, c in enumerate(coeffs))
    return np.linalg.solve(ctrb.T, np.eye(n)[:, -1]) @ pa


def gains(wn: float, beta: float, lag: float, ts: float) -> np.ndarray:
    """State-feedback gains ``v = -K x`` (``v`` in roll acceleration per unit ``beta``) on
    ``x = (int phi, phi, phi', w)`` (``w``, the modelled delivered ``v``, behind a lag only),
    every pole at ``-wn`` (``exp(-wn ts)`` for a digital controller)."""
    a, c = -A0, -A1
    if lag > 0:
        am = np.array(
            [[0, 1, 0, 0], [0, 0, 1, 0], [0, a, c, beta], [0, 0, 0, -1 / lag]], dtype=float
        )
        bm = np.array([0, 0, 0, 1 / lag], dtype=float)
    else:
        am = np.array([[0, 1, 0], [0, 0, 1], [0, a, c]], dtype=float)
        bm = np.array([0, 0, beta], dtype=float)
    n = am.shape[0]
    if ts > 0:
        # exact ZOH of the plant; the integral by forward Euler, as the law's states
        m = np.zeros((n + 1, n + 1))
        m[:n, :n], m[:n, n] = am, bm
        e = expm(m * ts)
        ad, bd = e[:n, :n], e[:n, n]
        ad[0, :] = 0.0
        ad[0, 0], ad[0, 1] = 1.0, ts
        bd[0] = 0.0
        pole = math.exp(-wn * ts)
        return _ackermann(ad, bd, np.poly([pole] * n))
    return _ackermann(am, bm, np.poly([-wn] * n))


def run(wn, *, beta_model, lag=0.0, rate=math.inf, hz=math.inf, noise=0.0, dt=1e-4):
    """(RMS roll over the window, fast content, peak |command|, peak |roll|) or a string."""
    ts = 1.0 / hz if math.isfinite(hz) else 0.0
    tau = lag if lag > 0 else (0.005 if math.isfinite(rate) else 0.0)
    k = gains(wn, beta_model, tau if lag > 0 else 0.0, ts)
    b_model = B_HEALTHY * beta_model
    # the steady state before the recovery: u0 holds the stuck torque
    u0_ss = -GAINS[2] * STUCK / float(GAINS[:2] @ (EFF[:2] * R[:2]))
    v_ss = b_model * u0_ss
    z = -v_ss / k[0]  # the integral that commands it
    phi = dphi = 0.0
    w = v_ss  # the modelled delivered v
    pos = R * u0_ss
    pos[2] = STUCK
    rng = np.random.default_rng(0)
    t0 = 7.5
    n = int(round((10.0 - t0) / dt))
    step = max(1, int(round(ts / dt))) if ts > 0 else 1
    uc = R * u0_ss
    v = v_ss
    rec_e = np.empty(n)
    rec_u = np.empty((n, 3))
    for i in range(n):
        t = t0 + i * dt
        if i % step == 0:
            pm = phi + noise * rng.standard_normal()
            dm = dphi + 10.0 * noise * rng.standard_normal()
            x = [z, pm, dm, w] if lag > 0 else [z, pm, dm]
            v = -float(k @ np.array(x))
            uc = R * (v / b_model)
            h = ts if ts > 0 else dt
            z += h * pm
            if lag > 0:
                w += h * (v - w) / lag
        stuck = t < T_RECOVER
        for j in range(3):
            if j == 2 and stuck:
                continue
            if tau > 0:
                pos[j] += dt * min(max((uc[j] - pos[j]) / tau, -rate), rate)
            else:
                pos[j] = uc[j]
        acc = (
            -A0 * phi
            - A1 * dphi
            - A2 * abs(dphi) * dphi
            - A3 * phi**3
            - A4 * phi * phi * dphi
            + float(GAINS @ (EFF * pos))
        )
        phi, dphi = phi + dt * dphi, dphi + dt * acc
        if not abs(phi) < math.pi:
            return f"diverges at {t:.3f} s"
        rec_e[i], rec_u[i] = phi, uc
    time = t0 + dt * np.arange(n)
    sel = (time >= WINDOW[0]) & (time <= WINDOW[1])
    sos = butter(2, 1.0, fs=1.0 / dt, output="sos")
    fast = max(float(np.sqrt(np.mean((c - sosfiltfilt(sos, c))[sel] ** 2))) for c in rec_u.T)
    after = time >= T_RECOVER
    return (
        float(np.sqrt(np.mean(rec_e[sel] ** 2))),
        fast,
        float(np.max(np.abs(rec_u[after]))),
        float(np.max(np.abs(rec_e[after]))),
    )


CASES = {
    "lag 50 ms": {"lag": 0.05},
    "digital 50 Hz": {"hz": 50.0},
    "rate 3080 rad/s (5 ms band)": {"rate": 3080.0},
    "noise 1.75e-4 rad": {"noise": 1.75e-4},
}


def main() -> int:
    print("| case | model | wn | error 8.5-10 s | fast | peak u | peak roll |")
    print("|---|---|---|---|---|---|---|")
    for name, hw in CASES.items():
        for label, beta in (("knows beta 0.753", B_AFTER / B_HEALTHY), ("healthy model", 1.0)):
            for wn in (5.0, 10.0, 15.0, 20.0, 30.0, 40.0, 60.0, 80.0):
                res = run(wn, beta_model=beta, **hw)
                if isinstance(res, str):
                    print(f"| {name} | {label} | {wn:g} | {res} | | | |", flush=True)
                    continue
                err, fast, peak, roll = res
                print(
                    f"| {name} | {label} | {wn:g} | {err:.2e} | {fast:.2e} | {peak:.3g} | "
                    f"{roll:.3g} |",
                    flush=True,
                )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
