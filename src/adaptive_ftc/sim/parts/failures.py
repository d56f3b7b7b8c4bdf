"""Failures part: the applied output of each actuator through the failure acting on it in
the interval (``instance``; affine failures evaluated in the loop, any other pattern through
the address of its own compiled module). The text is the same in every loop, whatever its
failures: they are numbers (``D.c``) and tables (``D.i``)."""

from __future__ import annotations

from adaptive_ftc.sim.parts.base import Build, Part

__all__ = ["AFFINE_BRANCHES", "DFAILURE_SRC", "FAILURE_SRC", "INSTANCE_SRC", "Failures"]

#: the affine kinds, evaluated in the loop (the head of both functions of FAILURE_SRC)
AFFINE_BRANCHES = """    c = D.c
    at = D.i[I_INST] + 4 * k
    s = D.i[at]
    o = D.i[at + 1]
    if s == 0:
        return c[o + 0] * u + c[o + 1]
    if s == 1:
        return (u + (min(((t - c[o + 0]) / c[o + 1]), c[o + 2]) * ((c[o + 3] * u + c[o + 4]) - u)))"""  # noqa: E501
#: the failed output of instance k (row [kind, offset, value address, slope address] of the
#: instance table) and its remembered form for the allocation: the same text in every loop.
#: ``a*u + b`` and its incipient form ``u + min((t - onset)/ramp, 1)*((a*u + b) - u)`` are
#: evaluated here, any other pattern through its address. Measured on hypersonic-direct-s1 (a
#: pattern of t alone from 40 s), against the patterns pasted in: the call costs 1-2 % of the
#: run; affine failures cost the same as before (the batch benchmark)
FAILURE_SRC = f'''@inl
def failure(k, t, x, u, D):
    """Applied output of a failed actuator (failure instance k)."""
{AFFINE_BRANCHES}
    return call_pattern(D.i[at + 2], t, x, u, c, o)


@inl
def failure_cached(k, j, t, x, u, D, fc):
    """failure(k, ...) of actuator j, a pattern of t alone (kind 2) remembered while t and
    k stay the same (fc[3 j:3 j + 3] = [t, k + 1, value])."""
{AFFINE_BRANCHES}
    if s == 2:
        if fc[3 * j] == t and fc[3 * j + 1] == k + 1:
            return fc[3 * j + 2]
        v = call_pattern(D.i[at + 2], t, x, u, c, o)
        fc[3 * j] = t
        fc[3 * j + 1] = k + 1
        fc[3 * j + 2] = v
        return v
    return call_pattern(D.i[at + 2], t, x, u, c, o)'''

#: the slope of failure instance k (for the control gain; the same text in every module)
DFAILURE_SRC = '''@inl
def dfailure(k, t, x, u, D):
    """d(applied output)/du of failure instance k."""
    c = D.c
    at = D.i[I_INST] + 4 * k
    s = D.i[at]
    o = D.i[at + 1]
    if s == 0:
        return c[o + 0]
    if s == 1:
        return (1.0 + (min(((t - c[o + 0]) / c[o + 1]), c[o + 2]) * (c[o + 3] - 1.0)))
    return call_pattern(D.i[at + 3], t, x, u, c, o)'''

#: the failure instance acting on an actuator in an interval (loops and control-gain modules)
INSTANCE_SRC = """@inl
def instance(ph, j, D):
    \"\"\"Failure instance of actuator j in interval ph (-1: healthy).\"\"\"
    return D.i[I_HEAD + ph * M + j]"""


class Failures(Part):
    """``uf[j]``: the output of actuator j after its failure (``acc`` when healthy)."""

    records = ("u_applied",)

    def rhs(self, b: Build) -> dict[str, list[str]]:
        return {
            "failure": [
                "        k = instance(ph, j, D)",
                "        uf[j] = acc if k < 0 else failure_cached(k, j, t, x, acc, D, fc)",
            ]
        }

    def tables(self, b: Build) -> list[str]:
        return [INSTANCE_SRC]

    def helpers(self, b: Build) -> list[str]:
        return [FAILURE_SRC]
