"""docs/method.md names where each formula lives, after **Code:**: as a link into the API
reference ({py:func}`.module.name`, checked here because Sphinx does not warn when a link
finds no entry), or as `module.name` for what the reference leaves out (private names).
Every such name is one of the package (a moved or renamed class leaves no stale reference)."""

import ast
import functools
import importlib
import inspect
import os
import pkgutil
import re

import pytest

import nitsche_dolfinx

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: Every module and folder of the package, by its dotted name inside it (``steppers.implicit``).
MODULES = {
    module.name.removeprefix("nitsche_dolfinx.")
    for module in pkgutil.walk_packages(nitsche_dolfinx.__path__, "nitsche_dolfinx.")
}


def module_prefix(parts: list[str]) -> int:
    """How many of ``parts`` name a module of the package (the longest such prefix that
    leaves a name after it), 0 if none."""
    for length in range(len(parts) - 1, 0, -1):
        if ".".join(parts[:length]) in MODULES:
            return length
    return 0


def code_names(path: str) -> list[str]:
    """The `module.name...` references of the **Code:** paragraphs of ``path``."""
    with open(path) as f:
        text = f.read()
    names = []
    text = ROLE.sub("", text)  # the links: test_roles_link_api_entries
    for paragraph in re.findall(r"\*\*Code:\*\*(.*?)(?:\n\n|\Z)", text, re.S):
        for token in re.findall(r"`([^`\n]+)`", paragraph):
            parts = token.split("(")[0].strip().split(".")
            if module_prefix(parts) and all(p.isidentifier() for p in parts):
                names.append(".".join(parts))
    return names


@pytest.mark.parametrize("document", ["method.md", "results.md"])
def test_code_references_name_the_package(document):
    names = code_names(os.path.join(REPO, "docs", document))
    missing, elsewhere = [], []
    for name in names:
        parts = name.split(".")
        length = module_prefix(parts)
        module, attributes = ".".join(parts[:length]), parts[length:]
        target = importlib.import_module(f"nitsche_dolfinx.{module}")
        for depth, attribute in enumerate(attributes):
            target = getattr(target, attribute, None)
            if target is None:
                missing.append(name)
                break
            defined = getattr(target, "__module__", None)
            if depth == 0 and callable(target) and defined != f"nitsche_dolfinx.{module}":
                elsewhere.append(f"{name} (defined in {defined})")  # imported there
    assert not missing, f"docs/{document} names what the package lacks: {missing}"
    assert not elsewhere, f"docs/{document} names things where they are not defined: {elsewhere}"


# A role of MyST, {py:kind}`target`, {py:kind}`title <target>` or {py:kind}`~target`
ROLE = re.compile(r"\{py:(\w+)\}`([^`]+)`")
#: The role that links each kind of object: Sphinx resolves a target that starts with a dot
#: by the kind too (a method named by {py:func} stays plain text).
ROLES = {"module": {"mod"}, "class": {"class", "exc"}, "function": {"func"},
         "method": {"meth"}, "attribute": {"attr"}, "data": {"data"}}  # fmt: skip


def roles(text: str) -> list[tuple[str, str]]:
    """The (kind, full target) of every py role of ``text``: a target that starts with a dot
    is relative to the package (docs/method.md writes `.module.name`)."""
    found = []
    for kind, content in ROLE.findall(text):
        target = re.search(r"<([^<>]+)>$", content)
        target = target.group(1) if target else content.lstrip("~")
        found.append((kind, "nitsche_dolfinx" + target if target.startswith(".") else target))
    return found


def documented_assignments(source: str) -> set[str]:
    """The names assigned in ``source`` with a ``#:`` comment or a docstring, as autodoc
    finds them: module data, class attributes and ``self.name`` in methods (``Class.name``)."""
    lines = source.splitlines()
    names = set()

    def documented(body, i):
        node, following = body[i], body[i + 1] if i + 1 < len(body) else None
        return (
            lines[node.lineno - 2].strip().startswith("#:")
            or "#:" in lines[node.lineno - 1]
            or isinstance(following, ast.Expr)
            and isinstance(following.value, ast.Constant)
            and isinstance(following.value.value, str)
        )

    def visit(body, prefix, method):
        for i, node in enumerate(body):
            if isinstance(node, ast.ClassDef) and not method:
                visit(node.body, prefix + node.name + ".", False)
            elif isinstance(node, ast.FunctionDef) and prefix and not method:
                visit(node.body, prefix, True)
            elif isinstance(node, (ast.Assign, ast.AnnAssign)) and documented(body, i):
                targets = getattr(node, "targets", [getattr(node, "target", None)])
                for target in [e for t in targets for e in getattr(t, "elts", [t])]:
                    if method and isinstance(target, ast.Attribute):
                        if isinstance(target.value, ast.Name) and target.value.id == "self":
                            names.add(prefix + target.attr)
                    elif not method and isinstance(target, ast.Name):
                        names.add(prefix + target.id)
            elif method:
                for field in ("body", "orelse", "finalbody"):
                    visit(getattr(node, field, []), prefix, True)

    visit(ast.parse(source).body, "", False)
    return names


@functools.cache
def assigned_in(module: str) -> set[str]:
    return documented_assignments(inspect.getsource(importlib.import_module(module)))


def attribute_documented(cls: type, name: str, inherited: bool = True) -> bool:
    """Whether autodoc documents the attribute ``name`` of ``cls``: a ``#:`` comment or a
    docstring where a class of the package (its bases too: an override keeps the doc)
    assigns it, or a field of a NamedTuple."""
    if name in getattr(cls, "_fields", ()):
        return True
    return any(
        f"{base.__qualname__}.{name}" in assigned_in(base.__module__)
        for base in (cls.__mro__ if inherited else [cls])
        if base.__module__.startswith("nitsche_dolfinx.")
    )


def api_entry(target: str) -> str:
    """The kind of the entry of docs/api.md (automodule of every module: its public
    documented members, those of ``__all__`` included) for ``target``, or why it has none."""
    parts = target.split(".")
    if parts[0] != "nitsche_dolfinx" or len(parts) < 2:
        return "not a module of the package"
    if ".".join(parts[1:]) in MODULES:
        return "module"
    length = module_prefix(parts[1:])
    if not length:
        return "not a module of the package"
    module = importlib.import_module(".".join(parts[: length + 1]))
    if any(part.startswith("_") for part in parts[length + 1 :]):
        return "private"
    name, *members = parts[length + 1 :]
    if name not in getattr(module, "__all__", vars(module)):
        return f"no {name} in {module.__name__}" + (" (its __all__)" * hasattr(module, "__all__"))
    obj = getattr(module, name)
    if inspect.isclass(obj) or inspect.isfunction(obj):
        if obj.__module__ != module.__name__ and name not in getattr(module, "__all__", ()):
            return f"{name} is imported into {module.__name__}"
        kind = "class" if inspect.isclass(obj) else "function"
    elif name in assigned_in(module.__name__):
        kind = "data"
    else:
        return f"{name}: no docstring or #: comment"
    for member in members:
        if kind != "class":
            return f"{member}: a member of a {kind}"
        owner = obj
        if member not in vars(owner):  # inherited, or an instance attribute
            ok = attribute_documented(owner, member, inherited=False)
            return "attribute" if ok else f"no {member} in {owner.__qualname__}"
        raw, obj = vars(owner)[member], getattr(owner, member)
        if inspect.isclass(obj):
            kind = "class"
        elif isinstance(raw, property):
            kind = "property"
        elif callable(raw) or isinstance(raw, (staticmethod, classmethod)):
            kind = "method"
        elif attribute_documented(owner, member):
            kind = "attribute"
        else:
            return f"{member}: no docstring or #: comment"
    if kind in ("class", "function", "method", "property") and not inspect.getdoc(obj):
        return f"{target}: no docstring"
    return "attribute" if kind == "property" else kind


def documents_with_roles() -> list[str]:
    docs = os.path.join(REPO, "docs")
    return sorted(name for name in os.listdir(docs) if name.endswith(".md")
                  and ROLE.search(open(os.path.join(docs, name)).read()))  # fmt: skip


@pytest.mark.parametrize("document", documents_with_roles())
def test_roles_link_api_entries(document):
    """Every {py:...} role of a page names an entry of the API reference, by the role of its
    kind: Sphinx leaves a role it cannot resolve as plain text, without a warning."""
    with open(os.path.join(REPO, "docs", document)) as f:
        found = roles(f.read())
    if document == "method.md":
        assert len(found) >= 360  # 382 when written: each formula links what computes it
    wrong = []
    for kind, target in found:
        entry = api_entry(target)
        if kind not in ROLES.get(entry, ()):
            wrong.append(f"{{py:{kind}}}`{target}`: {entry}")
    assert not wrong, f"docs/{document} links no API entry: {wrong}"


def test_layout_lists_every_module():
    """docs/layout.md has a section per folder of the package with a row for each of its
    modules (the layers' ``__init__.py`` aside; a folder inside a layer, such as
    ``common/compat/``, lists its own), and none that is gone."""
    with open(os.path.join(REPO, "docs", "layout.md")) as f:
        text = f.read().split("And around the package")[0]
    listed = set()
    for heading, body in re.findall(r"^## (.*)\n((?:(?!^## ).*\n?)*)", text, re.M):
        folder = re.fullmatch(r"`([\w/]+)/`", heading.strip())
        prefix = folder.group(1) + "/" if folder else ""
        listed |= {prefix + name for name in re.findall(r"^\| `(\w+\.py)`", body, re.M)}
    package = os.path.dirname(nitsche_dolfinx.__file__)
    present = set()
    for root, _, files in os.walk(package):
        folder = os.path.relpath(root, package)
        for name in files:
            layer_face = folder != "." and "/" not in folder and name == "__init__.py"
            if name.endswith(".py") and not layer_face:
                present.add(name if folder == "." else f"{folder}/{name}")
    assert len(present) > 70  # the modules were found at all
    assert present - listed == set(), "modules missing from docs/layout.md"
    assert listed - present == set(), "docs/layout.md lists modules that are gone"


#: The start of a Markdown list item: a line so begun within a paragraph starts a list.
LIST_ITEM = re.compile(r"\s*([-+*]|\d+[.)])\s")


def formula_breaks(path: str) -> list[str]:
    """Lines of ``path`` that break a formula: a line inside $...$ or $$...$$ that Markdown
    reads as a list item (it ends the paragraph, and the formula's dollars pair wrongly),
    and a display formula that shares a paragraph with text (MyST pairs its dollars with
    the text's)."""
    breaks, inline, fence = [], 0, False
    lines = open(path).read().split("\n")
    for number, line in enumerate(lines, 1):
        if line.startswith("```"):
            fence = not fence
        if fence or line.startswith("```") or not line.strip():
            inline = 0
            continue
        if inline and LIST_ITEM.match(line):
            breaks.append(f"{path}:{number}: {line.strip()}")
        text = re.sub(r"`[^`]*`", "", line).replace("\\$", "")
        if text.lstrip().startswith("$$") and inline == 0 and lines[number - 2].strip():
            breaks.append(f"{path}:{number}: a display formula inside a paragraph")
        inline = (inline + text.count("$")) % 2 if "$$" not in text else inline
        if "$$" in text and text.count("$$") % 2:
            inline = 1 - inline
    return breaks


@pytest.mark.parametrize("page", sorted(p for p in os.listdir(os.path.join(REPO, "docs"))
                                        if p.endswith(".md")))  # fmt: skip
def test_formulas_are_not_broken_by_markdown(page):
    """No line of a formula starts a list item, no display formula sits inside a
    paragraph of text: both rendered text as math on the site (docs/method.md, sections 4,
    8 and 13, before they were reflowed)."""
    assert not formula_breaks(os.path.join(REPO, "docs", page))
