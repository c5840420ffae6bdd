"""Bad input, refused before computing with one line naming the value and where it came from.

One table per entry point: the Python API (a ParameterError or ValueError naming the
value), the TOML configuration and the command line (exit status 2, the table or flag
and the value on stderr, no traceback, nothing computed), and the demos' flags.
"""

import math
import os

import pytest
from runs import MESH, MPIRUN, REPO, assert_one_line_error, ring_config, run

from nitsche_dolfinx import (
    ContactProblem,
    HybridScheme,
    Material,
    PlaneObstacle,
    Simulation,
    make_scheme,
)
from nitsche_dolfinx.cases import bar_problem
from nitsche_dolfinx.common import OutputParameters, TimeStepping
from nitsche_dolfinx.meshing import NormalWithin, check_body_mesh, load_mesh, tag_facets
from nitsche_dolfinx.output import PointValue
from nitsche_dolfinx.physics import CylinderObstacle, SphereObstacle


def bar(**kwargs):
    return bar_problem(nx=10, **kwargs)


def _bar_u():
    return Simulation(bar(), HybridScheme(), dt=0.1, t_end=0.2).u


def ring(t_end=0.02, **problem):
    """The ring of the README, short."""
    from nitsche_dolfinx import load_mesh

    mesh, tags = load_mesh(os.path.join(REPO, "meshes", "ring_2d.msh"))
    ring = ContactProblem(mesh, tags, Material(E=1000.0, nu=0.3), gamma0=1e-6, **problem)
    ring.add_obstacle(PlaneObstacle([0.0, 0.0], [0.0, 1.0]), 1)
    return ring


def shifted_ring():
    problem = ring()
    problem.set_initial_conditions(displacement=[0.0, -0.4])  # 0.4 into the ground
    return Simulation(problem, HybridScheme(), dt=0.005, t_end=0.02)


def nan_velocity():
    problem = bar()
    problem.set_initial_conditions(velocity=[math.nan])
    return Simulation(problem, HybridScheme(), dt=0.1, t_end=0.2)


def ring_with(**terms):
    """The README's ring with a term added through the API."""
    problem = ring()
    for name, args in terms.items():
        getattr(problem, name)(*args)
    return problem


API = {
    "material-string": (
        lambda: ContactProblem(*load_mesh(os.path.join(REPO, "meshes", "ring_2d.msh")), "steel"),
        "material='steel': must be a Material",
    ),
    "body-force-string": (
        lambda: ring_with(add_body_force=(["0", "down"],)),
        "body force[1]='down': unknown name 'down' (allowed: x, y, t, pi, e)",
    ),
    "body-force-huge": (
        lambda: ring_with(add_body_force=([0.0, -1e300],)),
        "body force must be finite, of magnitude at most 1e+100",
    ),
    "traction-nan": (
        lambda: ring_with(add_traction=(1, [math.nan, 0.0])),
        "traction must be finite",
    ),
    "dirichlet-time-function-inf": (
        lambda: ring_with(add_dirichlet=(1, lambda t: [0.0, math.inf])),
        "Dirichlet value must be finite",
    ),
    "dt-zero": (lambda: TimeStepping(0.0, 1.0), "dt=0.0"),
    "dt-nan": (lambda: TimeStepping(math.nan, 1.0), "dt=nan"),
    "t-end-below-dt": (lambda: TimeStepping(0.1, 0.05), "t_end=0.05"),
    "too-many-steps": (lambda: TimeStepping(1e-50, 1e50), "t_end=1e+50"),
    "dt-string": (
        lambda: Simulation(bar(), HybridScheme(), dt="0.1", t_end=1.0),
        "dt='0.1': the time step must be a number, got str",
    ),
    "dt-huge": (lambda: TimeStepping(1e200, 1e201), "dt=1e+200: the time step must be at most"),
    "dt-tiny": (lambda: TimeStepping(1e-200, 1e-199), "dt=1e-200: the time step must be positive"),
    "t-end-inf": (lambda: TimeStepping(0.1, math.inf), "t_end=inf: the final time must be finite"),
    "gamma0-zero": (lambda: bar(gamma0=0.0), "gamma0=0.0"),
    "gamma0-inf": (lambda: bar(gamma0=math.inf), "gamma0=inf"),
    "theta-nan": (lambda: bar(nitsche_theta=math.nan), "nitsche_theta=nan"),
    # the bar: gamma0 E = 1e-6, so |Theta| gamma0 E = 1e+294
    "theta-huge": (
        lambda: bar(nitsche_theta=1e300),
        "nitsche_theta=1e+300: |Theta| gamma0 E = 1e+294 is above 100",
    ),
    "theta-string": (lambda: bar(nitsche_theta="1"), "nitsche_theta='1': the Nitsche variant"),
    "gamma0-string": (lambda: bar(gamma0="1e-6"), "gamma0='1e-6': the Nitsche parameter must be"),
    "degree-string": (lambda: bar(degree="2"), "degree='2': the degree must be 1 or 2"),
    "degree-float": (lambda: bar(degree=1.5), "degree=1.5: the degree must be 1 or 2"),
    "quadrature-huge": (lambda: ring(quadrature_degree=1000), "quadrature_degree=1000"),
    "friction-string": (lambda: ring(friction="0.2"), "friction='0.2': the friction coefficient"),
    "friction-negative": (lambda: ring(friction=-0.2), "friction=-0.2"),
    "method-unknown": (lambda: bar(method="lagrange"), "method='lagrange'"),
    "mass-unknown": (lambda: bar(mass="heavy"), "mass='heavy'"),
    "degree-3": (lambda: bar(degree=3), "degree=3"),
    "redistributed-p2": (lambda: bar(degree=2, mass="redistributed"), "mass='redistributed'"),
    "lumped-p2-implicit": (
        lambda: Simulation(bar(degree=2, mass="lumped"), HybridScheme(), dt=0.1, t_end=0.2),
        "mass='lumped': the P2 lumped (HRZ) mass is for the verlet scheme",
    ),
    "mixed-with-friction": (lambda: ring(method="mixed", friction=0.1), "friction=0.1"),
    "E-inf": (lambda: Material(E=math.inf, nu=0.3), "E=inf"),
    "E-string": (lambda: Material(E="1000", nu=0.3), "E='1000': Young's modulus must be a number"),
    "E-bool": (lambda: Material(E=True, nu=0.3), "E=True: Young's modulus must be a number"),
    "E-huge": (lambda: Material(E=1e300, nu=0.3), "E=1e+300: Young's modulus must be at most"),
    "nu-string": (lambda: Material(E=1.0, nu="0.3"), "nu='0.3': Poisson's ratio must be a number"),
    "rho-huge": (lambda: Material(E=1.0, nu=0.3, rho=1e300), "rho=1e+300: the density"),
    "rho-tiny": (lambda: Material(E=1.0, nu=0.3, rho=1e-300), "rho=1e-300: the density"),
    "lame-bulk-negative": (
        lambda: Material.from_lame(-0.9, 1.0),
        "lmbda=-0.9: the bulk modulus lmbda + 2 mu / 3 must be positive",
    ),
    "E-negative": (lambda: Material(E=-1.0, nu=0.3), "E=-1.0"),
    "nu-half": (lambda: Material(E=1.0, nu=0.5), "nu=0.5"),
    "rho-nan": (lambda: Material(E=1.0, nu=0.3, rho=math.nan), "rho=nan"),
    "lame-mu-zero": (lambda: Material.from_lame(1.0, 0.0), "mu=0.0"),
    "theta-above-1": (lambda: make_scheme("theta", theta=1.5), "theta=1.5"),
    "newmark-beta": (lambda: make_scheme("newmark", beta=0.7), "beta=0.7"),
    "newmark-gamma": (lambda: make_scheme("newmark", gamma=-0.1), "gamma=-0.1"),
    "scheme-unknown": (lambda: make_scheme("leapfrog"), "scheme='leapfrog'"),
    "scheme-not-a-name": (lambda: make_scheme(["hybrid"]), "scheme=['hybrid']: unknown scheme"),
    "theta-scheme-string": (lambda: make_scheme("theta", theta="0.5"), "theta='0.5'"),
    "output-every-bool": (lambda: OutputParameters(output_every=True), "output_every=True"),
    "output-negative": (lambda: OutputParameters(output_every=-1), "output_every=-1"),
    "checkpoint-float": (lambda: OutputParameters(checkpoint_every=0.5), "checkpoint_every=0.5"),
    "obstacle-normal-zero": (lambda: PlaneObstacle([0.0], [0.0]), "normal=[0.0]: the plane's"),
    "obstacle-point-nan": (lambda: PlaneObstacle([math.nan], [1.0]), "point=[nan]: the plane's"),
    "obstacle-point-string": (
        lambda: PlaneObstacle(["a", 0.0], [0.0, 1.0]),
        "point=['a', 0.0]: the plane's point must be 1 to 3 numbers",
    ),
    "obstacle-point-matrix": (
        lambda: PlaneObstacle([[0.0, 0.0]], [0.0, 1.0]),
        "point=[[0.0, 0.0]]: the plane's point must be 1 to 3 numbers",
    ),
    "obstacle-point-huge": (
        lambda: PlaneObstacle([0.0, 1e300], [0.0, 1.0]),
        "point=[0.0, 1e+300]: the plane's point must have coordinates of magnitude at most",
    ),
    "obstacle-normal-other-dimension": (
        lambda: PlaneObstacle([0.0, 0.0], [0.0, 0.0, 1.0]),
        "normal=[0.0, 0.0, 1.0]: the normal must have as many coordinates as the point",
    ),
    "sphere-radius-string": (
        lambda: SphereObstacle([0.0, 0.0], "5"),
        "radius='5': the radius must be a number",
    ),
    "sphere-radius-zero": (lambda: SphereObstacle([0.0, 0.0], 0.0), "radius=0.0: the radius"),
    "sphere-side-unknown": (lambda: SphereObstacle([0.0, 0.0], 1.0, "above"), "side='above'"),
    "cylinder-axis-zero": (
        lambda: CylinderObstacle([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 1.0),
        "axis=[0.0, 0.0, 0.0]: the cylinder's axis must have a non-zero length",
    ),
    "obstacle-wrong-dimension": (
        lambda: ring().add_obstacle(PlaneObstacle([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]), 1),
        "3 coordinates, the mesh has 2",
    ),
    "absent-tag": (lambda: bar().add_dirichlet(42, 0.0), "facet tag 42"),
    "dirichlet-wrong-shape": (lambda: bar().add_dirichlet(2, [0.0, 0.0]), "[0.0, 0.0]"),
    "dirichlet-component-2-in-2d": (
        lambda: ring().add_dirichlet(3, 0.0, component=2),
        "component=2",
    ),
    "dirichlet-component-1-in-1d": (
        lambda: bar().add_dirichlet(2, 0.0, component=1),
        "component=1",
    ),
    "dirichlet-component-vector": (
        lambda: ring().add_dirichlet(3, [0.0, 0.0], component=0),
        "[0.0, 0.0]",
    ),
    "facet-selector-chooses-nothing": (
        lambda: tag_facets(bar().mesh, {5: lambda x: x[0] > 2.0}),
        "selector of tag 5 chooses no boundary facet",
    ),
    "facet-selector-not-callable": (lambda: tag_facets(bar().mesh, {5: 1.0}), "got 1.0"),
    "facet-normal-zero": (lambda: NormalWithin([0.0, 0.0], 5.0), "must not be zero"),
    "point-probe-outside": (lambda: PointValue(_bar_u(), [2.0], 0), "[2.0] is in no cell"),
    "mixed-with-hybrid": (
        lambda: Simulation(bar(method="mixed"), HybridScheme(), dt=0.1, t_end=1.0),
        "Crank-Nicolson only",
    ),
    "redistributed-with-hybrid": (
        lambda: Simulation(bar(mass="redistributed"), HybridScheme(), dt=0.1, t_end=1.0),
        "mass='redistributed'",
    ),
    "linear-solver-unknown": (
        lambda: Simulation(bar(), HybridScheme(), dt=0.1, t_end=1.0, linear_solver="qr"),
        "linear_solver='qr'",
    ),
    "initial-velocity-nan": (nan_velocity, "initial velocity"),
    "starts-inside-obstacle": (shifted_ring, "inside an obstacle"),
    "mesh-size-tiny": (lambda: check_body_mesh(1e-6, 2, 20.0), "mesh_size=1e-06"),
    "mesh-size-too-large": (lambda: check_body_mesh(50.0, 2, 20.0), "got 50.0"),
    "max-step-cuts-negative": (
        lambda: Simulation(bar(), HybridScheme(), dt=0.1, t_end=1.0, max_step_cuts=-1),
        "max_step_cuts=-1",
    ),
    "max-step-cuts-float": (lambda: TimeStepping(0.1, 1.0, 1.5), "max_step_cuts=1.5"),
    "reuse-jacobian-string": (
        lambda: Simulation(bar(), HybridScheme(), dt=0.1, t_end=1.0, reuse_jacobian="no"),
        "reuse_jacobian='no': must be True or False",
    ),
    "preconditioner-lag-negative": (
        lambda: Simulation(bar(), HybridScheme(), dt=0.1, t_end=1.0, preconditioner_lag=-1),
        "preconditioner_lag=-1: the preconditioner's lag must be an integer >= 0",
    ),
    "gamma0-scaling-unknown": (lambda: bar(gamma0_scaling="stress"), "gamma0_scaling='stress'"),
    "gamma0-E-too-large": (lambda: bar(gamma0=1e3), "gamma0 * E = 1e+03"),
    "mesh-file-is-a-folder": (lambda: load_mesh(REPO), "is a folder, not a mesh file"),
    "self-pair-direction": (
        lambda: bar().add_contact_pair(1, 1, direction=[1.0]),
        "self-contact (a surface paired",
    ),
    "pair-variant": (lambda: bar().add_contact_pair(1, 2, variant="x"), "variant='x'"),
    "pair-with-penalty": (
        lambda: ring(method="penalty").add_contact_pair(1, 2),
        "method='penalty': contact between bodies is Nitsche contact",
    ),
    "pair-direction-zero": (
        lambda: bar().add_contact_pair(1, 2, direction=[0.0]),
        "direction=[0.0]",
    ),
}


@pytest.mark.parametrize("name", list(API))
def test_api_refuses_bad_value(name):
    make, named = API[name]
    with pytest.raises(ValueError) as caught:
        make()
    assert named in str(caught.value)
    assert "\n" not in str(caught.value)


# -- the TOML configuration through the command line ----------------------------------------


def curved(kind: str, keys: str) -> dict:
    """The ring's ground replaced by an obstacle of type ``kind`` with ``keys``."""
    return {'type = "plane"': f'type = "{kind}"', "point = [0.0, 0.0]\nnormal = [0.0, 1.0]": keys}


def before_output(text: str) -> dict:
    """``text`` added to the ring's configuration, before its [output] table."""
    return {"[output]": f"{text}\n\n[output]"}


def dirichlet(keys: str) -> dict:
    """A [[dirichlet]] table on the ring's inner boundary (tag 3) with ``keys``."""
    return before_output(f"[[dirichlet]]\ntag = 3\n{keys}")


def facet_tag(keys: str) -> dict:
    """A [[facet_tag]] table of tag 9 with ``keys`` (and a probe over its facets)."""
    return before_output(
        f'[[facet_tag]]\ntag = 9\n{keys}\n\n[[probe]]\nname = "u"\nquantity = "velocity"\n'
        "facets = 9"
    )


TOML = {
    "E-inf": ({"E = 1000.0": "E = inf"}, "[material] E = inf: Young's modulus must be finite"),
    "E-string": ({"E = 1000.0": 'E = "1000"'}, "[material] E must be a number, got '1000'"),
    "E-huge": ({"E = 1000.0": "E = 1e300"}, "[material] E = 1e+300: Young's modulus must be at"),
    "lame-bulk-negative": (
        {"E = 1000.0\nnu = 0.3": "lmbda = -900.0\nmu = 1000.0"},
        "[material] lmbda = -900.0: the bulk modulus lmbda + 2 mu / 3 must be positive",
    ),
    # the ring: gamma0 E = 1e-3
    "theta-huge": (
        {"theta = 1.0": "theta = 1e300"},
        "[nitsche] theta = 1e+300: |Theta| gamma0 E = 1e+297 is above 100",
    ),
    "theta-large": ({"theta = 1.0": "theta = -2e5"}, "[nitsche] theta = -200000.0: |Theta|"),
    "dt-huge": (
        {"dt = 0.005": "dt = 1e200", "t_end = 1.0": "t_end = 1e201"},
        "[scheme] dt = 1e+200: the time step must be at most 1e+100",
    ),
    "load-huge": (
        {"value = [0.0, -1.0]": "value = [0.0, -1e300]"},
        "[body_force] value = [0.0, -1e+300]: must be finite (no nan or inf), of magnitude at most",
    ),
    "obstacle-point-huge": (
        {"point = [0.0, 0.0]": "point = [0.0, 1e300]"},
        "[[obstacle]] #1 point = [0.0, 1e+300]: must be at most 1e+100 in magnitude",
    ),
    "quadrature-huge": (
        {"degree = 1": "degree = 1\nquadrature_degree = 1000"},
        "[mesh] quadrature_degree = 1000: the quadrature degree must be an integer from 0 to 30",
    ),
    "generator-too-many-cells": (
        {'file = "ring_2d.msh"': 'generator = "block"\nnx = 100000\nny = 100000'},
        "[mesh] generator = 'block': width = 2.0, height = 1.0, nx = 100000, ny = 100000 make "
        "2e+10 cells, more than 5e+07",
    ),
    "mesh-gdim-4": (
        {'file = "ring_2d.msh"': 'file = "ring_2d.msh"\ngdim = 4'},
        "[mesh] gdim = 4: must be 1, 2 or 3",
    ),  # fmt: skip
    "E-and-lame": ({"rho = 1.0": "rho = 1.0\nlmbda = 3.0"}, "gives E and nu with lmbda"),
    "petsc-subtable": (
        {"[output]": "[petsc.snes]\nrtol = 1e-8\n\n[output]"},
        "[petsc] snes must be a string",
    ),
    "theta-for-hybrid": (
        {"t_end = 1.0": "t_end = 1.0\ntheta = 0.5"},
        "[scheme] theta = 0.5 is not a parameter of the 'hybrid' scheme",
    ),
    "obstacle-3d-point-2d-normal": (
        {"point = [0.0, 0.0]": "point = [0.0, 0.0, 0.0]"},
        "[[obstacle]] #1 normal = [0.0, 1.0]: the normal must have as many coordinates as the "
        "point [0.0, 0.0, 0.0]",
    ),
    "obstacle-3d-point": (
        {
            "point = [0.0, 0.0]": "point = [0.0, 0.0, 0.0]",
            "normal = [0.0, 1.0]": "normal = [0, 1, 0]",
        },
        "[[obstacle]] #1 point = [0.0, 0.0, 0.0]: has 3 components, the mesh is 2D",
    ),
    "nan-velocity": (
        {"velocity = [0.0, -1.0]": "velocity = [nan, -1.0]"},
        "[initial] velocity = [nan, -1.0]: must be finite",
    ),
    "inside-obstacle": (
        {"point = [0.0, 0.0]": "point = [0.0, 0.5]"},
        "[initial] initial displacement: the body starts 0.4 inside an obstacle",
    ),
    "too-many-steps": (
        {"dt = 0.005": "dt = 1e-50", "t_end = 1.0": "t_end = 1e50"},
        "[scheme] t_end = 1e+50: t_end / dt = 1e+100 steps, more than 1e+07",
    ),
    "gamma0-zero": ({"gamma0 = 1e-6": "gamma0 = 0.0"}, "[nitsche] gamma0 = 0.0"),
    "degree-3": ({"degree = 1": "degree = 3"}, "[mesh] degree = 3"),
    "output-every-negative": ({"every = 10": "every = -5"}, "[output] every = -5"),
    "gamma0-scaling-unknown": (
        {"gamma0 = 1e-6": 'gamma0 = 1e-6\ngamma0_scaling = "stress"'},
        "[nitsche] gamma0_scaling = 'stress'",
    ),
    "max-step-cuts-negative": (
        {"t_end = 1.0": "t_end = 1.0\nmax_step_cuts = -1"},
        "[scheme] max_step_cuts = -1",
    ),
    "unknown-table": ({"[output]": "[outputs]\nevery = 1\n\n[output]"}, "unknown table [outputs]"),
    "unknown-key": ({"degree = 1": "degree = 1\nelements = 2"}, "[mesh] unknown key 'elements'"),
    "nu-half": (
        {"nu = 0.3": "nu = 0.5"},
        "[material] nu = 0.5: Poisson's ratio must lie in (-1, 1/2)",
    ),
    "scheme-unknown": ({'name = "hybrid"': 'name = "leapfrog"'}, "[scheme] name = 'leapfrog'"),
    "pair-one-tag": (
        {"[output]": "[[contact_pair]]\ntags = [1]\n\n[output]"},
        "[[contact_pair]] #1 tags must be a list of two integer tags",
    ),
    "mesh-file-is-a-folder": (
        {'"ring_2d.msh"': '"."'},
        "is a folder, not a mesh file",
    ),
    # the contact method, the mass, the quadrature and the solver
    "friction-negative": (
        {"gamma0 = 1e-6": "gamma0 = 1e-6\nfriction = -0.2"},
        "[nitsche] friction = -0.2",
    ),
    "method-unknown": (
        {"gamma0 = 1e-6": 'gamma0 = 1e-6\nmethod = "lagrange"'},
        "[nitsche] method = 'lagrange': unknown contact method; choose one of nitsche,",
    ),
    "mixed-with-friction": (
        {"gamma0 = 1e-6": 'gamma0 = 1e-6\nmethod = "mixed"\nfriction = 0.1'},
        "[nitsche] friction = 0.1: the mixed method is frictionless",
    ),
    "redistributed-p2": (
        {"degree = 1": 'degree = 2\nmass = "redistributed"'},
        "[mesh] mass = 'redistributed': this mass needs P1 elements",
    ),
    "quadrature-negative": (
        {"degree = 1": "degree = 1\nquadrature_degree = -1"},
        "[mesh] quadrature_degree = -1",
    ),
    "linear-solver-unknown": (
        {"[output]": '[solver]\nlinear_solver = "qr"\n\n[output]'},
        "[solver] linear_solver = 'qr': unknown",
    ),
    "solver-not-boolean": (
        {"[output]": "[solver]\nreuse_jacobian = 1\n\n[output]"},
        "[solver] reuse_jacobian must be true or false, got 1",
    ),
    # generated meshes
    "file-and-generator": (
        {"degree = 1": 'degree = 1\ngenerator = "disk"'},
        "[mesh] needs one of file (a mesh file) and generator",
    ),
    "generator-key-for-file": (
        {"degree = 1": "degree = 1\norder = 2"},
        "[mesh] order = 2 is a key of the generated meshes, not of a mesh file",
    ),
    "generator-unknown": (
        {'file = "ring_2d.msh"': 'generator = "torus"'},
        "[mesh] generator = 'torus': unknown; choose one of bar, block",
    ),
    "generator-foreign-key": (
        {'file = "ring_2d.msh"': 'generator = "block"\nradius = 5.0'},
        "[mesh] radius = 5.0: not a key of the 'block' mesh (it takes width, height, nx, ny)",
    ),
    "generator-nx-zero": (
        {'file = "ring_2d.msh"': 'generator = "block"\nnx = 0'},
        "[mesh] nx = 0: must be at least 1",
    ),
    "generator-center-3d": (
        {'file = "ring_2d.msh"': 'generator = "disk"\ncenter = [0.0, 0.0, 20.0]'},
        "[mesh] center = [0.0, 0.0, 20.0]: must have 2 coordinates",
    ),
    "generator-too-fine": (
        {'file = "ring_2d.msh"': 'generator = "disk"\nmesh_size = 1e-6'},
        "[mesh] mesh_size=1e-06 would make about",
    ),
    # curved obstacles
    "sphere-in-2d": (
        curved("sphere", "center = [0.0, -5.0]\nradius = 5.0"),
        "[[obstacle]] #1 type = 'sphere': a sphere obstacle is 3D, the mesh is 2D",
    ),
    "circle-radius-negative": (
        curved("circle", "center = [0.0, -5.0]\nradius = -1.0"),
        "[[obstacle]] #1 radius = -1.0: the radius must be positive",
    ),
    "circle-without-radius": (
        curved("circle", "center = [0.0, -5.0]"),
        "[[obstacle]] #1 missing required key 'radius' (type 'circle')",
    ),
    "plane-with-radius": (
        {"normal = [0.0, 1.0]": "normal = [0.0, 1.0]\nradius = 5.0"},
        "[[obstacle]] #1 radius = 5.0: not a key of a plane obstacle (it takes point, normal, "
        "translation, angle, pivot, rotation_axis)",
    ),
    "circle-side-unknown": (
        curved("circle", 'center = [0.0, -5.0]\nradius = 5.0\nside = "above"'),
        "[[obstacle]] #1 side = 'above': unknown; choose one of outside, inside",
    ),
    "circle-center-3d": (
        curved("circle", "center = [0.0, -5.0, 0.0]\nradius = 5.0"),
        "[[obstacle]] #1 center = [0.0, -5.0, 0.0]: has 3 components, the mesh is 2D",
    ),
    # values in time and in space
    "body-force-3d": (
        {"value = [0.0, -1.0]": "value = [0.0, 0.0, -1.0]"},
        "[body_force] value = [0.0, 0.0, -1.0]: has 3 components, the mesh is 2D",
    ),
    "load-times-decreasing": (
        {"value = [0.0, -1.0]": "value = [[1.0, 0.0, -1.0], [0.5, 0.0, 0.0]]"},
        "[body_force] value = [[1.0, 0.0, -1.0], [0.5, 0.0, 0.0]]: must have increasing times",
    ),
    "load-rows-ragged": (
        {"value = [0.0, -1.0]": "value = [[0.0, 0.0, -1.0], [1.0, 0.0]]"},
        "must have rows [t, value...] of one length",
    ),
    "load-text": (
        {"value = [0.0, -1.0]": 'value = [0.0, "-9.81 * time"]'},
        "[body_force] value = [0.0, '-9.81 * time']: component 1: unknown name 'time'",
    ),
    "load-text-call": (
        {"value = [0.0, -1.0]": 'value = [0.0, "open(1)"]'},
        "component 1: function 'open' is not in the list",
    ),
    "load-text-scalar": (
        {"value = [0.0, -1.0]": 'value = "-9.81 * t"'},
        "[body_force] value = '-9.81 * t': has 1 component, the mesh is 2D",
    ),
    "profile-unknown": (
        {"value = [0.0, -1.0]": 'value = { profile = "square", value = [0.0, -1.0] }'},
        "needs profile = one of ramp, sine (got 'square')",
    ),
    "profile-duration-zero": (
        {"value = [0.0, -1.0]": 'value = { profile = "ramp", value = [0, -1], duration = 0.0 }'},
        "duration must be positive, got 0.0",
    ),
    "profile-missing-key": (
        {"value = [0.0, -1.0]": 'value = { profile = "sine", amplitude = [0.0, -1.0] }'},
        "misses 'frequency' (the 'sine' profile takes amplitude, frequency, phase)",
    ),
    "dirichlet-absent-tag": (
        {"[output]": "[[dirichlet]]\ntag = 42\nvalue = [0.0, 0.0]\n\n[output]"},
        "[[dirichlet]] #1 facet tag 42 is not in the mesh",
    ),
    "traction-2-components-1d": (
        {"[output]": "[[traction]]\ntag = 2\nvalue = 1.0\n\n[output]"},
        "[[traction]] #1 value = 1.0: has 1 component, the mesh is 2D",
    ),
    "initial-gradient-1d": (
        {"velocity = [0.0, -1.0]": "displacement = { gradient = [[1.0]] }"},
        "[initial] displacement = {'gradient': [[1.0]]}: has 1 component, the mesh is 2D",
    ),
    "initial-unknown-form": (
        {"velocity = [0.0, -1.0]": "displacement = { slope = [0.0, 1.0] }"},
        "takes the keys constant, gradient, hessian",
    ),
    # bodies, probes and columns
    "body-unknown-cell-tag": (  # the ring's .msh file has its cells' physical group, 1
        {"[initial]\nvelocity = [0.0, -1.0]": "[[body]]\ntag = 99\nvelocity = [0.0, -1.0]"},
        "[[body]] #1 tag = 99: not a cell tag of the mesh (it has [1])",
    ),
    "region-unknown-cell-tag": (
        {"[initial]": "[[region]]\ntag = 99\nE = 2000.0\nnu = 0.3\n\n[initial]"},
        "[[region]] #1 tag = 99: not a cell tag of the mesh (it has [1])",
    ),
    "body-and-initial-velocity": (
        {"[output]": "[[body]]\ntag = 1\nvelocity = [0.0, -1.0]\n\n[output]"},
        "[initial] velocity is given with [[body]] velocities: give one of them",
    ),
    "probe-scalar-component": (
        {
            "[output]": '[[probe]]\nname = "p"\nquantity = "contact_pressure"\ncomponent = 1\n'
            "\n[output]"
        },
        "[[probe]] #1 component = 1: the quantity is scalar",
    ),
    "probe-component-2d": (
        {"[output]": '[[probe]]\nname = "w"\nquantity = "velocity"\ncomponent = 2\n\n[output]'},
        "[[probe]] #1 component = 2: the mesh is 2D",
    ),
    "probe-absent-tag": (
        {"[output]": '[[probe]]\nname = "w"\nquantity = "velocity"\nfacets = 42\n\n[output]'},
        "[[probe]] #1 facet tag 42 is not in the mesh",
    ),
    "columns-unknown": (
        {"every = 10": 'every = 10\ncolumns = ["t", "energie"]'},
        "[output] columns = ['t', 'energie']: 'energie' is not a column of this run",
    ),
    "output-every-float": ({"every = 10": "every = 1.5"}, "[output] every must be an integer"),
    "columns-momentum-z": (
        {"every = 10": 'every = 10\ncolumns = ["t", "momentum_z"]'},
        "[output] columns = ['t', 'momentum_z']: 'momentum_z' is not a column of this run",
    ),
    "columns-second-obstacle": (
        {"every = 10": 'every = 10\ncolumns = ["t", "contact_force_2"]'},
        "'contact_force_2' is not a column of this run",
    ),
    # point probes
    "probe-point-outside": (
        before_output('[[probe]]\nname = "u"\nquantity = "displacement"\npoint = [0.0, 100.0]'),
        "[[probe]] #1 point = [0.0, 100.0]: is in no cell of the mesh",
    ),
    "probe-point-and-facets": (
        before_output(
            '[[probe]]\nname = "u"\nquantity = "velocity"\npoint = [0.0, 1.0]\nfacets = 1'
        ),
        "[[probe]] #1 gives point and facets: give one of them",
    ),
    "probe-point-of-pressure": (
        before_output('[[probe]]\nname = "p"\nquantity = "contact_pressure"\npoint = [0.0, 1.0]'),
        "[[probe]] #1 point = [0.0, 1.0]: contact_pressure is a mean over facets, not a value",
    ),
    "probe-point-3d": (
        before_output('[[probe]]\nname = "u"\nquantity = "velocity"\npoint = [0.0, 1.0, 0.0]'),
        "[[probe]] #1 point = [0.0, 1.0, 0.0]: has 3 components, the mesh is 2D",
    ),
    # one component of a Dirichlet value
    "dirichlet-component-3": (
        dirichlet("component = 3\nvalue = 0.0"),
        "[[dirichlet]] #1 component = 3: must be 0 (x), 1 (y) or 2 (z)",
    ),
    "dirichlet-component-negative": (
        dirichlet("component = -1\nvalue = 0.0"),
        "[[dirichlet]] #1 component = -1: must be 0 (x), 1 (y) or 2 (z)",
    ),
    "dirichlet-component-2d": (
        dirichlet("component = 2\nvalue = 0.0"),
        "[[dirichlet]] #1 component = 2: the mesh is 2D (components 0 to 1)",
    ),
    "dirichlet-component-vector": (
        dirichlet("component = 0\nvalue = [0.0, 0.0]"),
        "[[dirichlet]] #1 value = [0.0, 0.0]: has 2 components; one component (component = 0)",
    ),
    "dirichlet-component-table": (
        dirichlet("component = 1\nvalue = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.1]]"),
        "[[dirichlet]] #1 value = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.1]]: has 2 components;",
    ),
    "dirichlet-component-float": (
        dirichlet("component = 0.0\nvalue = 0.0"),
        "[[dirichlet]] #1 component must be an integer, got 0.0",
    ),
    # facets tagged by selectors
    "facet-tag-no-selector": (
        facet_tag(""),
        "[[facet_tag]] #1 (tag = 9) needs a selector: on_plane, normal_within, in_box",
    ),
    "facet-tag-zero": (
        before_output("[[facet_tag]]\ntag = 0\nnormal_within = { direction = [0.0, -1.0] }"),
        "[[facet_tag]] #1 tag = 0: must be from 1 to 2^31 - 1",
    ),
    "facet-tag-beyond-int32": (
        before_output("[[facet_tag]]\ntag = 2147483648\nnormal_within = { direction = [0, -1] }"),
        "[[facet_tag]] #1 tag = 2147483648: must be from 1 to 2^31 - 1",
    ),
    "facet-tag-unknown-selector": (
        facet_tag("on_line = { point = [0.0, 0.0] }"),
        "[[facet_tag]] #1 unknown key 'on_line' (known: tag, on_plane, normal_within, in_box)",
    ),
    "facet-tag-selector-not-table": (
        facet_tag("on_plane = [0.0, 1.0]"),
        "[[facet_tag]] #1 on_plane must be an inline table { key = value, ... }, got [0.0, 1.0]",
    ),
    "facet-tag-unknown-key": (
        facet_tag("on_plane = { point = [0.0, 0.0], normal = [0.0, 1.0], origin = [0.0, 0.0] }"),
        "[[facet_tag]] #1 on_plane unknown key 'origin' (known: point, normal, tolerance)",
    ),
    "facet-tag-missing-normal": (
        facet_tag("on_plane = { point = [0.0, 0.0] }"),
        "[[facet_tag]] #1 on_plane missing required key 'normal'",
    ),
    "facet-tag-nan-point": (
        facet_tag("on_plane = { point = [nan, 0.0], normal = [0.0, 1.0] }"),
        "[[facet_tag]] #1 on_plane point = [nan, 0.0]: must be finite",
    ),
    "facet-tag-zero-normal": (
        facet_tag("on_plane = { point = [0.0, 0.0], normal = [0.0, 0.0] }"),
        "[[facet_tag]] #1 on_plane = {'point': [0.0, 0.0], 'normal': [0.0, 0.0]}: the plane "
        "normal must not be zero",
    ),
    "facet-tag-negative-tolerance": (
        facet_tag("on_plane = { point = [0.0, 0.0], normal = [0.0, 1.0], tolerance = -1.0 }"),
        "[[facet_tag]] #1 on_plane tolerance = -1.0: must be >= 0",
    ),
    "facet-tag-angle": (
        facet_tag("normal_within = { direction = [0.0, -1.0], angle = 200.0 }"),
        "[[facet_tag]] #1 normal_within = {'direction': [0.0, -1.0], 'angle': 200.0}: the angle "
        "must lie in [0, 180] degrees, got 200.0",
    ),
    "facet-tag-box-upside-down": (
        facet_tag("in_box = { lower = [0.0, 1.0], upper = [1.0, 0.0] }"),
        "[[facet_tag]] #1 in_box = {'lower': [0.0, 1.0], 'upper': [1.0, 0.0]}: the box needs "
        "lower <= upper",
    ),
    "facet-tag-3d-point": (
        facet_tag("on_plane = { point = [0.0, 0.0, 0.0], normal = [0.0, 1.0] }"),
        "[[facet_tag]] #1 on_plane point = [0.0, 0.0, 0.0]: has 3 components, the mesh is 2D",
    ),
    "facet-tag-chooses-nothing": (
        facet_tag("on_plane = { point = [0.0, -5.0], normal = [0.0, 1.0] }"),
        "[[facet_tag]] #1 tag = 9: its selectors (on_plane) choose no boundary facet of the mesh",
    ),
    "facet-tag-none-of-both": (
        facet_tag(
            "normal_within = { direction = [0.0, 1.0] }\n"
            "in_box = { lower = [-10.0, -10.0], upper = [10.0, 0.5] }"
        ),
        "[[facet_tag]] #1 tag = 9: its selectors (normal_within, in_box) choose no boundary",
    ),  # fmt: skip
}


@pytest.mark.parametrize("name", list(TOML))
def test_configuration_refuses_bad_value(tmp_path, name):
    replace, named = TOML[name]
    config = ring_config(str(tmp_path), replace, t_end=1.0)
    out = tmp_path / "out"
    result = run("-m", "nitsche_dolfinx", "run", config, "--out", str(out))
    assert_one_line_error(result, named)
    assert not (out / "history.csv").exists()


# -- the command line's own flags ----------------------------------------------------------


def test_cli_refuses_bad_flags(tmp_path):
    """Each case: exit status 2, one line naming the flag or the file, nothing computed."""
    config = ring_config(str(tmp_path), t_end=1.0)
    a_file = tmp_path / "a_file"
    a_file.write_text("")
    binary = tmp_path / "binary.toml"
    binary.write_bytes(bytes(range(256)))
    cases = [
        (["run", str(binary)], f"{binary}: not a TOML file: not UTF-8 text (byte 0x80 at offset"),
        (["run", MESH], f"{MESH}: not valid TOML"),
        (["run", "/dev/null"], "/dev/null: the configuration is not a regular file"),
        (["run", config, "--checkpoint-every", "-1"], "--checkpoint-every -1"),
        (["run", config, "--out", str(a_file)], "is a file, not a folder"),
        (["run", str(tmp_path / "missing.toml")], "configuration file does not exist"),
        (["run", str(tmp_path)], "the configuration is a folder, not a TOML file"),
        (["run", config, "--restart", "--out", str(tmp_path / "new")], "no checkpoint in"),
        (["run", config, "--output-every", "-1"], "--output-every -1"),
        (["run", config, "--petsc", "=1"], "expected KEY=VALUE, got '=1'"),
    ]
    for flags, named in cases:
        result = run("-m", "nitsche_dolfinx", *flags)
        assert_one_line_error(result, named)
    assert not list(tmp_path.glob("**/history.csv"))


# -- the demos' flags --------------------------------------------------------------------

FLAGS = {
    "bar-nx-huge": (
        ["demos/bar_1d.py", "--nx", "1000000000"],
        "--nx 1000000000: would make 1e+09 cells, more than 5e+07",
    ),
    "block-nx-huge": (
        ["demos/friction_block_2d.py", "--nx", "100000"],
        "--nx 100000: would make 1e+10 cells",
    ),
    "bar-nitsche-theta-huge": (
        ["demos/bar_1d.py", "--nitsche-theta", "1e300"],
        "--nitsche-theta 1e+300: |Theta| gamma0 E = 1e+294 is above 100",
    ),
    "ring-dt-huge": (["demos/ring_2d.py", "--dt", "1e200"], "--dt 1e+200: the time step must"),
    "block-E-huge": (
        ["demos/friction_block_2d.py", "--E", "1e300"],
        "--E 1e+300: Young's modulus must be at most",
    ),
    "disk-mesh-size-tiny": (["demos/disk_2d.py", "--mesh-size", "1e-6"], "would make about"),
    "disk-t-end-below-dt": (["demos/disk_2d.py", "--t-end", "0.05"], "--t-end 0.05"),
    "disk-mu-negative": (["demos/disk_2d.py", "--mu", "-1"], "--mu -1"),
    "bar-nx-zero": (["demos/bar_1d.py", "--nx", "0"], "--nx 0"),
    "block-mu-negative": (["demos/friction_block_2d.py", "--mu", "-0.5"], "--mu -0.5"),
    "ring-dt-zero": (["demos/ring_2d.py", "--dt", "0"], "--dt 0"),
    "ring-max-step-cuts": (["demos/ring_2d.py", "--max-step-cuts", "99"], "--max-step-cuts 99"),
    "ring-mesh-folder": (["demos/ring_2d.py", "--mesh", "demos"], "is a folder, not a mesh file"),
    "disk-degree-3": (["demos/disk_2d.py", "--degree", "3"], "--degree 3"),
    "bar-gamma0-zero": (["demos/bar_1d.py", "--gamma0", "0"], "--gamma0 0"),
    "block-nx-zero": (["demos/friction_block_2d.py", "--nx", "0"], "nx=0"),
    "compare-nx-zero": (["demos/compare_methods_1d.py", "--nx", "0"], "nx=0"),
    "convergence-gamma0": (["demos/convergence_1d.py", "--gamma0", "-1"], "--gamma0 -1"),
    "ball-max-step-cuts": (["demos/ball_3d.py", "--max-step-cuts", "31"], "--max-step-cuts 31"),
    "bar-output-every-negative": (["demos/bar_1d.py", "--output-every", "-1"], "--output-every -1"),
    "compare-output-every-negative": (
        ["demos/compare_methods_1d.py", "--output-every", "-2"],
        "--output-every -2",
    ),
    "convergence-output-every-negative": (
        ["demos/convergence_1d.py", "--output-every", "-3"],
        "--output-every -3",
    ),
}


@pytest.mark.parametrize("name", list(FLAGS))
def test_demo_refuses_bad_flag(tmp_path, name):
    flags, named = FLAGS[name]
    out = tmp_path / "out"
    result = run(*flags, "--out", str(out))
    assert_one_line_error(result, named)
    assert not (out / "history.csv").exists()


def test_refusal_under_mpi_is_one_line(tmp_path):
    """Under mpirun -n 2 a bad TOML value is reported once (by rank 0), exit status 2."""
    if MPIRUN is None:
        pytest.skip("no mpirun")
    config = ring_config(str(tmp_path), {"nu = 0.3": "nu = 0.5"}, t_end=1.0)
    result = run("-m", "nitsche_dolfinx", "run", config, "--out", str(tmp_path / "o"), ranks=2)
    assert_one_line_error(result, "[material] nu = 0.5")
    assert result.stderr.count("nitsche-dolfinx: error:") == 1
