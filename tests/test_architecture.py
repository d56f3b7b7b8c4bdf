"""The import graph of ``src/adaptive_ftc``: no import cycles, and lower layers never import
higher ones (issue 27, "layout that shows the architecture"; docs/architecture.md draws it).

The graph is read with the stdlib :mod:`ast`, without importing anything. Two kinds of edges:

* **module level**: an import executed when the module is imported;
* **deferred**: an import inside a function (run on first call, e.g. to keep matplotlib or the
  compiler out of ``import adaptive_ftc``).

Both kinds count: a deferred import still makes the two modules depend on each other, so the
issue's "no import cycles" holds for the union of both. Imports under ``if TYPE_CHECKING:`` are
not edges (they never run; they exist for annotations). ``import a.b.c`` and
``from a.b import c`` (``c`` a submodule) are edges to ``a.b.c``; ``from a.b import name`` is an
edge to ``a.b`` (its ``__init__``). The parents that Python imports on the way (``a``, ``a.b``)
are not edges: a package's ``__init__`` only lists its public names.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = "adaptive_ftc"

#: The layers, lowest first: a module may import its own layer and the ones below it.
#: ``core`` is the library (parts, loop, engine, results); ``catalogue`` the thesis's scenarios,
#: claims and reproduction; ``applications`` what is built on both (campaigns, studies,
#: interop, the command line). The package's ``__init__`` (the public API) is above them all.
LAYERS: dict[str, tuple[str, ...]] = {
    "core": (
        "_atomic",
        "_feedback",
        "_figure_process",
        "_lazy",
        "_signals",
        "_units",
        "_version",
        "allocation",
        "approximators",
        "baselines",
        "controllers",
        "errors",
        "expressions",
        "faults",
        "hardware",
        "plants",
        "plots",
        "registry",
        "sim",
    ),
    "catalogue": ("claims", "report", "reproduce", "scenarios"),
    "applications": (
        "allocation_study",
        "campaigns",
        "cli",
        "export",
        "gym",
        "interop",
        "studies",
        "study_cli",
        "study_plots",
    ),
    "api": ("",),  # adaptive_ftc/__init__.py
}
ORDER = tuple(LAYERS)


def _modules(root: Path, package: str) -> dict[str, Path]:
    """``{dotted name: file}`` of every module of ``package`` under ``root``."""
    out = {}
    for path in sorted((root / package).rglob("*.py")):
        parts = list(path.relative_to(root).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def _is_type_checking(node: ast.If) -> bool:
    return "TYPE_CHECKING" in ast.unparse(node.test)


def _targets(
    node: ast.Import | ast.ImportFrom, module: str, is_pkg: bool, known: Iterable[str]
) -> set[str]:
    """The modules of the package that one import statement imports."""
    known = set(known)

    def owner(name: str) -> str | None:
        while name and name not in known:
            name = name.rpartition(".")[0]
        return name or None

    if isinstance(node, ast.Import):
        names = [a.name for a in node.names]
        return {m for n in names if (m := owner(n)) is not None}
    if node.level:
        base = module if is_pkg else module.rpartition(".")[0]
        for _ in range(node.level - 1):
            base = base.rpartition(".")[0]
        source = base + ("." + node.module if node.module else "")
    else:
        source = node.module or ""
    out = set()
    for alias in node.names:
        full = f"{source}.{alias.name}"
        target = full if full in known else owner(source)
        if target is not None:
            out.add(target)
    return out


def _imports(
    nodes: Iterable[ast.AST], in_function: bool
) -> Iterator[tuple[ast.Import | ast.ImportFrom, bool]]:
    """Every import statement under ``nodes`` and whether it is inside a function (the
    ``if TYPE_CHECKING:`` branches left out)."""
    for child in nodes:
        if isinstance(child, ast.If) and _is_type_checking(child):
            yield from _imports(child.orelse, in_function)  # the runtime branch only
            continue
        if isinstance(child, ast.Import | ast.ImportFrom):
            yield child, in_function
        nested = isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda)
        yield from _imports(ast.iter_child_nodes(child), in_function or nested)


def import_graph(root: Path = SRC, package: str = PACKAGE) -> tuple[dict, dict]:
    """``(module_level, deferred)``: each ``{module: set of modules it imports}``."""
    mods = _modules(root, package)
    top: dict[str, set[str]] = {m: set() for m in mods}
    deferred: dict[str, set[str]] = {m: set() for m in mods}
    for module, path in mods.items():
        is_pkg = path.name == "__init__.py"
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        for node, in_function in _imports(tree.body, False):
            edges = deferred if in_function else top
            edges[module] |= _targets(node, module, is_pkg, mods) - {module}
    return top, deferred


def cycles(graph: Mapping[str, Iterable[str]]) -> list[list[str]]:
    """One cycle per strongly connected component of ``graph`` with more than one module,
    as a path ``[a, b, ..., a]`` (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[set[str]] = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in graph:
                    continue
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = set()
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        comp.add(w)
                        if w == v:
                            break
                    if len(comp) > 1:
                        components.append(comp)
    return [_cycle_in(graph, comp) for comp in components]


def _cycle_in(graph: Mapping[str, Iterable[str]], comp: set[str]) -> list[str]:
    """A shortest cycle through the first module of a strongly connected component."""
    first = min(comp)
    paths = {first: [first]}
    queue = [first]
    while queue:
        v = queue.pop(0)
        for w in sorted(graph[v]):
            if w == first:
                return [*paths[v], first]
            if w in comp and w not in paths:
                paths[w] = [*paths[v], w]
                queue.append(w)
    raise AssertionError("not a strongly connected component")  # pragma: no cover


def layer_of(module: str) -> str | None:
    """The layer of ``adaptive_ftc.<module>`` (by its first name under the package)."""
    head = module.removeprefix(PACKAGE).removeprefix(".").split(".")[0]
    return next((layer for layer, heads in LAYERS.items() if head in heads), None)


def _union(a: Mapping[str, set[str]], b: Mapping[str, set[str]]) -> dict[str, set[str]]:
    return {m: a.get(m, set()) | b.get(m, set()) for m in {*a, *b}}


def _show(found: list[list[str]]) -> str:
    return "\n".join(" -> ".join(c) for c in found)


TOP, DEFERRED = import_graph()


def test_no_import_cycles_at_module_level():
    found = cycles(TOP)
    assert not found, f"import cycles of module-level imports:\n{_show(found)}"


def test_no_import_cycles_counting_deferred_imports():
    found = cycles(_union(TOP, DEFERRED))
    assert not found, f"import cycles (deferred imports in functions included):\n{_show(found)}"


def test_every_module_has_a_layer():
    missing = sorted(m for m in TOP if layer_of(m) is None)
    assert not missing, f"add these modules to LAYERS in {Path(__file__).name}: {missing}"


def test_lower_layers_never_import_higher_ones():
    bad = []
    for module, targets in sorted(_union(TOP, DEFERRED).items()):
        rank = ORDER.index(layer_of(module))
        for target in sorted(targets):
            if ORDER.index(layer_of(target)) > rank:
                bad.append(f"{module} ({layer_of(module)}) imports {target} ({layer_of(target)})")
    assert not bad, "imports from a higher layer:\n" + "\n".join(bad)


def test_docs_architecture_lists_the_layers_of_this_test():
    """docs/architecture.md draws the layers; its table must say what LAYERS says."""
    text = (SRC.parent / "docs" / "architecture.md").read_text(encoding="utf-8")
    for layer, heads in LAYERS.items():
        if layer == "api":
            continue
        row = next((ln for ln in text.splitlines() if ln.startswith(f"| {layer} |")), "")
        listed = (
            set(row.split("|")[2].replace("`", "").replace(" ", "").split(",")) if row else set()
        )
        assert listed == set(heads), f"docs/architecture.md, layer {layer}: {sorted(listed)}"


# ------------------------------------------------------------- the checker against a truth


def _write(root: Path, files: Mapping[str, str]) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")


def test_graph_tells_module_level_deferred_and_type_only_imports_apart(tmp_path):
    _write(
        tmp_path,
        {
            "pkg/__init__.py": "from pkg.a import f\n",
            "pkg/a.py": "from pkg import b\n\ndef f():\n    from pkg.sub import c\n",
            "pkg/b.py": (
                "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg import a\n"
                "else:\n    import pkg.sub.c\n"
            ),
            "pkg/sub/__init__.py": "",
            "pkg/sub/c.py": "from .. import b\nfrom . import d\nimport os\n",
            "pkg/sub/d.py": "from pkg.b import X\n",
        },
    )
    top, deferred = import_graph(tmp_path, "pkg")
    assert top == {
        "pkg": {"pkg.a"},
        "pkg.a": {"pkg.b"},
        "pkg.b": {"pkg.sub.c"},
        "pkg.sub": set(),
        "pkg.sub.c": {"pkg.b", "pkg.sub.d"},
        "pkg.sub.d": {"pkg.b"},
    }
    assert deferred["pkg.a"] == {"pkg.sub.c"} and not deferred["pkg.b"]


@pytest.mark.parametrize(
    ("graph", "expected"),
    [
        ({"a": {"b"}, "b": {"c"}, "c": set()}, []),
        ({"a": {"b"}, "b": {"a"}}, [["a", "b", "a"]]),
        ({"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": {"e"}, "e": {"d"}}, None),
    ],
)
def test_cycles_lists_one_cycle_per_strongly_connected_component(graph, expected):
    found = cycles(graph)
    if expected is not None:
        assert found == expected
    else:
        assert sorted(found) == [["a", "b", "c", "a"], ["d", "e", "d"]]
