"""The XDMF time series ``solution.xdmf``: its layout, its continuation by a restarted run,
and reading it back (docs/method.md section 6).

dolfinx's ``XDMFFile`` writes each field as a temporal collection of its own, which
ParaView shows as separate pieces (a displacement to warp by in one, the stress in
another) and meshio reads one of. After each level written, :class:`SeriesXML` puts it
into one collection, :data:`SERIES_NAME`, one grid per time level holding every field:
ParaView then shows one dataset with all the fields, and meshio's ``TimeSeriesReader``
reads them all. The HDF5 data are dolfinx's, untouched.
"""

from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ElementTree
from typing import NamedTuple

import numpy as np

__all__ = [
    "PART_SUFFIX",
    "SERIES_NAME",
    "Level",
    "SeriesXML",
    "continue_solution",
    "read_solution",
]

#: The working copy of an XDMF file while a time level is written (see
#: :class:`~nitsche_dolfinx.output.writers.SolutionWriter`).
PART_SUFFIX = ".xdmf-part"
_SEGMENT = re.compile(r"-restart(\d+)(\.h5|" + re.escape(PART_SUFFIX) + r")$")
#: The temporal collection of every field, one grid per time level.
SERIES_NAME = "fields"
_XINCLUDE = "http://www.w3.org/2001/XInclude"
_INCLUDE = f"{{{_XINCLUDE}}}include"
ElementTree.register_namespace("xi", _XINCLUDE)


class SeriesXML:
    """The XML of a series, kept on rank 0 as text between its levels: the mesh grids, and
    the levels of the collection :data:`SERIES_NAME`, each a grid with every field.

    dolfinx appends a level to a working copy that holds the mesh grids only
    (:meth:`working_copy`), as a temporal collection per field; :meth:`add` takes its
    fields into one new level and :meth:`text` is the whole file. Each level thus costs
    the parsing of one small file, whatever the number of levels before it. The real data
    items get ``DataType="Float" Precision="8"``: dolfinx writes doubles without saying so,
    and ParaView reads them in single precision otherwise.

    Args:
        path: An existing series to continue (any layout: the levels of dolfinx's
            collections per field are merged), or None for a new one.
    """

    def __init__(self, path: str | None = None):
        self.meshes: dict[str, str] = {}  # name: the mesh grid, as text
        self.levels: list[str] = []  # the level grids, as text
        if path is not None:
            self.add(path)

    def add(self, path: str) -> None:
        """Take the new mesh grids and the levels of the XDMF file ``path``."""
        domain = ElementTree.parse(path).getroot().find("Domain")
        for item in domain.iter("DataItem"):  # dolfinx's real data are doubles, untyped
            if "NumberType" not in item.attrib and "DataType" not in item.attrib:
                item.set("DataType", "Float")
                item.set("Precision", "8")
        levels = {}  # (time, mesh): the new level grids, in the order of their first field
        for grid in domain.findall("Grid"):
            if grid.get("GridType") == "Uniform":
                self.meshes.setdefault(grid.get("Name"), _text(grid, 2))
            elif grid.get("Name") == SERIES_NAME:
                self.levels.extend(_text(level, 3) for level in grid.findall("Grid"))
            else:
                for field in grid.findall("Grid"):
                    key = _level_key(field)
                    if key not in levels:
                        levels[key] = ElementTree.Element(
                            "Grid", Name=SERIES_NAME, GridType="Uniform"
                        )
                        levels[key].extend([field.find(_INCLUDE), field.find("Time")])
                    levels[key].extend(field.findall("Attribute"))
        self.levels.extend(_text(level, 3) for level in levels.values())

    def working_copy(self) -> str:
        """The file with the mesh grids only, for dolfinx to append a level to."""
        return _document(list(self.meshes.values()))

    def text(self) -> str:
        """The whole file."""
        grids = list(self.meshes.values())
        if self.levels:
            opening = f'    <Grid Name="{SERIES_NAME}" GridType="Collection" '
            opening += 'CollectionType="Temporal">'
            grids.append("\n".join([opening, *self.levels, "    </Grid>"]))
        return _document(grids)


def _level_key(grid) -> tuple[str, str]:
    """A level's time and mesh, as written (the mesh by the pointer of its include)."""
    return grid.find("Time").get("Value"), grid.find(_INCLUDE).get("xpointer")


def _text(element, depth: int) -> str:
    """An element as text indented for its ``depth`` in the document, without the namespace
    declaration that the document's root makes."""
    ElementTree.indent(element, space="  ", level=depth)
    element.tail = None
    text = ElementTree.tostring(element, encoding="unicode")
    return "  " * depth + text.replace(f' xmlns:xi="{_XINCLUDE}"', "", 1)


def _document(grids: list[str]) -> str:
    """An XDMF document of the grids (as text)."""
    head = '<?xml version="1.0"?>\n<!DOCTYPE Xdmf SYSTEM "Xdmf.dtd" []>\n'
    head += f'<Xdmf Version="3.0" xmlns:xi="{_XINCLUDE}">\n  <Domain>\n'
    return head + "\n".join(grids) + "\n  </Domain>\n</Xdmf>\n"


class Level(NamedTuple):
    """One time level of a series: ``t``, the node coordinates ``points`` (N, gdim or 3),
    the ``cells`` (rows of node indices in the XDMF order of ``cell_type``, e.g.
    ``"Tetrahedron_10"``, the same as VTK's) and ``fields``, name to values
    (N, components)."""

    t: float
    points: np.ndarray
    cells: np.ndarray
    cell_type: str
    fields: dict


def read_solution(path: str, t: float | None = None) -> list[Level]:
    """Every time level of an XDMF series written by this package, in order, read with
    h5py; with ``t``, only the level nearest to ``t``.

    Each level is read with the mesh its grid includes: after a restart the nodes are
    numbered anew (see :class:`~nitsche_dolfinx.output.writers.SolutionWriter`), so that the
    levels before and after it have meshes of their own.
    """
    import h5py  # optional: only reading a series back needs it (the fields are written by dolfinx)

    folder = os.path.dirname(path)
    domain = ElementTree.parse(path).getroot().find("Domain")
    meshes = [grid for grid in domain.findall("Grid") if grid.get("GridType") == "Uniform"]
    collections = [g for g in domain.findall("Grid") if g.get("GridType") == "Collection"]
    grids = [grid for collection in collections for grid in collection.findall("Grid")]
    times = [float(grid.find("Time").get("Value")) for grid in grids]
    if t is not None and grids:
        nearest = int(np.argmin(np.abs(np.asarray(times) - t)))
        grids, times = [grids[nearest]], [times[nearest]]

    def data(item):
        name, inside = item.text.strip().split(":", 1)
        with h5py.File(os.path.join(folder, name), "r") as h5:
            return h5[inside][()]

    levels = []
    for grid, time in zip(grids, times):
        named = re.search(r"Grid\[@Name='([^']+)'\]", grid.find(_INCLUDE).get("xpointer"))
        mesh = meshes[0]  # dolfinx's default: the first mesh of the file
        if named:
            (mesh,) = [m for m in meshes if m.get("Name") == named.group(1)]
        topology = mesh.find("Topology")
        fields = {a.get("Name"): data(a.find("DataItem")) for a in grid.findall("Attribute")}
        points = data(mesh.find("Geometry/DataItem"))
        cells = data(topology.find("DataItem"))
        levels.append(Level(time, points, cells, topology.get("TopologyType"), fields))
    return levels


def _series_files(path: str) -> tuple[set[int], bool]:
    """The numbers k of the files ``<stem>-restart<k>.*`` of the series ``path``, and whether
    a working copy of its XML is left (a write that a kill cut short)."""
    stem = os.path.splitext(path)[0]
    folder, base = os.path.dirname(stem) or ".", os.path.basename(stem)
    numbers, interrupted = set(), False
    for entry in os.listdir(folder):
        if not entry.startswith(base):
            continue
        rest = entry[len(base) :]
        found = _SEGMENT.fullmatch(rest)
        if found:
            numbers.add(int(found.group(1)))
        interrupted |= rest.endswith(PART_SUFFIX) and (rest == PART_SUFFIX or bool(found))
    return numbers, interrupted


def continuation(path: str) -> tuple[str, int]:
    """Where a restart continues the series ``path``: ``(stem of its data file, k)``.

    The mesh goes again into the grid ``mesh-restart<k>``, k the least number that no grid
    and no file of the series uses. The data go on in the HDF5 file of the last level,
    unless a kill cut a write short (its working copy of the XML is left): that file may
    then hold data of a level it never finished, which dolfinx before 0.10 cannot write
    again, and the data go to a new file ``<stem>-restart<k>.h5``.
    """
    stem = os.path.splitext(path)[0]
    numbers, interrupted = _series_files(path)
    root = ElementTree.parse(path).getroot()
    for grid in root.iter("Grid"):
        found = re.fullmatch(r"mesh-restart(\d+)", grid.get("Name", ""))
        if found:
            numbers.add(int(found.group(1)))
    k = 1
    while k in numbers:
        k += 1
    data = [item.text.strip().split(":", 1)[0] for item in root.iter("DataItem")]
    if interrupted or not data:
        return f"{stem}-restart{k}", k
    return os.path.join(os.path.dirname(path), os.path.splitext(data[-1])[0]), k


def remove_segments(stem: str) -> None:
    """Remove the data of the restarts of an earlier series ``<stem>.xdmf`` and the working
    copies of its XML, before a new series of that name starts."""
    folder = os.path.dirname(stem) or "."
    base = os.path.basename(stem)
    for entry in os.listdir(folder):
        rest = entry[len(base) :] if entry.startswith(base) else None
        if rest is not None and (rest == PART_SUFFIX or _SEGMENT.fullmatch(rest)):
            os.remove(os.path.join(folder, entry))


def _output_times(path: str) -> list[float] | None:
    """The time values of an XDMF file, or None if it, or an HDF5 file it names, is missing
    or unreadable."""
    if not os.path.isfile(path):
        return None
    folder = os.path.dirname(path)
    try:
        root = ElementTree.parse(path).getroot()
        for item in root.iter("DataItem"):
            if item.get("Format") == "HDF":
                data = (item.text or "").strip().split(":", 1)[0]
                if not os.path.isfile(os.path.join(folder, data)):
                    return None
        return [float(node.get("Value")) for node in root.iter("Time")]
    except (OSError, ValueError, TypeError, ElementTree.ParseError):
        return None


def continue_solution(path: str, t: float, step: int, comm) -> tuple[str, bool]:
    """Where a run restarted at time ``t`` (step ``step``) writes its fields.

    Returns ``(path, True)`` to append to ``path`` when it holds a readable series
    that ends at or before ``t``: the normal case, since a run stopped by a solver
    failure or a signal saves its last step. If it holds fields after ``t`` (the run
    was killed after its last periodic checkpoint) or cannot be read, the fields go
    to a new file ``<name>-from-step<step>.xdmf`` instead: ``(that path, False)``;
    the levels after ``t`` stay in ``path`` as the killed run wrote them.
    """
    decision = None
    if comm.rank == 0:
        times = _output_times(path)
        tolerance = 1e-9 * max(abs(t), 1.0)
        if times is None and not os.path.exists(path):
            decision = (path, False)
        elif times is not None and all(time <= t + tolerance for time in times):
            decision = (path, True)
        else:
            stem, extension = os.path.splitext(path)
            decision = (f"{stem}-from-step{step}{extension}", False)
    return comm.bcast(decision, root=0)
