"""A user scene file: a clamped square plate under follower pressure, large deflection.

Run it with
    flexbody run examples/clamped_plate_scene.py --set thickness=0.01 --set n=6

A scene file defines ``build(**parameters) -> Scene``; every keyword of ``build`` can be set with --set.
"""

import numpy as np

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix
from flexbody.loads import FollowerPressure
from flexbody.mesh import generators
from flexbody.scenes import Output, Scene, StaticAnalysis
from flexbody.shell.material import ShellMaterial


def build(n: int = 4, thickness: float = 0.02, pressure: float = 50.0, steps: int = 10) -> Scene:
    a = 1.0
    mesh = generators.strip(a, a, n, n)
    x = mesh.nodes
    edge = np.flatnonzero((np.abs(x[:, 0]) < 1e-9) | (np.abs(x[:, 0] - a) < 1e-9)
                          | (np.abs(x[:, 1]) < 1e-9) | (np.abs(x[:, 1] - a) < 1e-9))
    body = ShellBody(mesh, ShellMaterial(young=1.0e6, poisson=0.3, thickness=thickness))
    model = Model(body, [Fix(edge, "all")], [FollowerPressure(pressure)])
    centre = mesh.nearest_node([a / 2, a / 2, 0.0])
    return Scene("clamped_plate", "clamped square plate under follower pressure", model,
                 StaticAnalysis("load_control", tuple(np.linspace(0, 1, steps + 1)[1:])),
                 [Output("w_centre", centre, (0.0, 0.0, 1.0))],
                 parameters=dict(n=n, thickness=thickness, pressure=pressure, steps=steps))
