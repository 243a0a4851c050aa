"""The printed comparison tables of ``flexbody compare SCENE --with exudyn``.

Pure text from the comparison dict of ``flexbody.adapters.exudyn.compare`` (static or dynamic, the same
content as the JSON file); imports no exudyn.
"""

from __future__ import annotations

import math


def _fmt(value, spec: str = ".5g") -> str:
    """A value for a table cell: "-" for None, "nan" for NaN and infinities."""
    if value is None:
        return "-"
    if isinstance(value, float) and not math.isfinite(value):
        return "nan"
    return format(value, spec)


def _heading(result: dict, scene_suffix: str = "") -> list[str]:
    """The scene and parameter lines that open both tables."""
    options = f"  exudyn {result['exudyn_options']}" if result["exudyn_options"] else ""
    return [f"scene            {result['scene']}{scene_suffix}",
            f"parameters       {result['parameters']}{options}"]


def table_lines(result: dict) -> list[str]:
    """The printed comparison table (the same content as the JSON file), static or dynamic."""
    if result.get("kind") == "dynamic":
        return dynamic_table_lines(result)
    fb, ex = result["flexbody"], result["exudyn"]
    lines = _heading(result) + [f"flexbody         {fb['model']}", f"exudyn           {ex['model']}", ""]
    w = 14
    lines.append(f"{'':22}{'flexbody':>{w}}{'exudyn':>{w}}")
    for label, key, spec in [("DoFs", "dofs", "d"), ("load steps", "steps", "d"),
                             ("Newton iterations", "newton_iterations", "d"), ("build time [s]", "build_time_s", ".3f"),
                             ("solve time [s]", "wall_time_s", ".3f"), ("solve CPU time [s]", "cpu_time_s", ".3f"),
                             ("last load factor", "load_factor", ".4g"),
                             ("max ref. error", "max_rel_error", ".2e")]:
        lines.append(f"{label:22}{_fmt(fb[key], spec):>{w}}{_fmt(ex[key], spec):>{w}}")
    lines.append(f"{'converged':22}{str(fb['converged']):>{w}}{str(ex['converged']):>{w}}")
    lines.append("")
    lines.append(f"{'output':16}{'flexbody':>12}{'exudyn':>12}{'difference':>12}{'rel.diff':>10}"
                 f"{'reference':>11}{'err flexbody':>14}{'err exudyn':>12}")
    for r in result["outputs"]:
        lines.append(f"{r['name']:16}{_fmt(r['flexbody']):>12}{_fmt(r['exudyn']):>12}{_fmt(r['difference'], '.3e'):>12}"
                     f"{_fmt(r['rel_difference'], '.2e'):>10}{_fmt(r['reference']):>11}"
                     f"{_fmt(r['flexbody_ref_error'], '.2e'):>14}{_fmt(r['exudyn_ref_error'], '.2e'):>12}")
    if result["reference_source"]:
        lines.append(f"reference: {result['reference_source']} (errors: max over the table, relative to max |ref|)")
    if not fb["converged"]:
        lines.append(f"flexbody: {fb['message']}")
    if not ex["converged"]:
        lines.append(f"exudyn: {ex['message']}")
    return lines



def dynamic_table_lines(result: dict) -> list[str]:
    """The printed table of a dynamic comparison."""
    runs = [("flexbody", result["flexbody"]), ("exudyn", result["exudyn"])]
    if result.get("reference") is not None:
        runs.append(("exudyn RK4", result["reference"]))
    lines = _heading(result, " (dynamic)")
    lines += [f"{label:17}{run['model']}" for label, run in runs]
    lines.append("")
    w = 14
    lines.append(f"{'':28}" + "".join(f"{label:>{w}}" for label, _ in runs))

    def row(label, get, spec):
        vals = []
        for _, run in runs:
            try:
                vals.append(_fmt(get(run), spec))
            except (KeyError, TypeError, IndexError):
                vals.append("-")
        lines.append(f"{label:28}" + "".join(f"{v:>{w}}" for v in vals))

    row("DoFs (coordinates)", lambda r: r["dofs"], "d")
    row("time step", lambda r: r["time_step"], ".3g")
    row("steps", lambda r: r["steps"], "d")
    row("end time", lambda r: r["time"], ".4g")
    row("Newton iterations", lambda r: r["newton_iterations"], "d")
    row("build time [s]", lambda r: r["build_time_s"], ".3f")
    row("solve time [s]", lambda r: r["wall_time_s"], ".3f")
    row("solve CPU time [s]", lambda r: r["cpu_time_s"], ".3f")
    row("L_z(0)", lambda r: r["momentum"]["angular"]["initial"][2], ".6g")
    row("L_z(end)", lambda r: r["momentum"]["angular"]["final"][2], ".6g")
    row("angular momentum drift", lambda r: r["momentum"]["angular"]["max_rel_drift"], ".2e")
    row("strain energy max", lambda r: r["energy"]["strain"]["max"], ".5g")
    row("strain energy min (t > 0)", lambda r: r["energy"]["strain"]["min"], ".5g")
    row("strain energy mean (t > 0)", lambda r: r["energy"]["strain"]["mean"], ".5g")
    row("total energy drift", lambda r: r["energy"]["total"]["max_rel_drift"], ".2e")
    row("converged", lambda r: str(r["converged"]), "")
    lines.append("")
    samples = result["strain_energy_samples"]
    lines.append("strain (potential) energy history")
    keys = [k for k in ("flexbody", "exudyn", "reference") if k in samples]
    lines.append(f"{'t':>8}" + "".join(f"{k if k != 'reference' else 'exudyn RK4':>{w}}" for k in keys))
    for i, t in enumerate(samples["time"]):
        lines.append(f"{t:8.3f}" + "".join(f"{_fmt(samples[k][i]):>{w}}" for k in keys))
    lines.append("")
    head = f"{'output':14}{'flexbody':>12}{'exudyn':>12}{'difference':>12}{'max hist. diff':>16}{'rel.':>10}"
    has_ref = result.get("reference") is not None
    if has_ref:
        head += f"{'fb vs RK4':>11}{'ex vs RK4':>11}"
    lines.append(head)
    for r in result["outputs"]:
        line = (f"{r['name']:14}{_fmt(r['flexbody']):>12}{_fmt(r['exudyn']):>12}{_fmt(r['difference'], '.3e'):>12}"
                f"{_fmt(r['max_history_difference'], '.3e'):>16}{_fmt(r['rel_history_difference'], '.2e'):>10}")
        if has_ref:
            line += f"{_fmt(r.get('flexbody_vs_rk4'), '.2e'):>11}{_fmt(r.get('exudyn_vs_rk4'), '.2e'):>11}"
        lines.append(line)
    lines.append("(max hist. diff: over the recorded times, exudyn interpolated; rel.: / max |value| of both)")
    for label, run in runs:
        if not run["converged"]:
            lines.append(f"{label}: {run['message']}")
    return lines

