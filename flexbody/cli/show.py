"""``flexbody show SCENE``: what a scene models, its parameters (defaults, units) and its reference."""

from __future__ import annotations

from flexbody.cli.scene_input import build_scene, open_source

#: Units of the scenes' parameters by their (last) key. The scenes use consistent units (the spinning and
#: dynamic scenes SI: m, kg, s); mesh and step counts and switches have none.
PARAMETER_UNITS = {"thickness": "length", "radius": "length", "inner_radius": "length",
                   "outer_radius": "length", "length": "length", "width": "length", "young": "force/length^2",
                   "pressure": "force/length^2", "density": "mass/length^3", "dt": "s", "end_time": "s",
                   "ramp_time": "s", "omega": "rad/s", "angular_velocity": "rad/s", "steps": "load steps"}


def parameter_unit(key: str) -> str:
    """The unit of a scene parameter by its (last) key ("" for counts and switches)."""
    name = key.split(".")[-1]
    if name in PARAMETER_UNITS:
        return PARAMETER_UNITS[name]
    return "elements" if name == "n" or name.startswith("n_") else ""


def show_lines(source, scene) -> list[str]:
    """The text of ``flexbody show``: the scene, its parameters with defaults and units, its reference."""
    import inspect
    from flexbody.scenes.registry import builtin_scene
    model = scene.model
    lines = [f"scene            {scene.name} ({source.kind})", f"models           {scene.description}"]
    if source.kind == "builtin":
        doc = builtin_scene(source.name).summary
        if doc and doc != scene.description:
            lines.append(f"                 {doc}")
    lines.append(f"mesh             {model.body.mesh.n_nodes} nodes, {model.body.mesh.n_elements} elements "
                 f"({model.body.element_name}), {model.n_dof} DoFs")
    a = scene.analysis
    if scene.kind == "static":
        lines.append(f"analysis         static, {a.method}, {len(a.load_factors)} load steps to load factor "
                     f"{a.load_factors[-1]:g}" if getattr(a, "load_factors", None) else
                     f"analysis         static, {a.method}")
    else:
        lines.append(f"analysis         dynamic, time step {a.time_step:g} s to {a.end_time:g} s"
                     if hasattr(a, "end_time") else "analysis         dynamic")
    defaults = {}
    if source.kind in ("builtin", "python"):
        func = builtin_scene(source.name).builder if source.kind == "builtin" else None
        if func is not None:
            defaults = {k: p.default for k, p in inspect.signature(func).parameters.items()
                        if p.default is not inspect.Parameter.empty}
    params = {**defaults, **{k: v for k, v in scene.parameters.items() if k not in defaults}}
    if params:
        lines.append("parameters       (set with --set KEY=VALUE; default, unit)")
        for k, v in params.items():
            unit = parameter_unit(k)
            lines.append(f"  {k:20s} {v!r:>14s}  {unit}".rstrip())
    outs = ", ".join(o.name for o in scene.outputs)
    if outs:
        lines.append(f"outputs          {outs}")
    if scene.reference is not None:
        lines.append(f"reference        {scene.reference.source or 'given'}")
    else:
        lines.append("reference        none")
    return lines



def cmd_show(args) -> int:
    """``flexbody show SCENE``: what the scene models, its parameters and reference (builds, does not run)."""
    source = open_source(args.scene)
    scene = build_scene(source, {})
    for line in show_lines(source, scene):
        print(line)
    return 0
