"""s' part: the derivative of the filtered error, exact (from the plant derivative, SPEC §1)
or from a dirty-derivative filter of s (its states after the design's), and the robust
term ``q = s' + k s + k0 tanh(s/eps0)``."""

from __future__ import annotations

from adaptive_ftc.sim.layout import Misc
from adaptive_ftc.sim.parts.base import Build, Part

__all__ = ["SDot"]


class SDot(Part):
    """s' and ``q`` per output (work buffer ``q``); the s' of output 1 in ``misc``."""

    records = ("sdot", "q", "sdot_used")

    def build(self, b: Build) -> None:
        filtered = b.sdot == "filtered"
        self.at = b.states.claim("s_filter", b.p if filtered else 0, controller=True)
        if filtered:
            b.g.adaptive_names += [f"s_filter{i + 1}" for i in range(b.p)]

    def rhs(self, b: Build) -> dict[str, list[str]]:
        nx, p, vel = b.nx, b.p, b.loop.plant.velocity_index
        lines = ["    # q = s' + k s + k0 tanh(s/eps0)"]
        for i in range(p):
            s_at = nx + 2 * p + i
            if b.sdot == "exact":  # s' from the plant derivative (SPEC §1)
                lines.append(
                    f"    sd = ref[{3 * i + 2}] - xdot[{vel[i]}] + c[LAM + {i}] * sig[{nx + p + i}]"
                )
            else:  # dirty-derivative filter of s
                lines += [
                    f"    sd = (sig[{s_at}] - Y[{self.at + i}]) / c[FTAU]",
                    f"    dY[{self.at + i}] = sd",
                ]
            lines.append(
                f"    q[{i}] = robust_q(sd, sig[{s_at}], c[K + {i}], c[K0 + {i}], c[EPS0])"
            )
            if i == 0:
                lines.append(f"    misc[{int(Misc.SDOT_USED)}] = sd")
        return {"q": lines}

    def params(self, b: Build) -> dict[str, tuple[float, ...]]:
        return {"filter_tau": (0.01,)}
