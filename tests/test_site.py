"""The site's references are complete. The API reference (docs/api.md): every module of the
package has its page (made at build time), and every public name has a docstring that
autodoc shows. The TOML reference (docs/toml.md) has every key, each demo's page every flag of the
demo, and the gallery every demo with its pictures (the parts docs/_ext/generated.py
makes at build time; scripts/check_site.py checks the built pages for the same).

Public names are those of a module's ``__all__`` (else its names without a leading
underscore) that the module defines itself: its classes and functions with their
docstrings, its data with a ``#:`` comment (what autodoc reads for data), and the methods
and properties of its public classes (a docstring inherited from a base class counts, as
it does for autodoc). No Sphinx build: the checks read the modules and docs/api.md."""

from __future__ import annotations

import argparse
import ast
import importlib
import inspect
import os
import pkgutil
import re

import pytest

import nitsche_dolfinx
from nitsche_dolfinx.cli import command as cli
from nitsche_dolfinx.config import schema

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: Every public module and folder of the package (its folders are packages of modules).
MODULES = sorted(
    module.name
    for module in pkgutil.walk_packages(nitsche_dolfinx.__path__, "nitsche_dolfinx.")
    if not module.name.rsplit(".", 1)[-1].startswith("_")
)


def assigned_names(module) -> set[str]:
    """The names a module assigns at its top level (not those it imports)."""
    tree = ast.parse(inspect.getsource(module))
    names = set()
    for node in tree.body:
        targets = node.targets if isinstance(node, ast.Assign) else []
        if isinstance(node, ast.AnnAssign):
            targets = [node.target]
        for target in targets:
            for name in ast.walk(target):
                if isinstance(name, ast.Name):
                    names.add(name.id)
    return names


def public_names(module) -> list[str]:
    """The module's ``__all__``, or its names without a leading underscore."""
    names = getattr(module, "__all__", None)
    return list(names) if names is not None else [n for n in vars(module) if n[0] != "_"]


def defined_here(module, name: str) -> bool:
    """Whether ``name`` is a class or function of ``module`` (not imported into it)."""
    value = getattr(module, name)
    return getattr(value, "__module__", None) == module.__name__


def public_classes(module) -> list[type]:
    """The public classes that ``module`` defines."""
    return [
        getattr(module, name)
        for name in public_names(module)
        if inspect.isclass(getattr(module, name, None)) and defined_here(module, name)
    ]


def test_every_module_in_the_reference():
    """The API reference has a page per module of the package, made at build time
    (docs/_ext/generated.py): each an ``automodule`` with ``:members:``, and docs/api.md
    lists them all."""
    generated = _generated()
    assert generated.api_modules() == MODULES
    assert len(MODULES) > 50  # the package's modules were found at all
    for module in MODULES:
        page = generated.api_page(module)
        if hasattr(importlib.import_module(module), "__path__"):  # a folder: its modules
            assert f".. automodule:: {module}\n```" in page, page
            inside = [m for m in MODULES if m.startswith(module + ".")]
            assert inside and all(f"[`{m}`]({m}.md)" in page for m in inside), page
        else:
            assert f".. automodule:: {module}\n   :members:" in page, page
    listed = re.findall(r"\[`([\w.]+)`\]\(api/([\w.]+)\.md\)", generated.modules_markdown())
    assert sorted(name for name, _ in listed) == MODULES and all(a == b for a, b in listed)
    with open(os.path.join(REPO, "docs", "api.md")) as f:
        text = f.read()
    assert "<!-- generated: modules -->" in text and "api/*" in text


def test_public_names_have_docstrings():
    """Each public class and function has a docstring, each public constant a ``#:``
    comment; a name in ``__all__`` that the module lacks is reported too."""
    pycode = pytest.importorskip("sphinx.pycode")
    missing, absent, checked = [], [], 0
    for name in MODULES:
        module = importlib.import_module(name)
        comments = pycode.ModuleAnalyzer.for_module(name).find_attr_docs()
        assigned = assigned_names(module)
        for public in public_names(module):
            if not hasattr(module, public):
                absent.append(f"{name}.{public}")
                continue
            value = getattr(module, public)
            if inspect.ismodule(value):
                continue
            if inspect.isclass(value) or inspect.isroutine(value):
                if not defined_here(module, public):
                    continue  # imported: documented where it is defined
                documented = bool(inspect.getdoc(value))
            elif public in assigned:
                documented = ("", public) in comments
            else:
                continue  # data imported from another module
            checked += 1
            if not documented:
                missing.append(f"{name}.{public}")
    assert checked > 300  # the public names were found at all
    assert not absent, f"names in __all__ that their module lacks: {absent}"
    assert not missing, f"public names without a docstring (data: a #: comment): {missing}"


def test_public_methods_have_docstrings():
    """Each public method and property of a public class has a docstring, its own or that
    of the method it overrides."""
    missing, checked = [], 0
    for name in MODULES:
        module = importlib.import_module(name)
        for cls in public_classes(module):
            for key, value in vars(cls).items():
                if key.startswith("_"):
                    continue
                if isinstance(value, (staticmethod, classmethod)):
                    value = value.__func__
                if not (inspect.isfunction(value) or isinstance(value, property)):
                    continue
                checked += 1
                if not inspect.getdoc(getattr(cls, key)):
                    missing.append(f"{name}.{cls.__qualname__}.{key}")
    assert checked > 200  # the methods were found at all
    assert not missing, f"public methods and properties without a docstring: {missing}"


def _generated():
    """docs/_ext/generated.py, the site's generated parts (it needs no Sphinx)."""
    import sys

    sys.path.insert(0, os.path.join(REPO, "docs", "_ext"))
    try:
        import generated
    finally:
        sys.path.pop(0)
    return generated


def test_toml_reference_has_every_key():
    """The TOML page is made from the schema: every table, key, facet selector, obstacle
    and mesh generator that validation knows is on it, in a table row of its own."""
    with open(os.path.join(REPO, "docs", "toml.md")) as f:
        assert "<!-- generated: toml-keys -->" in f.read()
    text = schema.markdown()
    rows = set(re.findall(r"^\| `([^`]+)` \|", text, re.M))
    headers = set(re.findall(r"^### `([^`]+)`", text, re.M))
    missing = []
    for name, table in schema.SCHEMA.items():
        missing += [table.header(name)] * (table.header(name) not in headers)
        missing += [f"{name}.{key}" for key in table.keys if key not in rows]
    for registry in (schema.FACET_SELECTORS, schema.OBSTACLES):
        for name, entry in registry.items():
            missing += [name] * (name not in headers)
            missing += [f"{name}.{key}" for key in entry.keys if key not in rows]
    missing += [name for name in schema.MESH_GENERATORS if name not in rows]
    assert len(rows) > 80  # the rows were found at all (91 distinct names)
    assert not missing, f"TOML keys missing from docs/toml.md: {missing}"


def test_cli_reference_is_the_parser():
    """docs/cli.md renders the command's own parser (sphinx-argparse), whose every flag
    has a help text."""
    with open(os.path.join(REPO, "docs", "cli.md")) as f:
        text = f.read()
    assert ":module: nitsche_dolfinx.cli.command" in text and ":func: argument_parser" in text
    silent = []
    parsers = [cli.argument_parser()]
    while parsers:
        parser = parsers.pop()
        for action in parser._actions:
            if action.option_strings and not action.help:
                silent.append(action.option_strings[0])
            if isinstance(action, argparse._SubParsersAction):
                parsers += list(action.choices.values())
    assert not silent, f"flags of nitsche-dolfinx without a help text: {silent}"


def test_demo_pages_list_every_flag():
    """Each demo's page lists every flag of the demo's own parser, and every TOML file of
    demos/ is offered for download on a demo's page or the gallery."""
    generated = _generated()
    names = generated.demo_names()
    assert len(names) >= 19
    missing = []
    for name in names:
        assert generated.demo_title(name)
        table = "\n".join(generated.flags_markdown(name))
        for action in generated.demo_parser(name)._actions:
            for option in action.option_strings:  # not a part of a longer flag
                if not generated.has_flag(table, option):
                    missing.append(f"{name} {option}")
    assert not missing, f"demo flags missing from their pages: {missing}"
    offered = sorted(toml for tomls in generated.demo_tomls().values() for toml in tomls)
    present = sorted(os.path.basename(p) for p in os.listdir(os.path.join(REPO, "demos")))
    assert offered == [p for p in present if p.endswith(".toml")]


def test_gallery_has_every_demo():
    """``make gallery`` stored at least one picture of every demo, made by the demo's own
    command, and each picture the manifest names is there."""
    generated = _generated()
    entries = generated.gallery()
    assert sorted(entries) == generated.demo_names()
    for name, entry in entries.items():
        assert f"demos/{name}.py" in entry["command"], name
        assert entry["pictures"], f"the gallery has no picture of {name}"
        for picture in entry["pictures"]:
            assert os.path.exists(os.path.join(generated.GALLERY, picture["file"])), picture
            assert picture["caption"]


def test_docstrings_are_in_one_style():
    """Google's style (``Args:``, ``Returns:``, ``Raises:``; docs/layout.md), which the site
    reads with napoleon: no numpy sections and no reST fields, which it would show raw or
    mix with the others."""
    other = re.compile(r"^\s*(:param\b|:returns?:|:rtype:|(Parameters|Returns)\n\s*-{3,})", re.M)
    mixed = []
    for name in MODULES:
        module = importlib.import_module(name)
        members = [m for c in public_classes(module) for m in vars(c).values() if callable(m)]
        for value in [module, *vars(module).values(), *members]:
            doc = inspect.getdoc(value) if callable(value) or inspect.ismodule(value) else None
            if doc and getattr(value, "__module__", name) == name and other.search(doc):
                mixed.append(f"{name}.{getattr(value, '__qualname__', '')}")
    assert not mixed, f"docstrings not in Google's style: {mixed}"
