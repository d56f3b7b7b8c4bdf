"""Generate, cache and load one compiled module per closed-loop *structure*.

A closed loop is split into its structure (which plant and design functions, regressor kinds
and sizes, the shapes of its expressions, the solver) and its numbers (gains, plant parameters,
failure values and times, initial state). The structure becomes the text of a Python module that
reads like hand-written code; the numbers travel as data. Two loops that differ only in numbers
share one module, compiled once and cached on disk.

Cache layout: ``<cache dir>/loops/loop_<key>.py`` (and ``integrators_<key>.py``, the
integrators every loop shares; ``gain_<key>.py``, a plant's control gain; ``pattern_<key>.py``,
a failure pattern) with numba's cache files in ``__pycache__`` beside it. The
key hashes the generated text, the source of every module it imports, and the numba and
package versions, so an edited part never runs stale code. The cache directory is
``$ADAPTIVE_FTC_CACHE_DIR``, else ``$XDG_CACHE_HOME/adaptive-ftc`` (``~/.cache/adaptive-ftc``);
when no directory is writable, loops are compiled in memory (slower first runs, same results).
Modules whose parts are not importable (functions defined in ``__main__`` or a notebook) are
compiled in memory too.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.util
import math
import os
import re
import sys
import tempfile
import threading
import types
from collections.abc import Mapping
from pathlib import Path

from adaptive_ftc._version import __version__
from adaptive_ftc.errors import ConfigurationError

__all__ = [
    "cache_dir",
    "importable",
    "compile_expression",
    "emit",
    "emit_at",
    "load_module",
    "stats",
    "template",
]

_BEGIN = "# --- template: begin ---"
_lock = threading.RLock()
_modules: dict[str, types.ModuleType] = {}
_kept: dict[str, tuple] = {}
_stats = {"generated": 0, "loaded": 0, "in_memory": 0}


def importable(obj) -> str:
    """``"module:name"`` when ``obj`` can be imported by name from a module file, else ``""``
    (functions and classes of ``__main__``, of a notebook, or defined inside a function)."""
    modname = getattr(obj, "__module__", None)
    qual = getattr(obj, "__qualname__", "")
    if modname in (None, "__main__") or "<" in qual or "." in qual:
        return ""
    try:
        module = importlib.import_module(modname)
    except Exception:  # noqa: BLE001 - e.g. code executed from a string
        return ""
    if not getattr(module, "__file__", None):
        return ""
    name = obj.__name__
    named = getattr(module, name, None)
    if named is obj:
        return f"{modname}:{name}"
    # a decorator such as ``@plant`` rebinds the name to an object that keeps the function
    # as ``equations`` (itself perhaps a numba dispatcher): import it through that object
    wrapped = getattr(named, "equations", None)
    if wrapped is not None and getattr(wrapped, "py_func", wrapped) is obj:
        return f"{modname}:{name}.equations"
    return ""


# ----------------------------------------------------------------------------- expressions
def emit(node, names: Mapping[str, str], consts: list[float], base: str = "o") -> str:
    """Python text of expression tree ``node`` with its numbers lifted into ``consts``.

    Every literal becomes ``c[<base> + k]`` (appended to ``consts``), so expressions that differ
    only in their numbers generate the same text. Small integer powers stay structural
    (``a**2`` -> ``a * a``), as the interpreter they replace evaluated them.
    """
    kind = node[0]
    if kind == "const":
        consts.append(float(node[1]))
        return f"c[{base} + {len(consts) - 1}]"
    if kind == "var":
        return names[node[1]]
    if kind == "neg":
        return f"(-{emit(node[1], names, consts, base)})"
    if kind == "bin":
        op, a, b = node[1], node[2], node[3]
        if op == "**" and b[0] == "const" and b[1] in (2.0, 3.0):
            x = emit(a, names, consts, base)
            return f"({x} * {x})" if b[1] == 2.0 else f"({x} * {x} * {x})"
        ta = emit(a, names, consts, base)
        tb = emit(b, names, consts, base)
        if op == "**":
            return f"g_pow({ta}, {tb})"
        return f"({ta} {op} {tb})"
    from adaptive_ftc.sim.mathlib import FUNCTIONS

    args = ", ".join(emit(a, names, consts, base) for a in node[2])
    return f"{FUNCTIONS[node[1]]}({args})"


def emit_at(
    node, names: Mapping[str, str], consts: list[float], *, share_from: int | None = None
) -> str:
    """Like :func:`emit`, with the numbers appended to ``consts`` read as ``c[<index>]``.

    With ``share_from``, a number equal to one already in ``consts[share_from:]`` reuses its
    index, so repeated subexpressions (``sin(w*t)`` in a reference and its derivatives) are the
    same text and the compiler computes them once.
    """
    local: list[float] = []
    text = emit(node, names, local, base="_")
    index = []
    for v in local:
        k = None
        if share_from is not None:
            key = v.hex()
            k = next((i for i in range(share_from, len(consts)) if consts[i].hex() == key), None)
        if k is None:
            consts.append(v)
            k = len(consts) - 1
        index.append(k)
    return re.sub(r"c\[_ \+ (\d+)\]", lambda mt: f"c[{index[int(mt.group(1))]}]", text)


@functools.cache
def template(name: str) -> str:
    """The pasted part of ``templates/<name>.py`` (read once per process: a campaign generates
    a module text per member, and re-reading the templates cost ~3 ms of each 60 ms run)."""
    if name == "adaptive":  # one core per method (see templates.adaptive.specialise)
        from adaptive_ftc.sim.templates.adaptive import template_text

        return template_text().lstrip("\n")
    text = (Path(__file__).parent / "templates" / f"{name}.py").read_text()
    return text.split("\n" + _BEGIN + "\n", 1)[1].lstrip("\n")


# ----------------------------------------------------------------------------- cache
def cache_dir() -> Path | None:
    """The writable, private cache directory for generated loops, or ``None`` (compile in
    memory).

    Generated modules and numba's cache pickles are imported from it, so a folder is used only
    when it is the user's own: created with mode 0700, and an existing folder (the candidate
    and its ``loops``) must be owned by the current user and not writable by group or others.
    A folder that fails the check is skipped with a :class:`UserWarning` (another local user
    could have created ``/tmp/adaptive-ftc-<uid>`` first); when none is usable, loops are
    compiled in memory.
    """
    candidates = []
    if os.environ.get("ADAPTIVE_FTC_CACHE_DIR"):
        candidates.append(Path(os.environ["ADAPTIVE_FTC_CACHE_DIR"]))
    xdg = os.environ.get("XDG_CACHE_HOME")
    candidates.append(
        Path(xdg) / "adaptive-ftc" if xdg else Path.home() / ".cache" / "adaptive-ftc"
    )
    candidates.append(Path(tempfile.gettempdir()) / f"adaptive-ftc-{_user()}")
    for c in candidates:
        try:
            d = c / "loops"
            c.mkdir(mode=0o700, parents=True, exist_ok=True)
            d.mkdir(mode=0o700, exist_ok=True)
            why = _not_private(c) or _not_private(d)
            if why:
                _warn_unsafe(c, why)
                continue
            probe = d / f".probe-{os.getpid()}-{threading.get_ident()}"
            probe.write_text("")
            probe.unlink()
            return d
        except OSError:
            continue
    return None


def _not_private(folder: Path) -> str:
    """Why ``folder`` is not safe to import code from ("" when it is)."""
    if not hasattr(os, "getuid"):  # pragma: no cover - Windows: per-user profile folders
        return ""
    st = os.lstat(folder)
    import stat

    if stat.S_ISLNK(st.st_mode):
        return "it is a symbolic link"
    if st.st_uid != os.getuid():
        return f"it is owned by user id {st.st_uid}, not by you ({os.getuid()})"
    if st.st_mode & 0o022:
        return f"it is writable by group or others (mode {stat.S_IMODE(st.st_mode):o})"
    return ""


_warned: set[str] = set()


def _warn_unsafe(folder: Path, why: str) -> None:
    import warnings

    if str(folder) in _warned:
        return
    _warned.add(str(folder))
    warnings.warn(
        f"Not using the compile cache '{folder}': {why}. Generated code is imported from "
        "there, so it must be yours and private (chmod 700, or set ADAPTIVE_FTC_CACHE_DIR to "
        "a private folder); compiling elsewhere or in memory instead.",
        UserWarning,
        stacklevel=3,
    )


def _user() -> str:
    try:
        return str(os.getuid())
    except AttributeError:  # pragma: no cover - Windows
        return os.environ.get("USERNAME", "user")


_hashes: dict[tuple, str] = {}


def _source_hash(modules: list[str]) -> str:
    """Hash of the source files of ``modules``, remembered per file stamp (a campaign keys a
    loop per member: reading and hashing the files each time cost ~0.3 ms of each run)."""
    stamps = []
    for name in sorted(set(modules)):
        mod = sys.modules.get(name) or importlib.import_module(name)
        path = getattr(mod, "__file__", None)
        try:
            st = os.stat(path) if path else None
        except OSError:
            st = None
        stamps.append((name, path, st.st_mtime_ns if st else 0, st.st_size if st else 0))
    stamp = tuple(stamps)
    digest = _hashes.get(stamp)
    if digest is None:
        h = hashlib.sha256()
        for name, path, _, size in stamps:
            h.update(name.encode())
            if path and size:  # a size is only read from a path
                h.update(Path(path).read_bytes())
        digest = _hashes[stamp] = h.hexdigest()
    return digest


def _key(source: str, imports: list[str]) -> str:
    import numba

    key_src = "\n".join(
        [source, _source_hash(imports), numba.__version__, __version__, sys.version]
    )
    return hashlib.sha256(key_src.encode()).hexdigest()[:24]


def _memo(key: str, inject: Mapping[str, object] | None) -> str:
    return key + "".join(f":{n}={id(o):x}" for n, o in sorted((inject or {}).items()))


def is_cached(
    source: str,
    imports: list[str],
    inject: Mapping[str, object] | None = None,
    kind: str = "loop",
) -> bool:
    """Whether the module ``source`` is loaded in this process or compiled in the disk cache
    (numba's own ``NUMBA_CACHE_DIR`` included); ``kind`` as in :func:`load_module`."""
    key = _key(source, imports)
    if _memo(key, inject) in _modules:
        return True
    folder = cache_dir()
    if inject or folder is None:
        return False
    places = [folder / "__pycache__"]
    import numba
    from numba.core.caching import UserProvidedCacheLocator

    # numba.config sets its settings at import (mypy does not see them)
    numba_dir = numba.config.CACHE_DIR  # type: ignore[attr-defined]
    if numba_dir:  # numba then keeps every index there
        sub = UserProvidedCacheLocator.get_suitable_cache_subpath(str(folder / "x.py"))
        places.insert(0, Path(numba_dir) / sub)
    prefix = f"{kind}_{key}"
    return any(
        name.startswith(prefix) and name.endswith(".nbi") for p in places for name in _listing(p)
    )


_listings: dict[str, tuple[int, tuple[str, ...]]] = {}


def _listing(folder: Path) -> tuple[str, ...]:
    """The file names in ``folder`` (none when it does not exist), listed again only when its
    time stamp moved: ``aftc run`` asks :func:`is_cached` about each of its structures, and a
    well-used cache folder holds tens of thousands of files (a glob per question took 17 ms
    on one of 22,675: 0.34 s of a warm run)."""
    try:
        stamp = os.stat(folder).st_mtime_ns
    except OSError:
        return ()
    key = str(folder)
    seen = _listings.get(key)
    if seen is not None and seen[0] == stamp:
        return seen[1]
    with os.scandir(folder) as entries:
        names = tuple(e.name for e in entries)
    _listings[key] = (stamp, names)
    return names


@functools.cache
def _bind_libm() -> int:
    """Point the generated code's libm calls (``exp``, ``sin``, ``tanh``...) at the C library's
    current symbols; returns how many were rebound.

    numba binds every C math function to a wrapper of its own helper library (for Windows,
    where several C runtimes can be loaded at once). Its Linux wheels are built against an old
    glibc, so the wrapper then calls the compatibility entry point (``exp@GLIBC_2.2.5``: errno
    handling around the same computation): two extra calls per ``exp``. Measured on
    hypersonic-direct-s1 (RK4, 120 000 steps, 10 exp per right-hand side): integration 3-4 %
    faster, trajectories bit for bit the same. Done once, before any loop is loaded, on Linux
    only (elsewhere numba's binding stays).
    """
    if not sys.platform.startswith("linux"):
        return 0
    import ctypes
    import ctypes.util

    import llvmlite.binding as ll
    from numba.core import intrinsics
    from numba.core.registry import cpu_target

    cpu_target.target_context  # noqa: B018 - numba installs its own bindings on first use
    try:
        libm = ctypes.CDLL(ctypes.util.find_library("m") or "libm.so.6")
    except OSError:  # pragma: no cover - no shared C math library: keep numba's binding
        return 0
    done = 0
    for name in sorted(intrinsics.INTR_MATH):
        fn = getattr(libm, name, None)
        if fn is not None:
            ll.add_symbol(name, ctypes.cast(fn, ctypes.c_void_p).value)
            done += 1
    return done


@functools.cache
def _plain_typing_errors() -> bool:
    """Let numba write its typing messages without colorama's terminal set-up; ``True`` when
    changed.

    While it types a function, numba tries the overloads of every call and writes a message
    for each one it rejects, whether or not anybody reads it; with colorama installed (a
    dependency of many tools) each piece of such a message is wrapped in colorama's
    ``init``/``deinit``, which wraps ``sys.stdout`` and ``sys.stderr`` anew. Measured on a
    first ``aftc run hypersonic-direct-s1`` (session 13): 15,091 such pieces, 0.6-0.8 s of
    its 12-14 s of CPU. The messages keep their text without the bold-face escape codes, as
    numba writes them when ``NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING`` is set; left alone
    when a colour scheme was chosen (``NUMBA_COLOR_SCHEME``).
    """
    import numba
    from numba.core import errors

    # the one scheme object numba's modules took at import (errors.termcolor())
    scheme = errors.termcolor()
    chosen = getattr(numba.config, "COLOR_SCHEME", "no_color")
    if chosen != "no_color" or not hasattr(type(scheme), "_markup"):
        return False  # a chosen colour scheme, or no colorama: nothing to do
    scheme._markup = _plain_markup  # type: ignore[attr-defined]  # colorama's scheme has one
    return True


def _plain_markup(msg: str, color=None, style=None) -> str:
    return msg


def load_module(
    source: str,
    *,
    imports: list[str],
    inject: Mapping[str, object] | None = None,
    kind: str = "loop",
) -> types.ModuleType:
    """Compile (or load from the cache) the generated module ``source``.

    Parameters
    ----------
    source
        Module text. It reads the global ``CACHE`` to decide numba's ``cache=``.
    imports
        Names of the modules whose code it imports (their source is part of the cache key).
    inject
        Objects to place in the module before it runs (parts that cannot be imported, such as
        functions defined in ``__main__``); such modules are compiled in memory only.
    kind
        What the module holds (``"loop"``; ``"integrators"``, ``"gain"``, ``"pattern"`` for the
        shared integrators, a plant's control gain, a failure pattern): the start of its file
        and module names.
    """
    _bind_libm()
    _plain_typing_errors()
    key = _key(source, imports)
    # a module with injected parts is kept under their identities too: the same function
    # object (a plant of a notebook or a script) reuses its compiled loop, a redefined one
    # compiles anew; ``_kept`` holds the objects so that their ids are not reused
    memo = _memo(key, inject)
    with _lock:
        if memo in _modules:
            return _modules[memo]
        name = f"adaptive_ftc_{kind}_{key}"
        folder = None if inject else cache_dir()
        if folder is None:
            module = types.ModuleType(name)
            module.__dict__.update(inject or {})
            module.CACHE = False  # type: ignore[attr-defined]  # read by the generated code
            sys.modules[name] = module
            try:
                exec(compile(source, f"<generated loop {key}>", "exec"), module.__dict__)
            except Exception:
                sys.modules.pop(name, None)
                raise
            _stats["in_memory"] += 1
        else:
            path = folder / f"{kind}_{key}.py"
            if not path.exists() or path.read_text() != source:
                tmp = path.with_suffix(f".{os.getpid()}.{threading.get_ident()}.tmp")
                tmp.write_text(source)
                os.replace(tmp, path)
                _stats["generated"] += 1
            spec = importlib.util.spec_from_file_location(name, path)
            if spec is None or spec.loader is None:  # pragma: no cover
                raise ConfigurationError(f"Cannot load the generated loop module {path}.")
            module = importlib.util.module_from_spec(spec)
            module.CACHE = True  # type: ignore[attr-defined]  # read by the generated code
            # must be importable by name before it runs, or numba's cache cannot find it
            sys.modules[name] = module
            try:
                spec.loader.exec_module(module)
            except Exception:
                sys.modules.pop(name, None)
                raise
        _stats["loaded"] += 1
        _modules[memo] = module
        if inject:
            _kept[memo] = tuple(inject.values())
        return module


def stats() -> dict[str, int]:
    """Counters of this process: modules generated (written), loaded, compiled in memory, and
    numba compilations of loop entry points (``compiled``; 0 when every loop hit the cache)."""
    from adaptive_ftc.sim.solvers import compiled_entries

    compiled = 0
    for mod in list(_modules.values()):
        for fn in ("rhs", "control_gain", "signals", *compiled_entries()):
            disp = getattr(mod, fn, None)
            if disp is not None and hasattr(disp, "stats"):
                compiled += sum(disp.stats.cache_misses.values())
    return {**_stats, "modules": len(_modules), "compiled": compiled}


def compile_expression(expr, variables: Mapping[str, str] | None = None):
    """A compiled scalar function ``f(t, x, u)`` of an :class:`Expression` (in memory).

    ``variables`` maps the expression's names to ``t``, ``u`` or ``x[i]`` text; by default
    ``t`` and ``u`` map to themselves and ``x1..xn`` to ``x[0..n-1]``.
    """
    import numba
    import numpy as np

    from adaptive_ftc.sim import mathlib

    if variables is None:
        variables = {
            v: (f"x[{int(v[1:]) - 1}]" if v[:1] == "x" and v[1:].isdigit() else v)
            for v in expr.variables
        }
    consts: list[float] = []
    text = emit(expr.node, variables, consts)
    ns: dict[str, object] = {"math": math, "c": np.array(consts, dtype=float)}
    for name in mathlib.GUARDED:
        ns[name] = numba.njit(getattr(mathlib, name))
    exec(f"def f(t, x, u):\n    o = 0\n    return {text}\n", ns)
    return numba.njit(ns["f"])
