"""exudyn reference models of the built-in scenes, the side-by-side comparison, and our shell inside exudyn.

Importing this package imports exudyn (``pip install 'flexbody[exudyn]'``); nothing outside the adapters
imports it, so a scene that does not use exudyn never loads it. The modules:

- ``references_static``: the closest exudyn model of each built-in static scene (SE(3) and planar beams,
  the ANCF thin plate on mapped rectangles), built from the flexbody scene's physics, and its static run
  (``build_model``, ``solve``, ``run_reference``);
- ``references_dynamic``: the free ANCF plate of the dynamic ``spinning_plate``, run with exudyn's
  generalized-alpha and, as a reference, with RK4 (``build_dynamic_model``, ``solve_dynamic``,
  ``strain_energies``);
- ``compare``: both codes side by side (``compare`` returns the comparison dict, ``compare_cli`` is
  ``flexbody compare SCENE --with exudyn``; the tables are printed by ``flexbody.outputs.comparison_text``);
- ``ode2``: ``ShellODE2``, a flexbody ``Model`` as an exudyn ``ObjectGenericODE2`` (statics and dynamics),
  ``solve_scene_in_exudyn`` and ``hub_driven_membrane_in_exudyn``;
- ``options`` (the ``exudyn_`` options and which model each scene has) and ``system`` (exudyn plumbing
  shared by the others: settings, quiet solver runs, the static solver's pseudo-time as load factors).

Options of the exudyn model ride along in the scene parameters with the prefix ``exudyn_`` (and are removed
before the flexbody scene is built): ``exudyn_model`` ("beam3d", "beam2d" or "plate" for the strips,
"plate" otherwise), ``exudyn_nx``, ``exudyn_ny`` (element counts), ``exudyn_steps`` (uniform load steps,
used where the flexbody scene runs arc-length), ``exudyn_rtol`` (exudyn's relative Newton tolerance);
for dynamic scenes ``exudyn_energy_every`` (strain energy at every k-th recorded step), ``exudyn_reference``
("rk4": add the RK4 run), ``exudyn_reference_dt`` (1e-4) and ``exudyn_reference_end_time``.
"""

from flexbody.adapters.exudyn.compare import _json_ready, compare, compare_cli
from flexbody.adapters.exudyn.ode2 import ShellODE2, hub_driven_membrane_in_exudyn, solve_scene_in_exudyn
from flexbody.adapters.exudyn.options import DYNAMIC_SCENES, MODELS, model_kind, split_options
from flexbody.adapters.exudyn.references_dynamic import (ExudynDynamicModel, RadialOutput, _rigid_field,
                                                         build_dynamic_model, solve_dynamic, spinning_plate_model,
                                                         strain_energies)
from flexbody.adapters.exudyn.references_static import (ExudynModel, ExudynRun, TrackedOutput, _settings,
                                                        beam2d_strip, beam3d_strip, build_model, hemisphere_model,
                                                        plate_strip, pullout_cylinder_model, run_reference,
                                                        slit_annular_plate_model, solve, symmetry_coordinates)
from flexbody.outputs.comparison_text import dynamic_table_lines, table_lines

__all__ = [
    "DYNAMIC_SCENES", "MODELS", "ExudynDynamicModel", "ExudynModel", "ExudynRun", "RadialOutput", "ShellODE2",
    "TrackedOutput", "beam2d_strip", "beam3d_strip", "build_dynamic_model", "build_model", "compare",
    "compare_cli", "dynamic_table_lines", "hemisphere_model", "hub_driven_membrane_in_exudyn", "model_kind",
    "plate_strip", "pullout_cylinder_model", "run_reference", "slit_annular_plate_model", "solve",
    "solve_dynamic", "solve_scene_in_exudyn", "spinning_plate_model", "split_options", "strain_energies",
    "symmetry_coordinates", "table_lines",
]
