"""Constraint-aware versions of the thesis's adaptive laws (issue 25, item 2).

The thesis's laws (``u0 = Pi(z)^T theta``, ``theta' = gamma Pi q - gamma sigma theta`` with
``q = s' + k s + k0 tanh(s/eps0)``, §2.3, §4.4, ...) assume ideal actuators, exact
measurements and continuous time. Seen from the plant they are a very fast loop: ``theta``
integrates ``gamma Pi s'``, so ``u0`` moves by ``gamma |Pi|^2`` per unit of ``s`` (a
proportional path), and ``k0 tanh(s/eps0)`` adds an integral path of rate ``k + k0/eps0``
(200 1/s with the hypersonic gains). Rate limits, lag, slow sampling and noise break that loop
(measured in docs/hardware.md). :class:`ConstraintAware` is the *designer's model* of the
hardware; given to a design (``constraint_aware=ConstraintAware(...)``, an option of the
design, not another design) it derives, by the rules below, one configuration
(:class:`Configuration`) that changes the law in these established ways:

1. **Bandwidth scaling and smoothing of the robust term.** In the linear band
   ``u0 ~ gamma |Pi|^2 (s + K int s)`` with ``K = k + k0/eps0``, and ``s' = -b u0 + ...``
   with ``b = |d s'/d u0|`` (the plant's input gains along the allocation), so the law's
   poles solve ``l^2 + g l + g K = 0`` with the *loop gain* ``g = b gamma |Pi(z0)|^2``: its
   loop rate is ``w0 = max(g, sqrt(g K))``, measured on the loop when it is compiled
   (:meth:`AdaptiveController.bound`, :meth:`AdaptiveController.measured_loop_rate`; 202
   1/s on hypersonic-direct-s1, 73 on the manipulator, 48 on the spacecraft, 12700 on the
   wing rock; without a loop the proxy ``K``). The hardware admits
   ``w_max = min(C_CAP w0, C_LAG/lag, C_SAMPLE/T, C_MARGIN rate/(b_max A_LOOP),
   C_DELAY/(lag + T/2 + tau_d), C_NOISE/noise, sqrt(C_NOISE_DENSITY/n_d))``
   (:meth:`ConstraintAware.omega_max`): the lags of the loop add up (the actuator's, half a
   sample of hold, the time constant ``tau_d`` of the ``s'`` estimate; with rate or travel
   limits the command filter's ``1/omega_f`` too, against ``C_DELAY_LIMITED``), and noise
   counts by its std and by its density ``n_d = noise sqrt(2/f)`` at the rate ``f`` the law
   sees it (a 100 Hz controller sees the same std 3x denser than a 1 kHz sensor; through
   its decimation filter, the mean of the ``N`` readings of each period, the std is
   ``noise / sqrt(N)`` at the sensor's own density, and the filter's delay ``(N-1)/(2N) T``
   joins the loop's lags; the loop rate stays at most the one without the filter, which
   quiets the command: :attr:`ConstraintAware.decimation`, session 14). §4.4's
   loop gain ``alpha0 |rho| |Pi|^2 b`` grows with ``rho``: under a non-ideal model ``rho`` is
   projected on ``|rho| <= RHO_FACTOR |rho0|`` and the loop is sized for that bound
   (:meth:`SignEstimation.rho_bound`; ``RHO_FACTOR_INTEGRAL |rho0|`` where the law carries
   the error's integral, with ``lam >= 2 C_INTEGRAL_ZETA sqrt(k_I)``: session 15), and its
   direction estimate adapts ``r`` times slower than ``theta`` (``alpha1 -> r^2 alpha1``).
   The adaptation gains are scaled by ``r = min(1, w_max/g)`` (every gain of ``theta``;
   ``k -> r k``) and the robust term's slope ``k0/eps0`` by ``r_K`` so that ``sqrt(r g r_K
   K) <= w_max`` (``eps0 -> eps0/r_K``), and, where the gain may grow by ``growth`` along
   the run (§4.4), so that the slope is ``w_max / growth^2``: the linear band keeps ``g' >=
   K'`` (damping 0.5) down to ``1/growth`` of the gain at ``t0``:
   a loop whose adaptation is already slow keeps its gain and only its robust term is
   smoothed (the manipulator loses the arm with ``eta`` scaled below 0.3; its 50 ms chatter
   is the robust term's). On the hypersonic loop (``g ~ K``) both are ``w_max/w0``, which
   moves every closed-loop frequency of the law down at the same damping:
   the smoothing of the discontinuous term is tied to the actuator bandwidth and the sample
   rate (Slotine & Li 1991, §7.2: boundary layer no thinner than the unmodelled dynamics
   allow; Ioannou & Sun 1996, §8.5: the adaptive loop kept below the unmodelled dynamics).
   The boundary layer is also widened ``WIDEN`` times at the same slope (``k0 -> W k0``,
   ``eps0 -> W eps0 / r``): the saturating integral path limit-cycles behind a lag.
   Where the loop is slowed, ``lam -> min(max(lam, C_LAM w_max), lam / r, F lam)`` with
   ``F = LAM_FACTOR_MAX`` (``LAM_FACTOR_NOISE`` where noise binds): the scaled loop's
   low-frequency gain (what rejects a failure's disturbance) falls as ``r^2 lam``; this
   gives part of it back. ``lam`` stays below ``C_LAM_GAIN`` times the smallest scaled loop
   gain over the outputs (a filtered-error corner above the loop gain loses the loop), and
   with a travel limit or a tight rate limit (its bound below ``C_TIGHT w_max``)
   ``C_LAM_LIMITED`` replaces ``C_LAM``: a failure that removes most of the input gain
   leaves the hedged loop a quarter of its gain.
2. **Command filter with magnitude, rate and bandwidth limits** (Farrell, Polycarpou, Sharma &
   Dong, IEEE TAC 54(6), 2009; Sonneveldt, Chu & Mulder, JGCD 30(2), 2007), with rate or
   travel limits: the law's command ``u0c`` passes through
   ``u0' = clip(w_f (clip(u0c, -U, U) - u0), -R, R)`` before the allocation, with ``U`` and
   ``R`` the designer's travel and rate times ``C_MARGIN`` divided by ``max |b_j|`` (so no
   actuator is commanded past its limits) and ``w_f = C_FILTER w_max``. Where the rate
   limit is **tight** (a failure transient at the loop rate runs into it: ``C_MARGIN rate_u0
   / A_RATE < C_TIGHT w_max``), a single-output design without an allocator filters each
   actuator's command on its own instead (round 6): ``u_j' = clip(w_f (R_j clip(u0c, -U, U)
   - u_j), -C_MARGIN rate, C_MARGIN rate)``, so every actuator moves at up to its own rate
   (with the common filter, the least-allocated actuator moved at ``max |b_j|/|R_j|`` times
   less: the one left when the most-allocated actuator is lost), and the compensated error
   hedges what they deliver together, ``u0_reachable = sum_j G_j (u_j + u_j'/w_f) / sum_j
   G_j R_j`` with ``G_j`` the plant's nominal input gains at ``t0`` (pseudo-control hedging
   with an actuator model, Johnson & Calise 2003). Session 13 (round 7), for a single-output
   design with a fixed allocation and no placed feedback (:attr:`ConstraintAware.per_actuator`):
   with a travel limit (the rate not tight) ``U`` is the least-allocated actuator's travel
   and each actuator's command is clipped to its own after the allocation
   (:func:`_travel_bound`), and a digital law's filter is a discrete limiter (at ``C_EULER /
   T``, its value after the sample's step: no lag of its own in the delay budget,
   :attr:`ConstraintAware.discrete_limiter`). Round 8 (session 13): where that limiter's
   delay budget sets the loop rate (:meth:`ConstraintAware.delay_bound`; the noise at most
   ``C_INTEGRAL_NOISE`` of its density bound), the law's filtered
   error carries the tracking error's integral, ``s = e' + lam e + k_I int (e - xi/lam)``
   with ``k_I = (C_INTEGRAL w_max)^2`` (an integral sliding surface, Slotine & Li 1991,
   §7.1.3; :attr:`Configuration.error_integral`): more loop gain at low frequency (a stuck
   elevator's slow pattern) without a faster loop.
3. **Compensated error** (Farrell et al. 2009; the idea of pseudo-control hedging, Johnson &
   Calise, JGCD 26(6), 2003), with rate or travel limits: the laws see ``s - xi`` instead of
   ``s``, with ``xi' = -w_h xi + b (u0c - u0_reachable)``, ``b`` the loop's nominal
   ``|d s'/d u0|`` (``input_gain``, by default measured on the loop; §4.4, whose control
   direction is unknown, times the sign of its estimate ``rho``) and ``u0_reachable =
   u0 + u0'/w_f`` what the filter delivers: only the part of the command the limits did not
   deliver (not the filter's linear lag, which left a steady error) drives ``xi``, so the
   adaptation does not learn the saturation; ``xi`` returns slowly (``w_h = C_HEDGE
   w_max``), at a rate the actuator can follow. Measured: this is what ends the
   rate-limiter oscillation of the hypersonic loop at 2 rad/s (it diverged at 43 s with the
   back-calculation below). With ``input_gain = 0``: **anti-windup by back-calculation on
   the estimates** (Åström & Rundqwist, ACC 1989): ``theta' += -k_aw Pi (u0c -
   u0_reachable) / |Pi|^2`` pulls the law's command back to what the filter can deliver.
4. **Noise**: where the std bound ``C_NOISE/noise`` is the one that binds, the law sees its
   measurements (regressor inputs, errors, ``s``) through a first-order prefilter at
   ``C_MEASURE_NOISE w_max``, and its adaptation signal ``q`` through ``qf' = w_q (q - qf)``
   at ``C_PREFILTER_NOISE w_max`` (8 w each: 7 deg of phase each at the loop rate; round 2's
   4 w and 2 w took 41 deg and the loop resonated on the noise after the failures). Below
   that noise the lower loop rate alone quiets the command: measured on the
   hypersonic-hardware campaign, round 2's two prefilters' lags (12 and 25 ms at ``w`` = 20)
   let the loop drift into a limit cycle (member 8, noise 2.3e-4 rad on alpha and
   5.3e-4 rad/s on q: fast content 2e-3 rad at 20 s, 7.7e-2 at 100 s; with its rate and
   travel limits the loop was lost, error 0.12 rad), while the same law without them stayed
   at 2.6-3.8e-3 rad of fast content and 2-3e-5 rad of error. §4.3 (Nussbaum) adds its own
   rule where the std bound does not bind but the noise of ``s``, counted with the raised
   ``lam``, is above the density bound: its adaptation's regressor sees prefiltered
   measurements (``u0`` still the measured ones), ``lam`` is raised at most
   ``LAM_FACTOR_NOISE`` times (:func:`adaptation_regressor_rule`) and ``tau`` integrates
   ``q`` prefiltered at ``C_PREFILTER w_max`` (``NussbaumAdaptive.tau_prefilter``). Session
   15: where the rule takes the decimation filter (the noise sets the loop rate), the law's
   regressor, in the command and in the adaptation, sees the plant states low-passed at
   ``C_REGRESSOR_NOISE w_max`` (:attr:`ConstraintAware.regressor_prefilter`): the learnt
   ``theta`` makes the basis a rate feedback on the measured state, whose noise reached the
   command unfiltered up to the sampler's Nyquist frequency (not §4.4; the filter's delay
   counted in the delay budget).
5. **Projection of the estimates** on the ball ``|theta| <= theta_max`` (Pomet & Praly 1992;
   Lavretsky & Wise, *Robust and Adaptive Control*, 2013, §11.4), beside the thesis's
   sigma-modification: where the estimate is on the boundary and the law points outward,
   the outward component is removed. Off by default (``theta_max = inf``).

6. **Fixed feedback placed on the linearised plant** where the plant has a fast unstable
   open-loop mode (``C_FEEDBACK p_u > C_FEEDBACK_GATE w_max``, ``p_u`` the modulus of the
   linearised plant's fastest unstable mode at ``t0``,
   :meth:`AdaptiveController.open_loop_unstable_rate`; Stein, IEEE CSM 23(4) 2003, "respect
   the unstable"): a PID ``u0 += (kp e + kd e' + ki int e) / b`` beside the adaptive law (a
   baseline with integral action augmented by the adaptive law, as in Lavretsky & Wise 2013,
   ch. 10), after the command filter, with gains placed on the designer's linear model (the
   plant linearised at ``t0``, :meth:`AdaptiveController.open_loop_rows`, behind the declared
   lag and half a sample of hold) for the largest worst-case decay rate over an input gain
   cut by a third or not (:func:`placed_feedback`, ``FEEDBACK_GAIN_SCALES``); the adaptive
   law then runs below the placed loop's slowest mode (``r g <= C_AUGMENT |decay|``), with
   or without a declared delay (``PLACE_UNDELAYED``); its integral gain on a grid that
   reaches 0.85 ``p^3`` where the rate limit admits it (``FEEDBACK_KI_EXTEND``,
   ``FEEDBACK_KI_SWING``). Behind a declared lag the PID's output passes a lead ``(lag s +
   1) / (tau s + 1)`` that cancels the lag down to ``tau`` (``LEAD_MAX``, ``LEAD_SAMPLE``; a
   model-based lag compensation, e.g. Åström & Murray, *Feedback Systems*, 2008, §11.4), and
   the gains are placed behind ``tau``. The
   thesis law's ``u0 = Pi^T theta``
   is all adaptive: slowed to the hardware it cannot hold the wing rock (unstable at 30
   rad/s), and a raw fuzzy basis vanishes once the state leaves it; a proportional path on
   ``s`` at ``2 p_u`` (the rule before) stiffens the oscillator to where a lag of 35 ms or
   more leaves no phase.

A digital controller integrates every state of the law by forward Euler at its sample time
``T`` (:mod:`adaptive_ftc.hardware`); the rules keep every filter of the law at most
``C_EULER / T`` (stable Euler filters) and ``w_max T <= C_SAMPLE`` (the discrete-time-aware
bound on the adaptive loop). The measurement and command filters keep running while the
adaptation is frozen (``ClosedLoop(adapt=False)``).

The constants below were chosen once, on the hypersonic §2.3 cases of issue 25 (and the
manipulator and §4.3 cases where said), and are the same for every case, design and plant
(no tuning per case). Where they fail is measured in docs/hardware.md.

Guarantees (which holds for which combination):

- *ideal model* (no lag, no limits, continuous, no noise): :meth:`ConstraintAware.configure`
  returns the identity, the generated law is the thesis law (same code, same numbers) and
  the trajectories are the thesis's; the thesis's theorems hold.
- *lag / sampling*: the law is the thesis law with other gains (a valid choice of the
  thesis's gains, so Theorem 2.1's boundedness holds for the continuous idealisation), run
  slower than the unmodelled actuator and sampling dynamics: the usual robustness argument
  of adaptive control with unmodelled dynamics (Ioannou & Sun §8.5, sigma-modification:
  bounded signals for small enough unmodelled dynamics), not a proof for each case.
- *rate / travel limits*: the command filter makes every commanded actuator respect the
  designer's limits (a hard guarantee on the command; per actuator under a tight rate
  limit); with the compensated error the
  adaptation sees only the error the delivered command is responsible for (Farrell et al.
  2009: bounded compensated errors, the gap ``xi`` bounded while the limits are active a
  bounded time); stability of the limited loop is not guaranteed (measured: the hypersonic
  §2.3 and §4.4 loops are acceptable at 2 and 0.5 rad/s; before round 6's per-actuator
  filters, §2.3 diverged at 0.5 rad/s 2.2 s after the 80 s bias failure).
- *noise*: the lower bandwidth (and, where the std bound binds, the prefilters) bound the
  noise in the command (linear filtering), with sigma-modification keeping the estimates
  bounded; no dead-zone.
- *§4.4*: with a non-ideal model ``|rho| <= RHO_FACTOR |rho0|`` at all times (projection;
  ``RHO_FACTOR_INTEGRAL |rho0|`` where the law carries the error's integral);
  the sign estimate can still cross zero (from ``-rho0`` to ``+rho0``, as in the ideal runs).
- *projection*: ``|theta| <= theta_max`` at all times whatever the disturbance.

All of this is measured, case by case, in docs/hardware.md ("Designs under real hardware")
and by ``scripts/hardware_cases.py``.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from adaptive_ftc.errors import ConfigurationError

__all__ = ["ConstraintAware", "Configuration"]

#: ``w_max <= C_LAG / lag``: the law's loop rate below the actuator's bandwidth.
C_LAG = 1.0
#: ``w_max (lag + T/2 + tau_d) <= C_DELAY``: the law's loop rate within the phase the *sum*
#: of the loop's lags admits (the actuator's lag, half a sample of hold, the time constant
#: ``tau_d`` of the ``s'`` estimate). Each bound above takes one lag alone; combined they add
#: (a 13 ms lag at 100 Hz with a 20 ms ``s'`` filter passed every single bound at ``w`` = 20
#: and limit-cycled).
C_DELAY = 1.0
#: ... and ``w_max (lag + T/2 + tau_d + 1/omega_f) <= C_DELAY_LIMITED`` where rate or travel
#: limits are declared (the command filter's lag ``1/omega_f >= max(1/(C_FILTER w), lag,
#: T/C_EULER)`` counts too, and the hedged loop has less margin): measured on the
#: hypersonic-hardware campaign, member 7 (lag 13 ms, 100 Hz, rate 30 rad/s, travel 0.87;
#: 58 ms in all) limit-cycles at ``w`` = 18-20 (0.53 rad of fast content) and is quiet at 15
#: (5e-4 rad); with noise, a loop near that margin amplifies it (member 40: lag 39 ms,
#: 100 Hz, 4.5e-3 rad/s on q: 2.1e-2 rad of fast content at 0.8, 9.5e-3 at 0.7; member 60:
#: 1.8e-2 at 0.8, 1.3e-2 at 0.7).
C_DELAY_LIMITED = 0.7
#: the default time constant of the ``s'`` estimate (s) of a continuous controller with
#: noise (``SolverOptions.filter_tau_for``: ``max(S_FILTER_TAU, 2 T)``; a digital controller's
#: ``s'`` is always filtered, a continuous noiseless one's is exact).
S_FILTER_TAU = 0.01
#: ``w_max <= C_SAMPLE / T``: the law's loop rate per sample (forward Euler of the laws).
C_SAMPLE = 0.75
#: ``w_max <= C_NOISE / noise`` (noise: std of the measured ``s``).
C_NOISE = 0.15
#: ``w_max^2 n_d <= C_NOISE_DENSITY``, with ``n_d = noise sqrt(2 / f)`` the density (per root
#: hertz) of the noise the law sees, held at ``f = min(noise_rate, 1/T)``. The std bound above
#: treats 1 kHz and 100 Hz noise alike; a digital controller sees the same std in a band 10
#: (at 100 Hz) to 20 times narrower, i.e. a 3-4.5x larger density. Measured on the
#: hypersonic-hardware campaign (first 100 members): 8 of the 23 members at 100 Hz with
#: 3.5-4.9e-3 rad/s of noise on q had 0.0176-0.029 rad of fast content at ``w`` = 14-20
#: (target 0.0173); on member 15 the fast content falls as ``w^2`` to ``w^2.5`` (1.8e-2,
#: 9.9e-3, 4.0e-3, 1.9e-3 at ``w`` = 13.7, 10, 7, 5). The constant puts the 100 Hz members at
#: ``w`` = 12-13 and leaves continuous loops with the catalogue's noise (1e-3 rad, 1e-2
#: rad/s at 1 kHz: 14.8) to the std bound.
C_NOISE_DENSITY = 0.1
#: a rate limit is "tight" (``C_LAM_LIMITED``, below) where ``rate_u0 / A_RATE < C_TIGHT
#: w_max``: a failure transient of amplitude ``A_RATE`` at the loop rate would run into the
#: rate limit (the large-signal bound: the hedged loop must survive it with a low ``lam``).
A_RATE = 0.04
#: ``w_max <= rate_u0 / A_LOOP``: the loop's small-signal oscillation at its own rate, of
#: amplitude ``A_LOOP``, stays within the rate limit (the describing function of a rate
#: limiter: no phase loss below it). Rounds 1-4 used ``A_RATE`` here too; the command's
#: oscillation above 1 Hz on the noiseless acceptable hypersonic cases is at most 3e-3 rad
#: RMS (4e-3 amplitude), and the large transients (failures) are the command filter's and the
#: compensated error's (they respect the limit by construction). Measured (round 5) on
#: hypersonic-sign-s1-rho0pos at 0.5 rad/s (``w`` = 5.6 at 0.04, 11.2 at 0.02, 15 at 0.015,
#: 22.5 at 0.01): error 7.1e-3, 1.5e-3, 8.5e-4, 2.8e-4 rad (target 8.7e-4; 0.005: 3.7e-5), no
#: time at the rate limit; the same change through ``C_TIGHT`` (``A_RATE`` 0.01) made
#: hypersonic-direct-s1 at 2 rad/s non-tight (``lam`` x4) and lost it at 86.7 s, while its
#: loop rate is the cap's either way.
A_LOOP = 0.01
#: ``w_max <= C_CAP w0`` whenever any constraint is declared: the thesis's loop rate is
#: set for ideal hardware; measured, the hypersonic law limit-cycles above a tenth of it
#: under any lag or sampling.
C_CAP = 0.1
#: ``lam -> min(max(lam, C_LAM w_max), lam / r)`` where lag, sampling or rate bind (not
#: noise): the error filter's corner moved up to a fraction of the loop rate, which the
#: scaled loop gives back in low-frequency gain (error ~ 1/(r^2 lam)).
C_LAM = 0.8
#: ... and ``C_LAM_LIMITED`` where rate or travel limits are declared: there the loop must
#: also survive a failure that removes most of the input gain (hypersonic: 3/4) with the
#: hedged loop, whose small-signal proportional gain after the failure falls to a quarter of
#: ``w_max``; ``lam`` above it makes the filtered-error loop unstable (measured: the rate
#: 2 rad/s case oscillates after the 40 s failure with ``lam = 0.4 w_max``).
C_LAM_LIMITED = 0.125
#: a rate limit is "tight" (``C_LAM_LIMITED`` applies) where its bound on the loop rate is
#: below ``C_TIGHT w_max`` (hypersonic §2.3 at 2 rad/s: 22.5 against 20; §4.3 at half the
#: ideal peak rate, 30.5 rad/s: 343 against 15, where raising ``lam`` is what meets the
#: target, 3.8e-4 against 1.15e-3 without).
C_TIGHT = 2.0
#: (round 6) ... and there, with rate limits, each actuator of a single-output design gets its
#: own command filter at its own rate (:attr:`Configuration.actuator_rate`). Measured on
#: hypersonic-direct-s1 behind 0.5 rad/s elevators (allocation (1, 2)): the common filter's
#: rate, ``0.9 x 0.5 / 2``, held elevator 1 to 0.225 rad/s after elevator 2 stuck at 40 s,
#: and the loop diverged 2.2 s after the 80 s bias failure (no elevator ever at its own rate
#: limit); the common filter at elevator 1's rate (``/ min |R_j|``) holds it only with ``xi``
#: returning 3x slower and loses hypersonic-sign-s2-rho0neg at 2 rad/s (its elevator 2,
#: commanded past its rate, saturates unhedged); per-actuator filters hold both (4.3e-4 and
#: 9.7e-7 rad) at the shared ``C_HEDGE``. Gated on the tight test so that the loops whose
#: rate limit does not meet the failure transients (every member of the shipped campaigns,
#: the catalogue) keep the common filter and their trajectories.
#: ... and at most ``C_LAM_GAIN`` times the smallest scaled proportional loop gain
#: (:attr:`ConstraintAware.min_loop_gain`), never below the thesis's ``lam``.
C_LAM_GAIN = 0.8
#: widening of the robust term's boundary layer where the loop is slowed (its slope kept).
WIDEN = 3.0
#: ``lam`` is raised at most this many times ...
LAM_FACTOR_MAX = 4.0
#: ... and this many where noise binds (``lam`` multiplies the position noise in ``s``).
LAM_FACTOR_NOISE = 2.0
#: the command filter's bandwidth, in multiples of the law's loop rate ``w_max``.
C_FILTER = 4.0
#: the prefilter of the measurements the law sees, in multiples of ``w_max``.
C_MEASURE = 4.0
#: the prefilter of the adaptation signal, in multiples of ``w_max`` (the MIMO law's raised
#: outputs and §4.3's Nussbaum argument under noise).
C_PREFILTER = 2.0
#: where the noise's std bound ``C_NOISE / noise`` sets the loop rate, the law sees its
#: measurements through a prefilter at ``C_MEASURE_NOISE w_max`` and its adaptation signal
#: ``q`` through one at ``C_PREFILTER_NOISE w_max``: each costs ``atan(1/8)`` = 7 deg of
#: phase at the loop rate. Both filters are in series with the whole adaptive loop (``u0``
#: moves with ``Pi^T theta``, ``theta' ~ Pi q``); at round 2's ``4 w`` and ``2 w`` they took
#: 14 + 27 = 41 deg there and the loop, its gain lowered by the failures, resonated at
#: 1.5-2 Hz on the noise (hypersonic-sign-s1-rho0pos, noise 1e-3 rad / 1e-2 rad/s: fast
#: command content 1.33e-2 rad, 7.8e-4 without the noise; at ``8 w`` and ``8 w``
#: 7.1e-3, error 6.8e-4 -> 5.2e-4; noise seeds 1 and 2: 1.62e-2 / 1.75e-2 -> 7.0e-3 /
#: 6.6e-3; hypersonic-direct-s1: 1.41e-2 -> 1.32e-2). The filters' noise attenuation above
#: the loop rate is what they are there for; the band the loop tracks is the loop rate's.
C_PREFILTER_NOISE = 8.0
C_MEASURE_NOISE = 8.0
#: (session 15, round 11) where the decimation filter is taken (the noise sets the loop rate,
#: :attr:`ConstraintAware.regressor_prefilter`), the law's fuzzy basis, in its command and in
#: its adaptation, sees its plant-state inputs through a first-order low-pass at
#: ``C_REGRESSOR_NOISE w`` (at most ``C_EULER / T``): the learnt ``theta`` makes the basis a
#: rate feedback on the measured state (``du0/dq`` = -1.75 on issue 25's combination 1),
#: which passes the measurement noise to the command unfiltered up to the sampler's Nyquist
#: frequency; the loop needs that feedback only about its own rate. The filter costs
#: ``atan(1 / C_REGRESSOR_NOISE)`` = 14 deg of phase at the loop rate and a delay of ``1 /
#: (C_REGRESSOR_NOISE w)`` (25 ms at 9.9 1/s) on the learnt feedback, which the rule counts in
#: the delay budget (``C_DELAY``) before it takes the filter. Measured (combination 1, final
#: window 100-120 s, noise seeds 0 / 1 / 2): hypersonic-direct-s1 fast content 1.76e-2 /
#: 1.72e-2 / 1.77e-2 -> 1.46e-2 / 1.39e-2 / 1.52e-2 rad (target 1.73e-2), error 6.8-7.1e-4
#: -> 6.8-7.3e-4 (target 8.7e-4); at ``2 w`` 1.42e-2 / 1.30e-2 / 1.42e-2, at ``8 w`` 1.62e-2
#: (seed 0). Not §4.4 (its loop gain grows along the run with ``rho``): its failed loop at
#: this rate oscillates at 1-3 Hz without noise already, and the filter's phase loses it
#: (error 7.4e-4 -> 1.97e-3 rad, 2.3x its target; docs/hardware.md, "Round 11").
C_REGRESSOR_NOISE = 4.0
#: a digital filter's bandwidth is at most ``C_EULER / T``: forward Euler of ``x' = w (u -
#: x)`` has its pole at ``1 - w T``, stable below 2 and monotone (no ringing) up to 1. Round 2
#: used 0.5; at 50 Hz the command filter's floor ``T / C_EULER`` (40 ms) was then the largest
#: lag of the loop's budget (``C_DELAY_LIMITED``), and campaign member 65 (10 ms lag, 50 Hz,
#: a stuck elevator) tracked to 8.9e-4 rad instead of 4.1e-4.
C_EULER = 1.0
#: anti-windup rate (1/s), in multiples of the command filter's bandwidth.
C_AW = 1.0
#: decay rate of the compensated error, in multiples of ``w_max``: slow, so the part of the
#: error the limited command caused comes back to the law at a rate the actuator can follow
#: (at ``w_max`` it came back at once and the rate-limiter oscillation went on).
C_HEDGE = 0.1
#: the command filter keeps this fraction of the declared rate and travel (margin).
C_MARGIN = 0.9
#: §4.4 (sign estimation): the estimate ``rho`` of the control direction multiplies the law's
#: loop gain (``alpha0 |rho| |Pi|^2 b``). Under a non-ideal model it is projected on
#: ``|rho| <= RHO_FACTOR |rho0|`` and the rule sizes the loop for that bound, not for
#: ``rho0``: measured on hypersonic-sign-s1-rho0pos at 100 Hz, ``rho`` ran from 1 to 146 in
#: 0.2 s (the loop, sized at ``rho0``, sped up with it and diverged); in the ideal runs
#: ``|rho|`` stays within 1.0 (0.87-1.0 after its first 0.05 s, from +1 or -1). Round 4: the
#: law (4.54)-(4.55) conserves ``|theta|^2 / alpha0 + rho^2 / alpha1`` up to its leakage, so
#: every unit of ``|theta|^2`` the slowed law builds up in its transients (0.3-0.8, against
#: 0.01-0.05 in the ideal run) is paid for in ``rho^2`` and the loop gain: with ``alpha1``
#: scaled like ``alpha0`` (round 3), ``rho`` fell from 1 to 0.56 within 5 s behind a 20 ms
#: lag, crossed zero after the 80 s failure and the loop diverged at 87 s. ``alpha1`` is now
#: scaled by ``r^2`` (:meth:`SignEstimation.gains`), and on the 13 hardware cases of issue 25
#: ``|rho|`` stays within [0.96, 1.25] ``|rho0|`` after the first second (the bound is reached
#: at 100 Hz only), so the bound is 1.25 (round 3: 2, which sized the loop for twice the gain
#: it ran at and left it under-damped: 100 Hz chattered at 9.5 Hz with ``rho`` near 1). The
#: cost: from the wrong sign (``rho0 = -1``) the slower estimate must build up ``1/r`` times
#: more ``|theta|^2`` to cross zero; acceptable there on 4 of the 13 cases (round 3: 5;
#: docs/hardware.md).
RHO_FACTOR = 1.25
#: (session 15, round 11b) ... but where the rule gives the law the error's integral (the
#: delay budget of a discrete limiter sets the loop rate: :attr:`Configuration.error_integral`,
#: ``C_INTEGRAL``) the bound is ``RHO_FACTOR_INTEGRAL |rho0|`` = ``|rho0|``, and the loop is
#: sized for it (``gain_growth`` 1: ``r = w/g``, ``K' = w``, §2.3's sizing): there ``w`` is the
#: largest rate the loop's delays admit (``w (lag + T/2 + tau_d)`` = ``C_DELAY_LIMITED``), so
#: the loop gain must never exceed the one at ``t0`` (the projection keeps it there; the sign
#: estimate still crosses zero), and sized for ``1.25 |rho0|`` the loop ran at 0.8 of that gain
#: and 0.64 of the slope while ``rho`` stayed at 1.000 (``alpha1 r^2``: ``alpha1/alpha0``
#: 0.07; ``rho`` frozen: the same error): issue 25's second combination on
#: hypersonic-sign-s1-rho0pos, 2.40e-3 rad against 1.12e-3 sized at ``|rho0|`` (the §2.3 law
#: on the same failures: 1.06e-3; docs/hardware.md, "Round 11b").
RHO_FACTOR_INTEGRAL = 1.0
#: (session 15, round 11b) §4.4 with the error's integral: the surface's zero pair ``p^2 + lam
#: p + k_I`` damped at ``C_INTEGRAL_ZETA``, ``lam >= 2 C_INTEGRAL_ZETA sqrt(k_I)``
#: (:meth:`SignEstimation.configuration`; 1: Slotine & Li's ``s = (d/dt + l)^2 int e``, 1991
#: §7.1.3, a double zero at ``l = sqrt(k_I)``). Round 9 (session 14) measured the lever on both
#: laws: on §2.3 it costs the hypersonic-hardware campaign 5 of 500 members (k_I 9-20 at 200
#: Hz: the loop rings), so §2.3 keeps the thesis's ``lam``; §4.4 has no shipped campaign (a
#: probe's cost: :data:`C_INTEGRAL_LAM_MAX`), and on
#: issue 25's second combination (the loop sized at ``|rho0|``) the error falls 1.12e-3 ->
#: 6.0e-4 rad (noise seeds 1, 2: 6.3e-4, 5.7e-4; 0.8: 9.7e-4 to 1.1e-3 with 1.3-1.5e-2 of fast
#: content, 0.9: 7.4e-4 to 9.1e-4, fast up to 1.2e-2; docs/hardware.md, "Round 11b").
C_INTEGRAL_ZETA = 1.0
#: ... with ``lam`` raised at most ``C_INTEGRAL_LAM_MAX`` times the thesis's: where the delay
#: budget admits a faster loop the double zero asks ``lam = 2 C_INTEGRAL w`` = ``w/2``, and a
#: §4.4 probe campaign (the hypersonic-hardware spec on hypersonic-sign-s1-rho0pos, first 100
#: members, constraint-aware only) lost members 7 and 91 (100 Hz, ``w`` = 18-22, ``lam`` 9.1
#: and 11: fast content 1.05e-2 and 3.7e-2 against 8.67e-3; at ``lam`` 5-6 both pass): 96/100
#: against 98; capped at 2.5 (``lam`` 5; combination 2's 4.4 is under it) 98/100, the same
#: members (docs/hardware.md, "Round 11b"). A measured constant, like round 9's "at most
#: doubled" on §2.3. On all 500 members of the probe the damping still costs 11 (200 Hz mostly,
#: fast content 9e-3 to 2.6e-2 at ``lam`` 4.7-5): 482/500 against 491 with ``C_INTEGRAL_ZETA``
#: 0 (the bound at ``|rho0|`` alone; session 14: 486); ``C_INTEGRAL_ZETA = 0`` turns it off.
#: Round 12 (session 15): by sample time the damping costs 8 of 15 such members at 200 Hz (fast
#: content x2.8, median), 2 of 19 at 100 Hz and 1 of 47 at 50 Hz (x1.17, error x0.92); no gate on
#: the declared hardware separates lost from kept members (docs/hardware.md, "Round 12"). On
#: §2.3 (not taken) the same damping costs hypersonic-hardware ten members, 484/500 against 494.
C_INTEGRAL_LAM_MAX = 2.5


def integral_damping(cfg: Configuration, lam: float, min_loop_gain: float | None) -> Configuration:
    """``cfg`` with, where it carries the error's integral ``k_I``
    (:attr:`Configuration.error_integral`), ``lam`` at least ``2 C_INTEGRAL_ZETA sqrt(k_I)``:
    the surface ``p^2 + lam p + k_I``'s zero pair damped at :data:`C_INTEGRAL_ZETA` (1:
    Slotine & Li's ``(d/dt + l)^2 int e``), raised at most :data:`C_INTEGRAL_LAM_MAX` times
    the thesis's ``lam`` and at most ``C_LAM_GAIN`` times the smallest scaled loop gain (the
    rule's cap on ``lam``). §4.4's rule (``SignEstimation.configuration``; session 15, round
    11b); on §2.3 it was measured and not taken (round 12: its band of ``C_INTEGRAL`` is
    0.235-0.26, no wider than the rule's 0.24-0.27, and the hypersonic-hardware campaign
    loses ten members, 484/500 against 494). ``cfg`` unchanged where it carries no integral."""
    if cfg.error_integral <= 0:
        return cfg
    need = 2.0 * C_INTEGRAL_ZETA * math.sqrt(cfg.error_integral) / lam
    need = min(need, C_INTEGRAL_LAM_MAX)
    if min_loop_gain is not None and min_loop_gain > 0:
        need = min(need, C_LAM_GAIN * cfg.scale * min_loop_gain / lam)
    return cfg._replace(lam_factor=max(cfg.lam_factor, need))


#: a loop with a fixed feedback floor (:attr:`ConstraintAware.floor_delay`, the MIMO law's
#: ``C_FLOOR``): ``w_max <= C_FLOOR_SAMPLE / T`` instead of the shared ``C_SAMPLE``: the
#: floor and the normalised law (``mimo.C_SAMPLE_NORMALISED``) each move ``u0`` by about
#: ``w T s`` per sample. Measured: manipulator-mimo-s1 at 50 Hz (no limits, the ``s'``
#: estimate's lag ``T`` declared) at 0.5 / T loses the tracking (0.79 rad, 8.3 N m of fast
#: content), at 0.4 / T 3.5e-2 rad; the campaign's 20 Hz members unchanged (98 of 120), 100 Hz
#: 121 -> 122 of 123.
C_FLOOR_SAMPLE = 0.4

#: a loop with a floor whose noise's std bound ``C_NOISE / noise`` binds (issue 25's
#: manipulator noise case, 0.01 rad and 0.1 rad/s of joint noise: ``w`` = 1.5 1/s, which
#: lost the arm after the failures, 157 rad) sees its measurements through a first-order
#: prefilter at ``C_FLOOR_MEASURE w`` (at most ``C_EULER / T``), and runs at
#: :attr:`ConstraintAware.floor_noise_rate` (the prefiltered noise's bound,
#: ``C_NOISE_FLOOR``) where that is faster. Measured on that case with the loop rate forced
#: (error of the worse joint / fast content, targets 5e-2 rad / 0.36 N m): ``w`` = 8 with the
#: prefilter at 2w 0.11 / 0.12, at 4w 0.088 / 0.16; ``w`` = 12: 0.056 / 0.18 and 0.042 /
#: 0.24; ``w`` = 16: 0.037 / 0.25 (2w) and 0.030 / 0.29 (3w); ``w`` = 20: 0.028 / 0.34 and
#: 0.019 / 0.43; without the prefilter ``w`` = 4 already has 1.2 N m of fast content. Only
#: with the reference feedforward (``mimo.C_FEEDFORWARD``): the prefilter's lag in the loop
#: lost the arm or limit-cycled members before it (``floor_delay``). 0: no prefilter.
C_FLOOR_MEASURE = 2.0
#: ... the prefiltered noise of ``s`` times the loop rate (rad/s^2) the floor's proportional
#: path may carry: 0.2 gives ``w`` = 15.8 1/s on that case (0.15, the shared ``C_NOISE``:
#: 13.1)
C_NOISE_FLOOR = 0.2


#: the fixed proportional feedback's loop rate, in multiples of the plant's fastest unstable
#: open-loop mode ``p_u`` (``|lambda|`` of the linearised plant at ``t0``): "respect the
#: unstable" (Stein, IEEE CSM 23(4) 2003: a loop that stabilises a plant with an unstable pole
#: ``p`` needs a bandwidth of about ``2p``).
C_FEEDBACK = 2.0
#: ... added only where ``C_FEEDBACK p_u > C_FEEDBACK_GATE w_hw`` (``w_hw``: the loop rate the
#: hardware's bounds admit, without the cap ``C_CAP w0``): where the plant's unstable dynamics
#: are not far below what the hardware lets a loop do (the wing rock: ``p_u`` = 30.4 1/s,
#: ``w_hw`` = 8-1000 1/s), not where they are many times slower (hypersonic: ``p_u`` = 0.75;
#: the MIMO plants: none or 0.011). The same regime counts §2.4's compensator in the loop
#: gain and caps its linear regressor (:class:`FailureEstimation`).
C_FEEDBACK_GATE = 0.5
#: where the fixed feedback is placed, the adaptive law's loop rate is at most ``C_AUGMENT``
#: times the placed loop's worst-case decay rate: the adaptive law augments the placed loop
#: below its slowest mode. Measured on the wingrock-hardware campaign: at the hardware's
#: ``w_max`` (8-20 1/s) on top of the placed loop, members limit-cycled at 8-12 Hz with
#: 7e-3 rad of roll (frozen, they held 6e-6): 39 of the first 100 succeed; at 0.5, 431 of
#: 500; at 0.25, 436 (five bias failures more, whose learnt ``theta`` makes the raw fuzzy
#: basis ``Pi(z)^T theta`` a state feedback of gain ``|theta| / width``); at 0.1 the same
#: on those members.
C_AUGMENT = 0.25
#: ... and at least ``C_AUGMENT AUGMENT_FLOOR`` (1/s) where no placed gains are robustly
#: stable (the placed loop's ``decay >= 0``): the adaptation is then practically off.
AUGMENT_FLOOR = 0.01
#: the input-gain scales the placed feedback must stabilise (:func:`placed_feedback`): the
#: healthy gain and 65 % of it (every single failure of the wing rock's ailerons but a
#: stuck or nearly dead first aileron, which carries 47 % of the gain). Measured on the
#: wingrock-hardware campaign (constraint-aware only, 500 members): (0.5, 1) 436, (0.65, 1)
#: 455 (28 members with 35-50 ms lags gained, where no gains hold a halved input gain; 9
#: with the first aileron stuck lost), (0.8, 1) 450.
FEEDBACK_GAIN_SCALES = (0.65, 1.0)


#: where the plant is fast unstable the feedback is placed whether or not the designer's model
#: declares a delay (an actuator lag, a rate limiter's own linear band ``RATE_ONLY_TAU``, a
#: sample time); ``False``: only behind a declared delay, noise alone keeping the
#: proportional path on ``s`` at ``C_FEEDBACK p_u`` (session 11's rule) and the unslowed
#: law. Session 11 placed only behind a delay because the placed loop, its integral capped
#: at 0.3 ``p^3`` (decay about 8 1/s), did not settle the 8 s recovery of issue 25's noise
#: case within its 0.5 s (wingrock-direct-s1: placed 1.06e-2 rad against 2.0e-4). With the
#: integral grid extended (``FEEDBACK_KI_EXTEND``) the placed loop settles it: measured on
#: the noise case (1 % of the reference, judged 8.5-10 s), §2.3 5.3e-5 rad placed against
#: 2.0e-4 on the proportional path, §2.4 4.3e-4 against 0.44 (the proportional path has no
#: integral and §2.4's slowed compensator does not learn the stuck aileron's torque: the
#: roll is lost at 3 s). The wingrock-hardware campaign draws a rate limit for every member,
#: so every member declares a delay and the campaign is unchanged by this switch.
PLACE_UNDELAYED = True


#: the placed feedback's integral gain ``ki`` ranges over this interval times ``p^3``
#: (:func:`placed_feedback`), on 12 log-spaced points ...
FEEDBACK_KI_RANGE = (1e-3, 0.3)
#: ... and ``FEEDBACK_KI_EXTEND`` more points above it at the same log spacing (factor 1.68
#: per point: 0.50, 0.85 ``p^3``), so every gain of the 12 stays on the grid and a loop
#: whose decay does not gain from a faster integral keeps its gains. Why (issue 25, wing
#: rock, the 8 cases): the integral pole of the placed loop sits near ``-ki / (kp - a)``;
#: at 0.3 ``p^3`` it was the loop's slowest mode (-8.0 to -8.5 1/s on the lag 50 ms, 50 Hz
#: and rate cases, each at the cap) and the 8 s recovery (a 1461 rad/s^2 torque step) was
#: still decaying in the judged window 8.5-10 s. A failure-blind linear controller that
#: knows the plant settles that step within the window on each case
#: (``scripts/linear_reference_wingrock.py``). Raising the interval itself to ``(1e-3,
#: 1.0)`` moved every grid point and changed gains of members that were not at the cap
#: (wingrock-hardware member 44, behind 48 ms at 50 Hz with its first aileron stuck, lost:
#: damping 0.87 -> 0.40 ``p`` at the same decay). Measured with the extension (and
#: ``PLACE_UNDELAYED``): the decay -10.9 / -15.3 / -14.6 1/s on those three cases, and the
#: 8 cases of §2.3 and §2.4 acceptable (1 of 8 before; docs/hardware.md, "Wing rock §2.4").
FEEDBACK_KI_EXTEND = 2
#: ... admitted only where the declared rate limit lets the faster loop move an actuator by
#: ``FEEDBACK_KI_SWING`` (rad) at its decay rate: ``C_MARGIN rate >= FEEDBACK_KI_SWING
#: |decay|`` (the extended placement's decay; no rate limit: always). The swing is the
#: command change a failure's transient asks of an actuator (the wingrock-hardware
#: campaign's stuck values reach +-2 rad; the cases' recovery 6.1). Measured on the campaign
#: (constraint-aware only, 500 members): extended everywhere, 381 members' gains changed and
#: 9 of them (rate limits 10.4-22.8 rad/s, every one at its rate limit 94-99 % of the final
#: window, a rate-limit oscillation of 0.38-0.52 rad) were lost, 490/500 against 499; with
#: this gate 217 members change (rate limits 21.9 rad/s and up), none lost.
FEEDBACK_KI_SWING = 2.0


#: (session 13, round 8) where each actuator is clipped to its own travel behind a discrete
#: limiter (:attr:`ConstraintAware.discrete_limiter`, the travel per actuator), the law's
#: filtered error carries the tracking error's integral, ``s = e' + lam e + k_I int e_c``
#: with ``k_I = (C_INTEGRAL w_max)^2`` (:attr:`Configuration.error_integral`; an integral
#: sliding surface, Slotine & Li 1991, §7.1.3): the loop gain below ``C_INTEGRAL w_max``
#: rises by about ``k_I / (lam w)`` at a disturbance of frequency ``w``, without a higher
#: loop rate (the delay budget caps it) and without more gain on the measured ``e`` (its
#: noise) at the loop rate. Why (issue 25's second combination, hypersonic-direct-s1: the
#: stuck elevator's 0.5 rad/s pattern, which the law's state-dependent basis cannot learn,
#: was rejected by loop gain alone, 3.0e-3 rad against 8.7e-4). Measured there (``w`` =
#: 8.75, so ``k_I`` = 4.8; final-window error in rad): 0.2 (``k_I`` = 3.1) 1.2e-3, 0.25
#: 7.2e-4 (noise seed 1: 7.4e-4), 0.256 (5.0) 6.8e-4, 0.28 (6.0) 1.6e-3, 0.32 (8.0) lost
#: (0.17 rad): above it the lightly damped mode that every failure leaves near 4-6 rad/s
#: (the input gain falls to a quarter of the healthy one) loses its damping. With ``lam``
#: lowered to 1 beside it (less noise): 8.4e-4 (``k_I`` 4) to 8.2e-4 (5), diverged at 6.
C_INTEGRAL = 0.25
#: ... only where the noise the law sees is at most ``C_INTEGRAL_NOISE`` of the density bound
#: at the loop rate, ``w^2 n_d <= C_INTEGRAL_NOISE C_NOISE_DENSITY`` (combination 2: 0.16):
#: the added low-frequency gain carries the noise in the failed loop's band. Measured on the
#: hypersonic-hardware campaign (constraint-aware only, 500 members) with the delay-bound gate
#: alone: 241 members change, 64 track better and 177 worse (median +6 %), 491/500 against
#: 492 (two lost: 310, 200 Hz, fast content 9.7e-3 -> 1.9e-2; 336, 50 Hz, 7.2e-4 -> 1.02e-3
#: rad; one gained, 410; all three near 0.42 of the bound); with this gate 65 change (40
#: better, 25 worse), 492/500, the same members; at 0.33 90 change (48 / 42), 492.
C_INTEGRAL_NOISE = 0.25


#: the placed feedback's lead (issue 25, wing rock, session 12): the PID's output passes
#: ``(lag s + 1) / (tau s + 1)`` (a state per output), which cancels the declared actuator
#: lag down to ``tau = max(lag / LEAD_MAX, LEAD_SAMPLE T)``, and the gains are placed behind
#: ``tau`` instead of ``lag`` (:attr:`ConstraintAware.lead_lag`; 1 = no lead). Behind 35-50
#: ms the robust placement (input gain 0.65-1) had little decay left (-0.1 to -3.9 1/s;
#: -0.1 to -1.2 at 50 Hz: the failure's transient and a noise-driven slow mode were still in
#: the final window); behind the lead -3.6 (50 Hz) to -8.9 1/s. Measured on the
#: wingrock-hardware campaign (constraint-aware only, 500 members): 455 -> 499 (every member
#: with a lag of 20 ms or more succeeds); the high-frequency gain of the PID rises by
#: ``lag / tau`` (at most 3), the successful members' fast content stays at most 6.1e-3 rad
#: (threshold 0.185; 7.5e-3 before). On the 45 members that failed and 60 that succeeded:
#: ``LEAD_MAX`` 2: 103 of 105 (one of the 60 limit-cycles at its rate limit), 3 and 4: 104.
LEAD_MAX = 3.0
#: ... and ``tau >= LEAD_SAMPLE T``: the lead is a state of the law, integrated by forward
#: Euler at the sample time (``T / tau <= 1``: no sign flip from one sample to the next).
LEAD_SAMPLE = 1.0


def _ki_grid(extend: int) -> np.ndarray:
    """The placed feedback's integral gains over ``p^3``: 12 log-spaced points on
    ``FEEDBACK_KI_RANGE`` and ``extend`` more above it at the same spacing."""
    lo, hi = FEEDBACK_KI_RANGE
    base = np.geomspace(lo, hi, 12)
    ratio = (hi / lo) ** (1.0 / 11.0)
    return np.concatenate([base, hi * ratio ** np.arange(1, extend + 1)])


def _pade3(delay: float) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator of the order-3 Padé approximant of ``exp(-s delay)``."""
    c = (1.0, 0.5, 0.1, 1.0 / 120.0)
    num = np.array([(-1) ** k * c[k] * delay**k for k in range(3, -1, -1)])
    den = np.array([c[k] * delay**k for k in range(3, -1, -1)])
    return num, den


@functools.lru_cache(maxsize=256)
def placed_feedback(
    stiffness: float,
    damping: float,
    lag: float,
    delay: float,
    scales: tuple[float, ...] = FEEDBACK_GAIN_SCALES,
    n: int = 31,
    ki_extend: int = 0,
) -> tuple[float, float, float, float]:
    """The fixed feedback ``u0 += (kp e + kd e' + ki int e) / b`` placed on the designer's
    linear model: ``y'' = stiffness y + damping y' + beta b u0`` (the plant linearised at
    ``t0``), ``u0`` through a first-order lag ``lag`` and a delay ``delay`` (half a sample of
    hold; order-3 Padé). Returns ``(kp, kd, ki, decay)``: the gains (in units of ``y''`` per
    unit error) whose closed loop has the largest worst-case decay rate (``-decay``, ``decay``
    the largest real part of its poles) over the input-gain scales ``beta`` in ``scales``, on
    a grid of closed-loop stiffness ``kp - stiffness`` in ``[0.02, 3] p^2``, damping ``kd -
    damping`` in ``[-1, 6] p`` and ``ki`` in ``[1e-3, 0.3] p^3`` (``p^2 = max(|stiffness|,
    damping^2/4)``), with ``ki_extend`` more ``ki`` points above it at the same log spacing
    (``FEEDBACK_KI_EXTEND``).

    Why (issue 25, wing rock): behind a lag the loop must act where the lag costs little
    phase. The wing rock is a negatively damped oscillator at 30.4 rad/s; a proportional
    path on ``s`` (the rule's first fixed feedback: ``2 p_u``) stiffens it further (35-46
    rad/s), where a 35 ms lag takes 50-60 degrees. The placed gains cancel most of the
    stiffness (the oscillation moves down to where the lag costs little) and add damping, as
    the oracle does by knowing the model, but robustly to a loss of input gain; the integral
    removes the offset a failure's torque leaves on the softened loop (the adaptive law's
    raw fuzzy basis vanishes beyond 0.4 rad of roll and cannot)."""
    p2 = max(abs(stiffness), damping * damping / 4.0, 1e-12)
    p = math.sqrt(p2)
    grid = np.meshgrid(
        p2 * np.linspace(0.02, 3.0, n),
        p * np.linspace(-1.0, 6.0, n),
        p2 * p * _ki_grid(ki_extend),
        indexing="ij",
    )
    S, Dm, ki = (a.ravel() for a in grid)
    kp, kd = S + stiffness, Dm + damping
    nd, dd = _pade3(delay) if delay > 0 else (np.ones(1), np.ones(1))
    base = np.array([1.0, -damping, -stiffness, 0.0])  # times s: the integral's pole
    plant = np.polymul(np.polymul(base, [lag, 1.0]) if lag > 0 else base, dd)
    m = plant.size
    worst = np.full(S.size, -np.inf)
    for beta in scales:
        C = np.tile(plant, (S.size, 1))
        for j, gain in enumerate((kd, kp, ki)):  # beta (kd s^2 + kp s + ki) nd(s)
            for k, cn in enumerate(nd[::-1]):
                C[:, m - 1 - (2 - j + k)] += beta * gain * cn
        C = C / C[:, :1]
        M = np.zeros((S.size, m - 1, m - 1))
        M[:, 0, :] = -C[:, 1:]
        M[:, np.arange(1, m - 1), np.arange(m - 2)] = 1.0
        worst = np.maximum(worst, np.linalg.eigvals(M).real.max(axis=1))
    i = int(np.argmin(worst))
    return float(kp[i]), float(kd[i]), float(ki[i]), float(worst[i])


class Configuration(NamedTuple):
    """What :meth:`ConstraintAware.configure` derives (the numbers of the compiled law)."""

    #: bandwidth scale of the law (1 = the thesis's gains)
    scale: float
    #: factor on ``lam`` (1 = the thesis's)
    lam_factor: float
    #: widening of the robust term's boundary layer at the same linear-band slope:
    #: ``k0 -> W k0``, ``eps0 -> W eps0 / r`` (1 = none)
    widen: float
    #: command filter bandwidth (rad/s; inf = no filter)
    omega_f: float
    #: magnitude limit of the common command u0 (inf = none)
    u_max: float
    #: rate limit of u0 (per second; inf = none)
    u_rate: float
    #: prefilter bandwidth of the adaptation signal q (rad/s; inf = none)
    omega_q: float
    #: prefilter bandwidth of the measurements the law sees (rad/s; inf = none)
    omega_m: float
    #: back-calculation rate of the anti-windup (1/s; 0 = none)
    k_aw: float
    #: gain of the compensated-error (hedging) filter, the nominal input gain (0 = none)
    hedge: float
    #: decay rate of the compensated-error filter (1/s)
    omega_h: float
    #: radius of the projection ball of theta (inf = none)
    theta_max: float
    #: factor on the slope ``k0/eps0`` of the robust term's linear band (the law's integral
    #: path; 1 = the thesis's): ``eps0 -> W eps0 / slope_scale``
    slope_scale: float = 1.0
    #: gain of the fixed feedback on ``e'``: ``u0 += feedback e' + feedback_e e``
    #: (:func:`placed_feedback`; 0 = none)
    feedback: float = 0.0
    #: prefilter bandwidth of the measurements the *adaptation's* regressor sees (rad/s; inf
    #: = none): ``u0 = Pi(x)^T theta`` keeps the measured ``x``, the law of ``theta`` gets
    #: ``Pi`` of the prefiltered ``x`` (§4.3 under noise, :func:`adaptation_regressor_rule`)
    omega_r: float = math.inf
    #: a digital law's sample time where the command filter hands on the value after the
    #: sample's step, ``u0 = uf + T uf'`` (0 = its state ``uf``: one sample more of lag; the
    #: constraint-aware MIMO law, :meth:`MimoDirectAdaptive.sampled_configuration`)
    step: float = 0.0
    #: per-output gains of a fixed proportional feedback ``u0_i += f_i s_i`` (``()`` = none;
    #: the constraint-aware MIMO law's floor, :meth:`MimoDirectAdaptive.output_floor`)
    output_feedback: tuple = ()
    #: the floor ``output_feedback`` enters before the command filter (its rate and travel
    #: limits apply to it) instead of after it
    feedback_filtered: bool = False
    #: gain of the fixed feedback on ``e`` (see ``feedback``)
    feedback_e: float = 0.0
    #: gain of the fixed feedback on ``int e`` (a state per output; 0 = none)
    feedback_i: float = 0.0
    #: the fixed feedback's lead ``(lag s + 1) / (tau s + 1)``: ``(lag, tau)`` (``()`` =
    #: none; a state per output)
    feedback_lead: tuple = ()
    #: rate bound of each actuator's own command filter (inf = none: the allocation of the
    #: common filter's ``u0``); where finite (a tight rate limit), a single-output design
    #: without an allocator passes every actuator's command through its own filter at this
    #: rate, and the compensated error hedges what they deliver (:func:`emit`)
    actuator_rate: float = math.inf
    #: the nominal model's feedforward along the reference, ``u0 += u_ff(t + lead)`` with
    #: ``G(x_r) u_ff = y_r'' - f(x_r)`` (``x_r`` the state on the reference; before the command
    #: filter; the constraint-aware MIMO law, on its outputs with a floor,
    #: :meth:`MimoDirectAdaptive.floor_configuration`); ``-1`` = none, else the lead (s) that
    #: the reference is read ahead by
    feedforward: float = -1.0
    #: (session 13) the travel bound of each actuator's command after the allocation (inf =
    #: none): where finite, a single-output design without an allocator or a fixed feedback
    #: bounds its common command ``u0`` by the *least*-allocated actuator's travel,
    #: ``actuator_travel / min |R_j|``, and clips each actuator's command to
    #: ``actuator_travel`` after the allocation (:func:`emit`): the compensated error then
    #: hedges only the command no actuator can deliver
    actuator_travel: float = math.inf
    #: (session 13, round 8) the gain ``k_I`` (1/s^2) of the integral of the tracking error in
    #: the law's filtered error, ``s = e' + lam e + k_I int e_c`` (0 = none; a state per
    #: output): an integral sliding surface (Slotine & Li 1991, §7.1.3), which raises the
    #: loop gain below ``sqrt(k_I)`` without raising the gain on the measured ``e`` (its
    #: noise) at the loop rate; ``e_c = e - xi / lam`` with the compensated error's ``xi``
    #: where the command is hedged (the integral does not wind up on the limits)
    error_integral: float = 0.0
    #: (session 15) prefilter bandwidth (rad/s; inf = none) of the plant-state inputs of the
    #: law's regressor, in the command ``u0 = Pi(x_f)^T theta`` *and* in the adaptation
    #: (``C_REGRESSOR_NOISE``, :attr:`ConstraintAware.regressor_prefilter`): the errors and
    #: ``s`` stay as measured
    omega_b: float = math.inf

    @property
    def filtered(self) -> bool:
        return math.isfinite(self.omega_f)

    @property
    def prefiltered(self) -> bool:
        return math.isfinite(self.omega_q)

    @property
    def measured_through_filter(self) -> bool:
        return math.isfinite(self.omega_m)

    @property
    def projected(self) -> bool:
        return math.isfinite(self.theta_max)

    @property
    def adaptation_regressor_filtered(self) -> bool:
        """The adaptation's regressor sees prefiltered measurements (the command's does not)."""
        return (
            math.isfinite(self.omega_r)
            and not self.measured_through_filter
            and not self.regressor_filtered
        )

    @property
    def regressor_filtered(self) -> bool:
        """The regressor, in the command and in the adaptation, sees prefiltered plant states
        (the errors and ``s`` do not; session 15)."""
        return math.isfinite(self.omega_b) and not self.measured_through_filter

    @property
    def has_measurement_filters(self) -> bool:
        """One prefilter state per plant state (all the law's measurements, or only what the
        regressor sees)."""
        return (
            self.measured_through_filter
            or self.adaptation_regressor_filtered
            or self.regressor_filtered
        )


IDENTITY = Configuration(
    1.0, 1.0, 1.0, math.inf, math.inf, math.inf, math.inf, math.inf, 0.0, 0.0, 0.0, math.inf
)


def _number(owner: str, key: str, v, *, allow_inf: bool, positive: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v):
        raise ConfigurationError(f"`{key}` of {owner} must be a number; got {v!r}.")
    if not allow_inf and math.isinf(v):
        raise ConfigurationError(f"`{key}` of {owner} must be finite; got {v!r}.")
    if positive and not v > 0:
        raise ConfigurationError(f"`{key}` of {owner} must be > 0; got {v!r}.")
    if v < 0:
        raise ConfigurationError(f"`{key}` of {owner} must be >= 0; got {v!r}.")
    return float(v)


@dataclass(frozen=True, kw_only=True)
class ConstraintAware:
    """The designer's model of the hardware, from which a design derives its constraint-aware
    configuration (see the module docstring for the rules and the references).

    Declared apart from the loop's true hardware (``ClosedLoop.actuators``, ``.sensors``,
    ``.sample_time``), so a design can be studied under a mismatched model;
    :meth:`from_loop` derives it from the loop's own declared hardware.

    Parameters
    ----------
    lag
        Actuator time constant (s) the designer assumes; 0 = none.
    rate
        Actuator rate limit (actuator units per second); ``inf`` = none.
    travel
        Actuator travel: ``|u_j| <= travel``; ``inf`` = none.
    sample_time
        Controller sample time (s); 0 = continuous.
    noise
        Standard deviation of the measured filtered error ``s = e' + lam e`` (from the
        sensors: ``sqrt(noise(velocity)^2 + lam^2 noise(position)^2)``); 0 = none.
    bandwidth
        The law's loop rate (1/s) to use instead of the rule's ``w_max`` (``None``: the
        rule). For studies of the rule; not needed otherwise.
    theta_max
        Radius of the projection ball of each output's ``theta``; ``inf`` = no projection.
    input_gain
        The designer's nominal ``|d s'/d u0|`` of the healthy plant (``sum_j b_j dy''/du_j``;
        ``plant.input_gains()``): with rate or travel limits, the gain of the compensated-
        error filter that hedges the undelivered command out of the adaptation. ``None``
        (default): derived from the loop's plant at its initial state and its allocation
        (:meth:`AdaptiveController.nominal_input_gain`); 0 = no hedging. Not a constraint: a
        model with only ``input_gain`` is ideal.
    loop_rate
        The law's loop rate ``w0`` (1/s) on the loop it runs, which the rule slows down to
        ``w_max``. ``None`` (default): measured from the loop's nominal loop gain when the
        loop is compiled (:meth:`AdaptiveController.measured_loop_rate`: per output
        ``max(g, sqrt(g (k + k0/eps0)))`` with ``g = |d s'/d u0| x`` adaptation gain
        ``x |Pi(z0)|^2``, the poles of the law's linear band); without a loop, the proxy
        ``k + k0/eps0``. Not a constraint.
    loop_gain
        The law's proportional loop gain ``g = |d s'/d u0| x |Pi(z0)|^2`` x adaptation gain
        of the output whose ``loop_rate`` is the largest; ``None``: measured with
        ``loop_rate`` (without it, the adaptation gains and the robust term's slope are
        scaled alike). Not a constraint.
    min_loop_gain
        The smallest ``g`` over the outputs: ``lam`` is raised to at most ``C_LAM_GAIN`` times
        it after scaling (a filtered-error corner above the loop gain loses the loop: the
        manipulator's first joint, ``g = 1.8``, spins away with ``lam = 4``). ``None``:
        measured with ``loop_rate``. Not a constraint.
    b_max
        The largest ``|R_ij|`` of the allocation (the rate and travel of ``u0`` are the
        actuators' divided by it); ``None``: the loop's, when compiled. Not a constraint.
    gain_growth
        The factor by which the law's loop gain can grow along the run over the one measured at
        ``t0`` (§4.4: the projection bound of ``rho`` over ``|rho0|``, ``RHO_FACTOR``): the rule
        scales the adaptation for the grown gain, while its cap ``C_CAP w0`` stays a tenth of
        the thesis's loop rate. ``None``: the design's (:meth:`AdaptiveController.bound`; 1
        but for §4.4). Not a constraint.
    noise_rate
        The sensors' readings per second, each with its own noise (``Sensors.rate``): with
        ``noise``, its density, and for a digital law the readings per sample its decimation
        filter averages (:attr:`decimation`). Not a constraint alone.
    derivative_lag
        Time constant (s) of the loop's ``s'`` estimate (the solver's dirty-derivative filter,
        ``SolverOptions.filter_tau``), a lag in the law's loop. ``None`` (default): the
        solver's default for this model, ``max(0.01, 2 sample_time)`` where the controller is
        digital or the measurements noisy, else 0 (``s'`` exact); the digital MIMO law sets 0
        (:meth:`MimoDirectAdaptive.bound`: its backward-difference ``s'``, looked ahead
        through, adds no lag). Not a constraint alone.
    floor_delay
        Filled by :meth:`MimoDirectAdaptive.bound` where the law has a fixed feedback floor
        (``mimo.C_FLOOR``; not a constraint, leave it unset): the loop-rate rule then bounds
        the sum of the loop's lags as ``w (lag + T + tau_d) <= floor_delay`` with rate or
        travel limits (``C_DELAY`` without), without the command filter's lag (the floor is
        after the filter), ``w <= C_FLOOR_SAMPLE / T``, and noise by its std alone, ``w <=
        C_NOISE / noise``, with no prefilter (the floor's path carries the noise of ``s``
        times ``w / b``: measured on the manipulator-hardware campaign, the density bound
        (``w`` = 10.5 at 50 Hz) left 20 Hz members at 0.05-0.08 rad that track to 0.013 at
        the std bound's 22.7, with 0.10 N m of fast content against 0.36; the prefilters that
        the std bound adds lost the arm or limit-cycled 11 members at ``w`` = 31-44).

    feedback
        The fixed feedback the designer states instead of the rule's: a proportional path
        ``u0 += (feedback / b) s`` on the filtered error at that loop gain (1/s); 0 = none.
        ``None`` (default): the rule's, the placed feedback (:meth:`placement`) where
        :meth:`fast_unstable`.
    unstable_rate
        The modulus of the plant's fastest unstable open-loop mode (1/s); ``None``: measured
        on the loop (:meth:`AdaptiveController.open_loop_unstable_rate`). Not a constraint.
    open_loop
        ``(d y''/d y, d y''/d y')`` of the plant linearised at ``t0`` (the designer's linear
        model of the placed feedback); ``None``: measured on the loop
        (:meth:`AdaptiveController.open_loop_rows`). Not a constraint.

    model_feedforward
        The designer's model includes the plant's equations: the MIMO law with a floor adds
        the healthy model's feedforward along the reference (``mimo.C_FEEDFORWARD``; exported
        to C with the plant's equations and parameters, ``export_c``). False: none (nor a
        plant model in the exported controller: a plant ``export_c`` cannot translate). Not a
        constraint.
    per_actuator
        (session 13) The command filter is shaped by each actuator's own limits: with a travel
        limit (and a rate limit that is not tight), ``u0`` is bounded by the least-allocated
        actuator's travel and each actuator's command is clipped to its own travel after the
        allocation (``Configuration.actuator_travel``, :func:`emit`); a digital law's filter
        is a discrete limiter (:attr:`discrete_limiter`). ``None`` (default): filled by
        :meth:`AdaptiveController.bound`, true for a single-output design with a fixed
        allocation (no allocator) and limits, but where the placed feedback is
        (:meth:`fast_unstable`: the wing rock's loop was sized with the common filter). Not a
        constraint.
    decimation
        (session 14) The digital law's anti-aliasing filter: where the sensors are faster than
        the controller, a whole number ``N = noise_rate x sample_time >= 2`` of readings per
        sample, the law reads at each sample the mean of the ``N`` readings of the period
        (a boxcar, integrate-and-dump prefilter: Franklin, Powell & Workman, *Digital Control
        of Dynamic Systems*, 3rd ed., 1998, §6.3.2; Åström & Wittenmark, *Computer-Controlled
        Systems*, 3rd ed., 1997, §7.4; :attr:`readings`): the noise it sees is ``noise /
        sqrt(N)`` at the sensor's density, delayed by ``(N-1)/(2N)`` of a period, which the
        rule counts (:attr:`seen_noise`, :attr:`decimation_delay`), at a loop rate no higher
        than without the filter (:meth:`omega_max`). ``None`` (default):
        decided by :meth:`AdaptiveController.bound` on the loop, on where the model has such
        ``N`` and its noise lowers the rule's loop rate (the std or density bound below the
        hardware's other bounds, without the filter; a designer's ``bandwidth`` aside) and
        the loop's sensors give those ``N`` readings (elsewhere the filter would only add its
        delay), on single-output laws with a fixed allocation and no placed feedback (not
        :meth:`fast_unstable`; the wing rock's placed PID lost 3 of 500 campaign members
        with it, the MIMO laws were not measured: set ``True`` there to have it); a model
        not bound to a loop has it off. ``False``: off (the latest reading at
        each sample); ``True``: on, and a model without such ``N`` is refused. Not a
        constraint.
    regressor_prefilter
        (session 15) The law's regressor sees its plant-state inputs through a first-order
        low-pass at ``C_REGRESSOR_NOISE w`` (at most ``C_EULER / T``), in the command ``u0 =
        Pi(x_f)^T theta`` and in the adaptation alike (``Configuration.omega_b``); the errors
        and ``s`` stay as measured. The learnt ``theta`` makes the basis a rate feedback on the
        measured state, which passes the noise to the command unfiltered up to the sampler's
        Nyquist frequency; the loop needs it only about its own rate (the filter adds ``1 /
        (C_REGRESSOR_NOISE w)`` of delay to the learnt feedback, 14 deg at the loop rate).
        ``None`` (default): decided by :meth:`AdaptiveController.bound` on the loop, taken where
        the decimation filter is (the noise sets the loop rate), on laws whose loop gain does
        not grow along the run (``gain_growth`` = 1) and that do not estimate their input gain
        (not §4.4, ``AdaptiveController.estimates_input_gain``, measured to lose its failed
        loop with it, also where the error's integral bounds ``rho`` by ``|rho0|``), without a
        noise rule of their own for the regressor (not §4.3,
        ``AdaptiveController.regressor_noise_rule``) and where the delay budget with the
        filter's delay holds, ``w (lag + T/2 + tau_d + decimation delay) + 1/C_REGRESSOR_NOISE
        <= C_DELAY``; a model not bound to a loop has it off. ``False``: off; ``True``: on
        (where the configuration is not the identity and the measurements are not all
        prefiltered already). Not a constraint.

    Examples
    --------
    >>> ConstraintAware().is_ideal
    True
    >>> ConstraintAware(lag=0.05).configure(w0=205.0, b_max=2.0).scale  # 1/0.05 = 20 1/s
    0.0975609756097561
    """

    lag: float = 0.0
    rate: float = math.inf
    travel: float = math.inf
    sample_time: float = 0.0
    noise: float = 0.0
    bandwidth: float | None = None
    theta_max: float = math.inf
    input_gain: float | None = None
    loop_rate: float | None = None
    loop_gain: float | None = None
    min_loop_gain: float | None = None
    b_max: float | None = None
    derivative_lag: float | None = None
    noise_rate: float = 1000.0
    gain_growth: float | None = None
    feedback: float | None = None
    unstable_rate: float | None = None
    floor_delay: float | None = None
    open_loop: tuple[float, float] | None = None
    model_feedforward: bool = True
    per_actuator: bool | None = None
    decimation: bool | None = None
    regressor_prefilter: bool | None = None

    def __post_init__(self) -> None:
        owner = "ConstraintAware"
        _number(owner, "lag", self.lag, allow_inf=False)
        _number(owner, "rate", self.rate, allow_inf=True, positive=True)
        _number(owner, "travel", self.travel, allow_inf=True, positive=True)
        _number(owner, "sample_time", self.sample_time, allow_inf=False)
        _number(owner, "noise", self.noise, allow_inf=False)
        _number(owner, "theta_max", self.theta_max, allow_inf=True, positive=True)
        if self.input_gain is not None:
            _number(owner, "input_gain", self.input_gain, allow_inf=False)
        if self.loop_rate is not None:
            _number(owner, "loop_rate", self.loop_rate, allow_inf=False, positive=True)
        if self.loop_gain is not None:
            _number(owner, "loop_gain", self.loop_gain, allow_inf=False)
        if self.min_loop_gain is not None:
            _number(owner, "min_loop_gain", self.min_loop_gain, allow_inf=False)
        if self.b_max is not None:
            _number(owner, "b_max", self.b_max, allow_inf=False, positive=True)
        if self.bandwidth is not None:
            _number(owner, "bandwidth", self.bandwidth, allow_inf=False, positive=True)
        if self.derivative_lag is not None:
            _number(owner, "derivative_lag", self.derivative_lag, allow_inf=False)
        _number(owner, "noise_rate", self.noise_rate, allow_inf=True, positive=True)
        if self.gain_growth is not None:
            _number(owner, "gain_growth", self.gain_growth, allow_inf=False, positive=True)
        if self.feedback is not None:
            _number(owner, "feedback", self.feedback, allow_inf=False)
        if self.unstable_rate is not None:
            _number(owner, "unstable_rate", self.unstable_rate, allow_inf=False)
        if self.floor_delay is not None:
            _number(owner, "floor_delay", self.floor_delay, allow_inf=False, positive=True)
        if self.per_actuator is not None and not isinstance(self.per_actuator, bool):
            raise ConfigurationError(
                "`per_actuator` of ConstraintAware must be true, false or left unset; got "
                f"{self.per_actuator!r}."
            )
        if self.decimation is not None and not isinstance(self.decimation, bool):
            raise ConfigurationError(
                "`decimation` of ConstraintAware must be true, false or left unset; got "
                f"{self.decimation!r}."
            )
        if self.regressor_prefilter is not None and not isinstance(self.regressor_prefilter, bool):
            raise ConfigurationError(
                "`regressor_prefilter` of ConstraintAware must be true, false or left unset; "
                f"got {self.regressor_prefilter!r}."
            )
        if self.decimation and self.whole_readings < 2:
            raise ConfigurationError(
                "`decimation` of ConstraintAware averages the sensor readings of each "
                "controller sample: it needs a digital controller (`sample_time` > 0) whose "
                "sensors give a whole number N >= 2 of readings per sample (`noise_rate` x "
                f"`sample_time`); got sample_time = {self.sample_time!r} s and noise_rate = "
                f"{self.noise_rate!r} Hz. Leave `decimation` unset (on where that holds) or "
                "set it false."
            )
        if not isinstance(self.model_feedforward, bool):
            raise ConfigurationError(
                "`model_feedforward` of ConstraintAware must be true or false; got "
                f"{self.model_feedforward!r}."
            )
        if isinstance(self.open_loop, list):  # a scenario file's array
            object.__setattr__(self, "open_loop", tuple(self.open_loop))
        if self.open_loop is not None:
            if not isinstance(self.open_loop, tuple) or len(self.open_loop) != 2:
                raise ConfigurationError(
                    f"`open_loop` of {owner} must be a pair (d y''/d y, d y''/d y'); "
                    f"got {self.open_loop!r}."
                )
            for v in self.open_loop:
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                    raise ConfigurationError(
                        f"`open_loop` of {owner} must hold two finite numbers; "
                        f"got {self.open_loop!r}."
                    )

    @property
    def whole_readings(self) -> int:
        """``N = noise_rate x sample_time`` where it is a whole number (within 1e-9), else 0."""
        if not self.sample_time > 0 or not math.isfinite(self.noise_rate):
            return 0
        ratio = float(self.noise_rate) * float(self.sample_time)
        n = round(ratio)
        return int(n) if abs(ratio - n) <= 1e-9 * ratio else 0

    @property
    def readings(self) -> int:
        """The sensor readings the law's decimation filter averages per sample
        (:attr:`decimation` true: :attr:`whole_readings`); 1 = none (off, or left unset and
        not decided by :meth:`AdaptiveController.bound`)."""
        if self.decimation is not True:
            return 1
        return max(self.whole_readings, 1)

    @property
    def seen_noise(self) -> float:
        """The std of the measured ``s`` the law sees: ``noise``, or ``noise / sqrt(N)``
        through the decimation filter (:attr:`readings`)."""
        return self.noise / math.sqrt(self.readings)

    @property
    def decimation_delay(self) -> float:
        """The decimation filter's delay (s): the mean of ``N`` readings ``T/N`` apart lags
        the latest by ``(N-1)/(2N) T``; 0 without the filter."""
        n = self.readings
        return (n - 1) / (2.0 * n) * self.sample_time

    @property
    def is_ideal(self) -> bool:
        """No lag, no limits, continuous, no noise (and no override): the thesis law."""
        return (
            self.lag == 0
            and math.isinf(self.rate)
            and math.isinf(self.travel)
            and self.sample_time == 0
            and self.noise == 0
            and self.bandwidth is None
            and math.isinf(self.theta_max)
        )

    @classmethod
    def from_hardware(
        cls,
        *,
        actuators=None,
        sensors=None,
        sample_time: float = 0.0,
        plant=None,
        lam: float | tuple[float, ...] = 1.0,
        **overrides,
    ) -> ConstraintAware:
        """The model that believes the declared hardware: the largest lag (or ``1/omega`` of
        a second-order actuator), the smallest rate limit and travel over the actuators, the
        loop's sample time and the noise of ``s`` from the sensors' standard deviations on
        the first output's position and velocity states (``plant`` names them)."""
        lag, rate, travel, noise = 0.0, math.inf, math.inf, 0.0
        extra: dict = {}
        if actuators is not None and plant is not None:
            tab = actuators.table(plant.n_actuators)
            lag = float(np.max(tab[:, 0]))  # a rate limiter's own linear band included
            om = tab[:, 4]
            if np.any(om > 0):
                lag = max(lag, float(np.max(1.0 / om[om > 0])))
            rate = float(np.min(tab[:, 1]))
            travel = float(np.min(np.minimum(np.abs(tab[:, 2]), np.abs(tab[:, 3]))))
        if sensors is not None and plant is not None:
            std, _ = sensors.per_state(plant.aliases(), plant.n_states)
            lam1 = float(lam if isinstance(lam, (int, float)) else lam[0])
            sp = float(std[plant.position_index[0]])
            sv = float(std[plant.velocity_index[0]])
            noise = math.hypot(sv, lam1 * sp)
            extra["noise_rate"] = float(sensors.rate)
        return cls(
            **{
                "lag": lag,
                "rate": rate,
                "travel": travel,
                "sample_time": float(sample_time),
                "noise": noise,
                **extra,
                **overrides,
            }
        )

    @classmethod
    def from_loop(cls, loop, **overrides) -> ConstraintAware:
        """:meth:`from_hardware` of ``loop``'s declared actuators, sensors and sample time."""
        return cls.from_hardware(
            actuators=loop.actuators,
            sensors=loop.sensors,
            sample_time=loop.sample_time,
            plant=loop.plant,
            lam=loop.controller.lam,
            **overrides,
        )

    @property
    def s_lag(self) -> float:
        """The time constant of the ``s'`` estimate (:attr:`derivative_lag`, or its default)."""
        if self.derivative_lag is not None:
            return float(self.derivative_lag)
        if self.sample_time > 0 or self.noise > 0:
            return max(S_FILTER_TAU, 2.0 * self.sample_time)
        return 0.0

    def omega_max(self, w0: float, b_max: float = 1.0) -> tuple[float, bool]:
        """The rule: the law's loop rate the hardware admits (``w0`` = ``k + k0/eps0``), and
        whether the noise bound is the one that binds.

        With the decimation filter (:attr:`readings` > 1) the rule counts the noise the law
        sees through it and the filter's delay, and the loop rate is at most the one the
        rule gives without the filter (session 14, round 9): the filter quiets the command at
        the loop rate the sensor's readings alone admit, and does not buy a faster loop.
        Measured on issue 25's combination 1 (1 kHz readings, 200 Hz, 20 ms lag): the rule
        with the averaged reading's density runs the loop at 14.8 1/s instead of 9.9, and
        the fast content grows back about as ``w^2`` (hypersonic-direct-s1 2.7e-2 rad
        against 1.8e-2 at 9.9, target 1.73e-2; §4.4 1.9e-2 against 6.8e-3, target 8.7e-3),
        while the error, 4.0e-4 against 6.8e-4, had margin already (target 8.7e-4); the
        hypersonic-hardware campaign's first 100 members: 97 against 98 acceptable (docs/
        hardware.md, "Round 9 (session 14)")."""
        w, noisy = self._omega_max(w0, b_max)
        if self.readings > 1 and self.bandwidth is None:
            w_raw, _ = replace(self, decimation=False)._omega_max(w0, b_max)
            if w_raw < w:
                return w_raw, False
        return w, noisy

    def _omega_max(self, w0: float, b_max: float) -> tuple[float, bool]:
        """:meth:`omega_max` before the decimation filter's cap."""
        if self.bandwidth is not None:
            return min(w0, float(self.bandwidth)), False
        w = C_CAP * w0
        if self.lag > 0:
            w = min(w, C_LAG / self.lag)
        if self.sample_time > 0:
            w = min(w, C_SAMPLE / self.sample_time)
        if math.isfinite(self.rate):
            w = min(w, C_MARGIN * self.rate / max(abs(b_max), 1e-300) / A_LOOP)
        # the lags of the loop add up (C_DELAY); with limits, the command filter's too:
        # w (delay + max(1/(C_FILTER w), lag_f)) <= C_DELAY_LIMITED, with lag_f the command
        # filter's own floor (1/omega_f >= lag, T/C_EULER)
        # (the decimation filter's delay counts: its mean lags the latest reading)
        delay = self.lag + 0.5 * self.sample_time + self.s_lag + self.decimation_delay
        w_hw = w
        if self.floor_delay is not None:
            # a loop with a fixed feedback floor (the MIMO law, MimoDirectAdaptive.bound):
            # its own budget over the actuator's lag, a whole sample and the s' lag
            delay = self.lag + self.sample_time + self.s_lag + self.decimation_delay
            if delay > 0:
                w = min(w, (self.floor_delay if self.limited else C_DELAY) / delay)
            if self.sample_time > 0:
                w = min(w, C_FLOOR_SAMPLE / self.sample_time)
        elif delay > 0 and not self.limited:
            w = min(w, C_DELAY / delay)
        if self.limited and self.floor_delay is None and self.discrete_limiter:
            # a digital command filter that is a discrete limiter (``discrete_limiter``) adds
            # no lag of its own: the loop's lags alone against the limited budget
            if delay > 0:
                w = min(w, C_DELAY_LIMITED / delay)
        elif self.limited and self.floor_delay is None:
            lag_f = max(self.lag, self.sample_time / C_EULER)
            if delay + lag_f > 0:
                w = min(w, C_DELAY_LIMITED / (delay + lag_f))
            if delay > 0:
                w = min(w, (C_DELAY_LIMITED - 1.0 / C_FILTER) / delay)
        if self.noise > 0 and self.floor_delay is not None:
            # the std bound, or, where faster, the loop seeing its measurements through the
            # prefilter (MimoDirectAdaptive.floor_configuration: where the rate is above
            # the std bound)
            return max(min(w, C_NOISE / self.seen_noise), self.floor_prefiltered_rate(w_hw)), False
        if self.noise > 0:
            # the density bound lowers the loop rate only; where the std bound binds, the
            # measurements are prefiltered too (configure); both count the noise the law
            # sees (through the decimation filter: seen_noise)
            w = min(w, math.sqrt(C_NOISE_DENSITY / self.noise_density))
            if C_NOISE / self.seen_noise < w:
                return C_NOISE / self.seen_noise, True
        return w, False

    def delay_bound(self, w: float) -> bool:
        """The loop rate ``w`` is the one the delay budget of a discrete limiter admits,
        ``C_DELAY_LIMITED / (lag + T/2 + tau_d)`` (no other bound of the rule is lower: not
        the noise's, not the cap's)."""
        delay = self.lag + 0.5 * self.sample_time + self.s_lag + self.decimation_delay
        if not (self.discrete_limiter and delay > 0 and self.bandwidth is None):
            return False
        return w >= C_DELAY_LIMITED / delay * (1.0 - 1e-9)

    def regressor_prefilter_fits(self, w: float) -> bool:
        """The delay budget admits the regressor's prefilter (:attr:`regressor_prefilter`) at
        the loop rate ``w``: ``w (lag + T/2 + tau_d + decimation delay) + 1/C_REGRESSOR_NOISE
        <= C_DELAY`` (the filter's delay ``1 / (C_REGRESSOR_NOISE w)`` on the learnt feedback
        counted like the loop's other lags; issue 25's combination 1: 0.34 + 0.25)."""
        delay = self.lag + 0.5 * self.sample_time + self.s_lag + self.decimation_delay
        return w * delay + 1.0 / C_REGRESSOR_NOISE <= C_DELAY

    def floor_prefiltered_rate(self, w_hw: float) -> float:
        """The loop rate (1/s) a loop with a floor (``floor_delay`` set) admits when it sees
        its measurements through a first-order prefilter at ``C_FLOOR_MEASURE w`` (at most
        ``C_EULER / T``): ``w_hw`` (the cap, lag, sample and rate bounds) and the floor's
        delay budget with the prefilter's lag counted, ``w (lag + T + tau_d + T/C_EULER) <=
        budget - 1/C_FLOOR_MEASURE``, the sample bound ``C_FLOOR_SAMPLE / T`` and
        :attr:`floor_noise_rate`; 0 where no prefilter is admitted (``C_FLOOR_MEASURE`` = 0,
        no noise, no floor). The rule takes it where it is faster than the std bound ``C_NOISE
        / noise`` without a prefilter: issue 25's manipulator noise case (no delay but the
        ``s'`` estimate's 10 ms: 15.8 1/s against 1.5), not a campaign member with a rate
        limit (its budget, ``0.8 - 1/2``, over at least the ``s'`` estimate's 10 ms: at most
        30 1/s, the std bound of the campaign's largest noise, 5e-3 rad)."""
        if not (self.noise > 0 and self.floor_delay is not None and C_FLOOR_MEASURE > 0):
            return 0.0
        w = min(w_hw, self.floor_noise_rate)
        budget = (self.floor_delay if self.limited else C_DELAY) - 1.0 / C_FLOOR_MEASURE
        delay = self.lag + self.sample_time + self.s_lag + self.decimation_delay
        if self.sample_time > 0:
            delay += self.sample_time / C_EULER
            w = min(w, C_FLOOR_SAMPLE / self.sample_time)
        if delay > 0:
            w = min(w, max(budget, 0.0) / delay)
        return float(w)

    @property
    def floor_noise_rate(self) -> float:
        """The loop rate (1/s) a loop with a floor admits where it sees its measurements
        through a first-order prefilter at ``C_FLOOR_MEASURE w`` (``floor_delay`` set, the
        noise's std bound binding): the prefiltered noise of ``s`` has the std ``n_d
        sqrt(C_FLOOR_MEASURE w / 4)`` (``n_d``: :attr:`noise_density`; a first-order filter
        at ``a`` rad/s passes ``a/4`` Hz of white noise), and its proportional path ``w``
        times it is held to ``C_NOISE_FLOOR``: ``w = (C_NOISE_FLOOR / (n_d
        sqrt(C_FLOOR_MEASURE / 4)))^(2/3)``; ``inf`` without noise."""
        if not self.noise > 0:
            return math.inf
        n = self.noise_density * math.sqrt(C_FLOOR_MEASURE / 4.0)
        return (C_NOISE_FLOOR / n) ** (2.0 / 3.0)

    @property
    def noise_density(self) -> float:
        """The density (per root hertz) of the noise of ``s`` the law sees: ``noise sqrt(2 /
        f)``, held at ``f = min(noise_rate, 1/sample_time)``; through the decimation filter
        the mean of ``N`` readings, ``noise / sqrt(N)`` held at ``1/sample_time``: the
        sensor's own density ``noise sqrt(2 / noise_rate)`` (:attr:`seen_noise`)."""
        f = self.noise_rate
        if self.sample_time > 0:
            f = min(f, 1.0 / self.sample_time)
        return self.seen_noise * math.sqrt(2.0 / f)

    @property
    def limited(self) -> bool:
        """A rate or travel limit is declared (the law's command is filtered)."""
        return math.isfinite(self.rate) or math.isfinite(self.travel)

    @property
    def discrete_limiter(self) -> bool:
        """The law's command filter is a discrete limiter (session 13): a digital law with
        rate or travel limits whose model says so (:attr:`per_actuator`) runs its command
        filter at ``C_EULER / T`` and hands on its value after the sample's step (``u0 = uf
        + T uf'``, ``Configuration.step``): each sample's command is the law's, clipped to
        the travel and moved by at most ``T`` times the rate. Its forward-Euler pole is 0,
        so it adds no lag to the loop, and the delay budget counts none: ``w (lag + T/2 +
        tau_d) <= C_DELAY_LIMITED``. The filter at ``min(C_FILTER w, 1/lag, C_EULER / T)``
        added the actuator's lag once more (issue 25's second combination: ``w`` = 5.4
        against 8.75 1/s; forced to 7-8 1/s with that filter, the loop limit-cycled at the
        rate limit before any failure, 6.5-8e-3 rad over 30-40 s, against 1.6-2.1e-4 with
        the discrete limiter; at 12.5 1/s, a budget of 1.0, it limit-cycles too: 4.8e-3).
        """
        return bool(self.per_actuator) and self.sample_time > 0 and self.limited

    def configure(
        self,
        *,
        w0: float,
        b_max: float,
        lam: float = 1.0,
        input_gain: float = 0.0,
        slope: float | None = None,
        adaptive: bool = True,
    ) -> Configuration:
        """The configuration of a law whose linear-band loop rate is ``w0`` (``k + k0/eps0``)
        under this model, for an allocation whose largest gain is ``b_max`` and a filtered
        error ``s = e' + lam e``; ``input_gain`` is the loop's nominal ``|d s'/d u0|``, used
        when the model's own ``input_gain`` is ``None``; ``slope`` the law's ``K = k +
        k0/eps0`` where the design gives it (used where ``w0`` is the loop gain itself);
        ``adaptive``: the law has adaptive estimates (a baseline's own law, the oracle's, is
        not slowed below a placed feedback it does not have)."""
        if self.is_ideal:
            return IDENTITY
        w, noisy = self.omega_max(w0, b_max)
        scale = slope_scale = w / w0
        g = self.loop_gain
        if g is not None and g > 0 and scale < 1.0:
            # the law's linear band has the poles of l^2 + g l + g K = 0 (g: proportional
            # loop gain, K = k + k0/eps0, w0 = max(g, sqrt(g K))): the proportional gain is
            # scaled only where it is itself above w, the integral path so that
            # sqrt(g' K') <= w (a loop whose adaptation is slow already keeps it: the
            # manipulator loses the arm with eta scaled below 0.3)
            # (where g >= K, w0 = g says nothing of K: the design's own slope, ``slope``,
            # where it gives it; the wing rock's g = 88760 1/s against K = 2020 1/s: with
            # K taken as g, the integral path fell to 0.8 1/s and a stuck aileron's torque
            # was still not learnt 5 s later)
            big_k = w0 * w0 / g if w0 > g else (slope if slope is not None else g)
            growth = self.gain_growth or 1.0
            g = g * growth  # the largest loop gain along the run (§4.4)
            scale = min(1.0, w / g)
            # K' = w / growth^2: the linear band keeps its damping (g' >= K') down to the
            # smallest loop gain along the run, 1/growth of the one at t0 (§4.4: |rho| down
            # to |rho0| / RHO_FACTOR); growth = 1: K' = w, round 3's rule
            slope_scale = min(1.0, w * w / (scale * g) / big_k / (growth * growth))
        placed = self.placement(b_max, self._omega_m(w) if noisy else math.inf)
        if placed is not None and self.feedback is None and adaptive:
            # the adaptive law augments the placed loop below its slowest mode
            aug = min(1.0, C_AUGMENT * max(-placed[3], AUGMENT_FLOOR) / w)
            scale, slope_scale = scale * aug, slope_scale * aug
        lam_factor = 1.0
        limited = math.isfinite(self.rate) or math.isfinite(self.travel)
        rmin = min(scale, slope_scale)
        # a rate limit close to binding at the loop rate (a failure transient of A_RATE at
        # the loop rate runs into it)
        rate_bound = C_MARGIN * self.rate / max(abs(b_max), 1e-300) / A_RATE
        rate_tight = rate_bound < C_TIGHT * w
        # a travel limit on the common filter of a per-actuator model: each actuator clipped
        # to its own travel after the allocation, u0 bounded by the least-allocated one's
        # (constraints.emit): the hedge then sees only what no actuator can deliver (lam
        # stays the limited loop's: raised as for a loop without limits, C_LAM, the
        # hypersonic-hardware campaign's first 100 members lost 45, their commands carrying
        # the noise of s that lam multiplies)
        own_travel = bool(self.per_actuator) and math.isfinite(self.travel) and not rate_tight
        if rmin < 1.0:
            top = LAM_FACTOR_NOISE if noisy else LAM_FACTOR_MAX
            # a tight rate limit, or a travel limit
            tight = math.isfinite(self.travel) or rate_tight
            c_lam = C_LAM_LIMITED if tight else C_LAM
            lam_factor = min(max(1.0, c_lam * w / lam), 1.0 / rmin, top)
            if self.min_loop_gain is not None and self.min_loop_gain > 0:
                cap = C_LAM_GAIN * scale * self.min_loop_gain / lam
                lam_factor = max(1.0, min(lam_factor, cap))
        omega_f = math.inf
        if limited:
            omega_f = C_FILTER * w
            if self.lag > 0:
                omega_f = min(omega_f, 1.0 / self.lag)
            if self.sample_time > 0:
                omega_f = min(omega_f, C_EULER / self.sample_time)
            if self.discrete_limiter:
                omega_f = C_EULER / self.sample_time
        omega_q = omega_m = math.inf
        if noisy:
            omega_q = C_PREFILTER_NOISE * w
            omega_m = self._omega_m(w)
            if self.sample_time > 0:
                omega_q = min(omega_q, C_EULER / self.sample_time)
        feedback, feedback_e, feedback_i = self.feedback_gains(
            float(input_gain), b_max, lam * lam_factor, omega_m
        )
        b = max(abs(b_max), 1e-300)
        u_max = C_MARGIN * self.travel / b
        u_rate = C_MARGIN * self.rate / b
        # a tight rate limit: each actuator's command through its own filter at its own rate
        # (single-output designs without an allocator; constraints.emit), hedged by what they
        # deliver
        actuator_rate = C_MARGIN * self.rate if limited and rate_tight else math.inf
        actuator_travel = C_MARGIN * self.travel if own_travel else math.inf
        hedge = self.input_gain if self.input_gain is not None else float(input_gain)
        hedge = hedge if limited else 0.0
        # anti-windup: the compensated error where the loop's input gain is known (it keeps
        # the undelivered command out of the adaptation); back-calculation otherwise
        k_aw = C_AW * omega_f if limited and math.isfinite(omega_f) and hedge == 0 else 0.0
        # the integral sliding surface where each actuator is clipped to its own travel behind
        # a discrete limiter whose delay budget sets the loop rate, the noise well below its
        # density bound (C_INTEGRAL, C_INTEGRAL_NOISE; an adaptive law's, not a baseline's)
        error_integral = 0.0
        quiet = w * w * self.noise_density <= C_INTEGRAL_NOISE * C_NOISE_DENSITY
        if own_travel and self.discrete_limiter and adaptive and self.delay_bound(w) and quiet:
            error_integral = (C_INTEGRAL * w) ** 2
        omega_b = math.inf
        if self.regressor_prefilter and adaptive and not math.isfinite(omega_m):
            # the regressor's inputs low-passed, in the command and the adaptation (session 15)
            omega_b = C_REGRESSOR_NOISE * w
            if self.sample_time > 0:
                omega_b = min(omega_b, C_EULER / self.sample_time)
        lead: tuple[float, ...] = ()
        if placed is not None and self.feedback is None and self.lead_lag < self.lag:
            lead = (float(self.lag), self.lead_lag)
        return Configuration(
            scale,
            lam_factor,
            WIDEN if slope_scale < 1.0 else 1.0,
            omega_f,
            u_max,
            u_rate,
            omega_q,
            omega_m,
            k_aw,
            hedge,
            C_HEDGE * w,
            self.theta_max,
            slope_scale,
            feedback,
            feedback_e=feedback_e,
            feedback_i=feedback_i,
            feedback_lead=lead if feedback or feedback_e else (),
            actuator_rate=actuator_rate,
            step=float(self.sample_time) if self.discrete_limiter else 0.0,
            actuator_travel=actuator_travel,
            error_integral=error_integral,
            omega_b=omega_b,
        )

    def fast_unstable(self, b_max: float = 1.0) -> bool:
        """The plant's fastest unstable open-loop mode (``unstable_rate``, ``p_u``) is not far
        below the loop rate the hardware admits: ``C_FEEDBACK p_u > C_FEEDBACK_GATE w_hw``,
        ``w_hw`` the rule's ``w_max`` without its ``C_CAP w0`` term (the hardware's bounds
        alone; a designer's ``bandwidth`` counts). The wing rock (``p_u`` = 30.4 1/s) under
        any lag of 1 ms or more; not the hypersonic loops (0.75 1/s) nor the MIMO plants."""
        p_u = self.unstable_rate or 0.0
        if not p_u > 0 or self.is_ideal:
            return False
        w_hw, _ = self.omega_max(math.inf, b_max)
        return C_FEEDBACK * p_u > C_FEEDBACK_GATE * w_hw

    def _omega_m(self, w: float) -> float:
        """The measurement prefilter's bandwidth where the noise's std bound binds."""
        omega_m = C_MEASURE_NOISE * w
        if self.sample_time > 0:
            omega_m = min(omega_m, C_EULER / self.sample_time)
        return omega_m

    def placement(
        self, b_max: float = 1.0, omega_m: float = math.inf
    ) -> tuple[float, float, float, float] | None:
        """The placed fixed feedback ``(kp, kd, ki, decay)`` (:func:`placed_feedback` on the
        declared lag behind the feedback's lead, :attr:`lead_lag`, half a sample of hold and
        the measurement prefilter ``1/omega_m`` as delay; its integral grid extended,
        ``FEEDBACK_KI_EXTEND``, where ``C_MARGIN rate >= FEEDBACK_KI_SWING |decay|``) where
        :meth:`fast_unstable` and the plant's linearisation (:attr:`open_loop`) is known
        (and, with ``PLACE_UNDELAYED`` off, the model declares a lag or a sample time); else
        ``None``."""
        if self.open_loop is None or not self.fast_unstable(b_max):
            return None
        if not (PLACE_UNDELAYED or self.lag > 0 or self.sample_time > 0):
            return None
        delay = 0.5 * self.sample_time
        if math.isfinite(omega_m):
            delay += 1.0 / omega_m
        args = (
            float(self.open_loop[0]),
            float(self.open_loop[1]),
            self.lead_lag,
            delay,
            tuple(FEEDBACK_GAIN_SCALES),
        )
        placed = placed_feedback(*args, ki_extend=int(FEEDBACK_KI_EXTEND))
        # the faster integral only where the rate limit lets it swing an actuator
        if C_MARGIN * self.rate < FEEDBACK_KI_SWING * abs(placed[3]):
            placed = placed_feedback(*args)
        return placed

    @property
    def lead_lag(self) -> float:
        """The lag the placed feedback sees behind its lead: ``max(lag / LEAD_MAX,
        LEAD_SAMPLE T)``, at most the declared ``lag``."""
        return float(min(self.lag, max(self.lag / LEAD_MAX, LEAD_SAMPLE * self.sample_time)))

    def feedback_gains(
        self, input_gain: float, b_max: float = 1.0, lam: float = 1.0, omega_m: float = math.inf
    ) -> tuple[float, float, float]:
        """The gains ``(on e', on e, on int e)`` of the fixed feedback ``u0 += kd e' + kp e +
        ki int e``, over the nominal input gain ``b = |d s'/d u0|``; zeros = none.

        Where :meth:`fast_unstable` and the plant's linearisation is known
        (:attr:`open_loop`), placed on the designer's linear model (:func:`placed_feedback`:
        the declared lag behind the lead, :attr:`lead_lag`, half a sample of hold and the
        measurement prefilter ``1/omega_m`` as delay). A designer's ``feedback`` (1/s) is a
        proportional path on ``s = e' + lam e`` at that loop gain instead (``lam`` as the
        law runs it); without the linearisation (or, with ``PLACE_UNDELAYED`` off, without a
        declared lag or sample time), the rule's ``C_FEEDBACK p_u`` on ``s``."""
        b = self.input_gain if self.input_gain is not None else input_gain
        if not b > 0:
            return 0.0, 0.0, 0.0
        placed = self.placement(b_max, omega_m)
        if self.feedback is not None:
            rate = self.feedback
        elif not self.fast_unstable(b_max):
            rate = 0.0
        elif placed is not None:
            kp, kd, ki, _ = placed
            return kd / b, kp / b, ki / b
        else:
            rate = C_FEEDBACK * (self.unstable_rate or 0.0)
        if not rate > 0:
            return 0.0, 0.0, 0.0
        return rate / b, rate * lam / b, 0.0


def adaptation_regressor_rule(cfg: Configuration, ca: ConstraintAware, w: float) -> Configuration:
    """§4.3 (Nussbaum) under noise: the law of ``theta`` sees the regressor of prefiltered
    measurements (``omega_r = C_MEASURE w``, at most ``C_EULER / T``), the command ``u0 =
    Pi(x)^T theta`` still the measured one, where the noise of ``s`` the law runs with (at
    most ``lam_factor`` times the model's: ``lam`` multiplies the position noise) is above
    the density bound at the loop rate, ``w^2 lam_factor n_d > C_NOISE_DENSITY``. Not where
    the std bound binds (every measurement is prefiltered there already).

    Why: ``theta' = alpha0 N(tau) Pi(x_m) q`` multiplies two noisy signals whose noise is
    correlated (the measured pitch rate enters ``Pi`` and, through ``e' = y_d' - q_m``, ``s``
    and the dirty derivative ``s'`` in ``q``), so the gradient has a bias of the order of
    ``|dPi/dx| noise^2 / tau_d`` that no error balances: the classic noise-driven parameter
    drift (Ioannou & Sun 1996, §8.3). Measured on hypersonic-nussbaum-s1-pos with 1 % noise:
    ``|theta|`` drifts to 0.5 over the run (0.07 with the prefiltered regressor) and the
    drifted ``theta`` carries the measurement noise into the command through ``Pi(x_m)``
    (fast content 2.06e-2 rad, 100-500 Hz half of it; 1.74e-2 with the prefiltered
    regressor). Prefiltering what ``u0`` sees as well lags the loop (measured: worse).

    With it, ``lam`` is raised at most ``LAM_FACTOR_NOISE`` times, as where the std bound
    binds: ``lam`` multiplies the position noise in ``s``, which the loop tracks up to its
    rate (the rest of the fast content, 1-3 Hz about ``w``): measured, the noise case at
    ``lam`` x4 (the shared rule's 8) has 1.74e-2 rad, x2 1.10e-2 (error 4.9e-4 -> 7.3e-4).
    The cost: the wrong-signed runs (hypersonic-nussbaum-s1-neg, -s2-neg) need the larger
    ``lam`` to find the direction (``tau' = alpha1 q^2`` against the wrong-signed loop's
    growth); with noise they track (error 1.6e-4 to 7.2e-4) but keep 1.2x (s1-neg) and 8.7x
    (s2-neg) the fast-content target, after the Nussbaum gain cap of session 11
    (``NussbaumAdaptive.gain_cap``; docs/hardware.md)."""
    if cfg == IDENTITY or ca.noise <= 0 or cfg.measured_through_filter or cfg.regressor_filtered:
        return cfg
    if w * w * max(1.0, cfg.lam_factor) * ca.noise_density <= C_NOISE_DENSITY:
        return cfg
    omega_r = C_MEASURE * w
    if ca.sample_time > 0:
        omega_r = min(omega_r, C_EULER / ca.sample_time)
    return cfg._replace(omega_r=omega_r, lam_factor=min(cfg.lam_factor, LAM_FACTOR_NOISE))


# ---------------------------------------------------------------- compiled pieces of the law
def command_filter(uc, uf, omega_f, u_max, u_rate):
    """Derivative of the command filter: ``clip(w_f (clip(uc, -U, U) - uf), -R, R)``
    (Farrell et al. 2009, first order)."""
    target = min(max(uc, -u_max), u_max)
    return min(max(omega_f * (target - uf), -u_rate), u_rate)


def back_calculation(dY, phi, excess, k_aw, off, at, size):
    """Anti-windup: ``theta' -= k_aw Pi excess / |Pi|^2``, so ``Pi^T theta`` moves back
    towards the command the filter can deliver at ``k_aw`` (Åström & Rundqwist 1989)."""
    nrm = 1e-12
    for l in range(size):
        nrm += phi[off + l] * phi[off + l]
    d = k_aw * excess / nrm
    for l in range(size):
        dY[at + l] -= d * phi[off + l]


def hedged_q(q, s, xi, dxi, k, k0, eps0):
    """``q`` of the compensated error ``s - xi``: ``q - xi' - k xi + k0 (tanh((s - xi)/eps0)
    - tanh(s/eps0))``, where ``xi' = -w xi + b (u0c - u0)`` is the part of ``s`` that the
    limited command caused (Farrell et al. 2009; pseudo-control hedging, Johnson & Calise
    2003)."""
    return q - dxi - k * xi + k0 * (math.tanh((s - xi) / eps0) - math.tanh(s / eps0))


def capped_gain(phi, p2max, off, size):
    """``1 / max(1, |Pi|^2 / p2max)``: the factor that keeps an adaptive law's proportional
    path ``x |Pi|^2`` at most its value at ``|Pi|^2 = p2max`` (normalised gradient, Ioannou &
    Sun 1996, §4.3.4, applied only above the bound)."""
    p2 = 0.0
    for l in range(size):
        p2 += phi[off + l] * phi[off + l]
    return 1.0 / max(1.0, p2 / p2max)


def project_interval(d, v, v_max):
    """Projection of a scalar estimate on ``|v| <= v_max``: on or outside the boundary, an
    outward ``v'`` is set to 0 (Lavretsky & Wise 2013, §11.4, in one dimension)."""
    if abs(v) >= v_max and v * d > 0.0:
        return 0.0
    return d


def project_ball(dY, Y, theta_max, at, size):
    """Projection on ``|theta| <= theta_max`` (Lavretsky & Wise 2013, §11.4): on or outside
    the boundary, the outward component of ``theta'`` is removed."""
    th2 = 0.0
    dot = 0.0
    for l in range(size):
        th2 += Y[at + l] * Y[at + l]
        dot += Y[at + l] * dY[at + l]
    if th2 >= theta_max * theta_max and dot > 0.0:
        f = dot / th2
        for l in range(size):
            dY[at + l] -= f * Y[at + l]


def _filtered_regressors(
    g, at_m: int, what: str = "the adaptation's regressor of the prefiltered measurements"
) -> list[str]:
    """Generated lines writing ``phi`` again, from the prefiltered plant states ``Y[at_m:]``
    (inputs that are not plant states, errors and ``s``, stay as measured): ``u0 = Pi^T
    theta`` is computed before, so only the adaptive laws after these lines see them
    (``what``: the comment line that opens them)."""
    nx = g.nx
    lines = [f"    # constraint-aware: {what}"]
    off = 0
    for r, reg in enumerate(g.loop.controller.regressors_for(g.p)):
        idx = [g.signal(name, "the adaptation's regressor") for name in reg.inputs]
        for ln in reg.emit(g, idx, off, r):
            for i in sorted(set(idx)):
                if i < nx:
                    ln = ln.replace(f"sig[{i}]", f"Y[{at_m + i}]")
            lines.append(ln)
        off += reg.size
    return lines


def _regressor_command_lines(g, blocks, at_m: int) -> list[str]:
    """Generated lines that move each ``u0_r`` from ``Pi(x_m)^T theta`` (the approximator's)
    to ``Pi(x_f)^T theta``, ``x_f`` the prefiltered plant states ``Y[at_m:]``, and leave
    ``phi`` the filtered basis, which the adaptive laws after them use (session 15,
    ``Configuration.omega_b``); what else the design added to ``u0`` is kept."""
    lines = [
        f"    du{r} = -weighted_sum(phi, Y, {o}, {a}, {n})" for r, (o, a, n) in enumerate(blocks)
    ]
    lines += _filtered_regressors(g, at_m, "u0 and the adaptation from the filtered regressor")
    lines += [
        f"    u0[{r}] += du{r} + weighted_sum(phi, Y, {o}, {a}, {n})"
        for r, (o, a, n) in enumerate(blocks)
    ]
    return lines


def _floor_lines(cfg: Configuration, g, nx: int, p: int) -> list[str]:
    """The MIMO floor's lines, ``u0_i += f_i s_i`` per output with ``f_i > 0`` (its gains
    appended to the module's constants); none without a floor."""
    if not any(f > 0 for f in cfg.output_feedback):
        return []
    f0 = len(g.consts)
    g.consts.extend(float(f) for f in cfg.output_feedback)
    return ["    # constraint-aware: fixed proportional feedback on each s_i (floor)"] + [
        f"    u0[{i}] += c[{f0 + i}] * sig[{nx + 2 * p + i}]"
        for i, f in enumerate(cfg.output_feedback)
        if f > 0
    ]


def _delivery_weights(g) -> list[float] | None:
    """``G_j / sum_k G_k R_k`` over the actuators, ``G`` the plant's input gains of the first
    output at ``t0`` (the designer's nominal model): the weights with which each actuator's
    command counts in the delivered ``u0``; ``None`` where they cannot be formed."""
    loop = g.loop
    G = np.asarray(loop.plant.input_gains(loop.t0, np.asarray(loop.initial_state, float)))
    R = np.atleast_2d(np.asarray(loop.R, dtype=float))
    if G.shape != R.shape or G.shape[0] != 1 or not np.all(np.isfinite(G)):
        return None
    total = float(np.sum(G[0] * R[0]))
    if not abs(total) > 0:
        return None
    return [float(v) / total for v in G[0]]


#: the designer's model of the plant in a generated loop module (the model feedforward's):
#: the healthy plant's equations with its nominal parameters, named apart from the plant
#: side's ``plant_dynamics`` (which the failures feed) so that a controller that uses it is
#: told apart from one that needs the true plant (the oracle, the nominal inverse)
NOMINAL_MODEL_SRC = """@inl
def nominal_dynamics(t, x, u, p, xdot):
    \"\"\"The designer's model: the healthy plant's equations (no failures, no actuators).\"\"\"
    plant_dynamics(t, x, u, p, xdot)


@inl
def nominal_params(D):
    \"\"\"The designer's model's parameters: the plant's nominal ones.\"\"\"
    return plant_params(D)"""


def _feedforward_lines(cfg: Configuration, g, sign: float = 1.0) -> list[str]:
    """The nominal feedforward's lines (``Configuration.feedforward``): the healthy plant's
    model at the state on the reference read ``lead`` ahead, ``x_r`` (outputs and rates from
    the reference), solved for ``G(x_r) u_ff = y_r'' - f(x_r)`` along the allocation and added
    to ``u0`` of the outputs with a floor (``output_feedback`` > 0; every output without
    one); none without one. The model is ``nominal_dynamics`` with ``nominal_params(D)``
    (:data:`NOMINAL_MODEL_SRC`: the plant's equations and parameters, never its failures),
    and its scratch is the controller's own work buffer ``wb``, which holds ``[G | v | f |
    reference | x_r | u | x_r']``: the controller side of the loop carries it whole (the C
    export, :mod:`adaptive_ftc.export.controller_side`). ``sign`` -1: subtracted from ``u0``
    instead (the oracle's lead correction, :class:`~adaptive_ftc.controllers.OracleInverse`)."""
    floored = [f > 0 for f in cfg.output_feedback] or [True] * g.p
    if cfg.feedforward < 0 or not any(floored):
        return []
    from adaptive_ftc.controllers._solve import solve_guarded

    plant = g.loop.plant
    nx, p, m = g.nx, g.p, g.m
    pos, vel = tuple(plant.position_index), tuple(plant.velocity_index)
    if nx != 2 * p or sorted(pos + vel) != list(range(nx)):
        raise ConfigurationError(
            "The nominal feedforward needs a plant whose state is its outputs and their rates "
            f"(position_index and velocity_index covering all {nx} states); "
            f"{type(plant).__name__} has {pos} and {vel}. Leave `feedforward` at -1 for it."
        )
    g.use("nominal_solve", solve_guarded)
    f_at, r_at = p * p + p, p * p + 2 * p
    x_at = r_at + 3 * p
    u_at = x_at + nx
    d_at = u_at + max(m, p)
    g.n_w = max(g.n_w, d_at + nx)
    if NOMINAL_MODEL_SRC not in g.defs:
        g.defs.append(NOMINAL_MODEL_SRC)
    g.consts.append(float(cfg.feedforward))
    lead = f"c[{len(g.consts) - 1}]"
    lines = [
        "    # constraint-aware: the nominal model's feedforward along the reference read ahead",
        f"    reference(t + {lead}, c, wb[{r_at}:{x_at}])",
    ]
    for i in range(p):
        lines += [
            f"    wb[{x_at + pos[i]}] = wb[{r_at + 3 * i}]",
            f"    wb[{x_at + vel[i]}] = wb[{r_at + 3 * i + 1}]",
        ]
    lines += [
        f"    for kk in range(-1, {p}):",
        f"        for j in range({m}):",
        f"            wb[{u_at} + j] = 0.0 if kk < 0 else c[RMAT + kk * {m} + j]",
        f"        nominal_dynamics(t, wb[{x_at}:{u_at}], wb[{u_at}:{u_at + m}], "
        f"nominal_params(D), wb[{d_at}:{d_at + nx}])",
        "        if kk < 0:",
        *[f"            wb[{f_at + i}] = wb[{d_at + vel[i]}]" for i in range(p)],
        "        else:",
        *[f"            wb[{i * p} + kk] = wb[{d_at + vel[i]}] - wb[{f_at + i}]" for i in range(p)],
        *[f"    wb[{p * p + i}] = wb[{r_at + 3 * i + 2}] - wb[{f_at + i}]" for i in range(p)],
        f"    nominal_solve(wb, 0, {p}, 1e-9, wb[{u_at}:{u_at + p}])",
        *[
            f"    u0[{i}] {'+=' if sign > 0 else '-='} wb[{u_at + i}]"
            for i in range(p)
            if floored[i]
        ],
    ]
    return lines


def _travel_bound(cfg: Configuration, g) -> float | None:
    """The common command's travel bound where each actuator is clipped to its own travel
    after the allocation (``Configuration.actuator_travel``): ``actuator_travel / min |R_j|``
    over the allocated actuators, the command at which the last of them reaches its travel;
    ``None`` where the rule does not apply (several outputs, an allocator, a fixed feedback
    after the filter, the per-actuator filters of a tight rate limit, no travel).

    Why (session 13, issue 25's combination 2 on hypersonic-direct-s1: travel +-0.5 rad,
    allocation (1, 2)): the common filter bounded ``u0`` by the *most*-allocated actuator's
    travel, ``0.9 x 0.5 / 2`` = 0.225 rad, so that no actuator is ever commanded past its
    travel; after elevator 2 stuck at 40 s and elevator 1's 80 s bias (-0.2 rad at 75 %)
    elevator 1, alone, needed 0.27 rad and was held at 0.225 (half its travel): the loop
    diverged at 82.4 s. With the bound at the least-allocated actuator's travel (0.45 rad)
    and every actuator clipped to its own, the hedge sees only what no actuator can deliver
    (hedging each actuator's clipping, the stuck elevator's included, diverged at 83.4 s:
    the law cannot know that elevator 2's command drives nothing)."""
    if not (math.isfinite(cfg.actuator_travel) and cfg.filtered and g.p == 1):
        return None
    if g.loop.allocator is not None or cfg.feedback != 0 or cfg.feedback_e != 0:
        return None
    if math.isfinite(cfg.actuator_rate):
        return None
    R = np.abs(np.ravel(np.asarray(g.loop.R, dtype=float)))
    R = R[R > 0]
    if R.size == 0:
        return None
    return float(cfg.actuator_travel / R.min())


def emit(cfg: Configuration, g, blocks, at: int, single_output: bool, direction: str = ""):
    """Generated lines of the constraint-aware parts: ``(after u0, before the adaptive laws,
    after the adaptive laws, the measurements the law sees)``. The numbers go to ``D.c``
    (``g.consts``): configurations of the same shape share one compiled loop.

    States from ``at`` on: the compensated errors (one per output, with limits and an
    ``input_gain``) and the prefilters of ``q`` (one per output, with noise), which stop with
    the adaptation; then the measurement filters (one per plant state, with noise) and the
    command filters (one per output, with limits), which run even while adaptation is frozen
    (``g.free_running`` counts them). ``direction``: an expression of the sign of the input
    gain the hedging filter assumes (``""``: positive, the loop's nominal ``|d s'/d u0|``;
    §4.4, whose direction is unknown: the sign of its estimate ``rho``)."""
    p, nx = g.p, g.nx
    travel_u0 = _travel_bound(cfg, g)
    if travel_u0 is not None:  # each actuator clipped to its own travel after the allocation
        cfg = cfg._replace(u_max=travel_u0)
    c0 = len(g.consts)
    g.consts.extend([cfg.omega_f, cfg.u_max, cfg.u_rate, cfg.omega_q, cfg.k_aw, cfg.theta_max])
    g.consts.extend([cfg.omega_m, cfg.hedge, cfg.omega_h])
    wf, umax, urate, wq, kaw, tmax, wm, hg, wh = (f"c[{c0 + k}]" for k in range(9))
    beside = cfg.adaptation_regressor_filtered or cfg.regressor_filtered
    if beside:  # appended only here: other loops keep their c
        wm = f"c[{len(g.consts)}]"
        g.consts.append(cfg.omega_r if cfg.adaptation_regressor_filtered else cfg.omega_b)
    hedged = cfg.filtered and cfg.hedge > 0
    sign = f" * {direction}" if direction else ""
    # places of the states
    at_h = at
    at_q = at_h + (p if hedged else 0)
    at_m = at_q + (p if cfg.prefiltered else 0)
    at_f = at_m + (nx if cfg.has_measurement_filters else 0)
    at_i = at_f + (p if cfg.filtered else 0)
    at_l = at_i + (p if cfg.feedback_i != 0 else 0)
    lead = bool(cfg.feedback_lead) and (cfg.feedback != 0 or cfg.feedback_e != 0)
    end = at_l + (p if lead else 0)
    weights = None
    if hedged and math.isfinite(cfg.actuator_rate) and p == 1 and g.loop.allocator is None:
        weights = _delivery_weights(g)
    at_a = end
    if weights is not None:
        end += g.m
    at_z = end
    if cfg.error_integral != 0 and single_output:
        end += p
    if hedged:
        g.adaptive_names += [f"hedge{i + 1}" for i in range(p)]
    if cfg.prefiltered:
        g.adaptive_names += [f"q_prefilter{i + 1}" for i in range(p)]
    if cfg.has_measurement_filters:
        g.adaptive_names += [f"measurement_filter{i + 1}" for i in range(nx)]
    if cfg.filtered:
        g.adaptive_names += [f"command_filter{i + 1}" for i in range(p)]
    if cfg.feedback_i != 0:
        g.adaptive_names += [f"feedback_integral{i + 1}" for i in range(p)]
    if lead:
        g.adaptive_names += [f"feedback_lead{i + 1}" for i in range(p)]
    if weights is not None:
        g.adaptive_names += [f"actuator_filter{j + 1}" for j in range(g.m)]
    if end > at_z:
        g.adaptive_names += [f"error_integral{i + 1}" for i in range(p)]
    g.y0_extra.extend([0.0] * (end - at))  # assemble starts the measurement filters at x(0)
    g.free_running = end - at_m
    control, pre, post, measure = [], [], [], []
    if cfg.measured_through_filter:  # the law sees x + noise through a first-order filter
        seen = g.measured if g.loop.sensors is not None else "x[i]"
        measure = [
            f"    for i in range({nx}):  # constraint-aware: the law sees filtered measurements",
            f"        dY[{at_m} + i] = {wm} * ({seen} - Y[{at_m} + i])",
            f"        sig[i] = Y[{at_m} + i]",
        ]
    elif beside:  # the law sees x + noise; the filter runs beside for its regressor: the
        # adaptation's, or (session 15) the command's and the adaptation's
        seen = g.measured if g.loop.sensors is not None else "x[i]"
        who = "the adaptation's regressor" if cfg.adaptation_regressor_filtered else "the regressor"
        measure = [
            f"    for i in range({nx}):  # constraint-aware: {who} sees",
            f"        sig[i] = {seen}",
            f"        dY[{at_m} + i] = {wm} * (sig[i] - Y[{at_m} + i])  # ... these filtered",
        ]
        if cfg.adaptation_regressor_filtered:
            pre += _filtered_regressors(g, at_m)
        else:
            control += _regressor_command_lines(g, blocks, at_m)
    control += _feedforward_lines(cfg, g)
    if cfg.feedback_filtered:  # the MIMO floor before the command filter
        control += _floor_lines(cfg, g, nx, p)
    if cfg.filtered:
        g.use("command_filter", command_filter)
        control.append("    # constraint-aware: the law's command u0c through the command filter")
        if cfg.step > 0:
            g.consts.append(cfg.step)
        for i in range(p):
            f = at_f + i
            if cfg.step > 0:  # the filter's value after the sample's step
                control += [
                    f"    uc{i} = u0[{i}]",
                    f"    dY[{f}] = command_filter(uc{i}, Y[{f}], {wf}, {umax}, {urate})",
                    f"    u0[{i}] = Y[{f}] + c[{len(g.consts) - 1}] * dY[{f}]",
                ]
                continue
            control += [
                f"    uc{i} = u0[{i}]",
                f"    u0[{i}] = Y[{f}]",
                f"    dY[{f}] = command_filter(uc{i}, Y[{f}], {wf}, {umax}, {urate})",
            ]
    if weights is not None:  # each actuator's own command filter (its rate)
        a0 = len(g.consts)
        g.consts.extend(float(v) for v in np.ravel(g.loop.R))
        g.consts.extend(weights)
        g.consts.append(cfg.actuator_rate)
        m = g.m
        ar = f"c[{a0 + 2 * m}]"
        control += [
            "    # constraint-aware: each actuator's command through its own rate-limited filter",
            f"    for jj in range({m}):",
            f"        tj = c[{a0} + jj] * min(max(uc0, -{umax}), {umax})",
            f"        dY[{at_a} + jj] = min(max({wf} * (tj - Y[{at_a} + jj]), -{ar}), {ar})",
        ]
        g.allocate_lines = [f"        acc = Y[{at_a} + j]  # constraint-aware: its own filter"]
    if travel_u0 is not None:
        g.consts.append(cfg.actuator_travel)
        tr = f"c[{len(g.consts) - 1}]"
        g.allocate_lines = [f"        acc = min(max(acc, -{tr}), {tr})  # its own travel"]
    if cfg.feedback != 0 or cfg.feedback_e != 0:  # fixed feedback on the measured errors
        g.consts.extend([cfg.feedback, cfg.feedback_e])
        fd, fe = f"c[{len(g.consts) - 2}]", f"c[{len(g.consts) - 1}]"
        control.append("    # constraint-aware: fixed feedback on e' and e")
        fb = [f"{fd} * sig[{nx + p + i}] + {fe} * sig[{nx + i}]" for i in range(p)]
        if not lead:
            control += [f"    u0[{i}] += {fb[i]}" for i in range(p)]
        if cfg.feedback_i != 0:
            g.consts.append(cfg.feedback_i)
            fi = f"c[{len(g.consts) - 1}]"
            for i in range(p):
                control.append(f"    dY[{at_i + i}] = sig[{nx + i}]")
                if lead:
                    fb[i] += f" + {fi} * Y[{at_i + i}]"
                else:
                    control.append(f"    u0[{i}] += {fi} * Y[{at_i + i}]")
        if lead:  # (lag s + 1) / (tau s + 1): out = r fb - (r - 1) z, z' = (fb - z) / tau
            lag_l, tau_l = cfg.feedback_lead
            g.consts.extend([lag_l / tau_l, tau_l])
            lr, lt = f"c[{len(g.consts) - 2}]", f"c[{len(g.consts) - 1}]"
            for i in range(p):
                control += [
                    f"    fb{i} = {fb[i]}",
                    f"    dY[{at_l + i}] = (fb{i} - Y[{at_l + i}]) / {lt}",
                    f"    u0[{i}] += {lr} * fb{i} - ({lr} - 1.0) * Y[{at_l + i}]",
                ]
    if not cfg.feedback_filtered:  # the MIMO floor after the command filter
        control += _floor_lines(cfg, g, nx, p)
    if end > at_z:  # the integral sliding surface s = e' + lam e + k_I int e_c
        g.consts.append(cfg.error_integral)
        ki = f"c[{len(g.consts) - 1}]"
        control.append("    # constraint-aware: the law's filtered error with the error's integral")
        for i in range(p):
            ec = f"sig[{nx + i}]"
            if hedged:  # the compensated tracking error: no windup on the limits
                ec += f" - Y[{at_h + i}] / c[LAM + {i}]"
            control += [
                f"    dY[{at_z + i}] = {ec}",
                f"    sig[{nx + 2 * p + i}] += {ki} * Y[{at_z + i}]",
            ]
    if hedged:  # compensated error (Farrell et al. 2009)
        g.use("hedged_q", hedged_q)
        pre.append("    # constraint-aware: the laws see the compensated error s - xi")
        for i in range(p):
            h = at_h + i
            reach = f"(Y[{at_f + i}] + dY[{at_f + i}] / {wf})"
            if weights is not None:  # what the actuators' filters deliver, gain-weighted
                pre += [
                    "    ud0 = 0.0",
                    f"    for jj in range({g.m}):",
                    f"        ud0 += c[{a0 + g.m} + jj] * (Y[{at_a} + jj]"
                    f" + dY[{at_a} + jj] / {wf})",
                ]
                reach = "ud0"
            pre += [
                f"    dY[{h}] = -{wh} * Y[{h}] + {hg}{sign} * (uc{i} - {reach})",
                f"    q[{i}] = hedged_q(q[{i}], sig[{nx + 2 * p + i}], Y[{h}], dY[{h}],"
                f" c[K + {i}], c[K0 + {i}], c[EPS0])",
            ]
    if cfg.prefiltered:
        pre.append("    # constraint-aware: the laws see the prefiltered q")
        for i in range(p):
            pre += [
                f"    dY[{at_q + i}] = {wq} * (q[{i}] - Y[{at_q + i}])",
                f"    q[{i}] = Y[{at_q + i}]",
            ]
    if cfg.filtered and cfg.k_aw > 0:
        g.use("back_calculation", back_calculation)
        post.append("    # anti-windup: the estimates do not learn the limits")
        for r, (o, a, size) in enumerate(blocks):
            i = 0 if single_output else r
            excess = f"uc{i} - (Y[{at_f + i}] + dY[{at_f + i}] / {wf})"
            post.append(f"    back_calculation(dY, phi, {excess}, {kaw}, {o}, {a}, {size})")
    if cfg.projected:
        g.use("project_ball", project_ball)
        for _, a, size in blocks:
            post.append(f"    project_ball(dY, Y, {tmax}, {a}, {size})")
    return control, pre, post, measure
