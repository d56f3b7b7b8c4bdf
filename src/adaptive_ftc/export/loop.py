"""The closed loop of a scenario in C, around the exported controller (the FMU's ``loop`` part).

The plant side is the simulator's own: the generated module's ``rhs`` and ``jump``
(:mod:`adaptive_ftc.sim.compose`) translated whole (:mod:`adaptive_ftc.export.pyc`) with the
loop's numbers (``LoopData``: its failures, actuator and sensor tables, interval by interval)
as C arrays, and the simulator's fixed-step RK4 (``templates/rk4.py``: steps landing on every
sample and failure time). At every sample the exported controller (``aftc_step``) computes the
command from the measurement, which the plant then holds: the SIL check of
:func:`adaptive_ftc.export.sil.verify`, in C.
"""

from __future__ import annotations

import ast
import math

import numpy as np

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.export.c import _Library
from adaptive_ftc.export.pyc import DATA, DOUBLE, LONG, PTR, Source, Translator, c_float

__all__ = ["loop_source"]


def loop_source(lib: _Library, dt: float | None = None) -> tuple[str, dict]:
    """C text of ``lib``'s closed loop (plant side, data, RK4 driver) and its sizes.

    ``dt``: the RK4 step (default: the sample period split into steps of at most 1 ms, as
    :func:`~adaptive_ftc.export.sil.verify`).
    """
    from adaptive_ftc.sim import compose
    from adaptive_ftc.sim.compose import assemble
    from adaptive_ftc.sim.layout import Header

    loop = lib.loop
    T = float(loop.sample_time)
    if dt is None:
        dt = T / max(1, math.ceil(T / 1e-3 - 1e-9))
    tau = float(lib.values[lib.layout["c:filter_tau"]][0])
    asm = assemble(loop, sdot="filtered", filter_tau=tau)
    layout = compose.generate(loop, sdot="filtered")[3]
    if asm.data.p != ():
        raise ConfigurationError(
            "Cannot export the loop to C: the plant's parameters are not all numbers "
            "(arrays inside its NamedTuple); export the controller (--part controller)."
        )
    c = np.array(asm.data.c, dtype=float)
    ints = np.array(asm.data.i, dtype=np.int64)
    ints[Header.RHS] = ints[Header.JUMP] = ints[Header.GAIN] = 0
    inst_at = int(ints[Header.INST])
    patterns = layout["patterns"]
    pattern_src = ["def call_pattern(k, t, x, u, c, o):"]
    for n, pt in enumerate(patterns):
        ints[inst_at + 4 * n + 2] = n + 1 if pt is not None else 0
        ints[inst_at + 4 * n + 3] = 0
        if pt is not None:
            call = f"pattern{n + 1}(t, x, u, c, o)"
            pattern_src += [f"    if k == {n + 1}:", f"        return {call}"]
    pattern_src.append("    return 0.0")
    for n, pt in enumerate(patterns):
        if pt is not None:
            pattern_src += [f"def pattern{n + 1}(t, x, u, c, o):", f"    return {pt[0]}"]
    ptree = ast.parse("\n".join(pattern_src))
    pdefs = {
        d.name: Source(d, "<failure patterns>")
        for d in ptree.body
        if isinstance(d, ast.FunctionDef)  # all of them (narrows the type)
    }

    classes = {
        alias: tuple(_class_fields(lib, alias)) for alias in lib.g.classes if alias != "Gains"
    }

    own = {
        name: Source(lib.defs[name], "<generated loop module>", 0, lib.constants)
        for name in ("rhs", "jump")
    }

    def resolve(name: str):
        if name in pdefs:
            return pdefs[name]
        return own.get(name) or lib.resolve(name)

    pfx = "aftcl"
    gains_at = lib.layout["c:gains"].start
    tr = Translator(resolve, [], lib.gain_names, pfx, classes=classes, gains_at=gains_at)
    args = [DOUBLE, PTR, LONG, DATA, PTR]
    rhs = tr.function(resolve("rhs"), [*args, PTR], name=f"{pfx}_rhs")
    jump = tr.function(resolve("jump"), args, name=f"{pfx}_jump")
    ny = lib.ny
    names = asm.extra_names
    held = ny + names.index(f"held command of {loop.plant.actuator_names[0]}")
    n_all = asm.y0.size
    bps = np.asarray(asm.breakpoints, dtype=float)
    sizes = {
        "NY_ALL": n_all,
        "NW": asm.layout["w:size"].stop,
        "NPH": bps.size - 1,
        "HELD": held,
        "NSTATES": ny,
        "MEAS": int(ints[Header.MEAS]),
        "SAMP": int(ints[Header.SAMP]),
    }

    def arr(v, fmt) -> str:
        items = [fmt(x) for x in v]
        rows = [", ".join(items[k : k + 8]) for k in range(0, len(items), 8)]
        return "{\n    " + ",\n    ".join(rows) + "\n}"

    text = "\n\n".join(
        [
            "/* The closed loop around the exported controller (written by adaptive-ftc). */",
            '#include <math.h>\n#include <string.h>\n\n#include "aftc.h"\n#include "loop.h"',
            f"typedef struct {{ double *c; long *i; }} {pfx}_data;",
            tr.text(),
            f"static double loop_c[{c.size}] = {arr(c, lambda x: c_float(float(x)))};",
            f"static long loop_i[{ints.size}] = {arr(ints, lambda x: str(int(x)))};",
            f"static const double loop_bps[{bps.size}] = {arr(bps, lambda x: repr(float(x)))};",
            f"static const double loop_y0[{n_all}] = {arr(asm.y0, lambda x: c_float(float(x)))};",
            _DRIVER.replace("@RHS@", rhs).replace("@JUMP@", jump).replace("@DT@", repr(float(dt))),
        ]
    )
    header = "\n".join(
        [
            "/* loop.h: the closed loop around the exported controller (adaptive-ftc). */",
            "#ifndef AFTC_LOOP_H",
            "#define AFTC_LOOP_H",
            *[f"#define LOOP_{k} {v}" for k, v in sizes.items()],
            "typedef struct {",
            "    double Y[LOOP_NY_ALL], W[LOOP_NW];",
            "    double k1[LOOP_NY_ALL], k2[LOOP_NY_ALL], k3[LOOP_NY_ALL], k4[LOOP_NY_ALL];",
            "    double yt[LOOP_NY_ALL], y[AFTC_NY], r[AFTC_NR], u[AFTC_NU];",
            "    aftc_state s;",
            "    long ph;  /* the interval being integrated (NPH: the end) */",
            "    int samples;",
            "} loop_state;",
            "void loop_init(loop_state *L, const aftc_params *p);",
            "/* integrate whole intervals to t_end (a break time); 0, or -1 if t_end is none */",
            "int loop_advance(loop_state *L, const aftc_params *p, double t_end);",
            "double loop_time(const loop_state *L);",
            "#endif",
            "",
        ]
    )
    return text, {"header": header, "sizes": sizes, "asm": asm}


def _class_fields(lib: _Library, alias: str) -> tuple[str, ...]:
    import importlib

    target = lib.g.imports.get(alias, "")
    if not target:
        cls = lib.g.inject.get(alias)
    else:
        mod, name = target.split(":")
        cls = getattr(importlib.import_module(mod), name)
    fields = getattr(cls, "_fields", None)
    if fields is None:
        raise ConfigurationError(f"Cannot export the loop to C: {alias} is not a NamedTuple.")
    return fields


#: the loop's driver: templates/rk4.py's steps, the controller at every sample
_DRIVER = r"""
static const double loop_dt = @DT@;

static double tol_at(double t) { return 1e-9 * (fabs(t) > 1.0 ? fabs(t) : 1.0); }

double loop_time(const loop_state *L)
{
    return loop_bps[L->ph < LOOP_NPH ? L->ph : LOOP_NPH];
}

/* the start of interval ph: the simulator's interval update (actuators, input delay), then
   at a sample the exported controller's command from the measurement, held */
static void loop_start(loop_state *L, const aftc_params *p)
{
    aftcl_data D;
    long ph = L->ph, i;
    double a = loop_bps[ph];
    D.c = loop_c;
    D.i = loop_i;
    if (loop_i[LOOP_SAMP + ph] != 0 && L->samples > 0)
        for (i = AFTC_NY; i < LOOP_NSTATES; i++) L->Y[i] = L->s.Y[i];
    @JUMP@(a, L->Y, ph, &D, L->W);
    if (loop_i[LOOP_SAMP + ph] != 0) {
        for (i = 0; i < AFTC_NY; i++) L->y[i] = L->Y[i] + loop_c[LOOP_MEAS + ph * AFTC_NY + i];
        aftc_reference(p, a, L->r);
        aftc_step(&L->s, p, L->y, L->r, a, L->u);
        for (i = 0; i < AFTC_NU; i++) L->Y[LOOP_HELD + i] = L->u[i];
        L->samples++;
    }
}

void loop_init(loop_state *L, const aftc_params *p)
{
    memset(L, 0, sizeof(*L));
    memcpy(L->Y, loop_y0, sizeof(L->Y));
    aftc_init(&L->s, p);
    /* the controller starts where the simulator starts it (its filters at the true initial
       state: with sensors, the controller's own start would use the first measurement) */
    memcpy(&L->s.Y[AFTC_NY], &loop_y0[AFTC_NY], sizeof(double) * AFTC_NS);
    L->s.started = 1;
    L->ph = 0;
    loop_start(L, p);
}

int loop_advance(loop_state *L, const aftc_params *p, double t_end)
{
    aftcl_data D;
    long i, st, nsteps;
    double a, b, h, t, t1, hh;
    D.c = loop_c;
    D.i = loop_i;
    while (L->ph < LOOP_NPH && loop_bps[L->ph + 1] <= t_end + tol_at(t_end)) {
        a = loop_bps[L->ph];
        b = loop_bps[L->ph + 1];
        nsteps = (long)ceil((b - a) / loop_dt - 1e-9);
        if (nsteps < 1) nsteps = 1;
        h = (b - a) / (double)nsteps;
        for (st = 0; st < nsteps; st++) {
            t = a + (double)st * h;
            t1 = st == nsteps - 1 ? b : a + (double)(st + 1) * h;
            hh = t1 - t;
            @RHS@(t, L->Y, L->ph, &D, L->W, L->k1);
            for (i = 0; i < LOOP_NY_ALL; i++) L->yt[i] = L->Y[i] + 0.5 * hh * L->k1[i];
            @RHS@(t + 0.5 * hh, L->yt, L->ph, &D, L->W, L->k2);
            for (i = 0; i < LOOP_NY_ALL; i++) L->yt[i] = L->Y[i] + 0.5 * hh * L->k2[i];
            @RHS@(t + 0.5 * hh, L->yt, L->ph, &D, L->W, L->k3);
            for (i = 0; i < LOOP_NY_ALL; i++) L->yt[i] = L->Y[i] + hh * L->k3[i];
            @RHS@(t1, L->yt, L->ph, &D, L->W, L->k4);
            for (i = 0; i < LOOP_NY_ALL; i++)
                L->Y[i] = L->Y[i] + hh / 6.0 * (L->k1[i] + 2.0 * L->k2[i] + 2.0 * L->k3[i]
                                                + L->k4[i]);
        }
        L->ph++;
        if (L->ph < LOOP_NPH) loop_start(L, p);
    }
    return fabs(loop_time(L) - t_end) <= tol_at(t_end) ? 0 : -1;
}
"""
