"""The key vocabulary of a scene file: one :class:`TableSpec` per TOML table, with each key's type, allowed
values or range, default and a one-line doc (:class:`Key`).

The specs are data. :func:`flexbody.scenes.toml_values.read_table` reads a table by its spec,
:mod:`flexbody.scenes.toml_scene` builds the scene from what it read, :mod:`flexbody.scenes.toml_document`
takes the keys ``--set`` accepts by their bare name from here, and :mod:`flexbody.scenes.toml_key_tables`
renders the key tables of docs/scenes.md (``tools/scene_key_tables.py`` writes them).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

from flexbody.shell.variants import VARIANT_KEYS
from flexbody.time_functions import Pulse

#: the default of a required key
REQUIRED: Any = type("Required", (), {"__repr__": lambda self: "REQUIRED"})()

#: the most load steps a scene may ask for (a path needs far fewer; 1e10 steps exhausted the memory)
MAX_STEPS = 100_000

#: what a key's value may be: read with the :class:`flexbody.scenes.toml_values.Table` method of that name
#: ("any": read as given and checked by the builder; "selection": the node selection keys ``SELECTORS``;
#: "table"/"tables": a sub-table or an array of tables with a spec of its own)
KINDS = ("number", "integer", "boolean", "string", "vector", "numbers", "any", "selection", "table", "tables")


@dataclass(frozen=True)
class Key:
    """One key of a TOML table.

    Attributes
    ----------
    name : the key
    kind : one of :data:`KINDS`
    doc : one line: what the key means (the "meaning" column of docs/scenes.md)
    default : the value of an absent key (:data:`REQUIRED`: none; None: absent means "not given")
    choices : the allowed values of a string
    bound : "" (any), ">0" or ">=0": the range of a number
    minimum, maximum : the range of an integer
    only : the variants (values of the table's ``switch`` key) the key belongs to; empty: every variant
    shown : the default as docs/scenes.md shows it (when it is not the value's TOML spelling)
    listed : named in the list of allowed keys of an unknown-key error (False: a key read only in some
        scenes, e.g. a load's ``time_function`` in a dynamic one)
    form : the form of the value as docs/scenes.md shows it, for a key of kind "any" (checked by the builder)
    """

    name: str
    kind: str
    doc: str
    default: Any = REQUIRED
    choices: tuple[str, ...] = ()
    bound: str = ""
    minimum: int = 1
    maximum: int | None = None
    only: tuple[str, ...] = ()
    shown: str | None = None
    listed: bool = True
    form: str | None = None

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"key {self.name!r}: kind must be one of {KINDS}, got {self.kind!r}")
        if self.bound not in ("", ">0", ">=0"):
            raise ValueError(f"key {self.name!r}: bound must be '', '>0' or '>=0', got {self.bound!r}")

    def belongs_to(self, variant: str | None) -> bool:
        """Whether the key is a key of the table's ``variant`` (every key of a table without variants)."""
        return not self.only or variant is None or variant in self.only


@dataclass(frozen=True)
class TableSpec:
    """The keys of one TOML table.

    Attributes
    ----------
    path : the table's dotted name as docs/scenes.md heads it (``analysis.hub``; ``load`` for ``[[load]]``)
    keys : the keys, in the order they are read and listed
    doc : one line: what the table is
    array : an array of tables (``[[load]]``)
    switch : the key whose value picks the variant (``type``, ``method``), if any
    title : how docs/scenes.md names the table, if not by its heading (an inline table: ``time_function``)
    """

    path: str
    keys: tuple[Key, ...]
    doc: str
    array: bool = False
    switch: str | None = None
    title: str | None = None

    def __getitem__(self, name: str) -> Key:
        for key in self.keys:
            if key.name == name:
                return key
        raise KeyError(f"[{self.path}] has no key {name!r}")

    @property
    def heading(self) -> str:
        """``[path]`` or ``[[path]]`` (the top level: ``(top)``), or the title."""
        if self.title is not None:
            return self.title
        if not self.path:
            return "(top)"
        return f"`[[{self.path}]]`" if self.array else f"`[{self.path}]`"

    def names(self, variant: str | None = None) -> tuple[str, ...]:
        """The keys a ``variant`` of the table allows (all variants' keys if None), node selections expanded,
        in the order of the unknown-key message."""
        out: list[str] = []
        for key in self.keys:
            if key.listed and key.belongs_to(variant):
                out += SELECTORS if key.kind == "selection" else (key.name,)
        return tuple(dict.fromkeys(out))


# ----------------------------------------------------------------------------------------------------------
# Vocabularies shared by several tables
# ----------------------------------------------------------------------------------------------------------

#: mesh generators by name, and which of their parameters set the mesh density (used by ``flexbody bench``)
GENERATOR_NAMES = ("strip", "slit_annulus", "annulus", "cylinder", "spherical_cap", "regular_polygon")
DENSITY_PARAMETERS = {
    "strip": ("nx", "ny"), "slit_annulus": ("n_radial", "n_circ"), "annulus": ("n_radial", "n_circ"),
    "cylinder": ("n_circ", "n_axial"), "spherical_cap": ("n_meridian", "n_circ"), "regular_polygon": ("n_rings",),
}
#: generator parameters in radians that may be given in degrees with the suffix ``_deg``
RADIAN_PARAMETERS = ("angle",)
#: a hub's nodes may also be given by these
HUB_SHAPES = ("radius", "polygon")
#: the global directions of an output's ``component``
COMPONENTS = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}

def toml_text(value: Any) -> str:
    """A value as a TOML file writes it (numbers shortest: ``0``, ``0.05``, ``1e-08``)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_text(v) for v in value) + "]"
    return str(value)


_ZERO = [0.0, 0.0, 0.0]
_Z = [0.0, 0.0, 1.0]


# ----------------------------------------------------------------------------------------------------------
# The tables
# ----------------------------------------------------------------------------------------------------------

SELECTION = TableSpec("selection", (
    Key("set", "any", "a named node set or edge set of the mesh (the generator's sets, or the physical groups of a "
        "mesh file), or the union of several: `set = \"clamped\"`, `set = [\"clamped\", \"top\"]`", default=None,
        form="name or list of names"),
    Key("nodes", "any", "node indices (0-based): `nodes = [0, 5, 12]`", default=None, form="list of integers"),
    Key("near", "vector", "the node nearest to a point: `near = [6.0, 0.0, 0.0]`", default=None),
    Key("plane", "table", "every node on a plane (within 1e-8 of the model size): "
        "`plane = { point = [0, 0.5, 0], normal = [0, 1, 0] }` (below)", default=None),
    Key("ring", "table", "every node at distance `radius` from the axis through `center` (within 1e-8 of the model "
        "size): `ring = { radius = 0.75, center = [0, 0, 0], axis = [0, 0, 1] }` (below)", default=None),
), "which nodes: exactly one of these keys", title="a node selection")

#: the keys of a node selection (exactly one of them)
SELECTORS = SELECTION.names()

TOP = TableSpec("", (
    Key("name", "string", "scene name (JSON summary, HDF5 and rerun files)", shown="file name"),
    Key("description", "string", "one line", shown="`\"scene file NAME.toml\"`"),
    Key("mesh", "table", "the mesh: a generator and its parameters, or a mesh file"),
    Key("material", "table", "the shell material"),
    Key("element", "table", "the element variant and kernel", default={}),
    Key("bc", "tables", "boundary conditions", default=[]),
    Key("load", "tables", "loads (at least one in a static scene)", default=[]),
    Key("point_mass", "tables", "tip masses (dynamic)", default=[]),
    Key("analysis", "table", "the analysis: static (load control or arc length) or dynamic", default={}),
    Key("output", "tables", "the tracked quantities (at least one)", default=[]),
    Key("reference", "table", "a reference CSV to compare the outputs with", default=None),
), "the top level of a scene file")

MESH = TableSpec("mesh", (
    Key("generator", "string", "one of the generators below, with its parameters as keys (an angle may be given "
        "in degrees as `angle_deg`)", choices=GENERATOR_NAMES),
    Key("file", "string", "or a mesh file (gmsh `.msh`, `.vtu`, anything meshio reads), relative to the scene "
        "file; gmsh physical groups become sets: physical surfaces element sets, physical lines edge (and node) "
        "sets, physical points node sets; three-node triangles are upgraded to six-node ones. gmsh saves only the "
        "elements of physical groups once one exists: a file with line groups and no surface group has no "
        "triangles, and flexbody says so (add a physical surface, or set `Mesh.SaveAll = 1`). "
        "`examples/gmsh_two_part_plate.py` makes a mesh with gmsh's Python API (second-order triangles, "
        "physical groups), `examples/gmsh_two_part_plate.toml` runs it"),
), "a generated mesh or a mesh file: exactly one of `generator` and `file`")

MATERIAL = TableSpec("material", (
    Key("young", "number", "Young's modulus E"),
    Key("poisson", "number", "Poisson's ratio nu"),
    Key("thickness", "number", "the shell thickness h"),
    Key("density", "number", "mass density (dynamics only; > 0 for a dynamic analysis)", default=0.0),
    Key("shear_correction", "number", "transverse shear correction factor", default=5.0 / 6.0, shown="5/6"),
    Key("wrinkling", "boolean", "the tension-field membrane law: a film that wrinkles carries no compression "
        "(docs/theory.md); bending and transverse shear stay linear. MITC6 elements only; no mixed iteration",
        default=False),
), "the linear elastic shell material (`flexbody.shell.material.ShellMaterial`)")

ELEMENT = TableSpec("element", (
    Key("tying", "any", "MITC6 assumed strains; `\"point\"`: MITC6 with the classical point membrane tying; "
        "`\"mitc7\"`: MITC6 plus the condensed rotation bubble (more accurate in bending, 5-7x the run time, "
        "docs/locking.md); `\"mean\"`: as true; false: plain displacement-based strains, which lock (in Python: "
        "`MITC6()`, "
        "`MITC6(membrane=\"point\")`, `MITC7()`, `NoTying()` of `flexbody.shell.variants`)",
        default=True, choices=VARIANT_KEYS),
    Key("kernel", "string", "the element kernel: compiled, or `\"reference\"`: the readable numpy element (slow)",
        default="numba",
        choices=("numba", "reference")),
), "the element")

BC = TableSpec("bc", (
    Key("type", "string", "`\"fix\"`: the `components` fixed; `\"symmetry\"`: a symmetry plane",
        choices=("fix", "symmetry")),
    Key("selection", "selection", "which nodes (node selections, below)"),
    Key("components", "any", "any of `\"x\"`, `\"y\"`, `\"z\"` (global translations), `\"r1\"`, `\"r2\"` "
        "(rotations about the nodal in-plane axes), `\"translations\"`, `\"rotations\"`, `\"all\"` (clamped); a "
        "name or a list", default="all", only=("fix",), form="name or list of names"),
    Key("normal", "vector", "unit normal of the symmetry plane: no translation along it, no rotation out of it",
        default=None, only=("symmetry",), shown="the `plane` selection's normal"),
), "a boundary condition on a node selection", array=True, switch="type")

TIME_FUNCTION = TableSpec("load.time_function", (
    Key("type", "string", "the load factor lambda(t) of the load", choices=("ramp", "pulse", "table")),
    Key("time", "number", "t/T up to T, then 1", bound=">0", only=("ramp",)),
    Key("start", "number", "the pulse's start, s", default=0.0, bound=">=0", only=("pulse",)),
    Key("duration", "number", "the pulse's length T, s", bound=">0", only=("pulse",)),
    Key("shape", "string", "`\"sin2\"`: sin^2(pi (t - start)/T) on [start, start + T], 0 outside; `\"rect\"`: 1 on "
        "[start, start + T)", default="sin2", choices=Pulse.SHAPES, only=("pulse",)),
    Key("time", "numbers", "the table's times, increasing (linear interpolation, held at the ends)",
        only=("table",)),
    Key("value", "numbers", "the table's load factors, one per time", only=("table",)),
), "a load's own load factor in time (dynamic; `flexbody.time_functions.Ramp`, `Pulse`, `Table`)",
    switch="type", title="`[[load]]` `time_function`")

LOAD = TableSpec("load", (
    Key("type", "string", "the kind of load", choices=("nodal", "edge_force", "edge_moment", "surface_force",
                                                       "pressure")),
    Key("selection", "selection", "which nodes (node selections, below)", only=("nodal",)),
    Key("force", "vector", "the full force at *each* selected node (not divided among them)", default=_ZERO,
        only=("nodal",)),
    Key("moment", "vector", "the full moment at each selected node; a moment about the director does no work and "
        "is ignored", default=_ZERO, only=("nodal",)),
    Key("follower", "boolean", "true: components in the nodal frames, turning with them", default=False,
        only=("nodal",)),
    Key("set", "any", "an edge set name, or a list of distinct ones (their union, each edge loaded once)",
        only=("edge_force", "edge_moment"), form="name or list of names"),
    Key("density", "vector", "a dead line density per unit reference length, distributed consistently to the "
        "edge nodes; the part on supported nodes goes to the supports", only=("edge_force", "edge_moment")),
    Key("density", "vector", "a dead force per unit reference area on the whole surface", only=("surface_force",)),
    Key("value", "number", "a follower pressure on the current surface, along the director side normal",
        only=("pressure",)),
    Key("set", "any", "an element set name or a list of them (the physical surfaces of a mesh file): the pressure "
        "acts on those elements only", default=None, only=("pressure",), shown="all elements",
        form="name or list of names"),
    Key("time_function", "table", "`{ type = ... }`: the load's own load factor in time (dynamic only; below); "
        "without one the load follows `load_ramp_time`", default=None, listed=False),
), "a load: its size at load factor 1 (static) or its size in time (dynamic)", array=True, switch="type")

POINT_MASS = TableSpec("point_mass", (
    Key("mass", "number", "M, added to the translational mass of *each* selected node", bound=">=0"),
    Key("rotary", "number", "J, added to the director inertia of each selected node: the moment of inertia about "
        "every axis normal to the director (one number; a list is refused)", default=0.0, bound=">=0"),
    Key("selection", "selection", "which nodes (node selections, below)"),
), "tip masses (dynamic only; `flexbody.shell.inertia.PointMass`)", array=True)

ANALYSIS = TableSpec("analysis", (
    Key("type", "string", "`\"dynamic\"` for a time integration (below)", default="static",
        choices=("static", "dynamic")),
    Key("method", "string", "or `\"arc_length\"` (Crisfield; follows snap-through and snap-back)",
        default="load_control", choices=("load_control", "arc_length")),
    Key("steps", "integer", f"equal steps to `max_load_factor` (cut back automatically when Newton fails), at most "
        f"{MAX_STEPS}", default=10, maximum=MAX_STEPS, only=("load_control",)),
    Key("max_load_factor", "number", "the load factor to reach; all loads are multiplied by the load factor",
        default=1.0, bound=">0"),
    Key("load_factors", "numbers", "or the load factors to reach, increasing (not with `steps` or "
        "`max_load_factor`)", default=None, only=("load_control",)),
    Key("arc_increment", "number", "the first step's load increment", default=0.05, bound=">0",
        only=("arc_length",)),
    Key("max_load_increment", "number", "the largest load-factor change of a step (a dense record of the path)",
        default=None, bound=">0", only=("arc_length",), shown="none"),
    Key("max_steps", "integer", "the most steps; the run stops there with a message if `max_load_factor` is not "
        "reached", default=None, only=("arc_length",), shown="500"),
    Key("min_increment_ratio", "number", "cut-backs below this fraction of the first arc stop the run with a "
        "report", default=None, only=("arc_length",), shown="0.001"),
    Key("max_increment_ratio", "number", "the longest arc, in first arcs (a thin roof's snap-through is hundreds "
        "of first arcs long)", default=None, only=("arc_length",), shown="25"),
    Key("desired_iterations", "integer", "the step length adapts (x sqrt(desired / iterations), within x0.5..x2) "
        "towards this many iterations per step", default=None, only=("arc_length",), shown="5"),
    Key("newton", "table", "the Newton settings (below)", default=None),
    Key("stability", "boolean", "count the negative eigenvalues of the tangent at every step and report limit and "
        "bifurcation points (costs one symmetric factorization per step: docs/stability.md); `false` skips it",
        default=True),
), "a static analysis: load control or arc length", switch="method")

#: the arc-length keys of ``[analysis]`` passed on as :data:`integrators.static.ARC_LENGTH_OPTIONS`
ARC_LENGTH_KEYS = ("max_steps", "min_increment_ratio", "max_increment_ratio", "desired_iterations")

DYNAMIC = TableSpec("analysis", (
    Key("type", "string", "`\"dynamic\"` for a time integration", default="static", choices=("static", "dynamic")),
    Key("dt", "number", "time step (rounded down so that whole steps end at `end_time`), s", bound=">0"),
    Key("end_time", "number", "end time, s", bound=">0"),
    Key("rho_inf", "number", "spectral radius at infinite frequency, in [0, 1] (1: no numerical damping; 0: the "
        "most); absent: the default of the start (`flexbody.scenes.analysis.default_rho_inf`), and the summary "
        "says `rho_inf_default = true`", default=None, shown="0.9; 0.5 for a steady-spin start with a hub"),
    Key("policy", "string", "the iteration matrix: reused while it serves, or refreshed every iteration",
        default="modified", choices=("modified", "full")),
    Key("output_every", "integer", "record (and write) every k-th step; the last step always", default=1),
    Key("gravity", "vector", "body acceleration, applied as the nodal weights of the mass matrix (m_I g lumped, "
        "∫ρh N_I dA g consistent)", default=_ZERO),
    Key("load_ramp_time", "number", "the `[[load]]`s without a `time_function` grow linearly from 0 to full over "
        "this time (0: full from t = 0)", default=0.0, bound=">=0"),
    Key("initial", "table", "the initial velocity (below)", default=None),
    Key("hub", "table", "a hub spun up (below)", default=None),
    Key("integrator", "table", "the integrator settings (below)", default=None),
    Key("damping", "table", "Rayleigh damping (below)", default=None),
    Key("adaptive", "boolean", "error-controlled time steps (docs/dynamics.md, \"Adaptive time steps\"): `dt` is then "
        "the first step and the unit of the output times (every `output_every`-th multiple of `dt`, where the "
        "steps land, and the longest step); tolerance and limits in `[analysis.integrator]`; the summary and JSON "
        "report accepted and rejected steps (`time_steps`)", default=None, shown="false"),
    Key("mass", "string", "the mass matrix: `\"lumped\"` (HRZ, diagonal) or `\"consistent\"` (translations ∫ρh N_I "
        "N_J dA, director inertia lumped); used by everything that needs the mass (inertia, gravity, energies, "
        "momenta, mass damping, the steady spin); docs/dynamics.md \"Consistent mass\" compares the two (Python: "
        "`DynamicAnalysis(mass=...)`, `DynamicModel(mass=...)`)", default="lumped", choices=("lumped", "consistent")),
    Key("frame", "string", "where the equations of motion are solved: `\"inertial\"`, or `\"turning\"`: the frame "
        "turning with the steady spin of `[analysis.initial]` (centrifugal and Coriolis forces; outputs, energies "
        "and files stay inertial; needs loads and gravity along the spin axis or follower loads, and a hub turning "
        "with the frame); absent: turning for a steady-spin start that allows it, else inertial; the summary says "
        "which (`frame`); docs/dynamics.md \"Turning frame\"", default=None,
        shown="turning for a steady-spin start, else inertial", choices=("inertial", "turning")),
), "a dynamic analysis (`type = \"dynamic\"`): Lie-group generalized-alpha")

INITIAL = TableSpec("analysis.initial", (
    Key("state", "string", "`\"steady_spin\"`: start on the steady spin (relative equilibrium) at "
        "`angular_velocity` about the axis through `center` (`velocity` must be zero; a hub must turn at that rate "
        "from t = 0, `ramp_time = 0`); see docs/dynamics.md and `examples/spinning_membrane_steady.toml`",
        default="reference", choices=("reference", "steady_spin")),
    Key("velocity", "vector", "v0 of the rigid initial velocity field v0 + omega x (x - center)", default=_ZERO),
    Key("angular_velocity", "vector", "omega of the rigid initial velocity field", default=_ZERO),
    Key("center", "vector", "the point that moves with v0", default=None, shown="centre of mass"),
    Key("velocity_field", "tables", "velocity fields added to the initial velocity (to the spin's for a "
        "steady-spin start: a kick), below", default=[]),
), "the initial velocity (dynamic)")

VELOCITY_FIELD = TableSpec("analysis.initial.velocity_field", (
    Key("direction", "vector", "the velocity's direction"),
    Key("amplitude", "number", "the velocity's size (m/s)"),
    Key("radial", "any", "f with s = (r - a)/(b - a) held in [0, 1]: `\"uniform\"` 1, `\"linear\"` s, "
        "`\"quadratic\"` s^2; or a table `[[r...], [f...]]` (linear in r, held at its ends)", default="linear",
        form="name or [[r...], [f...]]"),
    Key("modes", "any", "the circumferential orders n (0: axisymmetric)", default=[0], form="list of integers >= 0"),
    Key("phase", "number", "radians", default=0.0),
    Key("inner_radius", "number", "a", default=None, shown="the nodes' smallest r"),
    Key("outer_radius", "number", "b", default=None, shown="the nodes' largest r"),
    Key("center", "vector", "a point on the axis of the polar coordinates", default=_ZERO),
    Key("axis", "vector", "the axis of the polar coordinates", default=_Z),
), "a velocity field added to the initial velocity: `amplitude` f(r) sum_n cos(n (theta - `phase`)) along "
   "`direction`", array=True)

HUB = TableSpec("analysis.hub", (
    Key("selection", "selection", "the nodes clamped to the hub (no `[[bc]]` needed for them); or `radius` or "
        "`polygon`"),
    Key("radius", "number", "or the nodes within this distance of the hub's axis (boundary nodes included, 1e-8 of "
        "the model size)", default=None, bound=">0"),
    Key("polygon", "table", "or the nodes inside the regular polygon `{ sides = 6, circumradius = r, angle = 0 }` "
        "about the axis (vertex 0 at `angle` radians from the polar angle's reference direction)", default=None),
    Key("angular_velocity", "vector", "the hub's final angular velocity, global"),
    Key("ramp_time", "number", "smooth spin-up omega(t) = omega (1 - cos(pi t / ramp_time)) / 2, then omega (0: "
        "omega from t = 0)", default=0.0, bound=">=0"),
    Key("center", "vector", "a point on the hub's axis", default=_ZERO),
), "a hub spun up (dynamic)")

POLYGON = TableSpec("analysis.hub.polygon", (
    Key("sides", "integer", "the number of sides", minimum=3),
    Key("circumradius", "number", "the distance of the vertices from the axis", bound=">0"),
    Key("angle", "number", "vertex 0's polar angle, radians", default=0.0),
), "the regular polygon of a hub", title="`[analysis.hub]` `polygon`")

DAMPING = TableSpec("analysis.damping", (
    Key("alpha_mass", "number", "a0 (1/s) of f_d = a0 M v + a1 Kᵐ v: damps every velocity, rigid motion included",
        default=None, bound=">=0", shown="0"),
    Key("beta_stiffness", "number", "a1 (s): damps the strain rates only (never a rigid spin)", default=None,
        bound=">=0", shown="0"),
    Key("ratio", "number", "instead of a0, a1: the damping ratio ζ at the frequencies `frequencies_hz`; a0 = "
        "2ζω1ω2/(ω1+ω2), a1 = 2ζ/(ω1+ω2)", default=None, bound=">=0"),
    Key("frequencies_hz", "numbers", "[f1, f2] (Hz, 0 < f1 ≤ f2; one value: ζ at f1)", default=None),
), "Rayleigh damping (dynamic; `flexbody.dynamics.RayleighDamping`)")

OUTPUT = TableSpec("output", (
    Key("name", "string", "the tracked quantity's name (unique, no `/`)"),
    Key("type", "string", "what is tracked (`\"angular_velocity\"`: dynamic only), below",
        default="displacement", choices=("displacement", "radial", "angular_velocity")),
    Key("selection", "selection", "which node (exactly one)", only=("displacement",)),
    Key("component", "string", "`\"x\"`, `\"y\"` or `\"z\"`: the displacement of the node along it",
        default=None, choices=tuple(COMPONENTS), only=("displacement",)),
    Key("direction", "vector", "or a direction vector: the displacement of the node along it", default=None,
        only=("displacement",)),
    Key("selection", "selection", "the nodes whose mean radial displacement about the axis is tracked "
        "(rotation-invariant, the stretch of a spinning body)", only=("radial",)),
    Key("center", "vector", "a point on the axis", default=_ZERO, only=("radial",)),
    Key("axis", "vector", "the axis", default=_Z, only=("radial",)),
    Key("scale", "number", "a factor (`-1` for \"minus U\")", default=1.0, only=("displacement", "radial")),
    Key("component", "string", "`\"x\"`, `\"y\"` or `\"z\"`: the global component of the body's fitted rigid angular "
        "velocity", choices=tuple(COMPONENTS), only=("angular_velocity",)),
), "a tracked quantity", array=True, switch="type")

REFERENCE = TableSpec("reference", (
    Key("file", "string", "a CSV file, relative to the scene file: `#` comment lines, a header row, numeric rows"),
    Key("load_factor", "string", "the column with the load factors (static)", default=None, only=("static",),
        shown="first column"),
    Key("time", "string", "the column with the times (dynamic)", default=None, only=("dynamic",),
        shown="first column"),
    Key("columns", "table", "`{ output = \"column\" }`", default=None, shown="outputs named like columns"),
    Key("source", "string", "where the reference comes from (printed in the bench report)", default=None,
        shown="first comment line"),
), "reference values to compare the outputs with")

RING = TableSpec("ring", (
    Key("radius", "number", "the distance of the nodes from the axis", bound=">0"),
    Key("center", "vector", "a point on the axis", default=_ZERO),
    Key("axis", "vector", "the axis", default=_Z),
), "the nodes at distance `radius` from the axis (a node selection)", title="`ring`")

PLANE = TableSpec("plane", (
    Key("point", "vector", "a point of the plane"),
    Key("normal", "vector", "the plane's normal"),
), "the nodes on a plane (a node selection)", title="`plane`")


def _settings_spec(path: str, settings: type, doc: str, skip: tuple[str, ...] = (),
                   integers: dict[str, Any] | None = None, bound: str = "",
                   bounds: dict[str, str] | None = None) -> TableSpec:
    """The spec of a table whose keys are the fields of a settings dataclass (integers >= ``minimum``, other
    numbers within ``bound``, or within ``bounds[name]`` for the fields named there)."""
    keys = []
    for f in fields(settings):
        if f.name in skip:
            continue
        kind = {bool: "boolean", int: "integer", str: "string"}.get(f.default.__class__, "number")
        number_bound = (bounds or {}).get(f.name, bound)
        keys.append(Key(f.name, kind, f"`{settings.__name__}.{f.name}`", default=None,
                        minimum=(integers or {}).get("minimum", 1), bound=number_bound if kind == "number" else "",
                        shown=f"`{toml_text(f.default)}`" if f.default is not None else "none"))
    return TableSpec(path, tuple(keys), doc)


def newton_spec() -> TableSpec:
    """``[analysis.newton]``: the fields of :class:`integrators.newton.NewtonSettings` (built when asked for)."""
    from integrators.newton import NewtonSettings
    return _settings_spec("analysis.newton", NewtonSettings,
                          "any field of `integrators.newton.NewtonSettings` (`rtol` in (0, 1), relative to the "
                          "model's own forces; there is no absolute tolerance); `policy = \"modified\"` reuses the "
                          "factorized tangent while it serves; `lazy_tangent = 0` makes the default \"full\" policy "
                          "classical Newton (a tangent every iteration, docs/performance.md); `mixed = false` turns "
                          "the mixed iteration (Gauss-point stresses iterated as unknowns, docs/theory.md) off")


def integrator_spec() -> TableSpec:
    """``[analysis.integrator]``: the fields of :class:`integrators.generalized_alpha.AlphaSettings` but those
    ``[analysis]`` sets (built when asked for: a static run never imports the integrator)."""
    from integrators.generalized_alpha import AlphaSettings
    return _settings_spec("analysis.integrator", AlphaSettings,
                          "any other field of `integrators.generalized_alpha.AlphaSettings` (`error_tolerance`: the "
                          "local position error per adaptive step as a fraction of the model size; `min_step`, "
                          "`max_step` in s; docs/dynamics.md, \"Adaptive time steps\"; `contraction_floor`: the least "
                          "contraction an estimate assumes, so that no step is accepted on an optimistic first ratio, "
                          "docs/dynamics.md, \"The kept matrix follows the surface\"; `local_error_fraction`: an "
                          "iterate is also accepted when its error is below this fraction of the step's local error "
                          "estimate, 0 iterates to `rtol` and "
                          "`atol` only, docs/dynamics.md, \"Iteration error against the local error\"); integers >= 0, "
                          "`contraction_floor` and `local_error_fraction` >= 0 (0: off), every other number > 0",
                          skip=("rho_inf", "policy", "adaptive"), integers={"minimum": 0}, bound=">0",
                          bounds={"contraction_floor": ">=0", "local_error_fraction": ">=0"})


def all_specs() -> tuple[TableSpec, ...]:
    """Every table's spec, in the order of docs/scenes.md."""
    return (SELECTION, TOP, MESH, MATERIAL, ELEMENT, BC, LOAD, TIME_FUNCTION, POINT_MASS, ANALYSIS, newton_spec(),
            DYNAMIC, INITIAL, VELOCITY_FIELD, HUB, POLYGON, integrator_spec(), DAMPING, OUTPUT, REFERENCE, RING, PLANE)


#: the top-level keys of a scene file
SECTIONS = TOP.names()

#: the tables whose plain keys ``--set`` accepts by their bare name although the file does not write them
SET_BY_NAME = (MATERIAL, ANALYSIS, DYNAMIC, ELEMENT)


def settable_keys() -> dict[str, str]:
    """Bare key -> dotted key of the plain keys (no table, no ``type``) of :data:`SET_BY_NAME`."""
    out: dict[str, str] = {}
    for spec in SET_BY_NAME:
        for key in spec.keys:
            if key.kind not in ("table", "tables", "selection") and key.name != "type":
                out[key.name] = f"{spec.path}.{key.name}"
    return out
