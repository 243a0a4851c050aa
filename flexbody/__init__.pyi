"""Type stub of flexbody/__init__.py: the public names, which the module loads on first use (PEP 562)."""

from typing import Any

from flexbody.assembly import Model as Model, ModelError as ModelError
from flexbody.body import ShellBody as ShellBody, ShellState as ShellState
from flexbody.constraints import (Fix as Fix, FixDirection as FixDirection, Symmetry as Symmetry, clamp as clamp,
                                  fix as fix, nodes_of as nodes_of)
from flexbody.dynamics import (DynamicModel as DynamicModel, PrescribedMotion as PrescribedMotion,
                               RayleighDamping as RayleighDamping)
from flexbody.loads import (FollowerPressure as FollowerPressure, NodalLoad as NodalLoad, edge_force as edge_force,
                            edge_moment as edge_moment, pressure as pressure, surface_force as surface_force)
from flexbody.mesh.generators import (annulus as annulus, cylinder as cylinder, regular_polygon as regular_polygon,
                                      slit_annulus as slit_annulus, spherical_cap as spherical_cap, strip as strip)
from flexbody.mesh.io import read_mesh as read_mesh, write_mesh as write_mesh
from flexbody.mesh.tri6 import MeshError as MeshError, Tri6Mesh as Tri6Mesh
from flexbody.results import reactions as reactions, stress_resultants as stress_resultants
from flexbody.scenes.runner import run_scene as run_scene
from flexbody.scenes.scene import Scene as Scene
from flexbody.scenes.sources import SceneError as SceneError, load_scene as load_scene
from flexbody.shell.inertia import PointMass as PointMass
from flexbody.shell.material import ShellMaterial as ShellMaterial
from flexbody.shell.variants import (MITC6 as MITC6, MITC7 as MITC7, ElementVariant as ElementVariant,
                                     NoTying as NoTying, variant_from_key as variant_from_key)
from flexbody.solve import (DynamicSolution as DynamicSolution, StaticSolution as StaticSolution,
                            solve_dynamic as solve_dynamic, solve_static as solve_static)
from flexbody.time_functions import Ramp as Ramp
from integrators.generalized_alpha import AlphaSettings as AlphaSettings
from integrators.newton import NewtonSettings as NewtonSettings

__version__: str
__all__: list[str]

def __getattr__(name: str) -> Any: ...
