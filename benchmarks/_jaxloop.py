"""The §2.3 hypersonic closed loop of ``c/hypersonic_loop.c`` in JAX, for the peer benchmark
(``bench_peers.py``, issue 29): the same equations (plant (2.50), 5x5 raw fuzzy basis, theta law
(2.29), robust term, elevators 1 and 2 with gains 1 and 2), the same failures (loss of
effectiveness, bias, stuck, affine, abrupt, one per elevator at most), members vmapped.

Two integrations, members in vector lanes (``jax.vmap``), float64:

* ``rk4``: classical RK4 written with ``jax.lax.fori_loop`` (diffrax has no classical RK4),
  on exactly this project's step grid (each interval of fixed failure pattern split into
  ``ceil((b - a)/dt)`` equal steps, the interval's failure pattern on all four stages), so a
  member's result can match its single run to rounding. Members with fewer steps than the
  longest are padded with steps of length 0 (which leave the state unchanged).
* ``dopri5``: ``diffrax.diffeqsolve`` with ``diffrax.Dopri5``, a ``PIDController`` (rtol, atol,
  max norm as this project's error control) inside a ``ClipStepSizeController`` whose
  ``jump_ts`` are the member's failure times (so steps stop at each jump). Its step-size
  control is diffrax's, not ours: results agree to the tolerance, not to rounding.

Only the final state is returned (the peers' common ground: the C batch prints final states).
Imported only when ``jax`` and ``diffrax`` are installed (never in CI).
"""

from __future__ import annotations

import math

import jax

jax.config.update("jax_enable_x64", True)

import diffrax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

P = (113.5891, 5.33e-6, -6565.0, 6875.0, -1.0, 0.0026, -6.83, 0.303, -0.23, 0.0292)
CEN = jnp.array([-1.25, -0.625, 0.0, 0.625, 1.25])
B = (1.0, 2.0)
LAM, K, K0, EPS0, GAMMA, SIGMA, THETA0 = 2.0, 5.0, 2.0, 0.01, 5.0, 0.01, 0.01
AW = 1.0 / (2.0 * 0.7071067811865476**2)
REF_AMP, REF_W = math.pi / 36.0, 0.2
MAX_INTERVALS = 5  # t0, tf and at most two onsets and two recoveries


def _applied(kind, p0, p1, u):
    """The failed elevator's output (kinds of the C program: 0 LOE, 1 bias, 2 stuck, 3
    affine)."""
    return jnp.select(
        [kind == 0, kind == 1, kind == 2, kind == 3], [p0 * u, u + p0, p0 + 0.0 * u, p0 * u + p1]
    )


def rhs(t, y, active, kind, p0, p1):
    """The closed-loop derivative; ``active[j]``: elevator ``j`` failed as ``kind[j]``."""
    x0, x1, th = y[0], y[1], y[2:]
    wt = REF_W * t
    sn, cs = jnp.sin(wt), jnp.cos(wt)
    r0, r1, r2 = REF_AMP * sn, REF_AMP * cs * REF_W, REF_AMP * (-sn) * REF_W * REF_W
    e, ed = r0 - x0, r1 - x1
    s = ed + LAM * e
    mu0 = jnp.exp(-AW * (x0 - CEN) ** 2)
    mu1 = jnp.exp(-AW * (x1 - CEN) ** 2)
    phi = (mu0[:, None] * mu1[None, :]).reshape(-1)
    u0 = jnp.dot(phi, th)
    usum = 0.0
    for j in range(2):
        u = B[j] * u0
        usum = usum + jnp.where(active[j], _applied(kind[j], p0[j], p1[j], u), u)
    xd1 = P[0] * (
        P[1] * (P[2] * x0 * x0 + P[3] * x0 + P[4])
        + P[5] * x1 * (P[6] * x0 * x0 + P[7] * x0 + P[8])
        + P[9] * (usum - x0)
    )
    sd = r2 - xd1 + LAM * ed
    q = sd + K * s + K0 * jnp.tanh(s / EPS0)
    return jnp.concatenate([jnp.stack([x1, xd1]), GAMMA * phi * q - GAMMA * SIGMA * th])


def member_arrays(x0, records, t_final: float, dt: float):
    """One member's numbers from its C failure records (``_cref.failure_records``): per
    elevator kind/onset/recovery/p0/p1 (kind -1: healthy), and its intervals (start, end,
    steps, which elevators are failed), padded to ``MAX_INTERVALS``."""
    kind, onset, rec, p0, p1 = [-1, -1], [np.inf] * 2, [np.inf] * 2, [0.0] * 2, [0.0] * 2
    for act, k, a, r, q0, q1, *_ in records:
        j = int(act) - 1
        if kind[j] != -1:
            raise ValueError("the JAX model holds one failure per elevator")
        kind[j], onset[j], rec[j], p0[j], p1[j] = int(k), a, r, q0, q1
    times = {0.0, t_final}
    times.update(v for v in (*onset, *rec) if 0.0 < v < t_final)
    bps = sorted(times)
    starts, ends, steps, act = [], [], [], []
    for a, b in zip(bps[:-1], bps[1:], strict=True):
        mid = 0.5 * (a + b)
        starts.append(a)
        ends.append(b)
        steps.append(max(1, math.ceil((b - a) / dt - 1e-9)))
        act.append([kind[j] >= 0 and onset[j] <= mid < rec[j] for j in range(2)])
    while len(starts) < MAX_INTERVALS:  # padding: empty intervals at t_final
        starts.append(t_final)
        ends.append(t_final)
        steps.append(0)
        act.append([False, False])
    y0 = np.concatenate([np.asarray(x0, dtype=float), np.full(25, THETA0)])
    return {
        "y0": y0,
        "kind": np.array(kind),
        "onset": np.array(onset),
        "recovery": np.array(rec),
        "p0": np.array(p0),
        "p1": np.array(p1),
        "start": np.array(starts),
        "end": np.array(ends),
        "steps": np.array(steps),
        "active": np.array(act),
        "jumps": np.array((sorted({*onset, *rec} - {np.inf}) + [t_final + 1.0] * 4)[:4]),
    }


def stack(members: list[dict]) -> dict:
    """The members' arrays stacked along a leading member axis (for ``jax.vmap``)."""
    return {k: jnp.asarray(np.stack([m[k] for m in members])) for k in members[0]}


def _rk4_member(m, n_total):
    cum = jnp.cumsum(m["steps"])

    def body(k, y):
        iv = jnp.searchsorted(cum, k, side="right")  # the interval of global step k
        iv = jnp.minimum(iv, MAX_INTERVALS - 1)
        first = cum[iv] - m["steps"][iv]
        n = m["steps"][iv]
        a, b = m["start"][iv], m["end"][iv]
        h = jnp.where(n > 0, (b - a) / jnp.maximum(n, 1), 0.0)
        st = k - first
        t = a + st * h
        t1 = jnp.where(st == n - 1, b, a + (st + 1) * h)
        hh = jnp.where(k < cum[-1], t1 - t, 0.0)  # padding steps: length 0
        act = m["active"][iv]
        f = lambda tt, yy: rhs(tt, yy, act, m["kind"], m["p0"], m["p1"])  # noqa: E731
        k1 = f(t, y)
        k2 = f(t + 0.5 * hh, y + 0.5 * hh * k1)
        k3 = f(t + 0.5 * hh, y + 0.5 * hh * k2)
        k4 = f(t1, y + hh * k3)
        return y + hh / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)

    return jax.lax.fori_loop(0, n_total, body, m["y0"])


_RK4 = jax.jit(jax.vmap(_rk4_member, in_axes=(0, None)), static_argnums=1)


def rk4(batch: dict, n_total: int):
    """Final states of the stacked members after RK4 (``n_total``: the largest step count;
    compiled once per batch shape and ``n_total``)."""
    return _RK4(batch, n_total)


def _dopri5_member(m, t_final, rtol, atol):
    def field(t, y, args):
        active = (t >= m["onset"]) & (t < m["recovery"]) & (m["kind"] >= 0)
        return rhs(t, y, active, m["kind"], m["p0"], m["p1"])

    controller = diffrax.ClipStepSizeController(
        diffrax.PIDController(rtol=rtol, atol=atol, norm=lambda v: jnp.max(jnp.abs(v))),
        jump_ts=m["jumps"],
    )
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(field),
        diffrax.Dopri5(),
        0.0,
        t_final,
        1e-3,
        m["y0"],
        stepsize_controller=controller,
        saveat=diffrax.SaveAt(t1=True),
        max_steps=10_000_000,
    )
    return sol.ys[-1]


_DOPRI5 = jax.jit(jax.vmap(_dopri5_member, in_axes=(0, None, None, None)), static_argnums=(1,))


def dopri5(batch: dict, t_final: float, rtol: float, atol: float):
    """Final states of the stacked members after diffrax's Dopri5 (compiled once per batch
    shape and ``t_final``)."""
    return _DOPRI5(batch, t_final, rtol, atol)
