"""The benchmark report of ``flexbody bench``: a Markdown table and PNG plots of error against run time.

``write_report(runs, out_dir)`` writes

- ``report.md``: per scene a table (mesh, DoFs, steps, wall time, max relative error, Newton iterations,
  tangent updates, factorizations, converged) and the plots below;
- ``error_vs_time.png``: max relative error against wall time, log-log, one line per scene;
- ``load_displacement_<scene>.png``: each tracked output against the load factor for every mesh, with the
  reference as markers;
- for a dynamic scene (runs on a sequence of time steps) ``time_history_<scene>.png``: each tracked output
  and the strain energy against time for every time step, reference as markers; its table adds the
  energy and angular-momentum drifts, and ``drift_vs_time.png`` plots those drifts against wall time;
- ``bench.json``: the same numbers, machine-readable (every run's summary and its load-output history).

Plots need matplotlib (``pip install matplotlib``, in the ``dev`` extra); it is imported only here, with the
Agg backend (no display). Without it the report still has its tables and says the plots were skipped.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import json
import math
import os
import platform
import re

import numpy as np


@dataclass
class BenchRun:
    """One run of a bench: a scene at one mesh.

    Attributes
    ----------
    scene : the scene's name
    label : the mesh, e.g. "nx=8, ny=1"
    parameters : the overrides it was built with
    summary : ``RunSummary.as_dict()`` (empty if the run failed before it started)
    history : the load factor and each tracked output per converged step
    reference : {output: (load_factors, values)} of the scene's reference, if any
    failure : why the run did not happen (a scene error), else None
    reference_source : where the reference comes from
    """

    scene: str
    label: str
    parameters: dict
    summary: dict = field(default_factory=dict)
    history: dict = field(default_factory=dict)
    reference: dict | None = None
    failure: str | None = None
    reference_source: str = ""

    @property
    def dofs(self) -> int:
        return int(self.summary.get("dofs", 0))

    @property
    def wall_time(self) -> float:
        return float(self.summary.get("wall_time_s", math.nan))

    @property
    def max_rel_error(self) -> float:
        value = self.summary.get("max_rel_error", math.nan)
        return math.nan if value is None else float(value)

    @property
    def converged(self) -> bool:
        return bool(self.summary.get("converged", False)) and self.failure is None

    @property
    def dynamic(self) -> bool:
        return self.summary.get("kind") == "dynamic" or "time" in self.history

    def drift(self, which: str) -> float:
        """A dynamic run's largest relative drift: "energy" (total energy) or "angular" / "linear" (momentum).

        NaN where the quantity is not conserved (energy: loads or prescribed motion; momenta: also supports
        or gravity): it changes by the work or impulse the body receives, which is not a drift.
        """
        try:
            conserved = (self.summary["energy"]["conservative"] if which == "energy"
                         else self.summary["momentum"]["isolated"])
            if not conserved:
                return math.nan
            value = (self.summary["energy"]["total"] if which == "energy" else self.summary["momentum"][which])
            value = value["max_rel_drift"]
        except (KeyError, TypeError):
            return math.nan
        return math.nan if value is None else float(value)


def mesh_label(parameters: dict, density_keys) -> str:
    """A short mesh description from the density parameters, e.g. ``"nx=8, ny=1"``."""
    keys = [k for k in density_keys if k in parameters] or list(parameters)
    return ", ".join(f"{k.rsplit('.', 1)[-1]}={parameters[k]}" for k in keys) or "default"


def _fmt(value: float, spec: str) -> str:
    return "-" if value is None or (isinstance(value, float) and not math.isfinite(value)) else format(value, spec)


def dynamic_markdown_table(runs: list[BenchRun]) -> str:
    """The Markdown table of the runs of one dynamic scene (one row per time step)."""
    lines = ["| run | DoFs | steps | wall time [s] | max rel. error | energy drift | ang. momentum drift "
             "| Newton iterations | tangent updates | factorizations | converged |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for r in runs:
        s = r.summary
        if r.failure is not None:
            lines.append(f"| {r.label} | - | - | - | - | - | - | - | - | - | failed: {r.failure} |")
            continue
        status = "yes" if s["converged"] else "no: " + str(s["message"]).replace("|", "/")[:80]
        lines.append(f"| {r.label} | {s['dofs']} | {s['steps']} | {_fmt(s['wall_time_s'], '.3f')} | "
                     f"{_fmt(r.max_rel_error, '.2e')} | {_fmt(r.drift('energy'), '.2e')} | "
                     f"{_fmt(r.drift('angular'), '.2e')} | {s['newton_iterations']} | {s['tangent_updates']} | "
                     f"{s['factorizations']} | {status} |")
    return "\n".join(lines)


def markdown_table(runs: list[BenchRun]) -> str:
    """The Markdown table of the runs of one scene."""
    if runs and all(r.dynamic for r in runs if r.failure is None) and any(r.failure is None for r in runs):
        return dynamic_markdown_table(runs)
    lines = ["| mesh | DoFs | steps | wall time [s] | max rel. error | Newton iterations | tangent updates "
             "| factorizations | converged |", "|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    for r in runs:
        s = r.summary
        if r.failure is not None:
            lines.append(f"| {r.label} | - | - | - | - | - | - | - | failed: {r.failure} |")
            continue
        status = "yes" if s["converged"] else "no: " + str(s["message"]).replace("|", "/")[:80]
        lines.append(f"| {r.label} | {s['dofs']} | {s['steps']} | {_fmt(s['wall_time_s'], '.3f')} | "
                     f"{_fmt(r.max_rel_error, '.2e')} | {s['newton_iterations']} | {s['tangent_updates']} | "
                     f"{s['factorizations']} | {status} |")
    return "\n".join(lines)


def _pyplot():
    """matplotlib.pyplot with the Agg backend, or None if matplotlib is not installed."""
    try:
        import matplotlib
    except ImportError:
        return None
    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt
    return plt


def _save(plt, fig, path: str, write: bool = True) -> bool:
    """Lay out, write (if ``write``) and close a figure; returns ``write``."""
    fig.tight_layout()
    if write:
        fig.savefig(path, dpi=120)
    plt.close(fig)
    return write


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name)


def plot_error_vs_time(runs: list[BenchRun], path: str) -> bool:
    """Max relative error against wall time (log-log), one line per scene; False if nothing to plot."""
    plt = _pyplot()
    by_scene: dict[str, list[BenchRun]] = {}
    for r in runs:
        if r.failure is None and math.isfinite(r.max_rel_error) and r.max_rel_error > 0 and r.wall_time > 0:
            by_scene.setdefault(r.scene, []).append(r)
    if plt is None or not by_scene:
        return False
    fig, ax = plt.subplots(figsize=(7, 5))
    for scene, rs in by_scene.items():
        # the line follows the refinement: more DoFs, or more time steps
        rs = sorted(rs, key=lambda r: (r.dofs, int(r.summary.get("steps", 0))))
        line, = ax.loglog([r.wall_time for r in rs], [r.max_rel_error for r in rs], "o-", label=scene)
        for r in rs:
            ax.annotate(r.label if r.dynamic else f"{r.dofs}", (r.wall_time, r.max_rel_error),
                        textcoords="offset points", xytext=(4, 4), fontsize=7, color=line.get_color())
            if not r.converged:
                ax.plot(r.wall_time, r.max_rel_error, "x", color="red", markersize=10)
    ax.set_xlabel("wall time of the analysis [s]")
    ax.set_ylabel("max relative error against the reference")
    ax.set_title("error against run time (labels: DoFs, or time step; red x: not converged)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return _save(plt, fig, path)


def plot_load_displacement(runs: list[BenchRun], path: str) -> bool:
    """Each tracked output against the load factor for every mesh of one scene, reference as markers."""
    plt = _pyplot()
    runs = [r for r in runs if r.failure is None and r.history.get("load_factor")]
    if plt is None or not runs:
        return False
    names = [k for k in runs[0].history if k != "load_factor"]
    if not names:
        return False
    fig, axes = plt.subplots(1, len(names), figsize=(4.5 * len(names), 4), squeeze=False)
    reference = runs[0].reference or {}
    for ax, name in zip(axes[0], names):
        for k, r in enumerate(runs):
            lam = [0.0] + list(r.history["load_factor"])
            val = [0.0] + list(r.history[name])
            ax.plot(val, lam, "-", lw=1.2, alpha=0.5 + 0.5 * (k + 1) / len(runs), label=r.label)
        if name in reference:
            lf, ref = reference[name]
            ax.plot(ref, lf, "ko", ms=3.5, mfc="none", label="reference")
        ax.set_xlabel(name)
        ax.set_ylabel("load factor")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(runs[0].scene)
    return _save(plt, fig, path)


def plot_drift_vs_time(runs: list[BenchRun], path: str) -> bool:
    """Energy and angular-momentum drift of the dynamic runs against wall time (log-log), one line per scene."""
    plt = _pyplot()
    by_scene: dict[str, list[BenchRun]] = {}
    for r in runs:
        if r.failure is None and r.dynamic and r.wall_time > 0:
            by_scene.setdefault(r.scene, []).append(r)
    if plt is None or not by_scene:
        return False
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    plotted = False
    for ax, which, title in ((axes[0], "energy", "total energy drift"), (axes[1], "angular", "angular momentum drift")):
        for scene, rs in by_scene.items():
            rs = [r for r in sorted(rs, key=lambda r: int(r.summary.get("steps", 0))) if r.drift(which) > 0]
            if not rs:
                continue
            plotted = True
            line, = ax.loglog([r.wall_time for r in rs], [r.drift(which) for r in rs], "o-", label=scene)
            for r in rs:
                ax.annotate(r.label, (r.wall_time, r.drift(which)), textcoords="offset points", xytext=(4, 4),
                            fontsize=7, color=line.get_color())
        ax.set_xlabel("wall time of the analysis [s]")
        ax.set_ylabel(f"max relative {title}")
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
    fig.suptitle("drift against run time (labels: time step)")
    return _save(plt, fig, path, plotted)


def plot_time_histories(runs: list[BenchRun], path: str) -> bool:
    """Each tracked output and the strain energy against time for every run of one dynamic scene."""
    plt = _pyplot()
    runs = [r for r in runs if r.failure is None and r.history.get("time")]
    if plt is None or not runs:
        return False
    names = [k for k in runs[0].history if k != "time"]
    panels = names + ["strain energy"]
    fig, axes = plt.subplots(1, len(panels), figsize=(4.5 * len(panels), 4), squeeze=False)
    reference = runs[0].reference or {}
    for ax, name in zip(axes[0], panels):
        for k, r in enumerate(runs):
            alpha = 0.5 + 0.5 * (k + 1) / len(runs)
            if name == "strain energy":
                eh = r.summary.get("energy_history", {})
                ax.plot(eh.get("time", []), eh.get("strain", []), "-", lw=1.2, alpha=alpha, label=r.label)
            else:
                ax.plot(r.history["time"], r.history[name], "-", lw=1.2, alpha=alpha, label=r.label)
        if name in reference:
            t, ref = reference[name]
            ax.plot(t, ref, "ko", ms=3.5, mfc="none", label="reference")
        ax.set_xlabel("time [s]")
        ax.set_ylabel(name)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(runs[0].scene)
    return _save(plt, fig, path)


def _jsonable(obj):
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return repr(obj) if not isinstance(obj, (str, int, float, bool, type(None), list, dict, tuple)) else obj


def _clean(value):
    """NaN and infinities as null, numpy values as Python values, recursively (strict JSON)."""
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    return _jsonable(value)


def write_report(runs: list[BenchRun], out_dir: str, command: str = "flexbody bench") -> str:
    """Write report.md, the PNG plots and bench.json to ``out_dir`` (created if needed); returns report.md's path."""
    os.makedirs(out_dir, exist_ok=True)
    scenes: dict[str, list[BenchRun]] = {}
    for r in runs:
        scenes.setdefault(r.scene, []).append(r)
    have_plt = _pyplot() is not None
    lines = ["# flexbody benchmark report: error against run time", "",
             f"Written by `{command}` on {platform.processor() or platform.machine()}, "
             f"Python {platform.python_version()}. Wall time is the analysis alone (mesh, model and numba "
             "compilation excluded); the error is the largest relative error of the tracked outputs against "
             "the scene's reference, |value - reference| / max|reference|, at the reference's load factors "
             "(dynamic scenes: at the reference's times; their runs are a sequence of time steps, and the "
             "drifts, shown where the quantity is conserved, are max |E - E0| / max(T + W + |Vg|) and "
             "max |L - L0| / max |L|).", ""]
    if not have_plt:
        lines += ["Plots skipped: matplotlib is not installed (`pip install matplotlib`).", ""]
    else:
        if plot_error_vs_time(runs, os.path.join(out_dir, "error_vs_time.png")):
            lines += ["![error against wall time](error_vs_time.png)", ""]
        if plot_drift_vs_time(runs, os.path.join(out_dir, "drift_vs_time.png")):
            lines += ["![energy and angular momentum drift against wall time](drift_vs_time.png)", ""]
    for scene, rs in scenes.items():
        lines += [f"## {scene}", ""]
        ref_source = next((r.reference_source for r in rs if r.reference_source), None)
        if ref_source:
            lines += [f"Reference: {ref_source}", ""]
        lines += [markdown_table(rs), ""]
        png = f"load_displacement_{_safe(scene)}.png"
        history_png = f"time_history_{_safe(scene)}.png"
        if have_plt and plot_load_displacement(rs, os.path.join(out_dir, png)):
            lines += [f"![load against displacement, {scene}]({png})", ""]
        elif have_plt and plot_time_histories(rs, os.path.join(out_dir, history_png)):
            lines += [f"![outputs against time, {scene}]({history_png})", ""]
    path = os.path.join(out_dir, "report.md")
    with open(path, "w") as fh:
        fh.write("\n".join(lines))
    data = [{"scene": r.scene, "mesh": r.label, "parameters": r.parameters, "summary": r.summary,
             "history": r.history, "failure": r.failure} for r in runs]
    with open(os.path.join(out_dir, "bench.json"), "w") as fh:
        json.dump(_clean(data), fh, indent=1)
    return path
