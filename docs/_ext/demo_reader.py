"""The demos as notebooks for myst-nb: each ``demos/*.py`` (a jupytext "light" script,
prose in comments, code between them) read as it is, as Python."""

import jupytext


def read_demo(text: str):
    notebook = jupytext.reads(text, fmt="py:light")
    notebook.metadata["kernelspec"] = {"name": "python3", "language": "python",
                                       "display_name": "Python 3"}  # fmt: skip
    notebook.metadata["language_info"] = {"name": "python"}
    return notebook
