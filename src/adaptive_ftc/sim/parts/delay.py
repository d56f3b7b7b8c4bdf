"""Input-delay part (``hardware.Actuators.delay``): per actuator a Pade approximant's states
(continuous control) or a shift register of whole samples (digital control), after every
other state; ``delayed`` gives the command that reaches the actuator."""

from __future__ import annotations

from adaptive_ftc.sim.layout import Misc
from adaptive_ftc.sim.parts.base import Build, Part

__all__ = ["Delay"]

_SAMPLING = int(Misc.SAMPLING)


class Delay(Part):
    """The delayed command of each actuator (nothing when no actuator has a delay)."""

    def build(self, b: Build) -> None:
        self.n = 0
        if not b.has_delay:
            self.at = b.states.claim("delay", 0)
            return
        from adaptive_ftc.hardware import pade_realization

        loop = b.loop
        assert loop.actuators is not None  # has_delay
        delays = loop.actuators.delays(b.m)
        if b.sampled:
            self.values = tuple(float(round(d / loop.sample_time)) for d in delays)
            self.n = int(max(self.values))
        else:
            self.values = delays
            self.n = loop.actuators.delay_order
            self.pade = pade_realization(self.n)
        what = "delayed command" if b.sampled else "delay state"
        names = b.loop.plant.actuator_names
        labels = [f"{what} {q + 1} of {a}" for a in names for q in range(self.n)]
        self.at = b.states.claim("delay", b.m * self.n, labels)

    def rhs(self, b: Build) -> dict[str, list[str]]:
        if not b.has_delay:
            return {}
        out = {"delay_command": ["        acc = delayed(j, Y, acc, D)  # the input delay"]}
        if not b.sampled:
            out["delay_dynamics"] = self._pade_dynamics(b)
        return out

    def _pade_dynamics(self, b: Build) -> list[str]:
        A, B = self.pade[0], self.pade[1]
        n = self.n
        lines = [
            f"    # input delay: Pade states x' = (A x + B u) / d (order {n}, balanced)",
            f"    for j in range({b.m}):",
            "        d = c[DELAY + j]",
            f"        at = {self.at} + j * {n}",
            "        if d == 0.0:",
            f"            for i in range({n}):",
            "                dY[at + i] = 0.0",
            "            continue",
        ]
        for r in range(n):
            terms = " + ".join(f"{A[r, q]!r} * Y[at + {q}]" for q in range(n))
            lines.append(f"        dY[at + {r}] = ({terms} + {B[r]!r} * u[j]) / d")
        return lines

    def jump(self, b: Build) -> dict[str, list[str]]:
        if not b.has_delay:
            return {}
        n, sampled = self.n, b.sampled
        # the delay line starts full of the first command (digital) or at the Pade
        # realization's steady state for it (continuous)
        fills = ["1.0"] * n if sampled else [repr(float(v)) for v in self.pade[4][:n]]
        out = {
            "jump_first": [
                "    if ph == 0:  # the delay line starts holding the first command",
                *([f"        misc[{_SAMPLING}] = 1.0"] if sampled else []),
                "        rhs(t, Y, ph, D, W, scratch)",
                *([f"        misc[{_SAMPLING}] = 0.0"] if sampled else []),
                f"        for j in range({b.m}):",
                f"            at = {self.at} + j * {n}",
                *[f"            Y[at + {q}] = {fills[q]} * W[U + j]" for q in range(n)],
            ]
        }
        if sampled:
            held = b.states["held_command"].start
            out["jump_sample_shift"] = [
                "        if ph > 0:  # the input delay: the held commands move one sample on",
                f"            for j in range({b.m}):",
                f"                at = {self.at} + j * {n}",
                f"                for i in range({n - 1}, 0, -1):",
                "                    Y[at + i] = Y[at + i - 1]",
                f"                Y[at] = Y[{held} + j]",
            ]
        return out

    def tables(self, b: Build) -> list[str]:
        if not b.has_delay:
            return []
        head = [
            "@inl",
            "def delayed(j, Y, uj, D):",
        ]
        if b.sampled:
            return [
                "\n".join(
                    [
                        *head,
                        '    """Command of actuator j after its input delay of k whole samples."""',
                        "    k = int(D.c[DELAY + j])",
                        "    if k == 0:",
                        "        return uj",
                        f"    return Y[{self.at} + j * {self.n} + k - 1]",
                    ]
                )
            ]
        C, Dd = self.pade[2], self.pade[3]
        out = " + ".join(f"{C[q]!r} * Y[at + {q}]" for q in range(self.n))
        return [
            "\n".join(
                [
                    *head,
                    '    """Command of actuator j after its input delay: the Pade output C x + D u."""',  # noqa: E501
                    "    if D.c[DELAY + j] == 0.0:",
                    "        return uj",
                    f"    at = {self.at} + j * {self.n}",
                    f"    return {out} + {Dd!r} * uj",
                ]
            )
        ]

    def params(self, b: Build) -> dict[str, tuple[float, ...]]:
        # a Pade approximant's delay (s) or a digital delay in samples, per actuator
        return {"delay": tuple(self.values)} if b.has_delay else {}
