"""A local Sphinx extension: the project's docstrings as their authors wrote them, and
cross-references to the names they re-export.

The docstrings of ``slam_env`` and ``agents`` are written to be read in the source and
in ``help()``: Gymnasium-style ``## Section`` headings in the env classes, Markdown pipe
tables, commands and code indented under a paragraph, and attribute docstrings of the
form ``(k,) bool: what it holds``. reStructuredText reads those differently (a heading
as a paragraph, a table as a line block, code as a block quote, and napoleon takes
``(k,) bool`` for a type to cross-reference), so :func:`markdown_to_rst` turns them
into the reStructuredText that shows what they say, before napoleon reads them, and
attribute docstrings are kept as written after it.

The package re-exports its public names (``slam_env.ekf.EKFSLAM`` is
``slam_env.ekf.filter.EKFSLAM``) and docstrings refer to names by the module they are
imported into. :func:`resolve_reference` follows such a name to the object and links
the page that documents it; a name that exists but is documented nowhere (a private
helper, an instance attribute) is shown as code without a link. A name that does not
exist stays a warning, so that a stale reference fails the ``-W -n`` build.
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import pkgutil
import re
from typing import Any

# --------------------------------------------------------------------------- docstrings

_TABLE_ROW = re.compile(r"^(\s*)\|(.*)\|\s*$")
_TABLE_RULE = re.compile(r"^\s*\|[\s:|-]+\|\s*$")
_HEADING = re.compile(r"^(\s*)#{1,6} (.+?)\s*$")
_UNDERLINE = re.compile(r"^(\s*)([-=~^])\2+\s*$")
_LIST_ITEM = re.compile(r"^\s*([-*+•]|\d+[.)]|#\.)\s")
_FIELD = re.compile(r"^\s*:[^:]+:")
# Spans whose text is taken literally: ``code`` and :role:`target`.
_LITERAL_SPAN = re.compile(r"``.+?``|:[\w:.-]+:`[^`]*`|`[^`]*`_?")


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip())


def _cells(row: str) -> list[str]:
    inner = _TABLE_ROW.match(row).group(2)
    return [cell.strip() for cell in re.split(r"(?<!\\)\|", inner)]


def _list_table(rows: list[str], pad: str) -> list[str]:
    """A Markdown pipe table (header, rule, rows) as a ``list-table``; a row whose first
    cell is empty continues the row above it."""
    header = _cells(rows[0])
    body: list[list[str]] = []
    for row in rows[2:]:
        cells = _cells(row)
        cells += [""] * (len(header) - len(cells))
        if body and not cells[0]:
            body[-1] = [f"{a} {b}".strip() for a, b in zip(body[-1], cells, strict=False)]
        else:
            body.append(cells)
    out = ["", f"{pad}.. list-table::", f"{pad}   :header-rows: 1", ""]
    for cells in [header, *body]:
        for k, cell in enumerate(cells):
            bullet = "* -" if k == 0 else "  -"
            out.append(f"{pad}   {bullet} {cell}".rstrip())
    out.append("")
    return out


def _escape_bars(line: str) -> str:
    """``|`` outside literal spans escaped (``|p − c|`` is not a substitution)."""
    parts, last = [], 0
    for m in _LITERAL_SPAN.finditer(line):
        parts.append(line[last : m.start()].replace("|", r"\|"))
        parts.append(m.group(0))
        last = m.end()
    parts.append(line[last:].replace("|", r"\|"))
    return "".join(parts)


def _plain_paragraph(para: list[str]) -> bool:
    """Whether ``para`` is running text at one indentation (not a list item, a field,
    a directive, a definition or a literal block's introduction)."""
    if not para or para[-1].rstrip().endswith("::"):
        return False
    first = para[0]
    if first.lstrip().startswith(".. ") or _LIST_ITEM.match(first) or _FIELD.match(first):
        return False
    return all(_indent(line) == _indent(first) for line in para)


def markdown_to_rst(lines: list[str]) -> list[str]:
    """The docstring ``lines`` with Markdown tables, ``#`` headings, stray ``|`` and
    indented code under a paragraph made reStructuredText (see the module's
    docstring); section underlines are made as long as their titles, a line that ends
    a list item, a definition or a block quote gets the blank line before it that
    reStructuredText asks for, and a paragraph's last line with an indented block under
    it becomes that block's term."""
    out: list[str] = []
    i, n = 0, len(lines)
    in_literal = -1  # the indentation of the paragraph that opened a literal block
    while i < n:
        line = lines[i]
        stripped = line.strip()
        if in_literal >= 0:
            if stripped and _indent(line) <= in_literal:
                in_literal = -1
            else:
                out.append(line)
                i += 1
                continue
        if _TABLE_ROW.match(line) and i + 1 < n and _TABLE_RULE.match(lines[i + 1]):
            j = i
            while j < n and _TABLE_ROW.match(lines[j]):
                j += 1
            out.extend(_list_table(lines[i:j], _TABLE_ROW.match(line).group(1)))
            i = j
            continue
        heading = _HEADING.match(line)
        if heading:
            out.extend(["", f"{heading.group(1)}.. rubric:: {heading.group(2)}", ""])
            i += 1
            continue
        underline = _UNDERLINE.match(line)
        if underline and out and out[-1].strip() and i > 0:
            title = out[-1]
            out.append(underline.group(1) + underline.group(2) * len(title.strip()))
            i += 1
            continue
        if stripped and out and not out[-1].strip():
            # An indented block after a blank line under a plain paragraph: code.
            k = len(out) - 1
            while k >= 0 and not out[k].strip():
                k -= 1
            end = k
            while k >= 0 and out[k].strip():
                k -= 1
            para = out[k + 1 : end + 1]
            if _plain_paragraph(para) and _indent(line) > _indent(para[0]):
                out.extend([" " * _indent(para[0]) + "::", ""])
                in_literal = _indent(para[0])
                out.append(line)
                i += 1
                continue
        if stripped and out and out[-1].strip() and _indent(line) < _indent(out[-1]):
            # The end of a list item, definition or block quote: a blank line first.
            out.append("")
        elif (
            stripped
            and len(out) > 1
            and out[-1].strip()
            and out[-2].strip()
            and _indent(line) > _indent(out[-1]) == _indent(out[-2])
            and not _LIST_ITEM.match(out[-1])
        ):
            # A definition under the last line of a paragraph: that line is its term.
            out.insert(len(out) - 1, "")
        if stripped.endswith("::"):
            out.append(line)
            in_literal = _indent(line)
            i += 1
            continue
        out.append(_escape_bars(line))
        i += 1
    return out


_ATTRIBUTE_KINDS = {"attribute", "data", "property"}
_WRITTEN: dict[tuple[str, str], list[str]] = {}


def before_napoleon(app, what, name, obj, options, lines) -> None:
    lines[:] = markdown_to_rst(lines)
    if what in _ATTRIBUTE_KINDS:
        _WRITTEN[(what, name)] = list(lines)


def after_napoleon(app, what, name, obj, options, lines) -> None:
    # Napoleon reads "(k,) bool: …" as a type and a description: keep it as written.
    written = _WRITTEN.pop((what, name), None)
    if written is not None:
        lines[:] = written


def dataclass_factories(app, what, name, obj, options, signature, return_annotation):
    """A dataclass's ``field(default_factory=f)`` shows as ``f()``, not ``<factory>``
    (which the signature parser cannot read)."""
    if signature and "<factory>" in signature and dataclasses.is_dataclass(obj):
        for f in dataclasses.fields(obj):
            if f.init and f.default_factory is not dataclasses.MISSING:
                made = getattr(f.default_factory, "__qualname__", "")
                shown = f"{made}()" if made.isidentifier() else "..."
                signature = signature.replace("<factory>", shown, 1)
    return signature, return_annotation


# --------------------------------------------------------------------------- references

_MISSING = object()
_OURS = ("slam_env", "agents")


def _home(obj: Any, owner: str | None) -> str:
    """The module ``obj`` is defined in: a module's own name, a class's or a
    function's ``__module__``, else (a constant, a property, an alias) its owner's."""
    if inspect.ismodule(obj):
        return obj.__name__
    if inspect.isclass(obj) or inspect.isroutine(obj):
        return getattr(obj, "__module__", None) or ""
    if owner:
        owner_obj = _import_path(owner)
        if owner_obj is not _MISSING:
            return _home(owner_obj, owner.rpartition(".")[0])
    return ""


def _ours(home: str) -> bool:
    return home.split(".")[0] in _OURS


def _import_path(path: str) -> Any:
    """The object a dotted path names (a module, or an attribute chain below one)."""
    parts = path.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for attr in parts[cut:]:
            obj = getattr(obj, attr, _MISSING)
            if obj is _MISSING:
                return _MISSING
        return obj
    return _MISSING


def _instance_attribute(cls: Any, name: str) -> bool:
    """Whether instances of ``cls`` have an attribute ``name`` that the class does not
    hold: annotated in a class body, or assigned as ``self.name`` in its source."""
    for klass in inspect.getmro(cls):
        if name in getattr(klass, "__annotations__", {}):
            return True
        try:
            source = inspect.getsource(klass)
        except (OSError, TypeError):
            continue
        if re.search(rf"\bself\.{re.escape(name)}\s*(:[^=]+)?=", source):
            return True
    return False


def _lookup(target: str, module: str | None, cls: str | None) -> tuple[Any, str | None]:
    """The object ``target`` names where the reference stands, and its owner's path
    (for members without a ``__module__``): looked up within the reference's class, its
    module and the packages above it, then as a full path. ``(None, None)`` for an
    instance attribute of one of the project's classes, ``_MISSING`` for nothing."""
    scopes = []
    if module and cls:
        scopes.append(f"{module}.{cls}")
    while module:  # the module, then the packages above it (``.codes.ERROR_NAMES``)
        scopes.append(module)
        module = module.rpartition(".")[0]
    scopes.append("")
    for scope in scopes:
        path = f"{scope}.{target}" if scope else target
        obj = _import_path(path)
        if obj is not _MISSING:
            return obj, path.rpartition(".")[0]
        owner_path, _, attr = path.rpartition(".")
        if owner_path:
            owner = _import_path(owner_path)
            if (
                inspect.isclass(owner)
                and _ours(owner.__module__)
                and _instance_attribute(owner, attr)
            ):
                return None, None  # exists, documented nowhere
    return _MISSING, None


def _candidates(obj: Any, owner: str | None, last: str) -> list[str]:
    """Where ``obj`` may be documented: its defining module's path, then the path
    through its owner (a re-export, a constant, a property)."""
    names = []
    module = getattr(obj, "__module__", None)
    qualname = getattr(obj, "__qualname__", None)
    if inspect.ismodule(obj):
        names.append(obj.__name__)
    elif module and qualname and "<" not in qualname:
        names.append(f"{module}.{qualname}")
    if owner:
        owner_obj = _import_path(owner)
        if inspect.ismodule(owner_obj) or inspect.isclass(owner_obj):
            # The owner's own path, if it is itself a re-export.
            for base in _candidates(owner_obj, None, owner.rpartition(".")[2]):
                names.append(f"{base}.{last}")
        names.append(f"{owner}.{last}")
    return names


def _link(env, app, node, contnode, name: str):
    domain = env.get_domain("py")
    role = "mod" if name in domain.modules else "obj"
    return domain.resolve_xref(env, node["refdoc"], app.builder, role, name, node, contnode)


def _documented_as(env, last: str, obj: Any) -> list[str]:
    """The documented names of the project that end in ``last`` (and, given ``obj``,
    name that very object)."""
    domain = env.get_domain("py")
    names = [*domain.objects, *domain.modules]
    found = [
        name
        for name in names
        if name.rpartition(".")[2] == last
        and _ours(name)
        and (obj is _MISSING or _import_path(name) is obj)
    ]
    return sorted(set(found))


def _sibling_defines(module: str | None, name: str) -> bool:
    """Whether exactly one module of ``module``'s package defines ``name`` (a constant
    a docstring names without importing it)."""
    if not module or not _ours(module):
        return False
    package = importlib.import_module(module.rpartition(".")[0] or module)
    owners = []
    for info in pkgutil.iter_modules(getattr(package, "__path__", [])):
        if info.name == "__main__":  # a command, not a module to import
            continue
        sibling = importlib.import_module(f"{package.__name__}.{info.name}")
        if name in _assigned_names(sibling):
            owners.append(sibling.__name__)
    return len(owners) == 1


def _assigned_names(module: Any) -> set[str]:
    """The names a module's own source assigns at its top level."""
    try:
        tree = ast.parse(inspect.getsource(module))
    except (OSError, TypeError, SyntaxError):
        return set()
    names = set()
    for statement in tree.body:
        targets = []
        if isinstance(statement, ast.Assign):
            targets = statement.targets
        elif isinstance(statement, ast.AnnAssign):
            targets = [statement.target]
        for target in targets:
            for leaf in ast.walk(target):
                if isinstance(leaf, ast.Name):
                    names.add(leaf.id)
    return names


def resolve_reference(app, env, node, contnode):
    """``missing-reference``: a Python name re-exported or imported elsewhere is linked
    where it is documented, a bare name that one documented object of the project
    bears is linked to it; a name that exists but is documented nowhere is shown as
    code. Anything else is left to warn."""
    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"].lstrip(".~")
    if target.startswith("self."):
        target = target[len("self.") :]
    last = target.rpartition(".")[2]
    obj, owner = _lookup(target, node.get("py:module"), node.get("py:class"))
    if obj is _MISSING:
        if "." not in target:  # a bare name of another module
            found = _documented_as(env, last, _MISSING)
            if len(found) == 1:
                return _link(env, app, node, contnode, found[0])
            if _sibling_defines(node.get("py:module"), target):
                return contnode  # an undocumented constant of the same package
        return None
    if obj is None:  # an instance attribute of one of the project's classes
        return contnode
    if not _ours(_home(obj, owner)):
        return None
    documented = env.get_domain("py")
    for name in _candidates(obj, owner, last):
        if name in documented.objects or name in documented.modules:
            return _link(env, app, node, contnode, name)
    found = _documented_as(env, last, obj)  # imported from where it is documented
    if len(found) == 1:
        return _link(env, app, node, contnode, found[0])
    # A real name with no page of its own (private, or not documented).
    return contnode


def setup(app):
    app.connect("autodoc-process-docstring", before_napoleon, priority=400)
    app.connect("autodoc-process-docstring", after_napoleon, priority=600)
    app.connect("autodoc-process-signature", dataclass_factories)
    app.connect("missing-reference", resolve_reference)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
