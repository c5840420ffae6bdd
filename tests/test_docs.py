"""docs/method.md names where each formula lives, after **Code:**, as `module.name`: every
such name is one of the package (a moved or renamed class leaves no stale reference)."""

import importlib
import os
import pkgutil
import re

import pytest

import nitsche_dolfinx

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MODULES = {module.name for module in pkgutil.iter_modules(nitsche_dolfinx.__path__)}


def code_names(path: str) -> list[str]:
    """The `module.name...` references of the **Code:** paragraphs of ``path``."""
    with open(path) as f:
        text = f.read()
    names = []
    for paragraph in re.findall(r"\*\*Code:\*\*(.*?)(?:\n\n|\Z)", text, re.S):
        for token in re.findall(r"`([^`\n]+)`", paragraph):
            parts = token.split("(")[0].strip().split(".")
            if len(parts) > 1 and parts[0] in MODULES and all(p.isidentifier() for p in parts):
                names.append(".".join(parts))
    return names


@pytest.mark.parametrize("document", ["method.md", "results.md"])
def test_code_references_name_the_package(document):
    names = code_names(os.path.join(REPO, "docs", document))
    if document == "method.md":
        assert len(names) > 100  # the references were found at all
    missing, elsewhere = [], []
    for name in names:
        module, *attributes = name.split(".")
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


def test_layout_lists_every_module():
    """docs/layout.md has a row for each module of the package, and none that is gone."""
    with open(os.path.join(REPO, "docs", "layout.md")) as f:
        text = f.read()
    listed = set(re.findall(r"`(\w+\.py)`", text.split("And around the package")[0]))
    present = {name for name in os.listdir(os.path.dirname(nitsche_dolfinx.__file__))}
    present = {name for name in present if name.endswith(".py")}
    assert present - listed == set(), "modules missing from docs/layout.md"
    assert listed - present == set(), "docs/layout.md lists modules that are gone"
