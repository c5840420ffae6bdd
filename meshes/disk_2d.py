"""Generate the disk of the 2D impact test (docs/method.md section 5) as a gmsh ``.msh`` file.

The disk has radius 20 and centre (0, 20), so it touches the line y = 0.
The geometry is :func:`nitsche_dolfinx.meshing.shapes.build_disk_model`, the same code
as :func:`nitsche_dolfinx.meshing.shapes.disk_mesh`. Physical groups:

- surface 1, "disk": the disk;
- curve 1, "contact": the lower half circle, y < 20 (Gamma_C);
- curve 2, "free": the upper half circle.

The file is written in the msh 4.1 ASCII format, which dolfinx reads through
``nitsche_dolfinx.meshing.meshes.load_mesh``. Usage::

    python meshes/disk_2d.py                      # meshes/disk_2d.msh, order 2, h = 8
    python meshes/disk_2d.py --mesh-size 4 --order 1 --out meshes/disk_fine_p1.msh
"""

from __future__ import annotations

import os

from nitsche_dolfinx.meshing import build_disk_model, msh_command

DEFAULT_OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "disk_2d.msh")


def main(argv: list[str] | None = None) -> None:
    """Parse the command line and write the mesh."""
    msh_command(
        argv,
        build_disk_model,
        "Mesh the disk of the 2D impact test with gmsh.",
        DEFAULT_OUT,
        "triangles",
    )


if __name__ == "__main__":
    main()
