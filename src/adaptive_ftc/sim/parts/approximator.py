"""Approximator part: the regressors (fuzzy bases, linear regressors), each emitted by its own
class, their parameters ``theta`` as states after the plant's, and ``u0 = Pi^T theta`` (2.22),
per output (3.26)."""

from __future__ import annotations

from adaptive_ftc.sim.parts.base import Build, Part

__all__ = ["Approximator"]


class Approximator(Part):
    """The regressor values ``Pi`` (work buffer ``phi``) and the theta blocks."""

    records = ("u0",)

    def build(self, b: Build) -> None:
        g, ctrl, nx = b.g, b.ctrl, b.nx
        regs = ctrl.regressors_for(b.p)
        self.sources: list[list[str]] = []
        self.theta_slices: list[slice] = []
        off = 0
        for r, reg in enumerate(regs):
            where = f"the regressor of design '{ctrl.design}'"
            idx = [g.signal(name, where) for name in reg.inputs]
            self.sources.append(reg.emit(g, idx, off, r))
            b.blocks.append((off, nx + off, reg.size))
            self.theta_slices.append(slice(off, off + reg.size))
            off += reg.size
        self.n_phi = off
        b.states.claim("theta", off, controller=True)
        if len(regs) == 1:
            g.adaptive_names += [f"theta_{l + 1}" for l in range(off)]
        else:
            for r, reg in enumerate(regs):
                g.adaptive_names += [f"theta{r + 1}_{l + 1}" for l in range(reg.size)]

    def rhs(self, b: Build) -> dict[str, list[str]]:
        lines = ["    # regressors and u0 = Pi^T theta (2.22), per output (3.26)"]
        for r, src in enumerate(self.sources):
            o, at, size = b.blocks[r]
            lines += src
            lines.append(f"    u0[{r}] = weighted_sum(phi, Y, {o}, {at}, {size})")
        return {"regressors": lines}

    def params(self, b: Build) -> dict[str, tuple[float, ...]]:
        return {"centers": tuple(b.g.centers), "spread": tuple(b.g.spread)}
