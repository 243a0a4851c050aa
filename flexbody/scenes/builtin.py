"""The built-in scenes by name: ``BUILTIN`` (name -> builder), ``DYNAMIC`` (the dynamic ones) and ``build``.

The scenes are registered once, with their metadata, in :mod:`flexbody.scenes.registry`; the builders live in
:mod:`flexbody.scenes.benchmark_scenes` (the paper's static benchmarks, Sze, Liu & Lo 2004) and
:mod:`flexbody.scenes.dynamic_scenes`. Each builder takes the mesh density and the physical parameters as
keyword arguments, so that a user (or ``--set``) can refine the mesh or change the thickness without touching
the package. The builders and the references of the dynamic scenes are importable from here too.
"""

from __future__ import annotations

from flexbody.scenes import registry
from flexbody.scenes.benchmark_scenes import (cantilever_end_moment, cantilever_end_shear, hemisphere,
                                              pullout_cylinder, slit_annular_plate)
from flexbody.scenes.dynamic_scenes import (CANTILEVER_ROOTS, cantilever_gravity_release, rigid_body_reference,
                                            rotating_annulus_displacement, settle_spin, spinning_membrane,
                                            spinning_plate, spinning_sail, swinging_strip, tumbling_plate)
from flexbody.scenes.scene import Scene

__all__ = ["BUILTIN", "DYNAMIC", "build", "cantilever_end_moment", "cantilever_end_shear", "slit_annular_plate",
           "pullout_cylinder", "hemisphere", "spinning_plate", "spinning_membrane", "spinning_sail",
           "tumbling_plate", "swinging_strip", "rotating_annulus_displacement", "cantilever_gravity_release",
           "CANTILEVER_ROOTS", "settle_spin", "rigid_body_reference"]

#: every built-in scene's builder, in the registry's order
BUILTIN = {name: entry.builder for name, entry in registry.SCENES.items()}
#: the built-in scenes with a dynamic analysis
DYNAMIC = registry.names("dynamic")


def build(name: str, **parameters) -> Scene:
    """Build a built-in scene by name, with parameter overrides."""
    return registry.builtin_scene(name).build(**parameters)
