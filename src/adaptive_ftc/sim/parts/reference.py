"""Reference part: the desired outputs and their first two derivatives, taken symbolically,
with their numbers lifted into ``D.c``; the right-hand side computes them once per time."""

from __future__ import annotations

from adaptive_ftc.expressions import Expression
from adaptive_ftc.sim.layout import Misc
from adaptive_ftc.sim.parts.base import Build, Part

__all__ = ["Reference"]


class Reference(Part):
    """``reference(t, c, out)``: y_d, y_d', y_d'' per output (in the work buffer ``ref``)."""

    records = ("yd", "yd_dot")

    def build(self, b: Build) -> None:
        g = b.g
        lines = [
            "@inl",
            "def reference(t, c, out):",
            '    """Desired outputs and their first two derivatives (taken symbolically)."""',
        ]
        for i, text in enumerate(g.loop.reference):
            name = g.loop.plant.output_names[i]
            e = Expression(text, ("t",), context=f"reference of output '{name}'")
            lines.append(f"    # output {name!r}: y_d and its derivatives (numbers in c)")
            start = len(g.consts)
            for d in range(3):
                text = g.constant_block(e.node, {"t": "t"}, share_from=start)
                lines.append(f"    r{3 * i + d} = {text}")
                e = e.derivative("t")
        # stored after all are computed: a store to ``out`` between them could alias ``c``
        # and keep the compiler from sharing sin(w t) and cos(w t) between y_d and its
        # derivatives
        lines += [f"    out[{k}] = r{k}" for k in range(3 * len(g.loop.reference))]
        lines += [
            "",
            "",
            "@hot",
            "def reference_at(t, c, out):",
            '    """:func:`reference` for Python (compiled only when called from there)."""',
            "    reference(t, c, out)",
        ]
        self.source = "\n".join(lines)

    def functions(self, b: Build) -> list[str]:
        return [self.source]

    def rhs(self, b: Build) -> dict[str, list[str]]:
        valid, when = int(Misc.REF_VALID), int(Misc.REF_TIME)
        return {
            "reference": [
                f"    if not (misc[{valid}] == 1.0 and misc[{when}] == t):"
                "  # reference cached per time",
                "        reference(t, c, ref)",
                *[f"        {line}" for line in b.g.per_time],
                f"        misc[{when}] = t",
                f"        misc[{valid}] = 1.0",
            ]
        }
