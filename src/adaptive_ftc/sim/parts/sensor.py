"""Sensor part: what the controller measures, the plant states plus a bias and noise held per
interval (``meas``, the measurement table of ``D.c``), and the tracking errors e = y_d - y and
filtered errors s (2.18) computed from them."""

from __future__ import annotations

from adaptive_ftc.sim.parts.base import Build, Part

__all__ = ["Sensor"]


class Sensor(Part):
    """The controller signals ``sig`` = [measured x, e, e', s]."""

    records = ("y", "e", "edot", "s")

    def rhs(self, b: Build) -> dict[str, list[str]]:
        nx, p = b.nx, b.p
        pos, vel = b.loop.plant.position_index, b.loop.plant.velocity_index
        measure = [
            f"    for i in range({nx}):",
            f"        sig[i] = {b.measured}  # what the sensors give"
            if b.has_meas
            else "        sig[i] = x[i]",
        ]
        errors = ["    # tracking errors e = y_d - y and filtered errors s (2.18)"]
        seen = "sig" if b.has_meas else "x"  # the controller's errors use the measurements
        for i in range(p):
            errors += [
                f"    e = ref[{3 * i}] - {seen}[{pos[i]}]",
                f"    ed = ref[{3 * i + 1}] - {seen}[{vel[i]}]",
                f"    sig[{nx + i}] = e",
                f"    sig[{nx + p + i}] = ed",
                f"    sig[{nx + 2 * p + i}] = filtered_error(e, ed, c[LAM + {i}])",
            ]
        return {"measure": measure, "errors": errors}

    def tables(self, b: Build) -> list[str]:
        return [
            "\n".join(
                [
                    "@inl",
                    "def meas(ph, i, D):",
                    '    """Measurement offset (bias + noise) of state i in interval ph."""',
                    "    return D.c[D.i[I_MEAS] + ph * NX + i]",
                ]
            )
        ]
