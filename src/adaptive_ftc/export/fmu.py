"""Export the digital controller of a loop, or the closed loop, as an FMI 2.0 co-simulation FMU.

The FMU wraps the C of :func:`~adaptive_ftc.export.export_c` (no Python inside): its sources
(``sources/``: the controller, its header and the FMI wrapper ``fmu.c``) and a binary for this
machine (``binaries/linux64``) built with the system C compiler. Inputs: the measured plant
states ``y.<state>`` and the reference ``r.<output>`` (with its two derivatives); outputs: the
commands ``u.<actuator>`` and the controller's states ``xc.<state>``; parameters: every
number of the params struct (the scenario's as start values).

Timing: the controller samples at ``t0 + k sample_time``. Leaving initialization it takes
the sample at ``t0`` from the inputs set then; a ``doStep`` that starts at a sample instant
takes that sample from the inputs set for it; the commands hold between samples (outputs
read after ``doStep(t, h)`` are those of the last sample before ``t + h``). Communication
steps may be shorter than the sample time, not longer.
"""

from __future__ import annotations

import hashlib
import os
import platform
import re
import shutil
import subprocess
import tempfile
import uuid
import zipfile
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import quoteattr

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.export.c import ExportedC, _Library, controller_loop

__all__ = ["ExportedFMU", "export_fmu"]


@dataclass(frozen=True)
class ExportedFMU:
    """What :func:`export_fmu` wrote: the ``.fmu`` file, its model identifier, its variables
    (names in value-reference order) and the C it wraps."""

    path: Path
    model_identifier: str
    variables: tuple[str, ...]
    c: ExportedC


def _fmi_headers() -> Path:
    """The folder of the FMI 2.0 headers (shipped with FMPy, 2-clause BSD)."""
    try:
        import fmpy
    except ImportError:
        raise ConfigurationError(
            "The FMU export needs the FMI 2.0 headers that FMPy ships: pip install fmpy "
            "(or adaptive-ftc[export])."
        ) from None
    d = Path(fmpy.__file__).parent / "c-code"
    if not (d / "fmi2Functions.h").exists():
        raise ConfigurationError(f"FMPy's FMI headers are missing from {d}; reinstall fmpy.")
    return d


def export_fmu(
    scenario,
    out_dir,
    *,
    part: str = "controller",
    sample_time: float | None = None,
    name: str | None = None,
    cc: str | None = None,
) -> ExportedFMU:
    """Write ``<name>.fmu``: an FMI 2.0 co-simulation FMU of ``scenario``'s digital controller.

    Parameters
    ----------
    scenario
        A scenario (object, catalogue name or file) or a closed loop.
    out_dir
        Folder to write the ``.fmu`` into (created if needed).
    part
        ``"controller"``: the controller alone (inputs ``y.*`` and ``r.*``, outputs ``u.*``
        and ``xc.*``, parameters: the params struct). ``"loop"``: the scenario's closed loop
        (:mod:`adaptive_ftc.export.loop`: the plant side of the simulator with the exported
        controller; no inputs, outputs ``x.*``, ``u.*``, ``xc.*``); its communication points
        must be break times of the loop (the samples, the failure times).
    sample_time
        The controller's period (s); default: the scenario's ``[digital] sample_time``.
    name
        Model identifier (a C identifier); default: the scenario's name made one.
    cc
        The C compiler of the binary (default: ``$CC`` or ``cc``).

    Raises
    ------
    ConfigurationError
        An unknown ``part``, no FMI headers (install fmpy), no compiler, or what
        :func:`~adaptive_ftc.export.export_c` refuses (for the loop: a plant whose Python the
        translator does not take).
    """
    if part not in ("controller", "loop"):
        raise ConfigurationError(
            f"`part` of the FMU export must be 'controller' or 'loop'; got {part!r}."
        )
    loop, tau = controller_loop(scenario, sample_time)
    from adaptive_ftc.sim.parts.base import decimation_readings

    readings = decimation_readings(loop, loop.controller.bound(loop))
    if readings > 1:
        raise ConfigurationError(
            "The FMU takes one measurement per sample (its inputs y.*), and this design's "
            f"decimation filter averages the {readings} sensor readings of each sample "
            "(ConstraintAware.decimation): export the C instead (`aftc export c`: "
            "<prefix>_read takes each reading, <prefix>_step their mean), or set "
            "`decimation = false` in [controller.constraint_aware] "
            "(ConstraintAware(decimation=False)) to export this loop as an FMU."
        )
    if name is None:
        base = getattr(scenario, "name", None) or (
            Path(str(scenario)).stem if not hasattr(scenario, "plant") else "controller"
        )
        name = re.sub(r"\W", "_", str(base))
        if not name or name[0].isdigit():
            name = "m_" + name
        name += f"_{part}"
    if not (name.isidentifier() and name.isascii()):
        raise ConfigurationError(f"`name` of the FMU must be a C identifier; got {name!r}.")
    cc = cc or os.environ.get("CC", "cc")
    if shutil.which(cc) is None:
        raise ConfigurationError(f"No C compiler {cc!r} on PATH: install gcc or clang, or set CC.")
    headers = _fmi_headers()
    if platform.system() != "Linux" or platform.machine() not in ("x86_64", "AMD64"):
        raise ConfigurationError(
            "The FMU export builds a linux64 binary and runs on x86-64 Linux only; export the "
            "C (aftc export c) and build it for your platform."
        )

    lib = _Library(loop, tau, "aftc")
    header, source = lib.render()
    files = {"aftc.h": header, "aftc.c": source}
    if part == "loop":
        from adaptive_ftc.export.loop import loop_source

        loop_c, info = loop_source(lib)
        files["loop.h"], files["loop.c"] = info["header"], loop_c
        variables, xml_vars, refs = _loop_variables(lib)
    else:
        variables, xml_vars, refs = _variables(lib, lib.last_fields)
    text = "".join(files.values()) + name
    digest = hashlib.sha256(text.encode()).hexdigest()
    guid = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, digest)) + "}"
    sources = ["fmu.c", *[f for f in files if f.endswith(".c")]]
    md = _model_description(lib, name, guid, xml_vars, variables, part, sources)
    if part == "loop":
        wrapper_text = wrapper(
            guid=guid,
            refs=refs,
            n_in=0,
            n_out=len(refs),
            includes='#include "aftc.h"\n#include "loop.h"',
            fields=_LOOP_FIELDS,
            part=_LOOP_PART,
        )
    else:
        wrapper_text = _wrapper(lib, guid, refs, len(variables))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        t = Path(tmp)
        (t / "sources").mkdir()
        (t / "binaries" / "linux64").mkdir(parents=True)
        for fname, ftext in files.items():
            (t / "sources" / fname).write_text(ftext)
        (t / "sources" / "fmu.c").write_text(wrapper_text)
        (t / "modelDescription.xml").write_text(md)
        so = t / "binaries" / "linux64" / f"{name}.so"
        cmd = [cc, "-O2", "-std=c99", "-shared", "-fPIC", "-fvisibility=hidden", f"-I{headers}"]
        cmd += [str(t / "sources" / f) for f in sources]
        cmd += ["-o", str(so)]
        done = subprocess.run([*cmd, "-lm"], capture_output=True, text=True, check=False)
        if done.returncode != 0:
            raise ConfigurationError(f"The FMU's binary did not build:\n{done.stderr.strip()}")
        path = out / f"{name}.fmu"
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
            for f in sorted(t.rglob("*")):
                if f.is_file():
                    z.write(f, f.relative_to(t).as_posix())
    c = lib.exported(Path("sources/aftc.h"), Path("sources/aftc.c"))
    return ExportedFMU(path=path, model_identifier=name, variables=tuple(variables), c=c)


def _xml_double(v: float) -> str:
    """``v`` as an ``xs:double`` (``INF``, ``-INF``, ``NaN``)."""
    if v != v:
        return "NaN"
    if v in (float("inf"), float("-inf")):
        return "INF" if v > 0 else "-INF"
    return repr(v)


# ----------------------------------------------------------------------------- variables
def _variables(lib: _Library, fields):
    """Names, XML elements and C references of the variables, in value-reference order:
    inputs y and r, outputs u and the controller's states, then the parameters."""
    plant = lib.loop.plant
    units = tuple(plant.units) + ("",) * plant.n_states
    pos, vel = plant.position_index, plant.velocity_index
    names: list[str] = []
    xml: list[str] = []
    refs: list[str] = []

    def add(name, causality, variability, ref, unit="", start=None, desc="", initial=None):
        vr = len(names)
        names.append(name)
        refs.append(ref)
        attrs = f'name={quoteattr(name)} valueReference="{vr}"'
        attrs += f' description={quoteattr(desc)} causality="{causality}"'
        attrs += f' variability="{variability}"'
        if initial:
            attrs += f' initial="{initial}"'
        real = "<Real"
        if unit:
            real += f" unit={quoteattr(unit)}"
        if start is not None:
            real += f' start="{_xml_double(float(start))}"'
        xml.append(f"    <ScalarVariable {attrs}>\n      {real}/>\n    </ScalarVariable>")

    for i, n in enumerate(plant.state_names):
        add(f"y.{n}", "input", "continuous", f"c->y[{i}]", units[i], 0.0, f"measured {n}")
    for i, n in enumerate(plant.output_names):
        u0, u1 = units[pos[i]], units[vel[i]]
        from adaptive_ftc.export.c import _per_second

        add(f"r.{n}", "input", "continuous", f"c->r[{3 * i}]", u0, 0.0, f"desired {n}")
        add(f"r.der({n})", "input", "continuous", f"c->r[{3 * i + 1}]", u1, 0.0,
            f"first derivative of the desired {n}")  # fmt: skip
        add(f"r.der2({n})", "input", "continuous", f"c->r[{3 * i + 2}]", _per_second(u1), 0.0,
            f"second derivative of the desired {n}")  # fmt: skip
    for j, a in enumerate(plant.actuator_names):
        add(f"u.{a}", "output", "discrete", f"c->u[{j}]", plant.actuator_units, None,
            f"command of {a} (held between samples)")  # fmt: skip
    for k, n in enumerate(lib.g.adaptive_names):
        add(f"xc.{n}", "output", "discrete", f"c->s.Y[{lib.nx + k}]", "", None,
            f"controller state {n} (after the last sample)")  # fmt: skip
    values = lib.values
    for f in fields:
        for k in range(f.size):
            nm = f.name if f.scalar else f"{f.name}[{k + 1}]"
            ref = f"c->p.{f.name}" if f.scalar else f"c->p.{f.name}[{k}]"
            add(nm, "parameter", "fixed", ref, "", values[f.start + k], f"params.{f.name}",
                "exact")  # fmt: skip
    for n, v in zip(lib.gain_names, lib.gain_values, strict=True):
        add(f"gains.{n}", "parameter", "fixed", f"c->p.gains.{n}", "", v, "adaptation gain",
            "exact")  # fmt: skip
    add("sample_time", "parameter", "fixed", "c->p.sample_time", "s", lib.loop.sample_time,
        "controller period", "exact")  # fmt: skip
    add("start_filters", "parameter", "fixed", "c->p.start_filters", "", 1.0,
        "1: the first sample starts the filters at the first measurement; 0: at initial.*",
        "exact")  # fmt: skip
    for k, (n, v) in enumerate(zip(lib.g.adaptive_names, lib._initial(), strict=True)):
        add(f"initial.{n}", "parameter", "fixed", f"c->p.initial[{k}]", "", v,
            f"initial value of {n}", "exact")  # fmt: skip
    return names, xml, refs


def _loop_variables(lib: _Library):
    """The loop FMU's outputs: plant states, commands and the controller's states, all at
    the last communication point (a break time of the loop)."""
    plant = lib.loop.plant
    units = tuple(plant.units) + ("",) * plant.n_states
    names: list[str] = []
    xml: list[str] = []
    refs: list[str] = []

    def add(name, variability, ref, unit, desc):
        vr = len(names)
        names.append(name)
        refs.append(ref)
        attrs = f'name={quoteattr(name)} valueReference="{vr}" description={quoteattr(desc)}'
        real = f"<Real unit={quoteattr(unit)}/>" if unit else "<Real/>"
        xml.append(
            f'    <ScalarVariable {attrs} causality="output" variability="{variability}">\n'
            f"      {real}\n    </ScalarVariable>"
        )

    for i, n in enumerate(plant.state_names):
        add(f"x.{n}", "continuous", f"c->L.Y[{i}]", units[i], f"plant state {n}")
    for j, a in enumerate(plant.actuator_names):
        add(f"u.{a}", "discrete", f"c->L.u[{j}]", plant.actuator_units,
            f"command of {a} (the exported controller's, held between samples)")  # fmt: skip
    for k, n in enumerate(lib.g.adaptive_names):
        add(f"xc.{n}", "discrete", f"c->L.Y[{lib.nx + k}]", "",
            f"controller state {n} at the last sample")  # fmt: skip
    return names, xml, refs


_LOOP_FIELDS = """    loop_state L;
    aftc_params p;"""

#: the loop's part: the scenario's closed loop from t0, advanced from break time to break time
_LOOP_PART = r"""
static void part_init(Instance *c)
{
    c->p = aftc_default_params;
    loop_init(&c->L, &c->p);
}

static fmi2Status part_start(Instance *c)
{
    loop_init(&c->L, &c->p);
    if (fabs(c->t0 - loop_time(&c->L)) > 1e-9 * (fabs(c->t0) > 1.0 ? fabs(c->t0) : 1.0)) {
        logmsg(c, fmi2Error, "the loop starts at the scenario's t0 only");
        return fmi2Error;
    }
    return fmi2OK;
}

static fmi2Status part_step(Instance *c, double t, double h)
{
    (void)t;
    if (loop_advance(&c->L, &c->p, t + h) != 0) {
        logmsg(c, fmi2Error, "communication points must be break times of the loop (its "
                             "samples and failure times) within the scenario's run");
        return fmi2Error;
    }
    return fmi2OK;
}
"""


def _model_description(
    lib: _Library, name: str, guid: str, xml_vars, names, part: str, sources
) -> str:
    from adaptive_ftc._version import __version__

    units = sorted({u for u in re.findall(r'unit="([^"]+)"', "\n".join(xml_vars))})
    outputs = [k + 1 for k, x in enumerate(xml_vars) if 'causality="output"' in x]
    plant, ctrl = lib.loop.plant, lib.loop.controller
    what = "Digital controller" if part == "controller" else "Closed loop, digital controller"
    desc = (
        f"{what} ({ctrl.design!r} {ctrl.equation}) of plant {plant.name!r}, "
        f"sampled every {lib.loop.sample_time:g} s; exported by adaptive-ftc {__version__}"
    )
    return "\n".join(
        [
            '<?xml version="1.0" encoding="UTF-8"?>',
            "<fmiModelDescription",
            '  fmiVersion="2.0"',
            f"  modelName={quoteattr(name)}",
            f'  guid="{guid}"',
            f"  description={quoteattr(desc)}",
            f'  generationTool="adaptive-ftc {__version__}"',
            '  variableNamingConvention="flat"',
            '  numberOfEventIndicators="0">',
            f'  <CoSimulation modelIdentifier="{name}" canHandleVariableCommunicationStepSize='
            '"true" canGetAndSetFMUstate="false" canSerializeFMUstate="false">',
            "    <SourceFiles>",
            *[f"      <File name={quoteattr(f)}/>" for f in sources],
            "    </SourceFiles>",
            "  </CoSimulation>",
            *(["  <UnitDefinitions>"] if units else []),
            *[f"    <Unit name={quoteattr(u)}/>" for u in units],
            *(["  </UnitDefinitions>"] if units else []),
            f'  <DefaultExperiment startTime="{_xml_double(float(lib.loop.t0))}" '
            f'stopTime="{_xml_double(float(lib.loop.t_final))}" '
            f'stepSize="{_xml_double(float(lib.loop.sample_time))}"/>',
            "  <ModelVariables>",
            *xml_vars,
            "  </ModelVariables>",
            "  <ModelStructure>",
            "    <Outputs>",
            *[f'      <Unknown index="{k}"/>' for k in outputs],
            "    </Outputs>",
            "    <InitialUnknowns>",
            *[f'      <Unknown index="{k}"/>' for k in outputs],
            "    </InitialUnknowns>",
            "  </ModelStructure>",
            "</fmiModelDescription>",
            "",
        ]
    )


# ----------------------------------------------------------------------------- wrapper
_HEAD = r"""/* FMI 2.0 co-simulation wrapper (written by adaptive-ftc). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fmi2Functions.h"
@INCLUDES@

#define GUID "@GUID@"
#define NIN @NIN@   /* inputs: value references [0, NIN) */
#define NOUT @NOUT@ /* outputs: [NIN, NIN + NOUT); parameters after */

typedef struct {
@FIELDS@
    double t0;
    int initialized;
    fmi2CallbackFunctions cb;
    char name[64];
} Instance;

typedef fmi2Component Comp;
typedef const fmi2ValueReference VRs[];

static double *ref(Instance *c, fmi2ValueReference vr)
{
    switch (vr) {
@CASES@
    default: return NULL;
    }
}

static void logmsg(Instance *c, fmi2Status st, const char *msg)
{
    if (c && c->cb.logger)
        c->cb.logger(c->cb.componentEnvironment, c->name, st, "logStatusError", msg);
}
"""

#: the controller's part: the sample at t0 + k sample_time from the inputs set for it
_CONTROLLER_PART = r"""
/* the sample at time t, if one is due (within rounding) */
static void sample(Instance *c, double t)
{
    double next = c->t0 + (double)c->k * c->p.sample_time;
    double tol = 1e-9 * (fabs(t) > 1.0 ? fabs(t) : 1.0);
    if (t >= next - tol) {
        aftc_step(&c->s, &c->p, c->y, c->r, t, c->u);
        c->k = (long)floor((t - c->t0) / c->p.sample_time + 0.5) + 1;
    }
}

static void part_init(Instance *c)
{
    c->p = aftc_default_params;
    aftc_init(&c->s, &c->p);
    memset(c->y, 0, sizeof(c->y));
    memset(c->r, 0, sizeof(c->r));
    memset(c->u, 0, sizeof(c->u));
    c->k = 0;
}

static fmi2Status part_start(Instance *c)
{
    if (!(c->p.sample_time > 0.0)) {
        logmsg(c, fmi2Error, "sample_time must be > 0");
        return fmi2Error;
    }
    aftc_init(&c->s, &c->p);  /* the parameters as set */
    c->k = 0;
    sample(c, c->t0);
    return fmi2OK;
}

static fmi2Status part_step(Instance *c, double t, double h)
{
    double tol = 1e-9 * (fabs(t) > 1.0 ? fabs(t) : 1.0);
    if (h > c->p.sample_time + tol) {
        logmsg(c, fmi2Error, "the communication step is longer than the sample time");
        return fmi2Error;
    }
    sample(c, t);
    return fmi2OK;
}
"""

_COMMON = r"""
FMI2_Export const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_Export const char *fmi2GetVersion(void) { return fmi2Version; }
FMI2_Export fmi2Status fmi2SetDebugLogging(Comp c, fmi2Boolean on, size_t n,
                                           const fmi2String cat[])
{
    (void)c; (void)on; (void)n; (void)cat;
    return fmi2OK;
}

FMI2_Export fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid,
                                          fmi2String location, const fmi2CallbackFunctions *cb,
                                          fmi2Boolean visible, fmi2Boolean logging)
{
    Instance *c;
    (void)location; (void)visible; (void)logging;
    if (!cb || !cb->allocateMemory || type != fmi2CoSimulation) return NULL;
    if (!guid || strcmp(guid, GUID) != 0) {
        if (cb->logger)
            cb->logger(cb->componentEnvironment, name, fmi2Error, "logStatusError", "wrong GUID");
        return NULL;
    }
    c = (Instance *)cb->allocateMemory(1, sizeof(Instance));
    if (!c) return NULL;
    memset(c, 0, sizeof(*c));
    c->cb = *cb;
    if (name) strncpy(c->name, name, sizeof(c->name) - 1);
    part_init(c);
    return c;
}

FMI2_Export void fmi2FreeInstance(Comp comp)
{
    Instance *c = (Instance *)comp;
    if (c && c->cb.freeMemory) c->cb.freeMemory(c);
}

FMI2_Export fmi2Status fmi2SetupExperiment(Comp comp, fmi2Boolean tolDef, fmi2Real tol,
                                           fmi2Real start, fmi2Boolean stopDef, fmi2Real stop)
{
    Instance *c = (Instance *)comp;
    (void)tolDef; (void)tol; (void)stopDef; (void)stop;
    c->t0 = start;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2EnterInitializationMode(Comp comp)
{
    (void)comp;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2ExitInitializationMode(Comp comp)
{
    Instance *c = (Instance *)comp;
    fmi2Status st = part_start(c);
    if (st == fmi2OK) c->initialized = 1;
    return st;
}

FMI2_Export fmi2Status fmi2Terminate(Comp comp)
{
    (void)comp;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2Reset(Comp comp)
{
    Instance *c = (Instance *)comp;
    part_init(c);
    c->initialized = 0;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetReal(Comp comp, VRs vr, size_t n, fmi2Real v[])
{
    Instance *c = (Instance *)comp;
    size_t i;
    for (i = 0; i < n; i++) {
        double *x = ref(c, vr[i]);
        if (!x) {
            logmsg(c, fmi2Error, "unknown value reference");
            return fmi2Error;
        }
        v[i] = *x;
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetReal(Comp comp, VRs vr, size_t n, const fmi2Real v[])
{
    Instance *c = (Instance *)comp;
    size_t i;
    for (i = 0; i < n; i++) {
        double *x = ref(c, vr[i]);
        if (!x || (vr[i] >= NIN && vr[i] < NIN + NOUT)) {
            logmsg(c, fmi2Error, "this variable cannot be set");
            return fmi2Error;
        }
        if (vr[i] >= NIN + NOUT && c->initialized) {
            logmsg(c, fmi2Error, "parameters are fixed after initialization");
            return fmi2Error;
        }
        *x = v[i];
    }
    return fmi2OK;
}

#define UNSUPPORTED(c) \
    do { logmsg((Instance *)(c), fmi2Error, "not supported"); return fmi2Error; } while (0)
#define NONE(n, c) \
    do { if ((n) == 0) return fmi2OK; UNSUPPORTED(c); } while (0)

FMI2_Export fmi2Status fmi2GetInteger(Comp c, VRs vr, size_t n, fmi2Integer v[])
{ (void)vr; (void)v; NONE(n, c); }
FMI2_Export fmi2Status fmi2GetBoolean(Comp c, VRs vr, size_t n, fmi2Boolean v[])
{ (void)vr; (void)v; NONE(n, c); }
FMI2_Export fmi2Status fmi2GetString(Comp c, VRs vr, size_t n, fmi2String v[])
{ (void)vr; (void)v; NONE(n, c); }
FMI2_Export fmi2Status fmi2SetInteger(Comp c, VRs vr, size_t n, const fmi2Integer v[])
{ (void)vr; (void)v; NONE(n, c); }
FMI2_Export fmi2Status fmi2SetBoolean(Comp c, VRs vr, size_t n, const fmi2Boolean v[])
{ (void)vr; (void)v; NONE(n, c); }
FMI2_Export fmi2Status fmi2SetString(Comp c, VRs vr, size_t n, const fmi2String v[])
{ (void)vr; (void)v; NONE(n, c); }
FMI2_Export fmi2Status fmi2GetFMUstate(Comp c, fmi2FMUstate *s)
{ (void)s; UNSUPPORTED(c); }
FMI2_Export fmi2Status fmi2SetFMUstate(Comp c, fmi2FMUstate s)
{ (void)s; UNSUPPORTED(c); }
FMI2_Export fmi2Status fmi2FreeFMUstate(Comp c, fmi2FMUstate *s)
{ (void)s; UNSUPPORTED(c); }
FMI2_Export fmi2Status fmi2SerializedFMUstateSize(Comp c, fmi2FMUstate s, size_t *n)
{ (void)s; (void)n; UNSUPPORTED(c); }
FMI2_Export fmi2Status fmi2SerializeFMUstate(Comp c, fmi2FMUstate s, fmi2Byte b[], size_t n)
{ (void)s; (void)b; (void)n; UNSUPPORTED(c); }
FMI2_Export fmi2Status fmi2DeSerializeFMUstate(Comp c, const fmi2Byte b[], size_t n,
                                               fmi2FMUstate *s)
{ (void)s; (void)b; (void)n; UNSUPPORTED(c); }
FMI2_Export fmi2Status fmi2GetDirectionalDerivative(Comp c, VRs u, size_t nu, VRs z, size_t nz,
                                                    const fmi2Real du[], fmi2Real dz[])
{ (void)u; (void)nu; (void)z; (void)nz; (void)du; (void)dz; UNSUPPORTED(c); }
FMI2_Export fmi2Status fmi2SetRealInputDerivatives(Comp c, VRs vr, size_t n,
                                                   const fmi2Integer order[], const fmi2Real v[])
{ (void)vr; (void)n; (void)order; (void)v; UNSUPPORTED(c); }
FMI2_Export fmi2Status fmi2GetRealOutputDerivatives(Comp c, VRs vr, size_t n,
                                                    const fmi2Integer order[], fmi2Real v[])
{ (void)vr; (void)n; (void)order; (void)v; UNSUPPORTED(c); }

FMI2_Export fmi2Status fmi2DoStep(Comp comp, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior)
{
    (void)noSetPrior;
    return part_step((Instance *)comp, t, h);
}

FMI2_Export fmi2Status fmi2CancelStep(Comp c) { UNSUPPORTED(c); }
FMI2_Export fmi2Status fmi2GetStatus(Comp c, const fmi2StatusKind k, fmi2Status *v)
{ (void)k; (void)v; UNSUPPORTED(c); }
FMI2_Export fmi2Status fmi2GetRealStatus(Comp c, const fmi2StatusKind k, fmi2Real *v)
{ (void)k; (void)v; UNSUPPORTED(c); }
FMI2_Export fmi2Status fmi2GetIntegerStatus(Comp c, const fmi2StatusKind k, fmi2Integer *v)
{ (void)k; (void)v; UNSUPPORTED(c); }
FMI2_Export fmi2Status fmi2GetBooleanStatus(Comp c, const fmi2StatusKind k, fmi2Boolean *v)
{ (void)k; (void)v; UNSUPPORTED(c); }
FMI2_Export fmi2Status fmi2GetStringStatus(Comp c, const fmi2StatusKind k, fmi2String *v)
{ (void)k; (void)v; UNSUPPORTED(c); }
"""

_CONTROLLER_FIELDS = """    aftc_state s;
    aftc_params p;
    double y[AFTC_NY], r[AFTC_NR], u[AFTC_NU];
    long k; /* the next sample is t0 + k sample_time */"""


def wrapper(
    *, guid: str, refs: list[str], n_in: int, n_out: int, includes: str, fields: str, part: str
) -> str:
    """The FMI 2.0 co-simulation wrapper: the head (``Instance`` with ``fields``, the value
    references ``refs``), the part (``part_init``, ``part_start``, ``part_step``) and the FMI
    functions."""
    cases = "\n".join(f"    case {vr}: return &{r};" for vr, r in enumerate(refs))
    head = _HEAD
    for key, value in (("GUID", guid), ("NIN", n_in), ("NOUT", n_out), ("INCLUDES", includes)):
        head = head.replace(f"@{key}@", str(value))
    head = head.replace("@FIELDS@", fields).replace("@CASES@", cases)
    return head + part + _COMMON


def _wrapper(lib: _Library, guid: str, refs: list[str], nvars: int) -> str:
    return wrapper(
        guid=guid,
        refs=refs,
        n_in=lib.nx + 3 * lib.p,
        n_out=lib.m + (lib.ny - lib.nx),
        includes='#include "aftc.h"',
        fields=_CONTROLLER_FIELDS,
        part=_CONTROLLER_PART,
    )
