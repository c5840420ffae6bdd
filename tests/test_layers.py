"""The package's folders are layers that look only down (docs/layout.md): every import of a
module of the package names its own folder or one before it in ``nitsche_dolfinx.LAYERS``,
and every folder is a layer. Read from the source with ``ast``, so that an import made
inside a function counts too."""

from __future__ import annotations

import ast
import os

import nitsche_dolfinx

PACKAGE = os.path.dirname(nitsche_dolfinx.__file__)
LAYERS = nitsche_dolfinx.LAYERS


def layer_of(parts: list[str]) -> str | None:
    """The layer of a module given by its path inside the package (None: the package's
    face, ``__init__.py`` or ``__main__.py``, which may import any layer)."""
    name = parts[0].removesuffix(".py")
    return name if name in LAYERS else None


def imported_layers(path: str, parts: list[str]) -> set[str]:
    """The layers the module at ``path`` imports from."""
    tree = ast.parse(open(path).read())
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level == 0 and (node.module or "").startswith("nitsche_dolfinx."):
                target = node.module.split(".")[1:]
            elif node.level > 0:
                base = parts[: len(parts) - node.level]
                target = base + (node.module.split(".") if node.module else [])
                if not node.module:  # from .. import name: each name a module or a folder
                    found |= {a.name for a in node.names if a.name in LAYERS}
                    continue
            else:
                continue
            if target and target[0] in LAYERS:
                found.add(target[0])
    return found


def modules():
    """``(path, parts)`` of every module of the package; parts: its path inside it."""
    for root, _, files in os.walk(PACKAGE):
        for name in sorted(files):
            if name.endswith(".py"):
                path = os.path.join(root, name)
                yield path, os.path.relpath(path, PACKAGE).split(os.sep)


def test_every_folder_is_a_layer():
    folders = {
        entry
        for entry in os.listdir(PACKAGE)
        if os.path.isfile(os.path.join(PACKAGE, entry, "__init__.py"))
    }
    tops = {
        entry.removesuffix(".py")
        for entry in os.listdir(PACKAGE)
        if entry.endswith(".py") and not entry.startswith("_")
    }
    assert folders | tops == set(LAYERS)


def test_imports_look_only_down():
    wrong, seen = [], 0
    for path, parts in modules():
        layer = layer_of(parts)
        if layer is None:
            continue
        for other in imported_layers(path, parts) - {layer}:
            seen += 1
            if LAYERS.index(other) > LAYERS.index(layer):
                wrong.append(f"{'/'.join(parts)} ({layer}) imports {other}")
    assert seen > 100  # the imports were read at all
    assert not wrong, "\n".join(wrong)
