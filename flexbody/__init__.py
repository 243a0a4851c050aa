"""flexbody: flexible multibody dynamics with a geometrically exact six-node triangular shell on SE(3).

The public API is this module: ``import flexbody as fb`` and build a model from a mesh, a material, the
shell body, its supports and its loads, then solve it::

    import flexbody as fb

    mesh = fb.strip(10.0, 1.0, 8, 1)                       # a 10 x 1 strip, sets "clamped" and "tip"
    body = fb.ShellBody(mesh, fb.ShellMaterial(young=1.2e6, poisson=0.0, thickness=0.1))
    model = fb.Model(body, [fb.clamp(mesh, "clamped")], fb.edge_force(mesh, "tip", [0.0, 0.0, 1.0]))
    solution = fb.solve_static(model, steps=4)
    print(solution.displacements()[mesh.nearest_node([10.0, 0.5, 0.0]), 2])

Groups of names (each documented with its object):

- meshes: :class:`Tri6Mesh`, the generators (:func:`strip`, :func:`annulus`, :func:`slit_annulus`,
  :func:`cylinder`, :func:`spherical_cap`, :func:`regular_polygon`), :func:`read_mesh`, :func:`write_mesh`;
- the shell: :class:`ShellMaterial`, :class:`ShellBody` (``element=`` one of the variants :class:`MITC6`,
  :class:`MITC7`, :class:`NoTying`; :func:`variant_from_key` maps the scene files' ``tying`` keys),
  :class:`ShellState`;
- supports: :func:`clamp`, :func:`fix` (on set names or node indices), :class:`Fix`, :class:`Symmetry`,
  :class:`FixDirection`;
- loads: :func:`edge_force`, :func:`edge_moment`, :func:`surface_force`, :func:`pressure`,
  :class:`NodalLoad`, :class:`FollowerPressure`;
- the model and its solves: :class:`Model`, :func:`solve_static`, :func:`solve_dynamic` (with
  :class:`NewtonSettings`, :class:`AlphaSettings`, :class:`RayleighDamping`, :class:`PrescribedMotion`,
  :class:`PointMass`, :class:`Ramp`), their results :class:`StaticSolution`, :class:`DynamicSolution`;
- post-processing: :func:`stress_resultants`, :func:`reactions`;
- scenes (what ``flexbody run`` runs): :func:`load_scene`, :func:`run_scene`, :class:`Scene`.

Importing flexbody is cheap: the names above are loaded on first use (PEP 562), so ``import flexbody``
compiles nothing and imports neither numba nor h5py, rerun or dask.

The core (``flexbody.lie``, ``flexbody.mesh``, ``flexbody.shell``, ``flexbody.body`` and the
``integrators`` package) never imports the outputs, the adapters or the command line.
"""

from __future__ import annotations

import importlib
from typing import Any

# First, before any kernel is compiled or loaded: numba's cache goes to a per-user directory, never into the
# installed package (see flexbody.kernel_cache).
from flexbody import kernel_cache as _kernel_cache  # noqa: F401

__version__ = "0.1.0"
__docformat__ = "numpy"

#: where each public name lives: name -> module (the attribute has the same name)
_PUBLIC: dict[str, str] = {
    # meshes
    "Tri6Mesh": "flexbody.mesh.tri6", "MeshError": "flexbody.mesh.tri6",
    "strip": "flexbody.mesh.generators", "annulus": "flexbody.mesh.generators",
    "slit_annulus": "flexbody.mesh.generators", "cylinder": "flexbody.mesh.generators",
    "spherical_cap": "flexbody.mesh.generators", "regular_polygon": "flexbody.mesh.generators",
    "read_mesh": "flexbody.mesh.io", "write_mesh": "flexbody.mesh.io",
    # the shell
    "ShellMaterial": "flexbody.shell.material", "ShellBody": "flexbody.body", "ShellState": "flexbody.body",
    "MITC6": "flexbody.shell.variants", "MITC7": "flexbody.shell.variants", "NoTying": "flexbody.shell.variants",
    "ElementVariant": "flexbody.shell.variants", "variant_from_key": "flexbody.shell.variants",
    # supports
    "clamp": "flexbody.constraints", "fix": "flexbody.constraints", "nodes_of": "flexbody.constraints",
    "Fix": "flexbody.constraints", "Symmetry": "flexbody.constraints", "FixDirection": "flexbody.constraints",
    # loads
    "edge_force": "flexbody.loads", "edge_moment": "flexbody.loads", "surface_force": "flexbody.loads",
    "pressure": "flexbody.loads", "NodalLoad": "flexbody.loads", "FollowerPressure": "flexbody.loads",
    # the model and its solves
    "Model": "flexbody.assembly", "ModelError": "flexbody.assembly",
    "solve_static": "flexbody.solve", "solve_dynamic": "flexbody.solve",
    "StaticSolution": "flexbody.solve", "DynamicSolution": "flexbody.solve",
    "NewtonSettings": "integrators.newton", "AlphaSettings": "integrators.generalized_alpha",
    "DynamicModel": "flexbody.dynamics", "RayleighDamping": "flexbody.dynamics",
    "PrescribedMotion": "flexbody.dynamics", "PointMass": "flexbody.shell.inertia",
    "Ramp": "flexbody.time_functions",
    # post-processing
    "stress_resultants": "flexbody.results", "reactions": "flexbody.results",
    # scenes
    "Scene": "flexbody.scenes.scene", "load_scene": "flexbody.scenes.sources",
    "run_scene": "flexbody.scenes.runner", "SceneError": "flexbody.scenes.sources",
}

__all__ = ["__version__", *_PUBLIC]

# Type checkers and IDEs read the same names from flexbody/__init__.pyi (imported eagerly there). They are not
# imported here under TYPE_CHECKING: the numba cache's digest follows this file's import statements
# (flexbody.kernel_cache), and every module of the API would then invalidate the compiled kernels.


def __getattr__(name: str) -> Any:
    """Load a public name on first use (PEP 562) and keep it in the module."""
    module = _PUBLIC.get(name)
    if module is None:
        raise AttributeError(f"module 'flexbody' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_PUBLIC))
