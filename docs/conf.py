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
