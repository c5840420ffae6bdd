"""Sphinx configuration of the documentation site: ``make docs`` builds it from the
repository's root (the README, docs/*.md, the demos themselves) into _site/html."""

import os
import shutil
import sys

from sphinx.ext.napoleon import Config
from sphinx.ext.napoleon.docstring import GoogleDocstring

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "_ext"))

project = "nitsche-dolfinx"
author = "the nitsche-dolfinx developers"
root_doc = "docs/index"
extensions = [
    "myst_nb",
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "sphinxarg.ext",
    "generated",
]
include_patterns = ["README.md", "docs/*.md", "docs/api/*.md", "demos/*.py"]  # docs/api: made
myst_enable_extensions = ["dollarmath", "amsmath"]
myst_heading_anchors = 3
nb_execution_mode = "off"
nb_custom_formats = {".py": ["demo_reader.read_demo", {}, False]}
html_theme = "furo"
autodoc_member_order = "bysource"
# each parameter's type beside its meaning (from the annotations), defaults in the signature
autodoc_typehints = "description"
html_extra_path = ["_ext/index.html"]
html_favicon = "_ext/favicon.svg"
#: MathJax 2 from Debian's libjs-mathjax (make docs installs it), copied into the site: the
#: pages render their formulas without fetching anything from the network.
MATHJAX = "/usr/share/javascript/mathjax"
MATHJAX_PARTS = ["MathJax.js", "config/TeX-AMS_CHTML.js", "extensions", "jax/input/TeX",
                 "jax/output/CommonHTML", "jax/element", "localization/en",
                 "fonts/HTML-CSS/TeX/woff"]  # fmt: skip
mathjax_path = "mathjax/MathJax.js?config=TeX-AMS_CHTML"
# MyST marks its pages' sections for MathJax to skip and its formulas with the class "math"
# (its settings are MathJax 3's: given here in MathJax 2's words)
myst_update_mathjax = False
mathjax2_config = {"tex2jax": {"processClass": "math|tex2jax_process",
                               "ignoreClass": "tex2jax_ignore|mathjax_ignore"}}  # fmt: skip


#: The docstrings are in Google's style (Args:, Returns:, Raises:), read by napoleon's
#: GoogleDocstring with these settings.
NAPOLEON = Config(napoleon_use_ivar=True, napoleon_numpy_docstring=False)


def _google_docstring(app, what, name, obj, options, lines):
    """A docstring in Google's style as reStructuredText. A data, attribute or property is
    read as any other docstring: napoleon would read its first line as ``type:
    description`` (``#: Facet tags: the bottom ...`` showed "Type: Facet tags"), and the
    package writes no type there."""
    plain = "object" if what in ("attribute", "data", "property") else what
    lines[:] = GoogleDocstring(lines, NAPOLEON, app, plain, name, obj, options).lines()


def _copy_mathjax(app, exception):
    """The parts of MathJax that the TeX-AMS_CHTML configuration loads, into _static."""
    if exception is not None or app.builder.format != "html":
        return
    target = os.path.join(app.outdir, "_static", "mathjax")
    for part in MATHJAX_PARTS:
        source, destination = os.path.join(MATHJAX, part), os.path.join(target, part)
        os.makedirs(os.path.dirname(destination), exist_ok=True)
        if os.path.isdir(source):
            shutil.copytree(source, destination, dirs_exist_ok=True)
        else:
            shutil.copy2(source, destination)


def setup(app):
    app.connect("build-finished", _copy_mathjax)
    app.connect("autodoc-process-docstring", _google_docstring)
