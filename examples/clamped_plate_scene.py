"""A user scene file: a clamped square plate under follower pressure, large deflection.

Run it with
    flexbody run examples/clamped_plate_scene.py --set thickness=0.01 --set n=6

A scene file defines ``build(**parameters) -> Scene``; every keyword of ``build`` can be set with --set.
"""

import numpy as np

import flexbody as fb
from flexbody.scenes import Output, StaticAnalysis


def build(n: int = 4, thickness: float = 0.02, pressure: float = 50.0, steps: int = 10) -> fb.Scene:
    a = 1.0
    mesh = fb.strip(a, a, n, n)                       # edge sets "clamped", "tip", "bottom", "top"
    body = fb.ShellBody(mesh, fb.ShellMaterial(young=1.0e6, poisson=0.3, thickness=thickness))
    model = fb.Model(body, [fb.clamp(mesh, ["clamped", "tip", "bottom", "top"])], [fb.pressure(mesh, pressure)])
    centre = mesh.nearest_node([a / 2, a / 2, 0.0])
    return fb.Scene("clamped_plate", "clamped square plate under follower pressure", model,
                    StaticAnalysis("load_control", tuple(np.linspace(0, 1, steps + 1)[1:])),
                    [Output("w_centre", centre, (0.0, 0.0, 1.0))],
                    parameters=dict(n=n, thickness=thickness, pressure=pressure, steps=steps))
