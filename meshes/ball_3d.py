"""Generate the ball of the 3D impact test (docs/method.md section 5) as a gmsh ``.msh`` file.

The ball has radius 20 and centre (0, 0, 20), so it touches the plane z = 0.
The geometry is :func:`nitsche_dolfinx.meshing.shapes.build_ball_model`, the same code
as :func:`nitsche_dolfinx.meshing.shapes.ball_mesh`. Physical groups:

- volume 1, "ball": the ball;
- surface 1, "contact": the lower hemisphere, z < 20 (Gamma_C);
- surface 2, "free": the upper hemisphere.

The file is written in the msh 4.1 ASCII format, which dolfinx reads through
``nitsche_dolfinx.meshing.meshes.load_mesh``. Usage::

    python meshes/ball_3d.py                      # meshes/ball_3d.msh, order 2, h = 8
    python meshes/ball_3d.py --mesh-size 4 --order 1 --out meshes/ball_fine_p1.msh
"""

from __future__ import annotations

import os

from nitsche_dolfinx.meshing import build_ball_model, msh_command

DEFAULT_OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "ball_3d.msh")


def main(argv: list[str] | None = None) -> None:
    """Parse the command line and write the mesh."""
    msh_command(
        argv,
        build_ball_model,
        "Mesh the ball of the 3D impact test with gmsh.",
        DEFAULT_OUT,
        "tetrahedra",
    )


if __name__ == "__main__":
    main()
