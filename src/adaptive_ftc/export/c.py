"""Export the digital controller of a closed loop as a self-contained C99 library.

The C is generated from the same text the simulator compiles: the loop's generated module
(:func:`adaptive_ftc.sim.compose.source_of`, with the ``s'`` filter) is parsed, the controller
side of its right-hand side is kept (measurements, errors, regressors, control law, allocation
``u = R^T u0``, ``s'`` filter, adaptive laws, constraint-aware parts) and the plant side dropped
(failures, actuators, plant dynamics), and that function and every part function it calls
(``controllers/laws.py``, the designs' laws, the guarded math) are translated by
:mod:`adaptive_ftc.export.pyc`. A controller with the designer's model of the plant (the
constraint-aware MIMO law's model feedforward, ``nominal_dynamics``) carries the plant's
equations, translated the same way, and its nominal parameters (``params.plant``).

One call of ``step`` does what the simulator's digital mode does at a sample: the command
``u`` from the measurement and the controller's states, and the derivatives of those states;
the states then move by ``sample_time`` times those derivatives (the simulator holds the
derivatives over the sample period, so its states move along the same straight line).
"""

from __future__ import annotations

import ast
import copy
import dataclasses
import importlib
import inspect
import math
import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.export.controller_side import controller_side
from adaptive_ftc.export.pyc import DOUBLE, PARAMS, PTR, Field, Source, Translator, c_float
from adaptive_ftc.sim.parts.skeleton import COMMANDS_ONLY_TEST

if TYPE_CHECKING:
    from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["ExportedC", "export_c", "controller_loop"]

#: settings of ``D.c`` that are one number (a ``double`` field, not an array)
_SCALARS = {"eps0", "filter_tau", "adapt", "act0"}
#: what each setting is, for the header (units where they are fixed)
_MEANING = {
    "constants": "numbers of the scenario's expressions (basis functions, Nussbaum function, "
    "reference, constraint-aware settings), in the order the generator lifted them",
    "lam": "lambda of the filtered error s = e' + lambda e (2.18), per output [1/s]",
    "k": "k of the robust term k s + k0 tanh(s/eps0) (2.20), per output",
    "k0": "k0 of the robust term, per output",
    "R": "allocation matrix R (p x m, row-major): u = R^T u0 (3.14)",
    "eps0": "eps0 of the robust term (boundary layer of tanh)",
    "filter_tau": "time constant of the s' filter (dirty derivative of s) [s]",
    "adapt": "1: adaptation on; 0: frozen (the adaptive states hold)",
    "centers": "centres of the fuzzy memberships, input by input",
    "spread": "1/(2 w^2) of each fuzzy membership",
    "plant": "the plant's parameters in the designer's model (the healthy plant's equations, "
    "no failures), which the model feedforward evaluates along the reference",
}
#: added to a refusal of the designer's model of the plant (``nominal_dynamics``)
_MODEL_NOTE = (
    "That part is the plant's model (its equations and parameters), which the constraint-aware "
    "MIMO law's model feedforward carries into the controller, and this plant cannot be "
    "translated to C: ConstraintAware(model_feedforward=False) leaves the feedforward out "
    "(or write the plant's equations in the subset above)."
)
#: the header's lines on the designer's model, where the controller carries it
_MODEL_HEADER = [
    " * Model feedforward: the controller evaluates the plant's equations (the designer's",
    " * model: the healthy plant, no failures, no actuators) with params.plant on the",
    " * scenario's reference read ahead of t (the same reference as <prefix>_reference). Set",
    " * params.plant to the nominal numbers of the plant it controls.",
    " *",
]


@dataclass(frozen=True)
class ExportedC:
    """What :func:`export_c` wrote: the files, the C prefix and the sizes of the interface."""

    header: Path
    source: Path
    prefix: str
    n_y: int  # measured plant states (input y)
    n_r: int  # reference values (input r: y_d, y_d', y_d'' per output)
    n_u: int  # actuator commands (output u)
    n_states: int  # controller states
    sample_time: float
    state_names: tuple[str, ...]
    #: sensor readings per sample the design averages (its decimation filter,
    #: ``ConstraintAware.decimation``): ``<prefix>_read`` takes each, ``<prefix>_step`` their
    #: mean; 1: none (``<prefix>_step`` takes the measurement)
    readings: int = 1


def controller_loop(scenario, sample_time: float | None = None) -> tuple[ClosedLoop, float]:
    """The closed loop whose controller :func:`export_c` exports and the ``s'`` filter's time
    constant: ``scenario`` (a :class:`~adaptive_ftc.scenarios.loader.Scenario`, a catalogue name
    or a file) with ``sample_time`` when given."""
    from adaptive_ftc.scenarios.loader import Scenario, load_scenario
    from adaptive_ftc.sim.engine import SolverOptions
    from adaptive_ftc.sim.system import ClosedLoop

    if isinstance(scenario, ClosedLoop):
        loop, solver = scenario, SolverOptions()
    else:
        sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
        loop, solver = sc.loop, sc.solver
    if sample_time is not None:
        if not (isinstance(sample_time, (int, float)) and 0 < sample_time < math.inf):
            raise ConfigurationError(
                f"`sample_time` of the C export must be a positive number of seconds; got "
                f"{sample_time!r}."
            )
        loop = dataclasses.replace(loop, sample_time=float(sample_time))
    if not loop.sample_time > 0:
        raise ConfigurationError(
            "The C export is of a digital controller, and this loop's controller is continuous: "
            "give a sample time (export_c(..., sample_time=0.005) or `aftc export c ... "
            "--sample-time 0.005`), or a scenario with a [digital] table."
        )
    tau = solver.filter_tau_for(loop)
    if not loop.sample_time < 2 * tau:
        raise ConfigurationError(
            f"The s' filter (time constant {tau:g} s) is unstable when the controller samples "
            f"every {loop.sample_time:g} s (it needs sample_time < 2 filter_tau): set the "
            f"scenario's [solver] filter_tau to at least {loop.sample_time:g} s."
        )
    return loop, tau


def export_c(
    scenario,
    out_dir,
    *,
    sample_time: float | None = None,
    prefix: str = "aftc",
) -> ExportedC:
    """Write the digital controller of ``scenario`` as ``<prefix>.h`` and ``<prefix>.c``.

    Parameters
    ----------
    scenario
        A :class:`~adaptive_ftc.scenarios.loader.Scenario`, a catalogue name, a scenario file or
        a :class:`~adaptive_ftc.sim.system.ClosedLoop`.
    out_dir
        Folder to write into (created if needed).
    sample_time
        The controller's period (s); default: the scenario's ``[digital] sample_time``.
    prefix
        Prefix of every C name (``aftc_step``, ``aftc_params``...): two exported controllers
        with different prefixes link into one program.

    Returns
    -------
    ExportedC

    Raises
    ------
    ConfigurationError
        A continuous controller without ``sample_time``; an unstable ``s'`` filter; a part
        written in Python the translator does not take (the message names the construct and
        its file and line).

    Examples
    --------
    >>> out = export_c("hypersonic-direct-s1", "build", sample_time=0.005)  # doctest: +SKIP
    >>> out.header.name  # doctest: +SKIP
    'aftc.h'
    """
    if not (isinstance(prefix, str) and prefix.isidentifier() and prefix.isascii()):
        raise ConfigurationError(
            f"`prefix` of the C export must be a C identifier (letters, digits, _); got {prefix!r}."
        )
    loop, tau = controller_loop(scenario, sample_time)
    lib = _Library(loop, tau, prefix)
    header, source = lib.render()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    h, c = out / f"{prefix}.h", out / f"{prefix}.c"
    h.write_text(header)
    c.write_text(source)
    return lib.exported(h, c)


# ----------------------------------------------------------------------------- the library
class _Library:
    """The C text of one loop's controller."""

    def __init__(self, loop, filter_tau: float, prefix: str):
        from adaptive_ftc.sim.compose import generate

        self.loop, self.prefix = loop, prefix
        text, data, g, layout = generate(loop, sdot="filtered")
        self.text, self.g, self.layout = text, g, layout
        self.values = np.array(data.c, dtype=float)
        self.values[layout["c:filter_tau"]] = filter_tau
        self.nx, self.p, self.m = g.nx, g.p, g.m
        self.ny, self.filt = layout["ny"], layout["filt"]
        self.tree = ast.parse(text)
        self.constants = _module_constants(self.tree)
        self.defs = {n.name: n for n in self.tree.body if isinstance(n, ast.FunctionDef)}
        if "rhs" in self.defs:  # the simulator's commands-only return (lean signals): not C's
            rhs = self.defs["rhs"]
            rhs.body = [
                st
                for st in rhs.body
                if not (isinstance(st, ast.If) and ast.unparse(st.test) == COMMANDS_ONLY_TEST)
            ]
        self.imported = _imported_names(self.tree)
        self.sources: dict[str, Source] = {}
        ctrl = loop.controller.bound(loop)
        from adaptive_ftc.sim.parts.base import decimation_readings

        #: sensor readings per sample the design averages (1: no decimation filter)
        self.readings = decimation_readings(loop, ctrl)
        self.gain_names = tuple(type(ctrl.gains())._fields)
        self.gain_values = tuple(float(v) for v in ctrl.gains())

    # -------------------------------------------------------------- part functions
    def resolve(self, name: str) -> Source | None:
        if name in self.sources:
            return self.sources[name]
        src = None
        if name in self.defs and name not in ("rhs", "jump"):
            src = Source(self.defs[name], "<generated loop module>", 0, self.constants)
        else:
            func = self._python_function(name)
            if func is not None:
                src = _source_of(func)
        if src is not None:
            self.sources[name] = src
        return src

    def _python_function(self, name: str):
        g = self.g
        if name in g.imports and name not in g.classes:
            target = g.imports[name]
            if not target:
                return g.inject.get(f"_py_{name}")
            mod, fn = target.split(":")
            obj = importlib.import_module(mod)
            for part in fn.split("."):
                obj = getattr(obj, part)
            return getattr(obj, "py_func", obj)
        if name in self.imported:
            obj = getattr(importlib.import_module(self.imported[name]), name)
            return getattr(obj, "py_func", obj)
        return None

    # -------------------------------------------------------------- the controller
    def controller_def(self) -> ast.FunctionDef:
        """The controller side of the generated ``rhs`` as ``controller(t, Y, D, W, dY)``."""
        rhs = copy.deepcopy(self.defs["rhs"])
        rhs.name = "controller"
        rhs.decorator_list = []
        rhs.args.args = [ast.arg(arg=a) for a in ("t", "Y", "D", "W", "dY")]
        rhs.body = controller_side(rhs.body, self.ny)
        if not rhs.body:
            raise ConfigurationError("Cannot export to C: the loop's controller is empty.")
        return rhs

    def classes(self) -> dict[str, tuple[str, ...]]:
        """``{alias: field names}`` of the NamedTuples of the generated module (the plant's
        parameters, which the designer's model ``nominal_params(D)`` builds), the gains'
        (``gains(D).name``, a field of the params struct) left out."""
        out = {}
        for alias in self.g.classes:
            if alias == "Gains":
                continue
            target = self.g.imports.get(alias, "")
            if target:
                mod, name = target.split(":")
                cls = getattr(importlib.import_module(mod), name)
            else:
                cls = self.g.inject.get(alias)
            fields = getattr(cls, "_fields", None)
            if fields is not None:
                out[alias] = tuple(fields)
        return out

    def fields(self) -> list[Field]:
        lay = self.layout
        out = [Field("constants", 0, lay["c:lam"].start)]
        for key, sl in lay.items():
            if not (isinstance(key, str) and key.startswith("c:")) or key == "c:gains":
                continue
            name = key[2:]
            out.append(Field(name, sl.start, sl.stop - sl.start, name in _SCALARS))
        return [f for f in out if f.size > 0]

    def exported(self, header: Path, source: Path) -> ExportedC:
        """The :class:`ExportedC` of this library written to ``header`` and ``source``."""
        return ExportedC(
            header=header,
            source=source,
            prefix=self.prefix,
            n_y=self.nx,
            n_r=3 * self.p,
            n_u=self.m,
            n_states=self.ny - self.nx,
            sample_time=float(self.loop.sample_time),
            state_names=tuple(self.g.adaptive_names),
            readings=self.readings,
        )

    def render(self) -> tuple[str, str]:
        pfx = self.prefix
        tr = Translator(self.resolve, self.fields(), self.gain_names, pfx, classes=self.classes())
        names = ("init", "reset", "step", "reference") + (("read",) if self.readings > 1 else ())
        tr.reserved = {f"{pfx}_{n}" for n in names}
        tr.notes = dict.fromkeys(("nominal_dynamics", "nominal_params"), _MODEL_NOTE)
        ctrl = Source(self.controller_def(), "<generated loop module: rhs>", 0, self.constants)
        cname = tr.function(ctrl, [DOUBLE, PTR, PARAMS, PTR, PTR], name=f"{pfx}__controller")
        reference = self.resolve("reference")
        assert reference is not None  # every generated loop module defines reference()
        ref = tr.function(reference, [DOUBLE, PARAMS, PTR], f"{pfx}__reference")
        used = tr.fields_used | {"lam", "k", "k0", "R", "eps0", "filter_tau", "adapt"}
        fields = [f for f in self.fields() if f.name in used]
        self.last_fields = fields  # the params struct's fields (the FMU's parameters)
        return self._header(fields), self._source(tr, fields, cname, ref)

    # -------------------------------------------------------------- text
    def _sizes(self) -> dict[str, int]:
        return {
            "NY": self.nx,
            "NR": 3 * self.p,
            "NU": self.m,
            "NS": self.ny - self.nx,
            "NW": self.layout["w:size"].stop,
        }

    def _header(self, fields: list[Field]) -> str:
        from adaptive_ftc._version import __version__

        pfx, P = self.prefix, self.prefix.upper()
        loop, plant, g = self.loop, self.loop.plant, self.g
        units = tuple(plant.units) + ("",) * plant.n_states
        pos, vel = plant.position_index, plant.velocity_index

        def unit(u: str) -> str:
            return f" [{u}]" if u else ""

        ys = [f" *   y[{i}] = {n}{unit(units[i])}" for i, n in enumerate(plant.state_names)]
        rs = []
        for i, name in enumerate(plant.output_names):
            u0, u1 = units[pos[i]], units[vel[i]]
            rs += [
                f" *   r[{3 * i}] = desired {name}{unit(u0)}",
                f" *   r[{3 * i + 1}] = its first derivative{unit(u1)}",
                f" *   r[{3 * i + 2}] = its second derivative{unit(_per_second(u1))}",
            ]
        us = [f" *   u[{j}] = command of {a}{unit(plant.actuator_units)}"
              for j, a in enumerate(plant.actuator_names)]  # fmt: skip
        ss = [f" *   states[{k}] = {n}" for k, n in enumerate(g.adaptive_names)]
        sizes = self._sizes()
        meaning = {**_MEANING}
        lines = [
            f"/* {pfx}.h: the digital controller of a closed loop, exported by adaptive-ftc "
            f"{__version__}.",
            " *",
            f" * Plant {plant.name!r}, design {loop.controller.design!r} "
            f"({loop.controller.equation}), {self.p} output(s), {self.m} actuator(s);",
            f" * sample time {loop.sample_time!r} s (a zero-order hold on u), s' from a "
            "first-order filter of s.",
            " * Generated from the code the simulator compiles (adaptive_ftc.sim.compose): do "
            "not edit; retune",
            f" * by copying {pfx}_default_params and changing its numbers.",
            " *",
            *self._per_sample(),
            " *",
            *[
                ln.replace("<prefix>", pfx)
                for ln in _MODEL_HEADER
                if any(f.name == "plant" for f in fields)
            ],
            f" * Inputs y[{P}_NY]: the measured plant states"
            + (f" (one sensor reading, of {pfx}_read)" if self.readings > 1 else ""),
            *ys,
            f" * Inputs r[{P}_NR]: the reference ({pfx}_reference computes the scenario's)",
            *rs,
            " * Input t: time [s] (the reference's and the failure basis' time)",
            f" * Outputs u[{P}_NU]: the actuator commands",
            *us,
            f" * Controller states ({P}_NS, in state.Y[{P}_NY + k]):",
            *ss,
            " */",
            f"#ifndef {P}_H",
            f"#define {P}_H",
            "",
            *[f"#define {P}_{k} {v}" for k, v in sizes.items()],
            *(
                [f"#define {P}_READINGS {self.readings}  /* sensor readings per sample */"]
                if self.readings > 1
                else []
            ),
            "",
            f"/* the design's adaptation gains ({type(loop.controller).__name__}) */",
            "typedef struct {",
            *[f"    double {n};" for n in self.gain_names],
            f"}} {pfx}_gains;",
            "",
            f"/* the numbers of the controller (the scenario's in {pfx}_default_params) */",
            "typedef struct {",
        ]
        for f in fields:
            what = meaning.get(f.name, f"D.c[{f.start}:{f.start + f.size}] of the loop")
            decl = f"double {f.name};" if f.scalar else f"double {f.name}[{f.size}];"
            lines.append(f"    {decl:<28} /* {what} */")
        lines += [
            f"    {pfx}_gains gains;",
            f"    double {'sample_time;':<21} /* controller period [s] */",
            f"    double {'start_filters;':<21} /* 1: the first step after init/reset starts the "
            "filters at the first measurement; 0: at initial[] */",
            f"    double initial[{P}_NS];{'':<{max(0, 8 - len(P))}} /* controller states at "
            "init/reset */",
            f"}} {pfx}_params;",
            "",
            "typedef struct {",
            f"    double Y[{P}_NY + {P}_NS];  /* the last measurement, then the controller's "
            "states */",
            f"    double dY[{P}_NY + {P}_NS]; /* the states' derivatives at the last sample */",
            f"    double W[{P}_NW];  /* work: signals, regressor, u0, u, reference, q */",
            "    int started;        /* 0 until the first step after init/reset */",
            *(
                [
                    f"    double sum[{P}_NY];  /* the readings since the last step, summed "
                    "(decimation filter) */",
                    "    int count;          /* how many */",
                ]
                if self.readings > 1
                else []
            ),
            f"}} {pfx}_state;",
            "",
            f"extern const {pfx}_params {pfx}_default_params;",
            "",
            f"void {pfx}_init({pfx}_state *state, const {pfx}_params *params);",
            f"void {pfx}_reset({pfx}_state *state, const {pfx}_params *params);",
            *(
                [
                    f"void {pfx}_read({pfx}_state *state, const double y[]);",
                    f"void {pfx}_step({pfx}_state *state, const {pfx}_params *params, "
                    "const double r[],",
                    "               double t, double u[]);",
                ]
                if self.readings > 1
                else [
                    f"void {pfx}_step({pfx}_state *state, const {pfx}_params *params, "
                    "const double y[],",
                    "               const double r[], double t, double u[]);",
                ]
            ),
            f"/* the scenario's reference at t: r[{P}_NR] as the inputs r above */",
            f"void {pfx}_reference(const {pfx}_params *params, double t, double r[]);",
            "",
            f"#endif /* {P}_H */",
            "",
        ]
        return "\n".join(lines)

    def _per_sample(self) -> list[str]:
        """The header's lines on the calls per sample (and per sensor reading, for a design
        with the decimation filter)."""
        pfx, P, n = self.prefix, self.prefix.upper(), self.readings
        if n == 1:
            return [
                " * C99, no heap, libm only. Per sample:",
                f" *   {pfx}_step(&state, &params, y, r, t, u);",
                " * computes the commands u from the measurement y and the reference r at time "
                "t, then moves",
                " * the controller's states on by one sample (their derivatives held over the "
                "sample, as the",
                " * simulator's digital mode does). The first step after init/reset starts the "
                "s' filter (and",
                " * any measurement filter) at the first measurement (params.start_filters = "
                "1, the default;",
                " * 0: they start at params.initial).",
            ]
        T = float(self.loop.sample_time)
        sensors = self.loop.sensors
        assert sensors is not None  # the filter needs the loop's sensors (decimation_readings)
        return [
            " * C99, no heap, libm only. Decimation filter (ConstraintAware.decimation): the "
            "design reads",
            f" * the mean of the {n} sensor readings of each sample period ({P}_READINGS; a "
            "boxcar,",
            f" * integrate-and-dump anti-aliasing prefilter). The sensor reads every {T / n!r} s "
            f"({float(sensors.rate):g} Hz),",
            f" * the controller samples every {T!r} s. Per sensor reading, the reading at "
            "each sample instant",
            " * included (e.g. from the ADC's end-of-conversion interrupt):",
            f" *   {pfx}_read(&state, y);",
            " * and per sample, after that sample instant's reading:",
            f" *   {pfx}_step(&state, &params, r, t, u);",
            " * computes the commands u from the mean of the readings given since the previous "
            f"{pfx}_step",
            f" * (those at t - {n - 1} T/{n}, ..., t; the first step after init/reset: those "
            "since then, which in",
            " * the simulator is the reading at t0 alone) and the reference r at time t, then "
            "moves the",
            " * controller's states on by one sample (their derivatives held over the sample, "
            "as the",
            " * simulator's digital mode does). A step with no reading since the previous "
            "one reuses",
            f" * the previous mean. {pfx}_step empties the sum: {pfx}_read and {pfx}_step must "
            "not interleave",
            f" * on one state (mask the reading's interrupt while {pfx}_step runs). The first "
            "step after",
            " * init/reset starts the s' filter (and any measurement filter) at the first mean "
            "(params.",
            " * start_filters = 1, the default; 0: they start at params.initial).",
        ]

    def _initial(self) -> np.ndarray:
        """The controller states at the start (as :func:`~adaptive_ftc.sim.compose.assemble`
        sets them; the filters are started at the first measurement by ``step``)."""
        loop, g, nx = self.loop, self.g, self.nx
        n_phi = self.layout["n_phi"]
        y = np.zeros(self.ny - nx)
        y[:n_phi] = loop.controller.theta0
        y[n_phi : self.filt - nx] = g.y0_extra
        if loop.adaptive_initial:
            n_ad = self.filt - nx
            if len(loop.adaptive_initial) != n_ad:
                raise ConfigurationError(
                    f"`adaptive_initial` has {len(loop.adaptive_initial)} values but the loop "
                    f"has {n_ad} adaptive states."
                )
            y[:n_ad] = loop.adaptive_initial
        return y

    def _step_head(self) -> str:
        """``<prefix>_read`` and the head of ``<prefix>_step`` of a design with the decimation
        filter: the step's measurement is the mean of the readings since the last step (the
        simulator's ``measured``, sim/parts/decimation.py; the translated law reads it as
        ``x``, export/controller_side.py)."""
        pfx, P = self.prefix, self.prefix.upper()
        return f"""void {pfx}_read({pfx}_state *state, const double y[])
{{
    int i;
    for (i = 0; i < {P}_NY; i++) state->sum[i] += y[i];
    state->count += 1;
}}

void {pfx}_step({pfx}_state *state, const {pfx}_params *params, const double r[], double t,
               double u[])
{{
    int i;
    const double *y = state->Y; /* the measurement: the mean of the period's readings */
    if (state->count > 0) {{ /* the decimation filter (none since the last step: the last mean) */
        for (i = 0; i < {P}_NY; i++) state->Y[i] = state->sum[i] / (double)state->count;
    }}
    for (i = 0; i < {P}_NY; i++) state->sum[i] = 0.0;
    state->count = 0;"""

    def _source(self, tr: Translator, fields, cname: str, ref: str) -> str:
        pfx, P = self.prefix, self.prefix.upper()
        lay, nx, p = self.layout, self.nx, self.p
        plant = self.loop.plant
        vals = self.values

        def arr(v) -> str:
            return "{" + ", ".join(c_float(float(x)) for x in v) + "}"

        init = []
        for f in fields:
            v = vals[f.start : f.start + f.size]
            init.append(f"    {c_float(float(v[0])) if f.scalar else arr(v)}, /* {f.name} */")
        init.append(f"    {arr(self.gain_values)}, /* gains */")
        init.append(f"    {c_float(float(self.loop.sample_time))}, /* sample_time */")
        init.append("    1.0, /* start_filters */")
        init.append(f"    {arr(self._initial())} /* initial */")
        ref_at = lay["w:ref"].start
        u_at = lay["w:u"].start
        names = self.g.adaptive_names
        pos, vel = plant.position_index, plant.velocity_index
        start = [
            "        /* the s' filter starts at s = e' + lambda e of the first measurement */",
            *[
                f"        state->Y[{self.filt + i}] = (r[{3 * i + 1}] - y[{vel[i]}])"
                f" + params->lam[{i}] * (r[{3 * i}] - y[{pos[i]}]);"
                for i in range(p)
            ],
        ]
        if "s_lookahead1" in names:  # the digital MIMO law's copy of the s' filter
            at = nx + names.index("s_lookahead1")
            start += [
                "        /* the MIMO law's copy of the s' filter (s_lookahead) too */",
                *[f"        state->Y[{at + i}] = state->Y[{self.filt + i}];" for i in range(p)],
            ]
        if "measurement_filter1" in names:
            at = nx + names.index("measurement_filter1")
            start += [
                "        /* the measurement filters start at the first measurement */",
                f"        for (i = 0; i < {P}_NY; i++) state->Y[{at} + i] = y[i];",
            ]
        step_head = (
            self._step_head()
            if self.readings > 1
            else f"void {pfx}_step({pfx}_state *state, const {pfx}_params *params, "
            "const double y[],\n"
            "               const double r[], double t, double u[])\n"
            "{\n"
            "    int i;\n"
            f"    for (i = 0; i < {P}_NY; i++) state->Y[i] = y[i];"
        )
        body = f"""#include <math.h>
#include <string.h>

#include "{pfx}.h"

/* ---- translated from the simulator's code (do not edit) ---- */
{tr.text()}

/* ---- the interface ---- */
const {pfx}_params {pfx}_default_params = {{
{chr(10).join(init)}
}};

void {pfx}_reset({pfx}_state *state, const {pfx}_params *params)
{{
    int i;
    memset(state, 0, sizeof(*state));
    for (i = 0; i < {P}_NS; i++) state->Y[{P}_NY + i] = params->initial[i];
    state->started = 0;
}}

void {pfx}_init({pfx}_state *state, const {pfx}_params *params)
{{
    {pfx}_reset(state, params);
}}

{step_head}
    for (i = 0; i < {P}_NR; i++) state->W[{ref_at} + i] = r[i];
    if (!state->started && params->start_filters != 0.0) {{
{chr(10).join(start)}
    }}
    state->started = 1;
    for (i = 0; i < {P}_NY + {P}_NS; i++) state->dY[i] = 0.0;
    {cname}(t, state->Y, params, state->W, state->dY);
    for (i = 0; i < {P}_NU; i++) u[i] = state->W[{u_at} + i];
    /* the derivatives held over the sample (the simulator's digital mode) */
    for (i = {P}_NY; i < {P}_NY + {P}_NS; i++) state->Y[i] += params->sample_time * state->dY[i];
}}

void {pfx}_reference(const {pfx}_params *params, double t, double r[])
{{
    {ref}(t, params, r);
}}
"""
        return body


def _per_second(unit: str) -> str:
    """``unit`` divided by seconds (``rad s-1`` -> ``rad s-2``, ``m/s`` -> ``m/s^2``)."""
    if not unit:
        return ""
    if unit.endswith(" s-1"):
        return unit[:-4] + " s-2"
    if unit.endswith("/s"):
        return unit + "^2"
    return f"{unit} s-1"


# ----------------------------------------------------------------------------- sources
def _module_constants(tree: ast.Module) -> dict:
    out = {}
    for node in tree.body:
        if (
            isinstance(node, ast.Assign)
            and len(node.targets) == 1
            and isinstance(node.targets[0], ast.Name)
            and isinstance(node.value, ast.Constant)
            and isinstance(node.value.value, (int, float))
            and not isinstance(node.value.value, bool)
        ):
            out[node.targets[0].id] = node.value.value
    return out


def _imported_names(tree: ast.Module) -> dict[str, str]:
    """``name -> module`` of the ``from adaptive_ftc... import name`` lines (the laws and the
    guarded math the generated module jits under their own names)."""
    out: dict[str, str] = {}
    for node in tree.body:
        if (
            isinstance(node, ast.ImportFrom)
            and node.module is not None
            and node.module.startswith("adaptive_ftc")
        ):
            for a in node.names:
                if a.asname is None:
                    out[a.name] = node.module
    return out


def _source_of(func) -> Source:
    """The :class:`Source` of a plain Python part function (its file and line)."""
    try:
        lines, first = inspect.getsourcelines(func)
        filename = inspect.getsourcefile(func) or "<unknown>"
    except (OSError, TypeError) as exc:
        raise ConfigurationError(
            f"Cannot export to C: the source of {getattr(func, '__qualname__', func)!r} is "
            "not available (defined interactively?); define it in a module file."
        ) from exc
    tree = ast.parse(textwrap.dedent("".join(lines)))
    node = tree.body[0]
    if not isinstance(node, ast.FunctionDef):
        raise ConfigurationError(
            f"Cannot export to C: {func!r} is not a plain function ({filename}:{first})."
        )
    node.decorator_list = []
    consts = {
        k: v
        for k, v in getattr(func, "__globals__", {}).items()
        if isinstance(v, (int, float)) and not isinstance(v, bool)
    }
    try:
        shown = str(Path(filename).relative_to(Path.cwd()))
    except ValueError:
        shown = filename
    return Source(node, shown, first - 1, consts)
