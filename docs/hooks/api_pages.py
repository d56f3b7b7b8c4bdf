"""mkdocs hook: the API reference is generated from the ``__all__`` of ``adaptive_ftc`` and of
each public module directly under it, so every public name has an entry and a new one cannot be
forgotten (``tests/test_docs_site.py`` checks it).

``docs/api.md`` holds the introduction and the marker ``<!-- api-reference -->``, replaced by
one section per module: its docstring and the names of its ``__all__`` (mkdocstrings). An
object exported by several modules is documented once, in the first module of
:data:`MODULE_ORDER` that exports it (or the first other one, alphabetically); the others list
it with a link. The top-level ``adaptive_ftc`` section is a table of its names, each linking to
where it is documented (names no module documents are documented there).

Every entry carries the HTML id ``<module>.<name>`` (mkdocstrings' heading ids, or an explicit
anchor for the cross-listed ones).
"""

from __future__ import annotations

from pathlib import Path

import griffe

ROOT = Path(__file__).resolve().parents[2]
MARKER = "<!-- api-reference -->"
PACKAGE = "adaptive_ftc"

#: the order of the sections (public modules not named here follow, alphabetically)
MODULE_ORDER = (
    "scenarios",
    "sim",
    "controllers",
    "plants",
    "faults",
    "approximators",
    "hardware",
    "baselines",
    "claims",
    "campaigns",
    "studies",
    "interop",
    "plots",
    "study_plots",
    "report",
    "reproduce",
    "errors",
    "cli",
)

OPTIONS = """    options:
      show_root_heading: false
      show_root_toc_entry: false
      show_if_no_docstring: true
      heading_level: 3
      members: [{members}]
"""


def _load() -> griffe.Module:
    return griffe.load(PACKAGE, search_paths=[str(ROOT / "src")], resolve_aliases=True)


def public_modules(pkg: griffe.Module) -> list[str]:
    """The public modules directly under the package that define ``__all__``, in page order."""
    names = [
        n
        for n, m in pkg.members.items()
        if not m.is_alias and m.is_module and not n.startswith("_") and m.exports is not None
    ]
    ordered = [n for n in MODULE_ORDER if n in names]
    return ordered + sorted(n for n in names if n not in ordered)


def _exports(mod: griffe.Module) -> list[str]:
    return [str(e) for e in (mod.exports or ())]


def _member(mod: griffe.Module, name: str) -> griffe.Object | None:
    """The object ``mod.name``: a member, or (a lazy ``__getattr__`` export) a submodule's."""
    try:
        obj = mod[name] if name in mod.members else None
        if obj is None:
            obj = next(m[name] for m in mod.modules.values() if name in m.members)
        return obj.final_target if obj.is_alias else obj
    except Exception:  # noqa: BLE001 - unresolvable: its own entry
        return None


def _key(mod: griffe.Module, name: str) -> str:
    """What identifies the object ``mod.name`` (its canonical path; data: its own path)."""
    target = _member(mod, name)
    if target is None:
        return f"{mod.path}.{name}"
    if target.is_attribute:
        return f"{mod.path}.{name}"
    return target.path


def generate(pkg: griffe.Module | None = None) -> str:
    """The Markdown of the generated reference."""
    pkg = pkg or _load()
    modules = [pkg[m] for m in public_modules(pkg)]
    home: dict[str, str] = {}  # object key -> the path of the entry documenting it
    for mod in modules:
        for name in _exports(mod):
            home.setdefault(_key(mod, name), f"{mod.path}.{name}")
    parts = []
    top_only = []
    rows = []
    for name in _exports(pkg):
        entry = home.get(_key(pkg, name))
        if entry is None:
            top_only.append(name)
            continue
        rows.append(f'| <span id="{PACKAGE}.{name}"></span>[`{name}`](#{entry}) | `{entry}` |')
    parts.append(f"## `{PACKAGE}`\n")
    parts.append(f"::: {PACKAGE}\n" + OPTIONS.format(members=""))  # the package docstring
    parts.append(
        f"`from {PACKAGE} import NAME` works for every name of this table (each links to "
        "its entry) and for those documented after it.\n"
    )
    parts.append("| Name | Documented as |\n| --- | --- |\n" + "\n".join(rows) + "\n")
    if top_only:
        parts.append(
            f"::: {PACKAGE}\n"
            + OPTIONS.format(members=", ".join(top_only))
            + "      show_docstring_description: false\n"
        )
    for mod in modules:
        own, elsewhere = [], []
        for name in _exports(mod):
            entry = home[_key(mod, name)]
            (own if entry == f"{mod.path}.{name}" else elsewhere).append((name, entry))
        direct = [n for n, _ in own if n in mod.members]
        parts.append(f"## `{mod.path}`\n")
        parts.append(f"::: {mod.path}\n" + OPTIONS.format(members=", ".join(direct)))
        for name in (n for n, _ in own if n not in mod.members):
            target = _member(mod, name)
            if target is None:
                raise ValueError(
                    f"`{mod.path}.__all__` names {name!r}, which neither the module nor its "
                    f"submodules define: remove it from `__all__` or define it."
                )
            parts.append(
                f'<span id="{mod.path}.{name}"></span>\n\n::: {target.path}\n'
                "    options:\n      show_root_heading: true\n      heading_level: 3\n"
            )
        if elsewhere:
            links = ", ".join(
                f'<span id="{mod.path}.{n}"></span>[`{n}`](#{e})' for n, e in elsewhere
            )
            parts.append(f"Also exported here (documented elsewhere): {links}.\n")
    return "\n".join(parts)


def on_page_markdown(markdown: str, page, **kwargs):  # noqa: ANN001, ANN201 - mkdocs hook
    if MARKER not in markdown:
        return markdown
    return markdown.replace(MARKER, generate())
