"""Campaign spec files (TOML): a base scenario, the designs to compare, N, a seed and
distributions over failures, initial state, reference amplitude and gains.

The format is described in ``docs/campaigns.md``. Like scenario files, a spec is validated as a
whole before anything runs; unlike them, *every* problem is reported at once (one line each) in
a single :class:`CampaignError`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from adaptive_ftc import _version, baselines
from adaptive_ftc.campaigns.activity import (
    ACTIVITY_SUCCESS_KEYS,
    ActivityCriterion,
    parse_activity,
)
from adaptive_ftc.campaigns.checks import (
    _PLACEHOLDER,
    MAX_CHUNK_SIZE,
    MAX_CHUNKS,
    MAX_RUNS,
    _check_kept_overlap,
    _fill,
    _inline_base,
    _short,
    _top_numbers,
    safe_name,
)
from adaptive_ftc.campaigns.hardware import HardwareSpec, parse_hardware
from adaptive_ftc.errors import (
    CampaignError,
    ConfigurationError,
    ExpressionError,
    ScenarioError,
    did_you_mean,
)
from adaptive_ftc.registry import FAILURE_MODELS
from adaptive_ftc.scenarios.loader import MAX_FILE_BYTES, Scenario, load_scenario
from adaptive_ftc.sim.budget import check_run_size
from adaptive_ftc.sim.system import ClosedLoop

__all__ = [
    "DESIGN_VARIANTS",
    "EXAMPLES",
    "CampaignError",
    "CampaignSpec",
    "Dist",
    "FailureModelSpec",
    "MAX_CHUNKS",
    "MAX_CHUNK_SIZE",
    "MAX_RUNS",
    "list_campaigns",
    "load_campaign",
    "register_design",
]

#: Folder of the example campaigns shipped with the package.
EXAMPLES = Path(__file__).with_name("examples")

_COMMON = ("actuator", "onset", "recovery", "ramp")
_TOP = {"name", "title", "description", "base", "runs", "seed", "chunk_size", "designs"}
_TOP |= {"duration", "success", "failures", "ranges", "hardware", "allocation"}
_FAILURE_KEYS = {"keep_base", "count", "actuators", "onset", "ramp"}
_FAILURE_KEYS |= {"recovery_probability", "duration", "models", "annunciated", "detection_delay"}
_FAILURE_KEYS |= {"false_alarm", "false_alarm_time"}
_SUCCESS_KEYS = {"rms_error_final", "final_window", "recovery_tolerance", *ACTIVITY_SUCCESS_KEYS}
_RANGE_KEYS = {"initial_state", "reference_amplitude", "gains"}
_TEXT_KEYS = ("name", "title", "description")


def _constraint_aware(loop: ClosedLoop) -> ClosedLoop:
    """The base design with its constraint-aware option derived from the member's hardware
    (:meth:`~adaptive_ftc.controllers.ConstraintAware.from_loop`: the designer knows the
    drawn lag, rate limit, travel, sample time and noise, not the failures)."""
    from adaptive_ftc.controllers import ConstraintAware

    ctrl = dataclasses.replace(loop.controller, constraint_aware=ConstraintAware.from_loop(loop))
    return dataclasses.replace(loop, controller=ctrl)


def _thesis_law(loop: ClosedLoop) -> ClosedLoop:
    """The base design without any constraint-aware option (the thesis law)."""
    ctrl = dataclasses.replace(loop.controller, constraint_aware=None)
    return dataclasses.replace(loop, controller=ctrl)


def _has_option(loop: ClosedLoop) -> bool:
    """Whether the loop's design has the constraint-aware option (a ``constraint_aware``
    field: every adaptive design of :mod:`adaptive_ftc.controllers`)."""
    ctrl = loop.controller
    return dataclasses.is_dataclass(ctrl) and any(
        f.name == "constraint_aware" for f in dataclasses.fields(ctrl)
    )


def _oracle_model(loop: ClosedLoop) -> ClosedLoop:
    """:func:`_constraint_aware`'s loop as the oracles run it: the same designer's model, but
    each command through the smoothing second-order command filter, never the discrete
    limiter with per-actuator travel of the single-output law (round 7,
    :attr:`~adaptive_ftc.controllers.ConstraintAware.per_actuator` ``False``). That limiter
    passes a sampled command on unsmoothed; the law smooths its own, the oracle's exact inverse
    does not: on the first 100 ``hypersonic-hardware`` members the oracle succeeds on 84 with it
    (its command over the fast-content limit at 200 Hz) and on 99 without (session 13; those
    100 rows are bit for bit session 12's oracle)."""
    from adaptive_ftc.controllers import ConstraintAware

    model = dataclasses.replace(ConstraintAware.from_loop(loop), per_actuator=False)
    ctrl = dataclasses.replace(loop.controller, constraint_aware=model)
    return dataclasses.replace(loop, controller=ctrl)


def _oracle(loop: ClosedLoop) -> ClosedLoop:
    """The oracle under the same hardware *and the same feedback design* as the member's
    ``constraint-aware`` design (issue 25, item 3; session 13):
    :func:`~adaptive_ftc.baselines.oracle` of :func:`_constraint_aware`'s loop with
    ``law_feedback``, i.e. :class:`~adaptive_ftc.controllers.OracleInverse` with that law
    (``law``): the exact inverse of the known (failed) plant where the law has its adaptation,
    beside the law's own command filter, smoothing of the robust term (per output on the MIMO
    law), placed PID and lead, per-output floors and measurement filters, all derived from the
    member's drawn hardware (the command filter the smoothing one: :func:`_oracle_model`). Its
    result is "how good could a controller that knows the failure
    be on this hardware": where it fails too, the member is evidence of an infeasible draw, not
    of a weak law. A base design without the constraint-aware option gets
    :func:`_oracle_plain`. On ideal hardware the model is ideal and the oracle is the
    thesis-gain one."""
    if not _has_option(loop):
        return baselines.oracle(loop)
    return baselines.oracle(_oracle_model(loop), law_feedback=True)


def _oracle_filtered(loop: ClosedLoop) -> ClosedLoop:
    """The campaigns' ``oracle`` of session 12, kept as ``oracle-filtered``:
    :func:`~adaptive_ftc.baselines.oracle` of :func:`_constraint_aware`'s loop without the
    law's feedback design, i.e. feedback linearisation knowing the failure with the designer's
    model's command filter, smoothing (the shared rule's, one for every output) and
    measurement filters, but none of the law's fixed feedback (placed PID and lead, MIMO
    floor). Weaker than the law itself on wing rock and the spacecraft (docs/hardware.md)."""
    return baselines.oracle(_oracle_model(loop) if _has_option(loop) else loop)


def _oracle_plain(loop: ClosedLoop) -> ClosedLoop:
    """The oracle with the thesis's gains and no designer's model (the campaigns' ``oracle``
    before issue 25's fair oracle): feedback linearisation knowing the failure, on the
    member's drawn hardware with no command filter; under lags, rate limits, sampling and
    noise its command chatters, so it is no yardstick there (kept for comparison)."""
    if not _has_option(loop):
        return baselines.oracle(loop)
    return baselines.oracle(loop, constraint_aware=None)


#: Designs a campaign can compare, by name: a function of the member's closed loop (base
#: design, drawn failures and hardware). ``adaptive`` is the base scenario's design as it is;
#: ``thesis-law`` and ``constraint-aware`` are that design without / with the constraint-aware
#: option (derived from each member's drawn hardware); ``oracle`` knows the failure and runs
#: under the same designer's model and fixed feedback as ``constraint-aware`` (:func:`_oracle`),
#: ``oracle-filtered`` under that model without the law's fixed feedback (session 12's
#: ``oracle``, :func:`_oracle_filtered`), ``oracle-plain`` is the thesis-gain oracle with no
#: command filter (:func:`_oracle_plain`); the others are
#: the baselines of :mod:`adaptive_ftc.baselines`. A user adds designs with
#: :func:`register_design`.
DESIGN_VARIANTS: dict[str, Callable[[ClosedLoop], ClosedLoop]] = {
    "adaptive": lambda loop: loop,
    "frozen": lambda loop: loop.frozen(),
    "thesis-law": _thesis_law,
    "constraint-aware": _constraint_aware,
    "fixed-gain": baselines.campaign_fixed_gain,
    "nominal-inverse": baselines.nominal_inverse,
    "oracle": _oracle,
    "oracle-filtered": _oracle_filtered,
    "oracle-plain": _oracle_plain,
}
#: Designs that need an adaptive base design with the ``constraint_aware`` option.
_OPTION_DESIGNS = ("thesis-law", "constraint-aware")


def register_design(name: str, make: Callable[[ClosedLoop], ClosedLoop]) -> None:
    """Make a design variant available to campaigns under ``name``.

    ``make`` turns the member's closed loop (base design, drawn failures) into the loop to
    simulate, e.g. ``lambda loop: loop.frozen()``.
    """
    if not callable(make):
        raise ConfigurationError(f"register_design('{name}', ...) needs a callable; got {make!r}.")
    DESIGN_VARIANTS[str(name)] = make


# ---------------------------------------------------------------------------- distributions
_KINDS = ("constant", "uniform", "loguniform", "normal", "integers", "choice")


@dataclass(frozen=True)
class Dist:
    """A distribution of one drawn value: ``constant``, ``uniform [a, b]``, ``loguniform [a, b]``,
    ``normal [mean, sd]`` (optionally clipped), ``integers [a, b]`` (inclusive) or ``choice``.

    Examples
    --------
    >>> d = Dist("uniform", (0.1, 0.9))
    >>> d.support()
    (0.1, 0.9)
    >>> 0.1 <= d.draw(np.random.default_rng(0)) <= 0.9
    True
    """

    kind: str
    args: tuple = ()
    weights: tuple[float, ...] | None = None
    clip: tuple[float, float] | None = None

    def draw(self, rng: np.random.Generator) -> Any:
        """One value (always consumes the generator the same way for a given kind)."""
        a = self.args
        if self.kind == "constant":
            return a[0]
        if self.kind == "vector":
            return tuple(d.draw(rng) for d in a)
        if self.kind == "uniform":
            return float(rng.uniform(a[0], a[1]))
        if self.kind == "loguniform":
            return float(math.exp(rng.uniform(math.log(a[0]), math.log(a[1]))))
        if self.kind == "normal":
            v = float(rng.normal(a[0], a[1]))
            return float(min(max(v, self.clip[0]), self.clip[1])) if self.clip else v
        if self.kind == "integers":
            return int(rng.integers(a[0], a[1], endpoint=True))
        p = None
        if self.weights is not None:
            w = np.asarray(self.weights, dtype=float)
            p = w / w.sum()
        return a[int(rng.choice(len(a), p=p))]

    def support(self) -> tuple[Any, ...]:
        """The extreme values a draw can take (every value for ``choice``/``constant``)."""
        if self.kind in ("constant", "choice"):
            return tuple(self.args)
        if self.kind == "vector":  # the all-low and the all-high vectors
            return (
                tuple(d.support()[0] for d in self.args),
                tuple(d.support()[-1] for d in self.args),
            )
        if self.kind == "normal":
            return tuple(self.clip) if self.clip else (-math.inf, math.inf)
        return (self.args[0], self.args[1])

    def scale(self) -> float:
        """Largest magnitude of the support (used to normalise severities)."""
        vals = [abs(v) for v in self.support() if isinstance(v, (int, float))]
        return max(vals) if vals else 1.0


def _number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _dist(
    value: Any,
    where: str,
    problems: list[str],
    *,
    numeric: bool = True,
    vector: bool = False,
    bounded: bool = False,
) -> Dist:
    """Parse a TOML value into a :class:`Dist`; record problems instead of raising.

    ``vector``: a list is a vector of distributions (a vector field of a failure model);
    elsewhere a list is refused. ``bounded``: the value feeds a model with a domain (failure
    fields and params, gains, the reference amplitude), so a ``normal`` needs ``clip``.
    """
    if _number(value) or (not numeric and isinstance(value, str)):
        return Dist("constant", (value,))
    if isinstance(value, list):  # a vector field (e.g. ParameterisedStuck coefficients)
        if not vector:
            problems.append(
                f"[{where}] must be one number or one distribution table such as "
                f"{{uniform = [a, b]}}, not a list; got {_short(value)}."
            )
            return Dist("constant", (0.0,))
        if not value:
            problems.append(f"[{where}] an empty list draws nothing; give at least one value.")
            return Dist("constant", (0.0,))
        items = tuple(
            _dist(v, f"{where}.{i + 1}", problems, numeric=numeric, bounded=bounded)
            for i, v in enumerate(value)
        )
        return Dist("vector", items)
    if not isinstance(value, dict):
        problems.append(
            f"[{where}] must be a number or a table such as {{uniform = [a, b]}}; got "
            f"{_short(value)}."
        )
        return Dist("constant", (0.0,))
    kinds = [k for k in value if k in _KINDS]
    extra = set(value) - set(_KINDS) - {"weights", "clip"}
    if len(kinds) != 1 or extra:
        bad = sorted(extra) or kinds
        hint = did_you_mean(bad[0], _KINDS) if bad else ""
        problems.append(
            f"[{where}] needs exactly one of {', '.join(_KINDS)} (plus `weights` for choice, "
            f"`clip` for normal); got keys {sorted(map(str, value))}.{hint}"
        )
        return Dist("constant", (0.0,))
    kind = kinds[0]
    for key, owner in (("weights", "choice"), ("clip", "normal")):
        if key in value and kind != owner:
            problems.append(f"[{where}] `{key}` only applies to `{owner}`, not to `{kind}`.")
    args = value[kind]
    args = tuple(args) if isinstance(args, list) else (args,)
    if kind == "choice":
        w = value.get("weights")
        if w is not None and (
            not isinstance(w, list)
            or len(w) != len(args)
            or not all(_number(x) and x >= 0 for x in w)
            or sum(w) <= 0
        ):
            problems.append(f"[{where}] `weights` must be {len(args)} numbers >= 0, not all 0.")
            w = None
        if not args:
            problems.append(f"[{where}] `choice` needs at least one value.")
            return Dist("constant", (0.0,))
        if numeric and not all(_number(a) for a in args):
            problems.append(f"[{where}] `choice` values must be finite numbers; got {list(args)}.")
            return Dist("constant", (0.0,))
        return Dist("choice", args, tuple(float(x) for x in w) if w else None)
    if len(args) != 2 or not all(_number(a) for a in args):
        problems.append(f"[{where}] `{kind}` needs two finite numbers [a, b]; got {list(args)}.")
        return Dist("constant", (0.0,))
    a, b = args
    if kind == "normal":
        clip = value.get("clip")
        if b <= 0:
            problems.append(f"[{where}] the standard deviation of `normal` must be > 0; got {b}.")
        if clip is not None:
            if not (isinstance(clip, list) and len(clip) == 2 and all(map(_number, clip))):
                problems.append(f"[{where}] `clip` must be two numbers [lo, hi].")
                clip = None
            elif clip[0] >= clip[1]:
                problems.append(f"[{where}] `clip` needs lo < hi; got {clip}.")
        elif bounded:
            problems.append(
                f"[{where}] `normal` without `clip` draws values without bound, which can leave "
                "the model's domain at run time (e.g. a negative effectiveness). Add "
                f"`clip = [lo, hi]` inside the domain, e.g. {{normal = [{a}, {b}], clip = "
                "[0, 1]} for an effectiveness, or use `uniform`."
            )
        return Dist("normal", (float(a), float(b)), clip=tuple(clip) if clip else None)
    if a > b:
        problems.append(f"[{where}] `{kind}` needs a <= b; got [{a}, {b}].")
    if kind == "loguniform" and a <= 0:
        problems.append(f"[{where}] `loguniform` needs a > 0; got [{a}, {b}].")
    if kind == "integers":
        if not all(float(x).is_integer() for x in args):
            problems.append(f"[{where}] `integers` needs whole numbers; got {list(args)}.")
        return Dist("integers", (int(a), int(b)))
    return Dist(kind, (float(a), float(b)))


# ---------------------------------------------------------------------------- failure models
@dataclass(frozen=True)
class FailureModelSpec:
    """How to draw one failure model: its weight in the mix, a distribution per field of the
    failure class, extra ``params`` for ``{name}`` placeholders in expression fields, and the
    drawn value that measures the severity."""

    model: str
    weight: float
    fields: tuple[tuple[str, Dist], ...]
    params: tuple[tuple[str, Dist], ...] = ()
    severity: str | None = None


def _model_spec(name: str, table: Any, problems: list[str]) -> FailureModelSpec | None:
    where = f"failures.models.{name}"
    if name not in FAILURE_MODELS:
        problems.append(
            f"[{where}] unknown failure model '{name}'.{did_you_mean(name, FAILURE_MODELS)} "
            f"Available: {', '.join(FAILURE_MODELS)}."
        )
        return None
    if not isinstance(table, dict):
        problems.append(f"[{where}] must be a table.")
        return None
    cls = FAILURE_MODELS[name]
    own = {f.name: f for f in dataclasses.fields(cls) if f.init and f.name not in _COMMON}
    allowed = set(own) | {"weight", "params", "severity"}
    for key in table:
        if key not in allowed:
            problems.append(
                f"[{where}] unknown key '{key}'.{did_you_mean(key, allowed)} "
                f"Allowed keys: {', '.join(sorted(allowed))}."
            )
    weight = table.get("weight", 1.0)
    if not _number(weight) or weight < 0:
        problems.append(f"[{where}] `weight` must be a number >= 0; got {weight!r}.")
        weight = 0.0
    params_t = table.get("params", {})
    if not isinstance(params_t, dict):
        problems.append(f"[{where}.params] must be a table of distributions.")
        params_t = {}
    params = []
    for k, v in params_t.items():
        if not _PLACEHOLDER.fullmatch(f"{{{k}}}"):
            problems.append(
                f"[{where}.params] `{_short(k)}` is not a usable placeholder name: use letters, "
                "digits and _ (not starting with a digit)."
            )
            continue
        params.append((k, _dist(v, f"{where}.params.{k}", problems, bounded=True)))
    fields = []
    for key, f in own.items():
        if key not in table:
            continue
        text_ok = any(t in str(f.type) for t in ("Value", "str"))
        d = _dist(
            table[key], f"{where}.{key}", problems, numeric=not text_ok, vector=True, bounded=True
        )
        fields.append((key, d))
    sev = table.get("severity")
    names = [k for k, _ in fields] + [k for k, _ in params]
    if sev is not None and sev not in names:
        problems.append(
            f"[{where}] `severity` must name a drawn field or param ({', '.join(names) or 'none'});"
            f" got {sev!r}."
        )
        sev = None
    spec = FailureModelSpec(name, float(weight), tuple(fields), tuple(params), sev)
    _check_extremes(spec, problems)
    return spec


def _check_extremes(spec: FailureModelSpec, problems: list[str]) -> None:
    """Build the failure at the extremes of every distribution: an impossible value (negative
    effectiveness, ...) is refused now instead of in the middle of the campaign."""
    cls = FAILURE_MODELS[spec.model]
    lows = {k: d.support()[0] for k, d in spec.params}
    base = {k: d.support()[0] for k, d in spec.fields}
    cases = [(base, lows)]
    for key, d in spec.fields:
        for v in d.support():
            cases.append(({**base, key: v}, lows))
    for key, d in spec.params:  # each drawn param at each end of its range
        for v in d.support():
            cases.append((base, {**lows, key: v}))
    seen = set()
    for case, params in cases:
        try:
            kwargs = {
                k: _fill(v, params, f"failures.models.{spec.model}.{k}") for k, v in case.items()
            }
            cls(actuator=1, onset=0.0, **kwargs)
        except CampaignError as exc:  # a placeholder problem: already names its field
            if str(exc) not in seen:
                seen.add(str(exc))
                problems.append(str(exc))
        except (ConfigurationError, ExpressionError, ValueError, TypeError) as exc:
            msg = str(exc)
            if msg not in seen:
                seen.add(msg)
                problems.append(f"[failures.models.{spec.model}] impossible draw: {msg}")


# ---------------------------------------------------------------------------- the spec
@dataclass(frozen=True)
class CampaignSpec:
    """A validated campaign: base scenario, designs, N, seed and the distributions.

    Build it with :func:`load_campaign`. ``data`` is the self-contained spec (base scenario
    inlined when it is a file) that is saved next to the results and hashed to recognise a
    campaign when it resumes.
    """

    name: str
    title: str
    base: Scenario
    designs: tuple[str, ...]
    runs: int
    seed: int
    chunk_size: int
    t_final: float
    count: Dist
    actuators: tuple[int, ...]
    onset: Dist
    ramp: Dist
    recovery_probability: float
    duration: Dist
    models: tuple[FailureModelSpec, ...]
    keep_base: bool
    initial_state: tuple[tuple[int, Dist], ...]
    reference_amplitude: Dist | None
    gains: tuple[tuple[str, Dist], ...]
    success_rms: float
    final_window: float
    recovery_tolerance: float
    data: dict[str, Any] = field(compare=False, repr=False)
    hardware: HardwareSpec | None = None
    #: the activity part of the success criterion (``None``: tracking only)
    activity: ActivityCriterion | None = None
    #: the allocators the designs name (``"adaptive+wls"``), by kind (``None``: fixed)
    allocators: tuple[tuple[str, Any], ...] = ()
    #: probability that a drawn failure is annunciated (``None``: not drawn, all silent)
    annunciated: float | None = None
    #: the detector's delay, drawn once per member (annunciated failures only)
    detection_delay: Dist | None = None
    #: probability that a member's detector reports a healthy actuator (``None``: never)
    false_alarm: float | None = None
    #: when a false alarm is raised
    false_alarm_time: Dist | None = None

    @property
    def allocation_columns(self) -> bool:
        """Whether the table has the allocation columns (``allocator``, ``annunciated``,
        ``detection_delay``, ``false_alarm``, ``false_alarm_time``, ``reachable``,
        ``reachability``): a design names an allocator, the failures can be annunciated or
        the detector can raise a false alarm."""
        return bool(self.allocators) or self.annunciated is not None or self.false_alarm is not None

    def allocator_kind(self, design: str) -> str:
        """The allocator of ``design``: its ``+kind`` suffix, else the base scenario's."""
        if "+" in design:
            return design.split("+", 1)[1]
        alloc = self.base.loop.allocator
        return "fixed" if alloc is None else str(getattr(type(alloc), "kind", "fixed"))

    @property
    def solver(self):
        """The solver every member runs with: the base scenario's, recording fine enough to
        judge the activity (:func:`~adaptive_ftc.sim.activity.max_record_dt` of the smallest
        sample time the campaign can draw) when the success criterion judges it."""
        solver = self.base.solver
        if self.activity is None:
            return solver
        from adaptive_ftc.sim.activity import max_record_dt

        times = [self.base.loop.sample_time]
        if self.hardware is not None and self.hardware.sample_time is not None:
            times += [float(v) for v in self.hardware.sample_time.support()]
        positive = [t for t in times if t > 0]
        dt = max_record_dt(1.0, min(positive) if positive else 0.0)
        if solver.record_dt is not None and solver.record_dt <= dt:
            return solver
        return dataclasses.replace(solver, record_dt=dt)

    def success_text(self) -> str:
        """The success criterion in words, with its numbers."""
        text = (
            f"completed and final-window ({self.final_window:g} s) RMS error <= "
            f"{self.success_rms:g}"
        )
        if self.activity is not None:
            text += "; " + self.activity.describe(self)
        return text

    @property
    def loop(self) -> ClosedLoop:
        """The base closed loop (duration overridden by the spec)."""
        return dataclasses.replace(self.base.loop, t_final=self.t_final)

    @property
    def n_chunks(self) -> int:
        """Number of part files the results are written in."""
        return -(-self.runs // self.chunk_size)

    @property
    def max_failures(self) -> int:
        """Largest number of drawn failures per member (width of the table)."""
        return int(max(self.count.support()))

    def digest(self) -> str:
        """SHA-256 of the self-contained spec and the package version: same digest, same
        campaign computed by the same code (a resume after an upgrade is refused)."""
        # key order matters (the model mix is drawn in spec order), so it is not sorted
        text = json.dumps(self.data, default=str)
        text = f"adaptive-ftc {_version.__version__}\n{text}"
        return hashlib.sha256(text.encode()).hexdigest()


def list_campaigns() -> list[str]:
    """Names of the example campaigns shipped with the package."""
    return sorted(p.stem for p in EXAMPLES.glob("*.toml"))


def _resolve(name_or_path: str | Path) -> Path:
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.exists():
        if not p.is_file():
            raise CampaignError(f"Campaign spec '{p}' does not exist.")
        return p
    candidate = EXAMPLES / f"{name_or_path}.toml"
    if candidate.is_file():
        return candidate
    names = list_campaigns()
    raise CampaignError(
        f"Unknown campaign '{name_or_path}'.{did_you_mean(str(name_or_path), names)} "
        f"Examples: {', '.join(names)}; or give a path to a .toml file."
    )


def load_campaign(
    spec: str | Path | dict[str, Any], *, base_dir: Path | None = None
) -> CampaignSpec:
    """Load and validate a campaign spec (example name, TOML path, or parsed dict).

    Raises
    ------
    CampaignError
        Listing every problem of the spec, one line each, before anything runs.

    Examples
    --------
    >>> spec = load_campaign("hypersonic-loe")
    >>> spec.designs
    ('adaptive', 'nominal-inverse', 'fixed-gain', 'frozen')
    """
    if isinstance(spec, dict):
        data, label = dict(spec), "campaign"
        base_dir = base_dir or Path.cwd()
    else:
        path = _resolve(spec)
        try:
            size = path.stat().st_size
            if size > MAX_FILE_BYTES:
                raise CampaignError(
                    f"{path}: the file has {size} bytes; campaign specs are limited to "
                    f"{MAX_FILE_BYTES} bytes."
                )
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except tomllib.TOMLDecodeError as exc:
            raise CampaignError(f"{path}: not valid TOML: {exc}.") from None
        except UnicodeDecodeError:
            raise CampaignError(f"{path}: not UTF-8 text; save the spec as UTF-8.") from None
        except OSError as exc:
            raise CampaignError(f"{path}: cannot read the file: {exc.strerror}.") from None
        except (ValueError, RecursionError, MemoryError) as exc:
            raise CampaignError(
                f"{path}: not a usable TOML file ({type(exc).__name__}: {str(exc)[:200]})."
            ) from None
        label, base_dir = str(path), path.parent
    problems: list[str] = []
    spec_obj = _parse(data, base_dir, problems)
    if problems:
        lines = "\n".join(f"  - {p}" for p in problems)
        raise CampaignError(f"{label}: {len(problems)} problem(s), nothing was run:\n{lines}")
    assert spec_obj is not None
    return spec_obj


def _parse(data: dict[str, Any], base_dir: Path, problems: list[str]) -> CampaignSpec | None:
    for key in data:
        if key not in _TOP:
            problems.append(
                f"[top] unknown key {_short(key)}.{did_you_mean(str(key), _TOP)} "
                f"Allowed keys: {', '.join(sorted(_TOP))}."
            )
    for key in _TEXT_KEYS:
        if key in data and not isinstance(data[key], str):
            problems.append(f"[top] `{key}` must be a text; got {_short(data[key])}.")
    if isinstance(data.get("name"), str) and not safe_name(data["name"]):
        problems.append(
            f"[top] `name` {_short(data['name'])} is used in file names: use 1-100 letters, "
            "digits, '.', '_' or '-', not starting with '.' or '-'."
        )
    # base scenario: a catalogue name, a file (relative to the spec) or an inlined scenario
    base = data.get("base")
    saved = dict(data)
    scenario = None
    try:
        if isinstance(base, dict):  # inlined by a previous save
            scenario = _inline_base(base, problems)
        elif isinstance(base, str):
            candidate = (base_dir / base) if base.endswith(".toml") else None
            if candidate is not None and candidate.is_file():
                scenario = load_scenario(candidate)
                saved["base"] = {"name": candidate.stem, "text": candidate.read_text("utf-8")}
            else:
                scenario = load_scenario(base)
        elif base is None:
            problems.append("[top] missing key 'base' (a catalogue scenario name or a .toml path).")
        else:
            problems.append(
                f"[top] `base` must be a catalogue scenario name or a .toml path; got "
                f"{_short(base)}."
            )
    except ScenarioError as exc:  # the base scenario itself is broken
        problems.append(f"[base] {exc}")
    available = list(DESIGN_VARIANTS) + _allocated_designs(data.get("designs"), problems)
    runs, seed, chunk, designs = _top_numbers(data, problems, available)
    if scenario is None:
        return None
    loop = scenario.loop
    m, n = loop.plant.n_actuators, loop.plant.n_states
    name = data["name"] if isinstance(data.get("name"), str) else "campaign"
    t_final = data.get("duration", loop.t_final)
    if not _number(t_final) or t_final <= loop.t0:
        problems.append(f"[top] `duration` must be a time > {loop.t0} s; got {_short(t_final)}.")
        t_final = loop.t_final
    else:
        try:  # each run of the campaign must fit the run-size budget
            check_run_size(dataclasses.replace(loop, t_final=float(t_final)), scenario.solver)
        except ConfigurationError as exc:
            problems.append(f"[top] `duration = {t_final:g}` s: {exc}")
            t_final = loop.t_final
    # success criterion
    st = data.get("success", {})
    _keys(st, _SUCCESS_KEYS, "success", problems)
    succ: dict[str, float] = {}
    for key, default in (
        ("rms_error_final", None),
        ("final_window", 0.1 * (t_final - loop.t0)),
        ("recovery_tolerance", None),
    ):
        v = st.get(key, default) if isinstance(st, dict) else default
        if key == "rms_error_final" and v is None:
            problems.append(
                "[success] missing `rms_error_final` (final-window RMS error below which a run "
                "counts as a success)."
            )
            v = 1.0
        if v is None:
            v = succ["rms_error_final"]
        if not _number(v) or v <= 0:
            problems.append(f"[success] `{key}` must be a positive number; got {v!r}.")
            v = 1.0
        succ[key] = float(v)
    activity = parse_activity(st if isinstance(st, dict) else {}, problems)
    bad_designs = [d for d in designs if d in _OPTION_DESIGNS]
    if bad_designs and not any(
        f.name == "constraint_aware" for f in dataclasses.fields(loop.controller)
    ):
        problems.append(
            f"[top] design(s) {', '.join(bad_designs)} need an adaptive base design with the "
            f"constraint-aware option; design '{loop.controller.design}' of the base has none. "
            "Use 'adaptive' or a base scenario with an adaptive design."
        )
    if succ["final_window"] >= t_final - loop.t0:
        problems.append(
            f"[success] `final_window` ({succ['final_window']:g} s) must be shorter than the run "
            f"({t_final:g} s)."
        )
    # failures
    ft = data.get("failures", {})
    _keys(ft, _FAILURE_KEYS, "failures", problems)
    ft = ft if isinstance(ft, dict) else {}
    acts = ft.get("actuators", list(range(1, m + 1)))
    if not isinstance(acts, list) or not acts:
        problems.append(f"[failures] `actuators` must be a list of actuator numbers; got {acts!r}.")
        acts = list(range(1, m + 1))
    for a in acts:
        if isinstance(a, bool) or not isinstance(a, int) or not 1 <= a <= m:
            problems.append(
                f"[failures] unknown actuator {a!r}: plant '{loop.plant.name}' has actuators "
                f"1..{m} ({', '.join(loop.plant.actuator_names)})."
            )
    n_listed = len(set(map(str, acts)))  # a bad actuator is reported once, not as a count
    acts = sorted({a for a in acts if isinstance(a, int) and 1 <= a <= m}) or [1]
    count = _dist(ft.get("count", 1), "failures.count", problems)
    if count.kind not in ("constant", "integers", "choice") or not all(
        float(v).is_integer() for v in count.support()
    ):
        problems.append("[failures.count] must be a whole number or {integers = [a, b]}.")
        count = Dist("constant", (1,))
    lo_c, hi_c = min(count.support()), max(count.support())
    if lo_c < 0 or hi_c > n_listed:
        problems.append(
            f"[failures.count] must stay in [0, {n_listed}] (the number of candidate "
            f"actuators); got [{lo_c}, {hi_c}]."
        )
        count = Dist("constant", (min(max(int(hi_c), 0), len(acts)),))
    onset = _dist(
        ft.get("onset", {"uniform": [loop.t0, 0.5 * t_final]}), "failures.onset", problems
    )
    o_lo, o_hi = min(onset.support()), max(onset.support())
    if o_lo < loop.t0:
        problems.append(
            f"[failures.onset] onsets must be >= {loop.t0} s; the range starts at {o_lo}."
        )
    if o_hi >= t_final:
        problems.append(
            f"[failures.onset] onset after the end: the range reaches {o_hi} s but runs end at "
            f"{t_final:g} s. Lower the upper bound below the duration."
        )
    ramp = _dist(ft.get("ramp", 0.0), "failures.ramp", problems)
    if min(ramp.support()) < 0:
        problems.append(f"[failures.ramp] ramps must be >= 0 s; got {min(ramp.support())}.")
    prob = ft.get("recovery_probability", 0.0)
    if not _number(prob) or not 0 <= prob <= 1:
        problems.append(f"[failures] `recovery_probability` must be in [0, 1]; got {prob!r}.")
        prob = 0.0
    duration = _dist(ft.get("duration", 10.0), "failures.duration", problems)
    if min(duration.support()) <= 0:
        problems.append(
            f"[failures.duration] time to recovery must be > 0 s; got {min(duration.support())}."
        )
    mt = ft.get("models", {})
    if not isinstance(mt, dict) or (not mt and hi_c > 0):
        problems.append(
            "[failures.models] needs at least one model table, e.g. "
            "[failures.models.loss_of_effectiveness] with `effectiveness = {uniform = [0, 1]}`."
        )
        mt = {}
    models = tuple(s for k, v in mt.items() if (s := _model_spec(k, v, problems)) is not None)
    if models and sum(s.weight for s in models) <= 0:
        problems.append("[failures.models] the model weights are all 0.")
    # ranges over initial state, reference amplitude, gains
    rt = data.get("ranges", {})
    _keys(rt, _RANGE_KEYS, "ranges", problems)
    rt = rt if isinstance(rt, dict) else {}
    x0 = rt.get("initial_state", [])
    if not isinstance(x0, list) or len(x0) > n:
        problems.append(
            f"[ranges] `initial_state` must list at most {n} values/distributions "
            f"({', '.join(loop.plant.state_names)})."
        )
        x0 = []
    x0d = tuple((i, _dist(v, f"ranges.initial_state.{i + 1}", problems)) for i, v in enumerate(x0))
    amp = rt.get("reference_amplitude")
    ampd = None
    if amp is not None:
        ampd = _dist(amp, "ranges.reference_amplitude", problems, bounded=True)
        lo_a = min(ampd.support())
        if lo_a <= 0:
            problems.append(
                "[ranges.reference_amplitude] the amplitude multiplies the base reference and "
                f"must be > 0 (0 leaves nothing to track, < 0 flips it); the range reaches "
                f"{lo_a}."
            )
    gt = rt.get("gains", {})
    if not isinstance(gt, dict):
        problems.append(
            f"[ranges.gains] must be a table of gain distributions, e.g. gains = {{gamma = "
            f"{{uniform = [0.5, 2]}}}}; got {_short(gt)}."
        )
        gt = {}
    ctrl_fields = {f.name for f in dataclasses.fields(loop.controller) if f.init} - {"regressor"}
    gains = []
    for key, v in gt.items():
        if key not in ctrl_fields:
            problems.append(
                f"[ranges.gains] unknown gain '{key}' of design "
                f"'{loop.controller.design}'.{did_you_mean(key, ctrl_fields)} "
                f"Available: {', '.join(sorted(ctrl_fields))}."
            )
            continue
        d = _dist(v, f"ranges.gains.{key}", problems, bounded=True)
        for value in d.support():
            try:
                dataclasses.replace(loop.controller, **{key: value})
            except (ConfigurationError, TypeError, ValueError) as exc:
                problems.append(f"[ranges.gains.{key}] impossible draw: {exc}")
                break
        gains.append((key, d))
    hardware = parse_hardware(
        data.get("hardware"),
        dataclasses.replace(loop, t_final=float(t_final)),
        scenario.solver,
        problems,
        _dist,
    )
    keep_base = ft.get("keep_base", False)
    if not isinstance(keep_base, bool):
        problems.append(f"[failures] `keep_base` must be true or false; got {_short(keep_base)}.")
        keep_base = False
    if keep_base and hi_c > 0:
        _check_kept_overlap(scenario, acts, onset, duration, prob, problems)
    allocators = _allocation(data.get("allocation"), designs, loop, problems)
    annunciated, delay = _annunciation(ft, problems)
    false_alarm, false_alarm_time = _false_alarm(ft, onset, loop, float(t_final), problems)
    if problems:
        return None
    return CampaignSpec(
        name=name,
        title=str(data.get("title", name)),
        base=scenario,
        designs=tuple(designs),
        runs=runs,
        seed=seed,
        chunk_size=chunk,
        t_final=float(t_final),
        count=count,
        actuators=tuple(acts),
        onset=onset,
        ramp=ramp,
        recovery_probability=float(prob),
        duration=duration,
        models=models,
        keep_base=keep_base,
        initial_state=x0d,
        reference_amplitude=ampd,
        gains=tuple(gains),
        success_rms=succ["rms_error_final"],
        final_window=succ["final_window"],
        recovery_tolerance=succ["recovery_tolerance"],
        data=saved,
        hardware=hardware,
        activity=activity,
        allocators=allocators,
        annunciated=annunciated,
        detection_delay=delay,
        false_alarm=false_alarm,
        false_alarm_time=false_alarm_time,
    )


def _keys(table: Any, allowed: set[str], where: str, problems: list[str]) -> None:
    if not isinstance(table, dict):
        problems.append(f"[{where}] must be a table; got {type(table).__name__}.")
        return
    for key in table:
        if key not in allowed:
            problems.append(
                f"[{where}] unknown key '{key}'.{did_you_mean(key, allowed)} "
                f"Allowed keys: {', '.join(sorted(allowed))}."
            )


# ---------------------------------------------------------------------------- allocation
def _allocated_designs(designs: Any, problems: list[str]) -> list[str]:
    """The ``design+kind`` names of ``designs`` (a design with an allocator of
    :mod:`adaptive_ftc.allocation`, e.g. ``"adaptive+wls"``); a bad part is reported here,
    naming the part and the choices."""
    from adaptive_ftc.allocation import ALLOCATORS

    out: list[str] = []
    for d in designs if isinstance(designs, list) else []:
        if not isinstance(d, str) or "+" not in d:
            continue
        out.append(d)
        design, kind = d.split("+", 1)
        if design not in DESIGN_VARIANTS:
            problems.append(
                f"[top] design {_short(d)}: unknown design '{design}' before the '+'."
                f"{did_you_mean(design, DESIGN_VARIANTS)} Available: "
                f"{', '.join(DESIGN_VARIANTS)}."
            )
        if kind not in ALLOCATORS:
            problems.append(
                f"[top] design {_short(d)}: unknown allocation kind '{kind}' after the '+'."
                f"{did_you_mean(kind, ALLOCATORS)} Use one of: {', '.join(ALLOCATORS)} "
                "(e.g. 'adaptive+wls')."
            )
    return out


def _allocation(
    table: Any, designs: list[str], loop: ClosedLoop, problems: list[str]
) -> tuple[tuple[str, Any], ...]:
    """The allocators the designs name (``design+kind``), by kind, built with the options of
    ``[allocation.<kind>]`` (``None`` for ``fixed``: the thesis's ``u = R^T u0``), each
    tried on the base loop."""
    from adaptive_ftc.allocation import ALLOCATORS, allocator_from_spec

    used = list(dict.fromkeys(d.split("+", 1)[1] for d in designs if "+" in d))
    tunable = [k for k in ALLOCATORS if k != "fixed"]
    options: dict[str, dict[str, Any]] = {}
    if table is not None:
        if not isinstance(table, dict):
            problems.append(
                f"[allocation] must be a table of allocator options, e.g. [allocation.adaptive] "
                f"with `gain = 5.0`; got {_short(table)}."
            )
            table = {}
        for kind, opts in table.items():
            if kind not in tunable:
                problems.append(
                    f"[allocation] unknown key {_short(kind)}.{did_you_mean(str(kind), tunable)} "
                    f"Options are given per allocation kind: {', '.join(tunable)} "
                    "(the fixed allocation has none)."
                )
            elif not isinstance(opts, dict):
                problems.append(
                    f"[allocation.{kind}] must be a table of the allocator's options; got "
                    f"{_short(opts)}."
                )
            elif kind not in used:
                problems.append(
                    f"[allocation.{kind}] options for an allocator no design uses: add "
                    f"'<design>+{kind}' to `designs` (e.g. 'adaptive+{kind}') or remove the table."
                )
            else:
                options[kind] = opts
    out: list[tuple[str, Any]] = []
    for kind in used:
        if kind not in ALLOCATORS:
            continue  # reported with the design
        try:
            alloc = None if kind == "fixed" else allocator_from_spec(kind, **options.get(kind, {}))
        except ConfigurationError as exc:
            problems.append(f"[allocation.{kind}] {exc}")
            continue
        out.append((kind, alloc))
        try:
            dataclasses.replace(loop, allocator=alloc)
        except ConfigurationError as exc:
            problems.append(f"[top] designs with '+{kind}': the base loop refuses it: {exc}")
    return tuple(out)


def _unused(ft: dict[str, Any], key: str, why: str, fix: str, problems: list[str]) -> None:
    """A ``[failures]`` key that means nothing without another one: a problem if given."""
    if ft.get(key) is not None:
        problems.append(f"[failures] `{key}` is given {why}: add {fix} or remove `{key}`.")


def _annunciation(ft: dict[str, Any], problems: list[str]) -> tuple[float | None, Dist | None]:
    """``[failures] annunciated`` (true, false or the probability that a drawn failure is
    reported to the allocator) and ``detection_delay`` (seconds from the onset: a number,
    ``[lo, hi]`` (uniform) or a distribution table, drawn once per member)."""
    known = ft.get("annunciated")
    delay = ft.get("detection_delay")
    if known is None:
        _unused(
            ft,
            "detection_delay",
            "but no failure is annunciated",
            "`annunciated = true` (or a probability such as 0.5)",
            problems,
        )
        return None, None
    if isinstance(known, bool):
        prob = 1.0 if known else 0.0
    elif _number(known) and 0 <= known <= 1:
        prob = float(known)
    else:
        problems.append(
            "[failures] `annunciated` must be true, false or the probability (0..1) that a "
            f"drawn failure is reported to the allocator; got {_short(known)}."
        )
        return None, None
    if delay is not None and prob == 0:
        problems.append(
            "[failures] `detection_delay` is given but `annunciated = false`: every failure is "
            "silent. Set `annunciated` to true or a probability, or remove `detection_delay`."
        )
    if isinstance(delay, list) and len(delay) == 2 and all(map(_number, delay)):
        delay = {"uniform": delay}  # [lo, hi]: uniform
    dist = _dist(0.0 if delay is None else delay, "failures.detection_delay", problems)
    lo = min(dist.support())
    if not lo >= 0:
        problems.append(
            f"[failures.detection_delay] delays must be >= 0 s (a detector reports after the "
            f"onset); the range reaches {lo}."
        )
    return prob, dist


def _false_alarm(
    ft: dict[str, Any], onset: Dist, loop: ClosedLoop, t_final: float, problems: list[str]
) -> tuple[float | None, Dist | None]:
    """``[failures] false_alarm``: the probability that the member's detector reports one
    healthy actuator (of the candidate ``actuators``, drawn uniformly) as failed, from
    ``false_alarm_time`` (default: the onset distribution) to the end of the run."""
    prob = ft.get("false_alarm")
    when = ft.get("false_alarm_time")
    if prob is None:
        _unused(
            ft,
            "false_alarm_time",
            "without `false_alarm`",
            "`false_alarm = 0.1` (the chance that a healthy actuator is reported failed)",
            problems,
        )
        return None, None
    if not _number(prob) or not 0 <= prob <= 1:
        problems.append(
            "[failures] `false_alarm` must be the probability (0..1) that a member's detector "
            f"reports a healthy actuator as failed; got {_short(prob)}."
        )
        return None, None
    if isinstance(when, list) and len(when) == 2 and all(map(_number, when)):
        when = {"uniform": when}  # [lo, hi]: uniform
    dist = onset if when is None else _dist(when, "failures.false_alarm_time", problems)
    lo, hi = min(dist.support()), max(dist.support())
    if lo < loop.t0 or hi >= t_final:
        problems.append(
            f"[failures.false_alarm_time] false alarms must fall in [{loop.t0:g}, {t_final:g}) "
            f"s, the run; the range is [{lo}, {hi}]."
        )
    return float(prob), dist
