"""A griffe extension that turns the reStructuredText bits of the docstrings into Markdown at
build time, so the site shows no raw Sphinx roles (the source docstrings stay as they are).

- ``:class:`X```, ``:func:``, ``:meth:``, ``:attr:``, ``:data:``, ``:mod:``, ``:exc:``,
  ``:obj:`` (with ``~`` and ``title <target>`` forms, relative ``.mod`` targets): an optional
  cross-reference (``<autoref optional>``) to the object resolved in the docstring's scope. It
  becomes a link when the object is on the site, and plain code otherwise (never a warning).
- ``:math:`x``` and the ``.. math::`` directive: the LaTeX source as code.
- RST simple tables (``=== ===`` rules): Markdown tables.
- Section underlines (``Title`` / ``-----``) that numpydoc does not know: a bold line.
- A paragraph ending in ``::`` before a literal block: a single ``:``.
- A bullet's continuation blocks, indented under its text as RST wants (2 spaces), indented
  4 spaces as Markdown wants (else a blank line ends the list item).
- A prose paragraph after the entries of a ``Parameters`` section (numpydoc would read its
  first word as a parameter): put under a ``Notes`` heading.

Used by mkdocs.yml (``extensions:`` of the mkdocstrings python handler).
"""

from __future__ import annotations

import html
import re

from griffe import Extension, Object

#: the numpydoc sections griffe's numpy parser reads (their underlines must stay)
NUMPY_SECTIONS = {
    "parameters",
    "other parameters",
    "returns",
    "yields",
    "receives",
    "raises",
    "warns",
    "warnings",
    "see also",
    "notes",
    "references",
    "examples",
    "attributes",
    "methods",
    "functions",
    "classes",
    "modules",
    "deprecated",
}

XREF_ROLES = ("class", "func", "meth", "attr", "data", "mod", "exc", "obj", "const", "any")
ROLE_RE = re.compile(r":(?:py:)?(?P<role>[a-z]+):`(?P<body>[^`]+)`")
MATH_DIRECTIVE_RE = re.compile(r"^(?P<indent>[ \t]*)\.\. math::[ \t]*(?P<first>.*)$")
TABLE_RULE_RE = re.compile(r"^[ \t]*=+(?:[ \t]+=+)+[ \t]*$")
UNDERLINE_RE = re.compile(r"^[ \t]*(-{3,}|={3,}|~{3,})[ \t]*$")
PARAM_LINE_RE = re.compile(r"^\*{0,2}\w+(\s*,\s*\*{0,2}\w+)*(\s*:.*)?$")


def _resolve(obj: Object, target: str) -> str:
    """The full path of ``target`` as seen from ``obj`` (``target`` itself when unknown)."""
    if target.startswith("."):
        # relative module reference: one dot is the object's package
        dots = len(target) - len(target.lstrip("."))
        module = obj if obj.is_module else obj.module
        base = module.path.split(".")
        if not module.is_package:
            base = base[:-1]
        base = base[: len(base) - (dots - 1)] if dots > 1 else base
        return ".".join([*base, target.lstrip(".")])
    head, _, rest = target.partition(".")
    try:
        path = obj.resolve(head)
    except Exception:  # noqa: BLE001 - griffe raises several kinds; unknown stays as written
        return target
    return f"{path}.{rest}" if rest else path


def _role(obj: Object, match: re.Match) -> str:
    role, body = match["role"], " ".join(match["body"].split())
    if role == "math":
        return f"<code>{html.escape(body)}</code>"
    if role not in XREF_ROLES:
        return f"<code>{html.escape(body)}</code>"
    explicit = re.fullmatch(r"(?P<title>.+?)\s*<(?P<target>[^>]+)>", body)
    if explicit:
        title, target = explicit["title"], explicit["target"]
    else:
        target = body
        short = target.startswith("~")
        target = target.lstrip("~")
        title = target.rsplit(".", 1)[-1] if short else target.lstrip(".")
        if role in ("func", "meth"):
            title += "()"
    identifier = _resolve(obj, target.lstrip("~"))
    return (
        f'<autoref identifier="{html.escape(identifier)}" optional>'
        f"<code>{html.escape(title)}</code></autoref>"
    )


def _table(lines: list[str]) -> list[str] | None:
    """A Markdown table from an RST simple table (its lines, rules included), or None."""
    rule = lines[0]
    indent = rule[: len(rule) - len(rule.lstrip())]
    spans = [m.span() for m in re.finditer(r"=+", rule)]
    rows = []
    for line in lines[1:]:
        if TABLE_RULE_RE.match(line):
            rows.append(None)
            continue
        cells = []
        for i, (a, _b) in enumerate(spans):
            end = spans[i + 1][0] if i + 1 < len(spans) else len(line)
            cells.append(line[a:end].strip().replace("|", "\\|"))
        rows.append(cells)
    # header: the rows before the second rule (when there is a third rule)
    if rows.count(None) >= 2:
        head_end = rows.index(None)
        header = [" ".join(c).strip() for c in zip(*rows[:head_end], strict=True)]
        body = [r for r in rows[head_end + 1 :] if r is not None]
    else:
        body = [r for r in rows if r is not None]
        header, body = body[0], body[1:]
    out = [indent + "| " + " | ".join(header) + " |"]
    out.append(indent + "|" + "|".join(" --- " for _ in header) + "|")
    out += [indent + "| " + " | ".join(r) + " |" for r in body]
    return out


def _prose_after_parameters(lines: list[str]) -> list[str]:
    """``lines`` with a ``Notes`` heading before a prose paragraph inside ``Parameters``."""
    out: list[str] = []
    section = None
    for i, line in enumerate(lines):
        nxt = lines[i + 1] if i + 1 < len(lines) else ""
        if line.strip() and UNDERLINE_RE.match(nxt):
            section = line.strip().lower()
        elif (
            section in ("parameters", "other parameters")
            and line.strip()
            and line == line.lstrip()
            and not UNDERLINE_RE.match(line)
            and not PARAM_LINE_RE.match(line.strip())
            and (i == 0 or not lines[i - 1].strip())
        ):
            out += ["Notes", "-----"]
            section = "notes"
        out.append(line)
    return out


def _indent_bullet_bodies(lines: list[str]) -> list[str]:
    """``lines`` with the body of each ``- `` bullet indented 4 spaces under the bullet, and
    a blank line between sibling bullets."""
    out: list[str] = []
    bullet = None  # indent of the open bullet
    for line in lines:
        indent = len(line) - len(line.lstrip())
        if line.strip():
            if line.lstrip().startswith(("- ", "* ")) and (bullet is None or indent <= bullet):
                if bullet is not None and out and out[-1].strip():
                    out.append("")  # a sibling item: without it Markdown continues the last
                bullet = indent
            elif bullet is not None and indent >= bullet + 2:
                line = "  " + line
            elif bullet is not None:
                bullet = None
        out.append(line)
    return out


def rst_to_markdown(obj: Object, text: str) -> str:
    """The docstring ``text`` of ``obj`` with its RST constructs turned into Markdown."""
    lines = _indent_bullet_bodies(_prose_after_parameters(text.splitlines()))
    out: list[str] = []
    i = 0
    while i < len(lines):
        line = lines[i]
        math = MATH_DIRECTIVE_RE.match(line)
        if math:
            indent, parts = math["indent"], [math["first"].strip()]
            i += 1
            while i < len(lines) and (
                lines[i].strip() == ""
                and i + 1 < len(lines)
                and len(lines[i + 1]) - len(lines[i + 1].lstrip()) > len(indent)
                and lines[i + 1].strip()
                or lines[i].strip()
                and len(lines[i]) - len(lines[i].lstrip()) > len(indent)
            ):
                parts.append(lines[i].strip())
                i += 1
            latex = " ".join(p for p in parts if p)
            out.append(f"{indent}`{latex}`")
            continue
        if TABLE_RULE_RE.match(line):
            block = [line]
            j = i + 1
            rules = 1
            while j < len(lines) and lines[j].strip():
                block.append(lines[j])
                rules += bool(TABLE_RULE_RE.match(lines[j]))
                j += 1
            if rules >= 2 and TABLE_RULE_RE.match(block[-1]):
                table = _table(block[:-1])
                if table:
                    if out and out[-1].strip():
                        out.append("")
                    out += table
                    i = j
                    continue
        if (
            i + 1 < len(lines)
            and line.strip()
            and UNDERLINE_RE.match(lines[i + 1])
            and line.strip().lower() not in NUMPY_SECTIONS
            and len(lines[i + 1].strip()) >= len(line.strip()) - 1
        ):
            out.append(f"**{line.strip()}**")
            out.append("")
            i += 2
            continue
        if line.rstrip().endswith("::") and not line.strip().startswith(".."):
            stripped = line.rstrip()[:-2].rstrip()
            line = stripped + ":" if stripped else ""
        out.append(line)
        i += 1
    text = "\n".join(out)
    return ROLE_RE.sub(lambda m: _role(obj, m), text)


class RstToMarkdown(Extension):
    """Rewrite every docstring of the loaded package (see the module docstring)."""

    def on_package(self, *, pkg: Object, **kwargs: object) -> None:
        seen: set[int] = set()
        stack = [pkg]
        while stack:
            obj = stack.pop()
            if id(obj) in seen or obj.is_alias:
                continue
            seen.add(id(obj))
            if obj.docstring is not None:
                obj.docstring.value = rst_to_markdown(obj, obj.docstring.value)
            stack.extend(m for m in obj.members.values() if not m.is_alias)
