"""Sphinx configuration of the documentation site: ``make docs`` builds it from the
repository's root (the README, docs/*.md, the demos themselves) into _site/html."""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "_ext"))

project = "nitsche-dolfinx"
author = "the nitsche-dolfinx developers"
root_doc = "docs/index"
extensions = [
    "myst_nb",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinxarg.ext",
]
include_patterns = ["README.md", "docs/*.md", "docs/api/*.md", "demos/*.py"]
myst_enable_extensions = ["dollarmath", "amsmath"]
myst_heading_anchors = 3
nb_execution_mode = "off"
nb_custom_formats = {".py": ["demo_reader.read_demo", {}, False]}
html_theme = "furo"
autodoc_member_order = "bysource"
napoleon_use_ivar = True
html_extra_path = ["_ext/index.html"]


def _plain_attribute_docstrings(app, what, name, obj, options, lines):
    """Napoleon reads the first line of the docstring of a data, attribute or property as
    ``type: description`` (``#: Facet tags: the bottom ...`` showed "Type: Facet tags");
    the package writes no type there, so these are read as any other docstring."""
    from sphinx.ext.napoleon import _process_docstring

    plain = "object" if what in ("attribute", "data", "property") else what
    _process_docstring(app, plain, name, obj, options, lines)


def setup(app):
    from sphinx.ext.napoleon import _process_docstring

    for listener in list(app.events.listeners["autodoc-process-docstring"]):
        if listener.handler is _process_docstring:
            app.disconnect(listener.id)
    app.connect("autodoc-process-docstring", _plain_attribute_docstrings)
