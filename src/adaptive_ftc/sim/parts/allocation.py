"""Allocation part: the commands ``u = R^T u0`` (3.14), one per actuator (``R`` in ``D.c``),
or those of a loop's allocator (``adaptive_ftc.allocation``, issue 31: pseudo-inverse or
weighted least squares around the annunciated failures, optionally with an estimate of each
actuator's effectiveness as states after the design's)."""

from __future__ import annotations

import numpy as np

from adaptive_ftc.sim.parts.base import Build, Part

__all__ = ["Allocation"]


class Allocation(Part):
    """``acc = sum_i R_ij u0_i`` per actuator j (or the allocator's ``u[j]``), then
    ``u[j] = acc`` (the commands)."""

    records = ("u_cmd",)

    def build(self, b: Build) -> None:
        self.prelude: list[str] = []
        self.adapt: list[str] = []
        self.settings: tuple[float, ...] = ()
        states: list[float] = []
        self.on = b.loop.allocator is not None
        if self.on:
            from adaptive_ftc.allocation.inloop import emit_allocation

            self.prelude, self.adapt, settings, states, size = emit_allocation(
                b.g, b.loop, rho_at=b.states.size, has_act=b.loop.has_actuator_dynamics
            )
            self.settings = tuple(settings)
            b.g.y0_extra += states
            b.work["alw"] = size  # the allocator's work buffer
        b.states.claim("allocator", len(states), controller=True)

    def rhs(self, b: Build) -> dict[str, list[str]]:
        if self.on:
            allocate = [
                *self.prelude,
                "    # the allocator's commands and actuator failures",
                f"    for j in range({b.m}):",
                "        acc = u[j]",
            ]
        else:
            allocate = [
                "    # allocation u = R^T u0 (3.14) and actuator failures",
                f"    for j in range({b.m}):",
                "        acc = 0.0",
                f"        for i in range({b.p}):",
                f"            acc += c[RMAT + i * {b.m} + j] * u0[i]",
            ]
        return {
            "allocate": allocate,
            "command": ["        u[j] = acc"],
            "allocator_adapt": self.adapt,
        }

    def params(self, b: Build) -> dict[str, tuple[float, ...]]:
        out = {"R": tuple(np.ravel(b.loop.R))}
        if self.on:  # the allocator's numbers (issue 31)
            out["alloc"] = self.settings
        return out
