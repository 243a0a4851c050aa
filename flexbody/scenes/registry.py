"""The built-in scenes, registered once: one :class:`BuiltinScene` per scene with what the tools around it need
(its kind, mesh-density parameters, the default mesh sequence of ``flexbody bench``, the exudyn reference
models).

The entries are data: the builders (:mod:`flexbody.scenes.benchmark_scenes`,
:mod:`flexbody.scenes.dynamic_scenes`, a function named as the scene) are imported only when a scene is built
or its builder is asked for.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

KINDS = ("static", "dynamic")


@dataclass(frozen=True)
class BuiltinScene:
    """A built-in scene and its metadata.

    Attributes
    ----------
    name : the scene's name, also the name of its builder function (``build(**parameters) -> Scene``)
    kind : "static" or "dynamic"
    density : the mesh-density parameters of the builder (``flexbody bench`` refines them; report labels)
    bench_meshes : the default mesh sequence of ``flexbody bench``, kept small (the five static scenes'
        sequences take about two minutes); empty: a dynamic scene is benched on the time steps dt, dt/2,
        dt/4 instead
    exudyn_models : the exudyn reference models of :mod:`flexbody.adapters.exudyn`, the default first (empty:
        none)
    exudyn_mesh : the two builder parameters that give the element counts of an exudyn plate model
    exudyn_rtol : the exudyn Newton tolerance of this scene (None: the model kind's)
    """

    name: str
    kind: str
    density: tuple[str, ...]
    bench_meshes: tuple[dict[str, Any], ...] = ()
    exudyn_models: tuple[str, ...] = ()
    exudyn_mesh: tuple[str, str] | None = None
    exudyn_rtol: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"scene {self.name!r}: kind must be 'static' or 'dynamic', got {self.kind!r}")
        if any(set(mesh) - set(self.density) for mesh in self.bench_meshes):
            raise ValueError(f"scene {self.name!r}: bench meshes may set only the density parameters {self.density}")

    @property
    def builder(self) -> Callable:
        """The builder function (imports its module: the static or the dynamic scenes)."""
        if self.kind == "static":
            from flexbody.scenes import benchmark_scenes as module
        else:
            from flexbody.scenes import dynamic_scenes as module
        return getattr(module, self.name)

    @property
    def summary(self) -> str:
        """The first line of the builder's docstring."""
        return (self.builder.__doc__ or "").strip().splitlines()[0]

    def build(self, **parameters):
        """The scene with ``parameters`` (keyword arguments of the builder) applied."""
        return self.builder(**parameters)


_STRIP_BENCH = (dict(nx=4), dict(nx=8), dict(nx=16))
_STRIP_EXUDYN = dict(exudyn_models=("beam3d", "beam2d", "plate"), exudyn_mesh=("nx", "ny"))

#: every built-in scene, in the order ``flexbody list`` shows them
SCENES: dict[str, BuiltinScene] = {entry.name: entry for entry in (
    # the paper's static benchmarks (Sze, Liu & Lo 2004)
    BuiltinScene("cantilever_end_moment", "static", ("nx", "ny"), _STRIP_BENCH, **_STRIP_EXUDYN),
    BuiltinScene("cantilever_end_shear", "static", ("nx", "ny"), _STRIP_BENCH, **_STRIP_EXUDYN),
    BuiltinScene("slit_annular_plate", "static", ("n_radial", "n_circ"),
                 (dict(n_radial=3, n_circ=9), dict(n_radial=5, n_circ=15)),
                 ("plate",), ("n_radial", "n_circ"), 1e-6),
    BuiltinScene("pullout_cylinder", "static", ("n_circ", "n_axial"),
                 (dict(n_circ=6, n_axial=4), dict(n_circ=8, n_axial=6), dict(n_circ=12, n_axial=8)),
                 ("plate",), ("n_circ", "n_axial"), 1e-6),
    BuiltinScene("hemisphere", "static", ("n_meridian", "n_circ"),
                 (dict(n_meridian=8, n_circ=8), dict(n_meridian=12, n_circ=12)),
                 ("plate",), ("n_circ", "n_meridian"), 1e-5),
    # dynamic scenes
    BuiltinScene("spinning_plate", "dynamic", ("nx", "ny"), exudyn_models=("plate",), exudyn_mesh=("nx", "ny")),
    BuiltinScene("spinning_membrane", "dynamic", ("n_radial", "n_circ")),
    BuiltinScene("spinning_sail", "dynamic", ("n_rings",)),
    BuiltinScene("tumbling_plate", "dynamic", ("nx", "ny")),
    BuiltinScene("swinging_strip", "dynamic", ("nx", "ny")),
)}


def names(kind: str | None = None) -> tuple[str, ...]:
    """The built-in scene names (of one ``kind``, "static" or "dynamic", if given)."""
    return tuple(name for name, entry in SCENES.items() if kind is None or entry.kind == kind)


def builtin_scene(name: str) -> BuiltinScene:
    """The registry entry of a built-in scene; raises KeyError naming the built-in scenes."""
    if name not in SCENES:
        raise KeyError(f"unknown scene {name!r}; built-in scenes: {', '.join(SCENES)}")
    return SCENES[name]


def bench_scenes() -> tuple[str, ...]:
    """The scenes ``flexbody bench`` runs by default: those with a bench mesh sequence, then the dynamic ones
    (on their time steps)."""
    return tuple(n for n, e in SCENES.items() if e.bench_meshes) + names("dynamic")


def exudyn_scenes(kind: str | None = None) -> tuple[str, ...]:
    """The built-in scenes with an exudyn reference model (of one ``kind``, if given)."""
    return tuple(n for n, e in SCENES.items() if e.exudyn_models and (kind is None or e.kind == kind))
