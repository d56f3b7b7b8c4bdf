"""Actuator part: first- or second-order actuators with position and rate limits (their
positions, and velocities, as states after the controller's; ``act``, the actuator table of
``D.c`` per interval, changed by the dynamics failures), or ideal actuators within their
position limits."""

from __future__ import annotations

from adaptive_ftc.sim.parts.base import Build, Part

__all__ = ["Actuator"]


class Actuator(Part):
    """What reaches the failures: the actuator position (a state) or the clipped command."""

    def build(self, b: Build) -> None:
        names = b.loop.plant.actuator_names
        m = b.m if b.has_act else 0
        self.at = b.states.claim("actuator_position", m, [f"position of {a}" for a in names][:m])
        m2 = b.m if b.has_act2 else 0
        self.at_vel = b.states.claim(
            "actuator_velocity", m2, [f"velocity of {a}" for a in names][:m2]
        )

    def rhs(self, b: Build) -> dict[str, list[str]]:
        if not b.has_act:
            return {}
        at = self.at
        return {
            "actuator_position": [
                "        if act(ph, j, 0, D) > 0.0 or act(ph, j, 4, D) > 0.0:  # position: a state",
                f"            acc = Y[{at} + j]",
                "        else:  # an ideal actuator within its position limits",
                "            acc = min(max(acc, act(ph, j, 2, D)), act(ph, j, 3, D))",
            ],
            "actuator_dynamics": self._dynamics(b),
        }

    def _dynamics(self, b: Build) -> list[str]:
        at, at_vel = self.at, self.at_vel
        uj = "uj" if b.has_delay else "u[j]"  # what reaches the actuator
        second = [
            "        omega = act(ph, j, 4, D)",
            "        if omega > 0.0:  # a' = clip(v), v' = w^2 (u - a) - 2 z w v",
            f"            target = min(max({uj}, act(ph, j, 2, D)), act(ph, j, 3, D))",
            f"            v = Y[{at_vel} + j]",
            "            rate = act(ph, j, 1, D)",
            f"            dY[{at} + j] = min(max(v, -rate), rate)",
            f"            dY[{at_vel} + j] = omega * omega * (target - Y[{at} + j])"
            " - 2.0 * act(ph, j, 5, D) * omega * v",
            "            continue",
            f"        dY[{at_vel} + j] = 0.0",
        ]
        return [
            "    # actuators: a' = clip((clip(u, lower, upper) - a) / tau, -rate, rate)",
            f"    for j in range({b.m}):",
            *(["        uj = delayed(j, Y, u[j], D)"] if b.has_delay else []),
            "        tau = act(ph, j, 0, D)",
            *(second if b.has_act2 else []),
            "        if tau > 0.0:",
            f"            target = min(max({uj}, act(ph, j, 2, D)), act(ph, j, 3, D))",
            "            rate = act(ph, j, 1, D)",
            f"            da = (target - Y[{at} + j]) / tau",
            f"            dY[{at} + j] = min(max(da, -rate), rate)",
            "        else:",
            f"            dY[{at} + j] = 0.0",
        ]

    def jump_uses_scratch(self, b: Build) -> bool:
        return b.has_act

    def jump(self, b: Build) -> dict[str, list[str]]:
        if not b.has_act:
            return {}
        uw = "delayed(j, Y, W[U + j], D)" if b.has_delay else "W[U + j]"
        return {
            "jump_actuator": [
                "    # an actuator that was ideal (or starts at its first command) is where its",
                "    # command puts it when it becomes a dynamic one",
                "    rhs(t, Y, ph, D, W, scratch)",
                f"    for j in range({b.m}):",
                "        if ph == 0:",
                "            was_ideal = D.c[ACT0] != 0.0",
                "        else:",
                "            was_ideal = act(ph - 1, j, 0, D) == 0.0 and act(ph - 1, j, 4, D) == 0.0",  # noqa: E501
                "        if was_ideal:",
                f"            Y[{self.at} + j] = min(max({uw}, act(ph, j, 2, D)), act(ph, j, 3, D))",  # noqa: E501
                *([f"            Y[{self.at_vel} + j] = 0.0"] if b.has_act2 else []),
            ]
        }

    def tables(self, b: Build) -> list[str]:
        return [
            "\n".join(
                [
                    "@inl",
                    "def act(ph, j, k, D):",
                    '    """Entry k of [tau, rate, lower, upper, omega, zeta] of actuator j, phase ph."""',  # noqa: E501
                    "    return D.c[D.i[I_ACT] + (ph * M + j) * 6 + k]",
                ]
            )
        ]

    def params(self, b: Build) -> dict[str, tuple[float, ...]]:
        loop = b.loop
        initial = loop.actuators and loop.actuators.initial
        return {"act0": (1.0 if b.has_act and not initial else 0.0,)}
