"""Plant part: the plant's own ``dynamics`` (imported, or the text of a plant written as
equations), its parameters as numbers in ``D.c`` (``plant_params``) and its envelope."""

from __future__ import annotations

import numpy as np

from adaptive_ftc.sim.parts.base import Build, Part

__all__ = ["Plant", "pack_plant"]


class Plant(Part):
    """x' = f(t, x, u_f, p): the plant states, first in ``Y``."""

    records = ("control_gain",)

    def build(self, b: Build) -> None:
        plant = b.loop.plant
        b.states.claim("plant", b.nx)
        self.source = plant.dynamics_source(b.g)
        self.env = tuple(float(v) for v in (getattr(plant, "envelope", ()) or ()))[: b.nx]

    def functions(self, b: Build) -> list[str]:
        return [self.source] if self.source else []

    def rhs(self, b: Build) -> dict[str, list[str]]:
        return {
            "plant": [
                "    plant_dynamics(t, x, uf, plant_params(D), xdot)",
                f"    for i in range({b.nx}):",
                "        dY[i] = xdot[i]",
            ]
        }

    def tables(self, b: Build) -> list[str]:
        self.values, self.expr = pack_plant(b.g, b.loop.plant.parameter_values())
        return [
            "\n".join(
                [
                    "@inl",
                    "def plant_params(D):",
                    '    """The plant\'s parameters (their numbers live in D.c, from PLANT on)."""',
                    "    c = D.c",
                    f"    return {self.expr}",
                ]
            )
        ]

    def params(self, b: Build) -> dict[str, tuple[float, ...]]:
        return {"envelope": self.env, "plant": tuple(self.values)}


def pack_plant(g, value) -> tuple[list[float], str]:
    """The plant's parameters as numbers for ``D.c`` (from ``PLANT`` on) and the expression
    that rebuilds them in ``plant_params``; ``([], "D.p")`` when they cannot be flattened
    (arrays inside a NamedTuple, a class defined in ``__main__``...): then they travel in
    ``LoopData.p``."""
    from adaptive_ftc.sim.codegen import importable

    vals: list[float] = []

    def pack(v) -> str | None:
        if isinstance(v, (bool, np.bool_)):
            vals.append(1.0 if v else 0.0)
            return f"(c[PLANT + {len(vals) - 1}] != 0.0)"
        if isinstance(v, (int, np.integer)):
            if abs(int(v)) > 2**53:
                return None
            vals.append(float(v))
            return f"int(c[PLANT + {len(vals) - 1}])"
        if isinstance(v, (float, np.floating)):
            vals.append(float(v))
            return f"c[PLANT + {len(vals) - 1}]"
        if isinstance(v, tuple):
            packed = [pack(x) for x in v]
            parts = [part for part in packed if part is not None]
            if len(parts) < len(packed):
                return None
            if hasattr(type(v), "_fields"):
                if not importable(type(v)):
                    return None
                alias = g.use_class(f"_Params{len(g.classes)}", type(v))
                return f"{alias}({', '.join(parts)})"
            return "(" + "".join(f"{part}, " for part in parts) + ")"
        return None

    if isinstance(value, np.ndarray) and value.ndim == 1 and value.dtype.kind == "f":
        # a plant written as equations indexes its numbers as ``c[k]``: a tuple serves (a
        # function without reference counting cannot return a view of ``D.c``)
        vals = [float(v) for v in value]
        return vals, "(" + "".join(f"c[PLANT + {k}], " for k in range(len(vals))) + ")"
    expr = pack(value) if hasattr(type(value), "_fields") else None
    if expr is None:
        return [], "D.p"
    return vals, expr
