"""The version differences of the other libraries: numpy's trapezoid rule, pyvista's mesh of
a function space and the symbols VTK binds, and the C compilers' log lines of FFCx's builds.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys

import dolfinx.plot
import numpy as np

__all__ = ["own_symbols", "quiet_form_compilation", "trapezoid", "vtk_mesh"]


#: ``numpy.trapz`` was removed in numpy 2 in favour of ``numpy.trapezoid``.
trapezoid = getattr(np, "trapezoid", None) or np.trapz


def vtk_mesh(V):
    """``(topology, cell types, points)`` of a function space for pyvista.

    ``dolfinx.plot.vtk_mesh`` from 0.7, ``create_vtk_mesh`` before.
    """
    function = getattr(dolfinx.plot, "vtk_mesh", None) or dolfinx.plot.create_vtk_mesh
    return function(V)


@contextlib.contextmanager
def own_symbols():
    """Let the libraries loaded in the block bind their own symbols first (RTLD_DEEPBIND).

    dolfinx 0.5 leaves RTLD_GLOBAL in the dlopen flags after its import, so that its
    C++ template instances (std::regex among them) come first for every library
    loaded later; VTK's pip wheels, built with another C++ ABI, then crash in
    std::regex (std::bad_alloc) when they draw a colour bar. Import pyvista (and
    render) inside this block.
    """
    flags = sys.getdlopenflags()
    sys.setdlopenflags(os.RTLD_NOW | getattr(os, "RTLD_DEEPBIND", 0))
    try:
        yield
    finally:
        sys.setdlopenflags(flags)


class _BuildLogFilter:
    """Drops the INFO lines of C compilers that setuptools logs on the root logger while
    FFCx/cffi compile a form (dolfinx 0.5: pages of ``INFO:root ... gcc ...``)."""

    @staticmethod
    def filter(record) -> bool:
        build = "distutils" in record.pathname or "setuptools" in record.pathname
        return not (build and record.levelno < 30)


def quiet_form_compilation() -> None:
    """Silence the compiler lines of form compilation, unless the environment variable
    ``NITSCHE_DOLFINX_VERBOSE`` is set (idempotent)."""
    root = logging.getLogger()
    if os.environ.get("NITSCHE_DOLFINX_VERBOSE") or any(
        isinstance(f, _BuildLogFilter) for f in root.filters
    ):
        return
    root.addFilter(_BuildLogFilter())
