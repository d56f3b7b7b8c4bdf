"""Design-law part: the design's control law and compensator (after ``u0``), its adaptive
laws, its own states after the regressors' (kappa, tau, rho...), its robust-term settings and
its gains (a NamedTuple rebuilt from ``D.c``).

The design itself emits the lines (``emit_control`` / ``emit_adapt`` of
:class:`~adaptive_ftc.controllers.base.AdaptiveController`)."""

from __future__ import annotations

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim.parts.base import Build, Part

__all__ = ["Design"]


class Design(Part):
    """The control and adaptive laws, the states they add and the freeze of adaptation."""

    records = ("u_f", "gain")

    def build(self, b: Build) -> None:
        g, ctrl = b.g, b.ctrl
        extra_at = b.states.size
        n0 = len(g.y0_extra)
        # ``gains(D).x`` at each use: building them once per call (``gs = gains(D)``) ran
        # 1.5 % slower (the NamedTuple then lives across the whole right-hand side)
        self.control = gains_per_use(ctrl.emit_control(g, b.blocks, extra_at))
        self.adapt = gains_per_use(ctrl.emit_adapt(g, b.blocks, extra_at))
        b.states.claim("design", len(g.y0_extra) - n0, controller=True)

    def rhs(self, b: Build) -> dict[str, list[str]]:
        # the adaptive states stop, but for the free-running filters of the constraint-aware
        # option (the last ones before the s' filter)
        stop = b.states["s_filter"].start - b.g.free_running
        return {
            "control": self.control,
            "freeze": [
                "    if c[ADAPT] == 0.0:  # adaptation frozen",
                f"        for i in range({b.nx}, {stop}):",
                "            dY[i] = 0.0",
            ],
            "freeze_end": ["        return"],
            "adapt": self.adapt,
        }

    def tables(self, b: Build) -> list[str]:
        gains = b.ctrl.gains()
        self.gains = tuple(float(v) for v in gains)
        alias = b.g.use_class("Gains", type(gains))
        args = ", ".join(f"c[GAINS + {k}]" for k in range(len(gains)))
        return [
            "\n".join(
                [
                    "@inl",
                    "def gains(D):",
                    '    """The design\'s gains (their numbers live in D.c, from GAINS on)."""',
                    "    c = D.c",
                    f"    return {alias}(" + args + ")",
                ]
            )
        ]

    def params(self, b: Build) -> dict[str, tuple[float, ...]]:
        p = b.p
        lam, k, k0, eps0 = b.ctrl.robust_settings()  # the thesis's or constraint-aware
        return {
            "lam": per_output(lam, p, "lam"),
            "k": per_output(k, p, "k"),
            "k0": per_output(k0, p, "k0"),
            "eps0": (float(eps0),),
            "adapt": (1.0 if b.loop.adapt else 0.0,),
            "gains": self.gains,
        }


def gains_per_use(lines: list[str]) -> list[str]:
    """A design's lines with its gains read from ``D.c`` where they are used."""
    return [ln.replace("D.gains.", "gains(D).") for ln in lines]


def per_output(value, p: int, name: str) -> tuple[float, ...]:
    """``value`` (one number, or one per output) as one number per output."""
    if isinstance(value, (int, float)):
        return (float(value),) * p
    vals = tuple(float(v) for v in value)
    if len(vals) == 1:
        return vals * p
    if len(vals) != p:
        raise ConfigurationError(f"`{name}` needs one value per output ({p}); got {len(vals)}.")
    return vals
