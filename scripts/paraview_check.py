"""Open a demo's solution.xdmf in ParaView and read every field at every time level.

Run with ParaView's interpreter (ParaView 5.11: ``apt-get install paraview``)::

    pvpython --force-offscreen-rendering scripts/paraview_check.py out/two_balls_3d/solution.xdmf

Prints the time levels and fields ParaView sees, the points, cells and bounds of the
mesh with each field's magnitude range at the middle and last levels, and how many
(level, field) pairs were read, missing or not finite; exits with status 1 if any is.
"""

import math
import sys

from paraview import servermanager
from paraview.simple import Xdmf3ReaderT


def leaves(data):
    """The datasets of a (multi-block, multi-piece) output."""
    if data.IsA("vtkDataSet"):
        yield data
    elif data.IsA("vtkMultiBlockDataSet"):
        for i in range(data.GetNumberOfBlocks()):
            if data.GetBlock(i) is not None:
                yield from leaves(data.GetBlock(i))
    elif data.IsA("vtkMultiPieceDataSet"):
        for i in range(data.GetNumberOfPieces()):
            if data.GetPiece(i) is not None:
                yield from leaves(data.GetPiece(i))


def main(path: str) -> int:
    reader = Xdmf3ReaderT(FileName=[path])
    times = list(reader.TimestepValues) if reader.TimestepValues else [0.0]
    print(f"{path}: {len(times)} time levels from {times[0]:g} to {times[-1]:g}")
    read, bad = set(), 0
    for t in times:
        reader.UpdatePipeline(t)
        for block in leaves(servermanager.Fetch(reader)):
            point_data = block.GetPointData()
            for k in range(point_data.GetNumberOfArrays()):
                array = point_data.GetArray(k)
                read.add((t, array.GetName()))
                ranges = [array.GetRange(c) for c in range(array.GetNumberOfComponents())]
                bad += not all(math.isfinite(x) for r in ranges for x in r)
                if t in (times[len(times) // 2], times[-1]):
                    low, high = array.GetRange(-1)
                    print(
                        f"  t = {t:g} {array.GetName()}: {block.GetNumberOfPoints()} points, "
                        f"{block.GetNumberOfCells()} cells, bounds "
                        f"{[round(b, 2) for b in block.GetBounds()]}, magnitude {low:.4g} to "
                        f"{high:.4g}"
                    )
    names = sorted({name for _, name in read})  # every field seen at any level
    print(f"fields: {', '.join(names)}")
    missing = [(t, name) for t in times for name in names if (t, name) not in read]
    print(
        f"read {len(read)} (level, field) pairs of {len(times) * len(names)}: "
        f"{len(missing)} missing, {bad} not finite"
    )
    for t, name in missing:
        print(f"  missing: {name} at t = {t:g}")
    return 1 if missing or bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
