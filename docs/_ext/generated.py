"""The parts of the site made from the code when it is built, so that they cannot go stale:

- the TOML reference (docs/toml.md): :func:`nitsche_dolfinx.config.schema.markdown`, from the
  objects that validate a file;
- on each demo's page (the demo file itself, read by ``demo_reader``): its first picture
  under the title, then its pictures, its flags (from its own parser) and links to
  download the script and its TOML files;
- the gallery (docs/gallery.md): every demo with its pictures;
- the API reference: a page per module of the package (docs/api/, not committed) and
  their list with each module's summary (docs/api.md).

The pictures are the stored outputs of ``make gallery`` (``scripts/gallery.py`` runs the
demos and writes ``docs/gallery/gallery.json``). Each page holds a marker comment,
``<!-- generated: NAME -->``, that the text replaces as the page is read.
"""

from __future__ import annotations

import argparse
import glob
import hashlib
import json
import os
import re
import runpy
import sys

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DEMOS = os.path.join(REPO, "demos")
GALLERY = os.path.join(REPO, "docs", "gallery")
API = os.path.join(REPO, "docs", "api")


def api_modules() -> list[str]:
    """The package's public modules and folders (not those whose name starts with ``_``),
    sorted: a folder comes just before its modules."""
    import pkgutil

    import nitsche_dolfinx

    found = pkgutil.walk_packages(nitsche_dolfinx.__path__, "nitsche_dolfinx.")
    return sorted(m.name for m in found if not m.name.rsplit(".", 1)[-1].startswith("_"))


def api_page(module: str) -> str:
    """The reference page of ``module``: autodoc of every public member; a folder's page
    has its docstring and its modules' links (its members are documented where defined)."""
    import importlib

    if hasattr(importlib.import_module(module), "__path__"):
        inside = [m for m in api_modules() if m.startswith(module + ".")]
        links = "".join(f"- [`{m}`]({m}.md)\n" for m in inside)
        return f"# `{module}`\n\n```{{eval-rst}}\n.. automodule:: {module}\n```\n\n{links}"
    return f"# `{module}`\n\n```{{eval-rst}}\n.. automodule:: {module}\n   :members:\n```\n"


def write_api_pages(app=None) -> None:
    """docs/api/MODULE.md for every public module, before Sphinx looks for its sources
    (a page left by a module that is gone is removed)."""
    os.makedirs(API, exist_ok=True)
    pages = {f"{module}.md": api_page(module) for module in api_modules()}
    for name in os.listdir(API):
        if name not in pages:
            os.remove(os.path.join(API, name))
    for name, text in pages.items():
        path = os.path.join(API, name)
        if not os.path.exists(path) or open(path).read() != text:
            with open(path, "w") as f:
                f.write(text)


def modules_markdown() -> str:
    """docs/api.md's list: a table per layer (``nitsche_dolfinx.LAYERS``, lowest first),
    each module linked to its page with its docstring's summary, the folder first."""
    import importlib

    import nitsche_dolfinx
    from nitsche_dolfinx.post import markdown_cell, markdown_table

    def summary(module: str) -> str:
        doc = (importlib.import_module(module).__doc__ or "").strip()
        text = " ".join(doc.split("\n\n")[0].split())
        return re.sub(r":(\w+):`", r"{py:\1}`", text)  # reST's roles in MyST's words

    modules = api_modules()
    sections = []
    for layer in nitsche_dolfinx.LAYERS:
        name = f"nitsche_dolfinx.{layer}"
        rows = [
            [f"[`{module}`](api/{module}.md)", markdown_cell(summary(module))]
            for module in modules
            if module == name or module.startswith(name + ".")
        ]
        sections.append(f"## `{layer}`\n\n" + markdown_table(["module", "what it holds"], rows))
    return "\n\n".join(sections) + "\n"


def demo_names() -> list[str]:
    """The demos: the stems of ``demos/*.py``, sorted."""
    return sorted(os.path.splitext(os.path.basename(p))[0] for p in glob.glob(f"{DEMOS}/*.py"))


def demo_title(name: str) -> str:
    """The demo's title: the first heading of its prose."""
    with open(os.path.join(DEMOS, f"{name}.py")) as f:
        for line in f:
            match = re.match(r"# # (.+)", line)
            if match:
                return match.group(1).strip()
    raise ValueError(f"demos/{name}.py has no title (a line '# # Title')")


def demo_tomls() -> dict[str, list[str]]:
    """Each demo's TOML files: a file belongs to the first demo its leading comment names
    (``demos/NAME.py``); files that name none are listed under ``""``."""
    owners: dict[str, list[str]] = {name: [] for name in demo_names()}
    owners[""] = []
    for path in sorted(glob.glob(f"{DEMOS}/*.toml")):
        with open(path) as f:
            head = "".join(line for line, _ in zip(f, range(5)))
        named = [m for m in re.findall(r"demos/(\w+)\.py", head) if m in owners]
        owners[named[0] if named else ""].append(os.path.basename(path))
    return owners


def gallery() -> dict:
    """The manifest of ``make gallery``: each demo's command and pictures."""
    path = os.path.join(GALLERY, "gallery.json")
    if not os.path.exists(path):
        return {}
    with open(path) as f:
        return json.load(f)["demos"]


class _Parsed(Exception):
    def __init__(self, parser):
        self.parser = parser


def demo_parser(name: str) -> argparse.ArgumentParser:
    """The demo's own argument parser: the demo runs as ``__main__`` up to the point where
    it parses its arguments, and stops there (nothing is computed)."""
    original = argparse.ArgumentParser.parse_known_args

    def parsed(self, *args, **kwargs):
        raise _Parsed(self)

    argv, path = sys.argv, list(sys.path)
    argparse.ArgumentParser.parse_known_args = parsed
    sys.argv, sys.path[:0] = [f"demos/{name}.py"], [DEMOS]
    try:
        runpy.run_path(os.path.join(DEMOS, f"{name}.py"), run_name="__main__")
    except _Parsed as stop:
        return stop.parser
    finally:
        argparse.ArgumentParser.parse_known_args = original
        sys.argv, sys.path[:] = argv, path
    raise ValueError(f"demos/{name}.py parses no arguments")


def flag_rows(parser: argparse.ArgumentParser) -> list[tuple[str, str]]:
    """(the flag as typed, its meaning with its default) for each option of ``parser``."""
    formatter = parser._get_formatter()
    rows = []
    for action in parser._actions:
        if not action.option_strings:
            continue
        flag = ", ".join(action.option_strings)
        if action.nargs != 0:
            flag += " " + formatter._format_args(action, action.dest.upper())
        meaning = " ".join(formatter._expand_help(action).split()) if action.help else ""
        shown = action.nargs != 0 and action.default not in (None, argparse.SUPPRESS)
        if shown and "default" not in meaning:
            meaning += f" (default: {action.default})"
        rows.append((flag, meaning))
    return rows


def has_flag(text: str, option: str) -> bool:
    """Whether ``text`` holds ``option`` as a flag of its own (not a part of a longer one,
    as ``--compare`` of ``--no-compare``)."""
    return re.search(rf"(?<![\w-]){re.escape(option)}(?![\w-])", text) is not None


def flags_markdown(name: str) -> list[str]:
    """The table of the demo's flags, as Markdown lines."""
    from nitsche_dolfinx.post import markdown_cell, markdown_table

    rows = [[f"`{markdown_cell(flag)}`", markdown_cell(meaning)]
            for flag, meaning in flag_rows(demo_parser(name))]  # fmt: skip
    return markdown_table(["flag", "meaning"], rows).split("\n")


def _figure(path: str, caption: str, width: str = "") -> list[str]:
    lines = [f"```{{figure}} {path}", f":alt: {caption}"]
    return lines + ([f":width: {width}"] if width else []) + ["", caption, "```", ""]


def _sha256(path: str) -> str:
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def demo_additions(name: str, text: str) -> str:
    """The demo file's text with its first picture under the title and, at the end, its
    pictures, flags and downloads, as jupytext "light" Markdown cells (comments)."""
    entry = gallery().get(name)
    pictures = entry["pictures"] if entry else []
    if pictures:
        first = pictures[0]
        figure = _figure(f"../docs/gallery/{first['file']}", first["caption"], "80%")
        lines = text.split("\n")
        title = next(i for i, line in enumerate(lines) if line.startswith("# # "))
        lines[title + 1 : title + 1] = ["#"] + ["# " + x if x else "#" for x in figure]
        text = "\n".join(lines)
    tail = []
    if pictures:
        tail += ["## Pictures", "",
                 f"Made by `make gallery`, which runs `{entry['command']}` "
                 f"(OUT a folder; {entry['seconds']:.0f} s, version {entry['version']}, "
                 f"commit {entry['commit']}).", ""]  # fmt: skip
        if entry["demo_sha256"] != _sha256(os.path.join(DEMOS, f"{name}.py")):
            tail += [f"The demo has changed since: `make gallery DEMOS={name}` redraws them.", ""]
        for picture in pictures:
            tail += _figure(f"../docs/gallery/{picture['file']}", picture["caption"])
    tail += ["## Flags", "", f"`python demos/{name}.py --help` lists them:", ""]
    tail += flags_markdown(name) + [""]
    tail += ["## Download", "", f"- the script: {{download}}`{name}.py <{name}.py>`"]
    for toml in demo_tomls()[name]:
        tail.append(f"- its TOML file: {{download}}`{toml} <{toml}>` "
                    f"(`nitsche-dolfinx run demos/{toml}`)")  # fmt: skip
    cells = "\n".join("# " + line if line else "#" for line in tail)
    return text.rstrip("\n") + "\n\n" + cells + "\n"


def gallery_markdown() -> str:
    """The gallery page: every demo, its title and pictures, linked to its page."""
    entries = gallery()
    lines = []
    for name in demo_names():
        lines += [f"## {demo_title(name)}", "", f"{{doc}}`demos/{name}.py </demos/{name}>`", ""]
        for picture in entries.get(name, {}).get("pictures", []):
            lines += [f"```{{image}} gallery/{picture['file']}", f":alt: {picture['caption']}",
                      ":width: 48%", f":target: ../demos/{name}.html", "```"]  # fmt: skip
        lines.append("")
    own = demo_tomls()[""]
    if own:
        lines += ["## TOML files of their own", ""]
        lines += [f"- {{download}}`{toml} <../demos/{toml}>`" for toml in own] + [""]
    return "\n".join(lines)


def _toml_keys() -> str:
    from nitsche_dolfinx.config import schema

    return schema.markdown()


MARKERS = {"toml-keys": _toml_keys, "gallery": gallery_markdown, "modules": modules_markdown}


def read_source(app, docname: str, source: list[str]) -> None:
    """Fill in a page's generated parts as it is read (Sphinx's ``source-read``)."""
    if docname == "README":  # a page of its own for the links to it, but the front page
        source[0] = "---\norphan: true\n---\n" + source[0]  # shows it: not in the sidebar
    elif docname.startswith("demos/"):
        source[0] = demo_additions(docname[len("demos/") :], source[0])
    for name, make in MARKERS.items():
        marker = f"<!-- generated: {name} -->"
        if marker in source[0]:
            source[0] = source[0].replace(marker, make())


def setup(app):
    app.connect("builder-inited", write_api_pages)
    app.connect("source-read", read_source)
    return {"parallel_read_safe": True}
