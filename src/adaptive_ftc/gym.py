"""Any scenario as a Gymnasium environment (optional extra: ``pip install adaptive-ftc[gym]``).

``import adaptive_ftc.gym`` registers one id per catalogue design family
(:data:`CATALOGUE_IDS`, e.g. ``adaptive_ftc/HypersonicDirect-v0``); ``import adaptive_ftc``
registers nothing. Any scenario (catalogue name, TOML file or
:class:`~adaptive_ftc.Scenario`) runs as :class:`ScenarioEnv`::

    import gymnasium as gym
    import adaptive_ftc.gym  # registers the ids

    env = gym.make("adaptive_ftc/HypersonicDirect-v0", mode="residual")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample() * 0)

The environment is the simulator's digital-control run (:mod:`adaptive_ftc.hardware`), advanced
one controller sample at a time by :class:`~adaptive_ftc.sim.DigitalStepper`: the same
compiled loop, its plant integrated between samples by the scenario's solver under the
zero-order-held command. One step is one control period (the scenario's ``sample_time``, or
``dt``).

- **Action**: ``mode="direct"``: the actuator commands (one per actuator; a ``Box`` bounded
  by the declared travel ``[lower, upper]`` of the scenario's actuators where declared, else
  unbounded); the design's laws are frozen (it is not in the loop). ``mode="residual"``: a
  correction added to the command of the scenario's design (or the variant ``design``, any
  name of :data:`adaptive_ftc.campaigns.DESIGN_VARIANTS`), whose laws keep adapting; a zero
  correction is the simulator's run of that design.
- **Observation**: the measured plant state (the true state plus the scenario's sensor bias
  and noise, the noise seeded per episode from the environment's seed; for a design with the
  decimation filter, ``ConstraintAware.decimation``, the mean of the sample period's sensor
  readings that the design reads), then per output the
  reference ``y_d`` and ``y_d'`` (and ``y_d''`` where the design uses it: ``sdot="exact"``);
  :attr:`ScenarioEnv.observation_names` names them.
- **Reward** of a step (at its end, time ``t``; ``e = y_d - y`` on the true outputs, ``u``
  the command applied over the step, ``u_prev`` the one before)::

      r = -(tracking_weight * sum(e**2) + effort_weight * sum(u**2)
            + rate_weight * sum((u - u_prev)**2))

  defaults ``tracking_weight = 1``, ``effort_weight = 0``, ``rate_weight = 0`` (no
  ``u_prev`` on the first step: no rate term). A step on which the run stops (a state over
  the divergence bound or outside the plant's envelope, a non-finite signal) is
  ``terminated`` with ``r = -divergence_penalty`` (default 1000) and the
  :class:`~adaptive_ftc.RunStatus` and :class:`~adaptive_ftc.StatusReason` in ``info``.
  Reaching ``t_final`` is ``truncated``.
- **Failures**: the scenario's own, or, with ``campaign=`` (a campaign name, file or
  :class:`~adaptive_ftc.campaigns.CampaignSpec`), a member drawn per episode by
  :func:`~adaptive_ftc.campaigns.draw_member` (its failures, initial state, reference
  amplitude, gains and hardware): the member index comes from the environment's seed, or
  ``reset(options={"member": i})`` replays member ``i`` of the campaign.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from adaptive_ftc.errors import ConfigurationError, did_you_mean
from adaptive_ftc.scenarios.loader import Scenario, load_scenario
from adaptive_ftc.sim.engine import SolverOptions
from adaptive_ftc.sim.status import RunStatus, describe
from adaptive_ftc.sim.stepper import DigitalStepper
from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["CATALOGUE_IDS", "MODES", "ScenarioEnv", "register_catalogue"]

#: What an action is: the actuator commands, or a correction added to the design's.
MODES = ("direct", "residual")

#: Registered ids -> (catalogue scenario, keyword arguments of :class:`ScenarioEnv`): one id
#: per design family of the catalogue (plant and design), on its first scenario. ``dt`` where
#: the scenario's controller is continuous: the longest of 10, 5, 2 ms at which the design, as
#: a digital controller with its own command (``mode="residual"``, zero correction),
#: completes with its final-window tracking error near the continuous run's; where none does
#: (docs/deploying.md lists them), 2 ms.
CATALOGUE_IDS: dict[str, tuple[str, dict[str, Any]]] = {
    "adaptive_ftc/HypersonicDirect-v0": ("hypersonic-direct-s1-digital", {}),
    "adaptive_ftc/HypersonicEstimation-v0": ("hypersonic-estimation-s1", {"dt": 0.005}),
    "adaptive_ftc/HypersonicNussbaum-v0": ("hypersonic-nussbaum-s1-pos", {"dt": 0.002}),
    "adaptive_ftc/HypersonicSign-v0": ("hypersonic-sign-s1-rho0pos", {"dt": 0.002}),
    "adaptive_ftc/WingrockDirect-v0": ("wingrock-direct-s1", {"dt": 0.002}),
    "adaptive_ftc/WingrockEstimation-v0": ("wingrock-estimation-s1", {"dt": 0.002}),
    "adaptive_ftc/ManipulatorMimo-v0": ("manipulator-mimo-s1", {"dt": 0.002}),
    "adaptive_ftc/SpacecraftMimo-v0": ("spacecraft-mimo-s1", {"dt": 0.01}),
    "adaptive_ftc/PendulumDirect-v0": ("pendulum-direct", {"dt": 0.002}),
    "adaptive_ftc/PendulumNussbaum-v0": ("pendulum-nussbaum-reversed", {"dt": 0.002}),
    "adaptive_ftc/PendulumSign-v0": ("pendulum-sign-reversed", {"dt": 0.002}),
    "adaptive_ftc/TwomassMimo-v0": ("twomass-mimo", {"dt": 0.005}),
}


class ScenarioEnv(gymnasium.Env):
    """A scenario's closed loop as a :class:`gymnasium.Env` (see the module docstring).

    Parameters
    ----------
    scenario
        Catalogue name, TOML file or :class:`~adaptive_ftc.Scenario`; may be left out when
        ``campaign`` is given (its base scenario).
    mode
        ``"direct"``: the action is the actuator commands; ``"residual"``: a correction added
        to the design's command.
    design
        ``mode="residual"``: the design whose command is corrected, a name of
        :data:`adaptive_ftc.campaigns.DESIGN_VARIANTS` (``"adaptive"``: the scenario's own).
    dt
        Control period (s); default: the scenario's ``sample_time`` (required when the
        scenario's controller is continuous).
    solver
        Integration between samples; default: the scenario's (compiled methods only).
    campaign
        Draw each episode's failures (and the campaign's other ranges) from this campaign.
    t_final
        End of an episode (s); default: the scenario's (or the campaign's duration).
    tracking_weight, effort_weight, rate_weight
        Weights of the reward's terms (see the module docstring); each >= 0.
    divergence_penalty
        The reward's penalty on the step where the run stops (>= 0).
    action_bounds
        ``(low, high)``, numbers or one per actuator: the action space's bounds instead of
        the declared travel (direct mode) or none (residual mode).

    Examples
    --------
    >>> env = ScenarioEnv("hypersonic-direct-s1-digital", mode="residual", t_final=0.05)
    >>> obs, info = env.reset(seed=1)
    >>> env.observation_names
    ('alpha', 'q', 'y_d[alpha]', "y_d'[alpha]")
    >>> obs, reward, terminated, truncated, info = env.step(np.zeros(2))
    >>> info["time"], terminated, truncated
    (0.005, False, False)
    """

    metadata = {"render_modes": []}

    def __init__(
        self,
        scenario: str | Path | Scenario | None = None,
        *,
        mode: str = "direct",
        design: str = "adaptive",
        dt: float | None = None,
        solver: SolverOptions | None = None,
        campaign=None,
        t_final: float | None = None,
        tracking_weight: float = 1.0,
        effort_weight: float = 0.0,
        rate_weight: float = 0.0,
        divergence_penalty: float = 1000.0,
        action_bounds: tuple | None = None,
    ) -> None:
        super().__init__()
        if mode not in MODES:
            raise ConfigurationError(
                f"`mode` of ScenarioEnv must be one of {', '.join(MODES)}; got {mode!r}."
                f"{did_you_mean(str(mode), MODES)}"
            )
        self.mode = mode
        self.campaign = _campaign(campaign) if campaign is not None else None
        if scenario is None:
            if self.campaign is None:
                raise ConfigurationError(
                    "ScenarioEnv needs a scenario (catalogue name, TOML file or Scenario) or "
                    "a campaign."
                )
            sc = self.campaign.base
        else:
            sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
            if self.campaign is not None and self.campaign.base.name != sc.name:
                raise ConfigurationError(
                    f"Campaign '{self.campaign.name}' draws its members from scenario "
                    f"'{self.campaign.base.name}', not '{sc.name}': give only campaign=."
                )
        self.scenario = sc
        from adaptive_ftc.campaigns.spec import DESIGN_VARIANTS

        if design not in DESIGN_VARIANTS:
            raise ConfigurationError(
                f"Unknown design {design!r} for ScenarioEnv.{did_you_mean(design, DESIGN_VARIANTS)}"
                f" Use one of {', '.join(DESIGN_VARIANTS)}."
            )
        if mode == "direct" and design != "adaptive":
            raise ConfigurationError(
                f"`design` ({design!r}) chooses the design whose command a residual corrects: "
                "it needs mode='residual' (in direct mode the action is the whole command)."
            )
        self.design = design
        base = self.campaign.loop if self.campaign is not None else sc.loop
        if t_final is not None:
            if not (isinstance(t_final, (int, float)) and math.isfinite(t_final)):
                raise ConfigurationError(f"`t_final` must be a time in seconds; got {t_final!r}.")
            base = dataclasses.replace(base, t_final=float(t_final))
        if dt is None:
            dt = base.sample_time
            if not dt > 0:
                raise ConfigurationError(
                    f"Scenario '{sc.name}' has a continuous controller: give the control "
                    "period `dt` (s) of the environment, e.g. dt=0.005."
                )
        if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not dt > 0:
            raise ConfigurationError(f"`dt` must be a positive period in seconds; got {dt!r}.")
        self.dt = float(dt)
        self._base = dataclasses.replace(base, sample_time=self.dt)  # checks dt vs the run
        if self.campaign is not None:
            self.solver = solver or self.campaign.solver
        else:
            self.solver = solver or sc.solver
        if self.solver.compiled_method is None:
            raise ConfigurationError(
                f"ScenarioEnv integrates with the compiled methods; the solver's method "
                f"{self.solver.method!r} is scipy's. Pass solver=SolverOptions(method='rk4') "
                "(or 'dopri5', 'rodasp', 'rodas5p', 'auto')."
            )
        self.weights = {}
        for key, value in (
            ("tracking_weight", tracking_weight),
            ("effort_weight", effort_weight),
            ("rate_weight", rate_weight),
            ("divergence_penalty", divergence_penalty),
        ):
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float))
                or not math.isfinite(value)
                or value < 0
            ):
                raise ConfigurationError(
                    f"`{key}` of ScenarioEnv must be a finite number >= 0; got {value!r}."
                )
            self.weights[key] = float(value)
        plant = self._base.plant
        self.loop: ClosedLoop = self._episode_loop(self._base)
        sdot = self.solver.sdot_for(self.loop)
        n_der = 3 if sdot == "exact" else 2
        self._n_ref = n_der
        names = list(plant.state_names)
        for out in plant.output_names:
            names += ["y_d" + "'" * d + f"[{out}]" for d in range(n_der)]
        self.observation_names: tuple[str, ...] = tuple(names)
        self.observation_space = spaces.Box(-np.inf, np.inf, (len(names),), dtype=np.float64)
        m = plant.n_actuators
        self.action_names: tuple[str, ...] = tuple(plant.actuator_names)
        low, high = self._bounds(action_bounds, m)
        self.action_space = spaces.Box(low, high, (m,), dtype=np.float64)
        self.member: int | None = None
        self._stepper: DigitalStepper | None = None
        self._prev: np.ndarray | None = None

    # ------------------------------------------------------------------ construction helpers
    def _bounds(self, action_bounds, m: int) -> tuple[np.ndarray, np.ndarray]:
        if action_bounds is not None:
            try:
                low, high = action_bounds
                low = np.broadcast_to(np.asarray(low, dtype=float), (m,)).copy()
                high = np.broadcast_to(np.asarray(high, dtype=float), (m,)).copy()
            except (TypeError, ValueError):
                raise ConfigurationError(
                    f"`action_bounds` of ScenarioEnv is (low, high), each a number or one "
                    f"number per actuator ({m}); got {action_bounds!r}."
                ) from None
            if not np.all(low < high):
                raise ConfigurationError(
                    f"`action_bounds` of ScenarioEnv: every low must be below its high; got "
                    f"{action_bounds!r}."
                )
            return low, high
        low, high = np.full(m, -np.inf), np.full(m, np.inf)
        act = self._base.actuators
        if self.mode == "direct" and act is not None:
            table = act.table(m)  # [tau, rate, lower, upper, omega, zeta] per actuator
            low, high = table[:, 2].copy(), table[:, 3].copy()
        return low, high

    def _episode_loop(self, loop: ClosedLoop, noise_seed: int | None = None) -> ClosedLoop:
        """The loop an episode runs: the design variant (residual) or the frozen design
        (direct), the environment's control period, the episode's noise seed."""
        from adaptive_ftc.campaigns.spec import DESIGN_VARIANTS

        loop = dataclasses.replace(loop, sample_time=self.dt)
        if self.mode == "residual":
            loop = DESIGN_VARIANTS[self.design](loop)
        else:
            loop = loop.frozen()
        if noise_seed is not None and loop.sensors is not None and loop.sensors.has_noise:
            loop = dataclasses.replace(
                loop, sensors=dataclasses.replace(loop.sensors, seed=noise_seed)
            )
        return loop

    # ------------------------------------------------------------------ the Gymnasium API
    def reset(
        self, *, seed: int | None = None, options: dict | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode: draw its noise seed (and campaign member) from the seed."""
        super().reset(seed=seed)
        options = dict(options or {})
        unknown = set(options) - {"member"}
        if unknown:
            raise ConfigurationError(
                f"Unknown reset option(s) {sorted(unknown)} of ScenarioEnv; the only one is "
                "'member' (a campaign member's index)."
            )
        rng = self.np_random
        base = self._base
        self.member = None
        if self.campaign is not None:
            base = self._member_loop(options.get("member"), rng)
        elif "member" in options:
            raise ConfigurationError(
                "reset(options={'member': ...}) replays a campaign member: this environment "
                "has no campaign (ScenarioEnv(campaign=...))."
            )
        noise_seed = int(rng.integers(0, 2**31 - 1))
        self.loop = self._episode_loop(base, noise_seed)
        self._stepper = DigitalStepper(self.loop, self.solver)
        self._prev = None
        info = {"time": self._stepper.time, "member": self.member, "noise_seed": noise_seed}
        return self._observe(), info

    def step(self, action) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Hold the action's command for one control period (see the module docstring)."""
        st = self._stepper
        if st is None:
            raise ConfigurationError("Call reset() before step().")
        if st.done:
            raise ConfigurationError(
                f"The episode has ended at t = {st.time:g} s; call reset() to start another."
            )
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        shape = self.action_space.shape
        assert shape is not None  # a Box's shape is always set
        if a.size != shape[0] or not np.all(np.isfinite(a)):
            raise ConfigurationError(
                f"The action must be {shape[0]} finite numbers (one per "
                f"actuator: {', '.join(self.action_names)}); got {action!r}."
            )
        sample = st.sample()
        u = sample.command + a if self.mode == "residual" else a
        status, reason = st.advance(u)
        info: dict[str, Any] = {
            "time": st.time,
            "command": u.copy(),
            "design_command": sample.command,
            "status": status,
            "member": self.member,
        }
        w = self.weights
        if status is not RunStatus.COMPLETED:
            info["reason"] = reason
            info["message"] = describe(status, reason, f"'{self.loop.name}'")
            obs = self._observe()
            if not np.all(np.isfinite(obs)):
                obs = np.nan_to_num(obs, nan=0.0, posinf=1e300, neginf=-1e300)
            return obs, -w["divergence_penalty"], True, False, info
        e = self._tracking_error()
        cost = w["tracking_weight"] * float(e @ e) + w["effort_weight"] * float(u @ u)
        if self._prev is not None:
            du = u - self._prev
            cost += w["rate_weight"] * float(du @ du)
        self._prev = u
        info["tracking_error"] = e
        return self._observe(), -cost, False, st.done, info

    # ------------------------------------------------------------------ observation
    @property
    def state(self) -> np.ndarray:
        """The whole state vector of the loop now (plant, controller, held values; names in
        :attr:`state_names`), a copy."""
        return self._running().state

    @property
    def state_names(self) -> tuple[str, ...]:
        """Names of the entries of :attr:`state`."""
        asm = self._running().asm
        return (*self.loop.plant.state_names, *asm.adaptive_names, *asm.extra_names)

    def _running(self) -> DigitalStepper:
        if self._stepper is None:
            raise ConfigurationError("Call reset() first.")
        return self._stepper

    def _observe(self) -> np.ndarray:
        st = self._running()
        ref = st.reference()
        parts = [st.measured()]
        for i in range(self.loop.plant.n_outputs):
            parts.append(ref[3 * i : 3 * i + self._n_ref])
        return np.concatenate(parts)

    def _tracking_error(self) -> np.ndarray:
        st = self._running()
        ref = st.reference()
        pos = self.loop.plant.position_index
        return np.array([ref[3 * i] - st.Y[pos[i]] for i in range(len(pos))])

    def _member_loop(self, member, rng) -> ClosedLoop:
        from adaptive_ftc.campaigns.sampling import draw_member

        spec = self.campaign
        assert spec is not None  # called by reset() only for an environment over a campaign
        if member is not None:
            if isinstance(member, bool) or not isinstance(member, (int, np.integer)):
                raise ConfigurationError(
                    f"reset option 'member' is a campaign member's index (an integer); got "
                    f"{member!r}."
                )
            drawn = draw_member(spec, int(member))
            if drawn.loop is None:
                raise ConfigurationError(
                    f"Member {int(member)} of campaign '{spec.name}' is invalid: {drawn.error}"
                )
        else:
            for _ in range(100):  # invalid draws are rare; skipped, deterministically
                drawn = draw_member(spec, int(rng.integers(0, 2**31 - 1)))
                if drawn.loop is not None:
                    break
            else:
                raise ConfigurationError(
                    f"Campaign '{spec.name}' gave 100 invalid members in a row; check its "
                    "failure ranges (e.g. with `aftc campaign validate`)."
                )
        self.member = drawn.index
        loop = drawn.loop
        if loop.t_final != self._base.t_final:
            loop = dataclasses.replace(loop, t_final=self._base.t_final)
        return loop


def _campaign(campaign):
    from adaptive_ftc.campaigns.spec import CampaignSpec, load_campaign

    if isinstance(campaign, CampaignSpec):
        return campaign
    return load_campaign(campaign)


def register_catalogue() -> list[str]:
    """Register :data:`CATALOGUE_IDS` with Gymnasium (done by ``import adaptive_ftc.gym``;
    ids already registered are left as they are); returns the ids."""
    for env_id, (name, kwargs) in CATALOGUE_IDS.items():
        if env_id not in gymnasium.registry:
            gymnasium.register(
                id=env_id,
                entry_point="adaptive_ftc.gym:ScenarioEnv",
                kwargs={"scenario": name, **kwargs},
                disable_env_checker=False,
            )
    return list(CATALOGUE_IDS)


register_catalogue()
