"""Sampler part: a digital controller. At each sample (``jump`` in an interval flagged in the
sample table of ``D.i``) the command and the controller states' derivatives are computed and
held (states after the actuators'); between samples the loop uses the held values."""

from __future__ import annotations

from adaptive_ftc.sim.layout import Misc
from adaptive_ftc.sim.parts.base import Build, Part

__all__ = ["Sampler"]

_SAMPLING = int(Misc.SAMPLING)


class Sampler(Part):
    """The held command (one per actuator) and held controller derivatives."""

    def build(self, b: Build) -> None:
        self.ny = ny = b.states.controller_stop
        names = b.loop.plant.actuator_names if b.sampled else ()
        held = b.g.adaptive_names if b.sampled else ()
        self.at_hu = b.states.claim(
            "held_command", len(names), [f"held command of {a}" for a in names]
        )
        n_hd = (ny - b.nx) if b.sampled else 0
        self.at_hd = b.states.claim(
            "held_derivative", n_hd, [f"held derivative of {n}" for n in held]
        )

    def rhs(self, b: Build) -> dict[str, list[str]]:
        if not b.sampled:
            return {}
        held = self._held(b)
        return {
            "hold_command": [
                f"        if misc[{_SAMPLING}] == 0.0:  # between samples: the held command",
                f"            acc = Y[{self.at_hu} + j]",
            ],
            "hold": [
                "    # held command and held controller derivatives change only at samples",
                f"    for i in range({self.at_hu}, {b.states.size}):",
                "        dY[i] = 0.0",
            ],
            "frozen_hold": ["    " + ln for ln in held],
            "after_adapt": held,
        }

    def _held(self, b: Build) -> list[str]:
        return [
            f"    if misc[{_SAMPLING}] == 0.0:  # between samples: the derivatives computed at"
            " the sample",
            f"        for i in range({b.nx}, {self.ny}):",
            f"            dY[i] = Y[{self.at_hd - b.nx} + i]",
        ]

    def jump_uses_scratch(self, b: Build) -> bool:
        return b.sampled

    def jump(self, b: Build) -> dict[str, list[str]]:
        if not b.sampled:
            return {}
        return {
            "jump_sample": [
                # (a decimating loop flags its sensor readings between samples 2)
                f"    if D.i[D.i[I_SAMP] + ph] {'== 1' if b.readings > 1 else '!= 0'}:"
                "  # a controller sample: new command and derivatives, held",
            ],
            "jump_sample_body": [
                f"        misc[{_SAMPLING}] = 1.0",
                "        rhs(t, Y, ph, D, W, scratch)",
                f"        misc[{_SAMPLING}] = 0.0",
                f"        for j in range({b.m}):",
                f"            Y[{self.at_hu} + j] = W[U + j]",
                f"        for i in range({b.nx}, {self.ny}):",
                f"            Y[{self.at_hd - b.nx} + i] = scratch[i]",
            ],
        }
