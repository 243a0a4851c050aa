"""The side-by-side comparison of a built-in scene in flexbody and in its exudyn reference model.

``compare`` runs both codes and returns the comparison as a plain dict (the content of the JSON file; its
docstring lists the keys); ``compare_cli`` is what ``flexbody compare SCENE --with exudyn`` calls: it runs
``compare``, prints the table (``flexbody.outputs.comparison_text``) and writes the JSON.
"""

from __future__ import annotations

import json
import math
import sys
import time

import numpy as np

import exudyn as exu

from flexbody.adapters.exudyn.options import (DYNAMIC_OPTIONS, DYNAMIC_SCENES, OPTION_PREFIX, STATIC_OPTIONS,
                                              model_kind, split_options)
from flexbody.adapters.exudyn.references_dynamic import build_dynamic_model, energy_summary, solve_dynamic
from flexbody.adapters.exudyn.references_static import build_model, solve
from flexbody.outputs.comparison_text import table_lines
from flexbody.scenes import build
from flexbody.scenes.scene import Scene, run_scene


def _time_ratios(fb: dict, ex: dict) -> tuple[float | None, float | None]:
    """(wall, CPU) time ratios exudyn / flexbody of the solves, None where flexbody's time is zero."""
    ratio = ex["wall_time_s"] / fb["wall_time_s"] if fb["wall_time_s"] > 0 else None
    cpu_ratio = ex["cpu_time_s"] / fb["cpu_time_s"] if fb["cpu_time_s"] > 0 else None
    return ratio, cpu_ratio


# ----------------------------------------------------------------------------------------------------------
# static scenes
# ----------------------------------------------------------------------------------------------------------

def _flexbody_dict(scene: Scene, summary, build_time: float, cpu_time: float) -> dict:
    d = summary.as_dict()
    return {
        "model": f"flexbody six-node SE(3) shell ({scene.model.body.element_name}), "
                 f"{summary.elements} triangles",
        "dofs": d["dofs"], "elements": d["elements"], "steps": d["steps"],
        "newton_iterations": d["newton_iterations"], "converged": d["converged"], "message": d["message"],
        "load_factor": d["load_factor"], "build_time_s": build_time, "wall_time_s": d["wall_time_s"],
        "cpu_time_s": cpu_time,
        "outputs": d["outputs"], "errors": d["errors"], "max_rel_error": d["max_rel_error"],
        "history": {k: [float(x) for x in v] for k, v in summary.history.items()},
    }


def _max_error(errors: list[dict], name: str) -> float | None:
    vals = [e["rel_error"] for e in errors if e["quantity"] == name]
    return max(vals) if vals else None


def _output_rows(scene: Scene, fb: dict, ex: dict) -> list[dict]:
    """One row per output; rel_difference is |difference| / the largest |value| either code reached."""
    rows = []
    for out in scene.outputs:
        a, b = fb["outputs"].get(out.name), ex["outputs"].get(out.name)
        ref = None
        if scene.reference is not None and out.name in scene.reference.values:
            ref = float(np.asarray(scene.reference.values[out.name])[-1])
        diff = None if a is None or b is None else b - a
        scale = max([abs(v) for v in fb["history"][out.name] + ex["history"][out.name]], default=0.0) or 1.0
        rows.append({"name": out.name, "flexbody": a, "exudyn": b, "difference": diff,
                     "rel_difference": None if diff is None else abs(diff) / scale, "reference": ref,
                     "flexbody_ref_error": _max_error(fb["errors"], out.name),
                     "exudyn_ref_error": _max_error(ex["errors"], out.name)})
    return rows


def _compare_static(scene_name: str, scene_params: dict, options: dict) -> dict:
    """``compare`` for a static scene (see ``compare``)."""
    dynamic_only = sorted(set(options) & set(DYNAMIC_OPTIONS))
    if dynamic_only:
        raise ValueError(f"exudyn options {', '.join(OPTION_PREFIX + o for o in dynamic_only)} are for dynamic "
                         f"scenes ({', '.join(DYNAMIC_SCENES)}) only")
    t0 = time.perf_counter()
    scene = build(scene_name, **scene_params)
    fb_build = time.perf_counter() - t0
    model = build_model(scene, options)            # before the flexbody run: reads the unloaded scene
    c0 = time.process_time()
    summary = run_scene(scene)
    fb = _flexbody_dict(scene, summary, fb_build, time.process_time() - c0)
    ex = solve(model, scene.reference).as_dict()
    ratio, cpu_ratio = _time_ratios(fb, ex)
    return {
        "scene": scene_name, "parameters": dict(scene.parameters), "exudyn_options": options,
        "flexbody": fb, "exudyn": ex, "outputs": _output_rows(scene, fb, ex),
        "reference_source": scene.reference.source if scene.reference is not None else None,
        "wall_time_ratio": ratio, "cpu_time_ratio": cpu_ratio, "ok": bool(fb["converged"] and ex["converged"]),
    }


# ----------------------------------------------------------------------------------------------------------
# dynamic scenes
# ----------------------------------------------------------------------------------------------------------

def _flexbody_dynamic_dict(scene: Scene, summary, build_time: float, cpu_time: float) -> dict:
    d = summary.as_dict()
    eh = d["energy_history"]
    e = d["energy"]
    scale = float(np.max(np.asarray(eh["kinetic"]) + np.asarray(eh["strain"]) + np.abs(eh["gravity"])))
    energy = energy_summary(eh["time"], eh["strain"], eh["total"], scale)
    energy["total"]["max_rel_drift"] = e["total"]["max_rel_drift"]
    L = np.asarray(summary.energies["angular_momentum"], float)
    angular = dict(d["momentum"]["angular"], history=L.tolist())
    return {
        "model": f"flexbody six-node SE(3) shell ({scene.model.body.element_name}), "
                 f"{summary.elements} triangles, Lie-group generalized-alpha ({d['policy']})",
        "dofs": d["dofs"], "elements": d["elements"], "steps": d["steps"], "time_step": d["time_step"],
        "end_time": d["end_time"], "rho_inf": d["rho_inf"], "newton_iterations": d["newton_iterations"],
        "tangent_updates": d["tangent_updates"], "factorizations": d["factorizations"],
        "converged": d["converged"], "message": d["message"], "time": d["time"], "build_time_s": build_time,
        "wall_time_s": d["wall_time_s"], "cpu_time_s": cpu_time, "outputs": d["outputs"],
        "history": {k: [float(x) for x in v] for k, v in summary.history.items()},
        "energy_history": {k: eh[k] for k in ("time", "kinetic", "strain", "total")},
        "momentum": {"angular": angular}, "energy": energy,
    }


def _history_difference(a: dict, b: dict, name: str, t_max: float | None = None) -> tuple[float, float]:
    """(max |b - a|, that / max |value| of both) over a's times inside both histories (b interpolated)."""
    ta, tb = np.asarray(a["time"], float), np.asarray(b["time"], float)
    if ta.size == 0 or tb.size == 0:
        return float("nan"), float("nan")
    hi = min(ta[-1], tb[-1]) if t_max is None else min(ta[-1], tb[-1], t_max)
    keep = ta <= hi + 1e-12
    va = np.asarray(a[name], float)[keep]
    vb = np.interp(ta[keep], tb, np.asarray(b[name], float))
    diff = float(np.abs(vb - va).max())
    scale = max(float(np.abs(va).max()), float(np.abs(vb).max())) or 1.0
    return diff, diff / scale


def _samples(runs: dict[str, dict], t_end: float, n: int = 11) -> dict:
    """The strain (potential) energy of each run at n equidistant times (linear interpolation)."""
    times = np.linspace(0.0, t_end, n)
    out = {"time": times.tolist()}
    for key, run in runs.items():
        if run is None:
            continue
        eh = run["energy_history"]
        t = np.asarray(eh["time"], float)
        vals = np.interp(times, t, eh["strain"]) if t.size else np.full(n, np.nan)
        out[key] = [float(v) if tt <= t[-1] + 1e-12 else None for v, tt in zip(vals, times)] if t.size else \
            [None] * n
    return out


def _dynamic_output_rows(scene: Scene, fb: dict, ex: dict, ref: dict | None) -> list[dict]:
    """One row per output: final values and history differences; against the RK4 run if there is one."""
    rows = []
    for out in scene.outputs:
        diff, rel = _history_difference(fb["history"], ex["history"], out.name)
        row = {"name": out.name, "flexbody": fb["outputs"].get(out.name), "exudyn": ex["outputs"].get(out.name),
               "max_history_difference": diff, "rel_history_difference": rel}
        a, b = row["flexbody"], row["exudyn"]
        row["difference"] = None if a is None or b is None else b - a
        if ref is not None and ref["history"]["time"]:
            t_ref = ref["history"]["time"][-1]
            row["flexbody_vs_rk4"] = _history_difference(ref["history"], fb["history"], out.name, t_ref)[1]
            row["exudyn_vs_rk4"] = _history_difference(ref["history"], ex["history"], out.name, t_ref)[1]
        rows.append(row)
    return rows


def _compare_dynamic(scene_name: str, scene_params: dict, options: dict) -> dict:
    """``compare`` for a dynamic scene (see ``compare``)."""
    for key in STATIC_OPTIONS:
        if key in options:
            raise ValueError(f"exudyn option {OPTION_PREFIX + key} is for static scenes only")
    reference = options.get("reference")
    if reference is not None and str(reference).lower() not in ("0", "false", "no", "1", "true", "rk4", "yes"):
        raise ValueError(f"exudyn_reference must be rk4 (or 1/true, 0/false), got {reference!r}")
    use_reference = reference is not None and str(reference).lower() not in ("0", "false", "no")
    t0 = time.perf_counter()
    scene = build(scene_name, **scene_params)
    fb_build = time.perf_counter() - t0
    model = build_dynamic_model(scene, options)
    scene.model.warm_up()                          # numba compilation is neither wall nor CPU time of the run
    c0 = time.process_time()
    summary = run_scene(scene)
    fb = _flexbody_dynamic_dict(scene, summary, fb_build, time.process_time() - c0)
    ex = solve_dynamic(model, energy_every=int(options.get("energy_every", 1)))
    ref = None
    if use_reference:
        ref_model = build_dynamic_model(scene, options, time_step=float(options.get("reference_dt", 1e-4)),
                                        end_time=float(options.get("reference_end_time", model.end_time)))
        ref_model.record_every = max(1, int(round(model.time_step / ref_model.time_step)))
        ref = solve_dynamic(ref_model, "rk4", energy_every=int(options.get("energy_every", 1)))
    rows = _dynamic_output_rows(scene, fb, ex, ref)
    ratio, cpu_ratio = _time_ratios(fb, ex)
    ok = bool(fb["converged"] and ex["converged"] and (ref is None or ref["converged"]))
    return {
        "scene": scene_name, "kind": "dynamic", "parameters": dict(scene.parameters), "exudyn_options": options,
        "flexbody": fb, "exudyn": ex, "reference": ref, "outputs": rows,
        "strain_energy_samples": _samples({"flexbody": fb, "exudyn": ex, "reference": ref}, model.end_time),
        "reference_source": "exudyn RK44 on the same ANCF model" if ref is not None else None,
        "wall_time_ratio": ratio, "cpu_time_ratio": cpu_ratio, "ok": ok,
    }


# ----------------------------------------------------------------------------------------------------------
# the comparison, and the command behind ``flexbody compare``
# ----------------------------------------------------------------------------------------------------------

def compare(scene_name: str, params: dict | None = None) -> dict:
    """Run a built-in scene in flexbody and its exudyn reference model; report both side by side.

    Parameters
    ----------
    scene_name : a scene of ``MODELS``
    params : flexbody scene parameters, plus exudyn options prefixed ``exudyn_`` (the package docstring)

    Returns
    -------
    dict with keys
        "scene", "parameters" (flexbody), "exudyn_options";
        "flexbody" and "exudyn": model, dofs, elements, steps, newton_iterations, converged, message,
        load_factor (last reached), build_time_s, wall_time_s, cpu_time_s (process CPU time of the solve,
        robust on a loaded machine), outputs (final values), errors (per
        tabulated load level, ``compare_with_reference``), max_rel_error, history (load_factor and every
        output per converged step); exudyn adds kind, coordinates, constraints, newton_rtol;
        "outputs": one row per tracked output: name, flexbody, exudyn, difference (exudyn - flexbody),
        rel_difference (|difference| / the largest |value| of that output in either history), reference
        (final tabulated value or None), flexbody_ref_error and exudyn_ref_error (max relative error
        over the table, or None);
        "reference_source", "wall_time_ratio" and "cpu_time_ratio" (exudyn / flexbody, solve only),
        "ok" (both converged).

    A dynamic scene (``DYNAMIC_SCENES``: ``spinning_plate``) returns instead the keys
        "scene", "kind" ("dynamic"), "parameters", "exudyn_options";
        "flexbody" and "exudyn" (and "reference", the optional RK4 run of the same exudyn model with
        ``exudyn_reference=rk4``, ``exudyn_reference_dt`` (1e-4), ``exudyn_reference_end_time``, else
        None): model, dofs, elements, steps, time_step, end_time, rho_inf, newton_iterations, converged,
        message, time (reached), build_time_s, wall_time_s, cpu_time_s, outputs (final), history (time and
        every output per recorded step), energy_history (time, kinetic, strain, total),
        momentum["angular"] (initial, final, max_drift, max_rel_drift = max_t |L(t) - L(0)| / max_t |L|,
        history; about the origin), energy (strain max / min / mean over t > 0, final; total initial,
        max_drift, max_rel_drift); flexbody adds tangent_updates and factorizations, exudyn
        jacobians, energy_eval_time_s (the strain-energy post-processing, not in the solve time);
        "outputs": per output name, flexbody, exudyn, difference (final), max_history_difference and
        rel_history_difference (over the recorded times, / max |value| of both), with a reference also
        flexbody_vs_rk4 and exudyn_vs_rk4 (relative history differences over the reference window);
        "strain_energy_samples": time and the strain energy of each run at 11 equidistant times;
        "reference_source", "wall_time_ratio", "cpu_time_ratio", "ok".
    The exudyn option ``exudyn_energy_every`` evaluates exudyn's strain energy at every k-th recorded step.
    """
    scene_params, options = split_options(params)
    model_kind(scene_name, options)                # fail before the (possibly long) flexbody build
    if scene_name in DYNAMIC_SCENES:
        return _compare_dynamic(scene_name, scene_params, options)
    return _compare_static(scene_name, scene_params, options)


def _json_ready(value):
    """The comparison as strict JSON values: numpy scalars as Python numbers, NaN and infinities as null."""
    if isinstance(value, dict):
        return {str(k): _json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(v) for v in value]
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value


def compare_cli(scene_name: str, params: dict, json_path: str | None, quiet: bool) -> int:
    """``flexbody compare SCENE --with exudyn``: print the table, write the JSON; 0 on success, 2 on failure.

    Failure: an unknown scene or option, a model that cannot be built, an unwritable JSON file, or a run
    that did not converge (the table and JSON are still written then). The failure is one line on stderr.
    """
    try:
        result = compare(scene_name, params)
    except (KeyError, ValueError, TypeError, exu.SolverError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"flexbody compare: error: {msg}", file=sys.stderr)
        return 2
    if not quiet:
        print("\n".join(table_lines(result)))
    if json_path:
        try:
            with open(json_path, "w", encoding="utf-8") as fh:
                json.dump(_json_ready(result), fh, indent=2)
        except OSError as exc:
            print(f"flexbody compare: error: cannot write {json_path!r}: {exc.strerror or exc}", file=sys.stderr)
            return 2
        if not quiet:
            print(f"written          {json_path}")
    if not result["ok"]:
        failed = [f"{k}: {result[k]['message']}" for k in ("flexbody", "exudyn", "reference")
                  if result.get(k) is not None and not result[k]["converged"]]
        print(f"flexbody compare: error: run did not converge ({'; '.join(failed)})", file=sys.stderr)
        return 2
    return 0

