"""Constraint-aware part: the option of a design that respects the hardware
(``controllers/constraints.py``): its measurement filters, command filter, hedging and
projection, emitted by the design (``emit_constraint_aware``), with their states after the
design's and the allocator's. Nothing for the thesis law."""

from __future__ import annotations

from adaptive_ftc.sim.parts.base import Build, Part
from adaptive_ftc.sim.parts.design import gains_per_use

__all__ = ["ConstraintAware"]


class ConstraintAware(Part):
    """The constraint-aware lines around the design's (measurement, control, adaptation)."""

    def build(self, b: Build) -> None:
        g, ctrl = b.g, b.ctrl
        n0 = len(g.y0_extra)
        self.measure: list[str] = []
        self.control: list[str] = []
        self.pre: list[str] = []
        self.post: list[str] = []
        self.allocate: list[str] = []
        if ctrl.constraint_aware is not None:  # its states after the design's own
            control, pre, post, self.measure = ctrl.emit_constraint_aware(
                g, b.blocks, b.states.size
            )
            self.control, self.pre, self.post = map(gains_per_use, (control, pre, post))
            self.allocate = list(g.allocate_lines)
        b.states.claim("constraint_aware", len(g.y0_extra) - n0, controller=True)

    def rhs(self, b: Build) -> dict[str, list[str]]:
        return {
            "measure_override": self.measure,
            "control": self.control,
            "adapt_pre": self.pre,
            "adapt_post": self.post,
            **({"allocate": self.allocate} if self.allocate else {}),
        }
