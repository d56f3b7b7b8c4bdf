"""Allocation part: the commands ``u = R^T u0`` (3.14), one per actuator (``R`` in ``D.c``)."""

from __future__ import annotations

import numpy as np

from adaptive_ftc.sim.parts.base import Build, Part

__all__ = ["Allocation"]


class Allocation(Part):
    """``acc = sum_i R_ij u0_i`` per actuator j, then ``u[j] = acc`` (the commands)."""

    records = ("u_cmd",)

    def rhs(self, b: Build) -> dict[str, list[str]]:
        return {
            "allocate": [
                "    # allocation u = R^T u0 (3.14) and actuator failures",
                f"    for j in range({b.m}):",
                "        acc = 0.0",
                f"        for i in range({b.p}):",
                f"            acc += c[RMAT + i * {b.m} + j] * u0[i]",
            ],
            "command": ["        u[j] = acc"],
        }

    def params(self, b: Build) -> dict[str, tuple[float, ...]]:
        return {"R": tuple(np.ravel(b.loop.R))}
