"""The run summary of ``flexbody run`` as printed lines (the same content as its ``--json`` file)."""

from __future__ import annotations

def balance_lines(d: dict) -> list[str]:
    """The energy and momentum lines of a dynamic run's summary."""
    e, m = d["energy"], d["momentum"]
    lines = [f"energy           kinetic {e['kinetic']['initial']:.5g} -> {e['kinetic']['final']:.5g}, strain "
             f"{e['strain']['initial']:.5g} -> {e['strain']['final']:.5g} (max {e['strain']['max']:.5g}), "
             f"gravity {e['gravity']['initial']:.5g} -> {e['gravity']['final']:.5g}"
             + (f", dissipated {e['dissipated']['final']:.5g}" if e.get("dissipated", {}).get("final") else ""),
             f"energy drift     {e['total']['max_rel_drift']:.3e} (max |E - E0| / max(T + W + |Vg|), E = T + W + Vg + D"
             f"{'' if e['conservative'] else '; not conserved: loads or prescribed motion do work'})",
             f"momentum drift   linear {m['linear']['max_rel_drift']:.3e}, angular {m['angular']['max_rel_drift']:.3e}"
             f" ({'isolated body: both conserved' if m['isolated'] else 'not isolated: exchanged with supports, loads or gravity'})"]
    return lines


def summary_lines(summary) -> list[str]:
    """The printed run summary (the same content as the --json file)."""
    d = summary.as_dict()
    dynamic = d.get("kind") == "dynamic"
    if dynamic:
        reached = (f"time reached {d['time']:.4g} s of {d['end_time']:.4g} s, dt {d['time_step']:.4g} s, "
                   f"rho_inf {d['rho_inf']:g}{' (default)' if d.get('rho_inf_default') else ''}, {d['policy']} iteration matrix, "
                   f"{d.get('mass', 'lumped')} mass, {d.get('frame', 'inertial')} frame")
        ts = d.get("time_steps", {})
        if ts.get("adaptive"):
            reached += (f"; adaptive: {ts['accepted']} accepted, rejected {ts['rejected_error']} (error) + "
                        f"{ts['rejected_newton']} (Newton), dt {ts['min']:.3g} to {ts['max']:.3g} s")
    else:
        reached = f"load factor reached {d['load_factor']:.4g}"
    lines = [
        f"scene            {d['scene']}" + (" (dynamic)" if dynamic else ""),
        f"DoFs / elements  {d['dofs']} / {d['elements']}",
        f"steps            {d['steps']}  ({reached})",
        f"Newton           {d['newton_iterations']} iterations, {d['tangent_updates']} tangent updates, "
        f"{d['factorizations']} factorizations" + (f" ({d['newton_iteration']} iteration)"
                                                   if "newton_iteration" in d else "")
        + (f"; per step {d['iterations_per_step']:.2f} iterations, {d['factorizations_per_step']:.3f} "
           "factorizations" if dynamic else ""),
        f"wall time        set-up {d['setup_time_s']:.2f} s, compilation {d['compile_time_s']:.2f} s "
        f"(or loading from the cache), solve {d['solve_time_s']:.2f} s",
    ]
    for k, v in d["outputs"].items():
        lines.append(f"output           {k} = {v:.6g}")
    if dynamic:
        lines += balance_lines(d)
    if d["errors"]:
        worst = max(d["errors"], key=lambda e: e["rel_error"])
        at = f"time {worst['time']:.4g} s" if dynamic else f"load factor {worst['load_factor']:.3g}"
        if worst.get("measure") == "path":
            versus = (f"nearest point of the reference path {worst['reference']:.5g} at load factor "
                      f"{worst['reference_load_factor']:.3g}; distance in the normalised (value, load) plane")
        else:
            versus = f"vs reference {worst['reference']:.5g}" + (
                ", interpolated between recorded steps" if worst.get("measure") == "interpolated" else "")
        lines.append(f"max rel. error   {d['max_rel_error']:.3e}  ({worst['quantity']} at {at}: "
                     f"{worst['value']:.5g} {versus})")
    if d.get("stability"):
        lines += stability_lines(d["stability"])
    if not d["converged"]:
        lines.append(f"NOT CONVERGED    {d['message']}")
    if d.get("warnings"):
        lines.append(f"WARNING          not to be trusted: {'; '.join(d['warnings'])} (docs/robustness.md)")
    return lines


def stability_lines(st: dict) -> list[str]:
    """The stability lines of a static run's summary (``RunSummary.as_dict()["stability"]``): the count of
    negative eigenvalues of the tangent at the last step, and every limit or bifurcation point passed."""
    n = st.get("final_negative_eigenvalues")
    if n is None:
        return []
    lines = [f"stability        {'stable' if n == 0 else 'UNSTABLE'} final equilibrium: {n} negative eigenvalue(s) "
             "of the tangent" + ("" if n == 0 else " (a perturbation leaves it; see the critical points)")]
    for c in st["critical_points"]:
        lines.append(f"critical point   {c['kind']} between load factors {c['load_factor_before']:.6g} and "
                     f"{c['load_factor_after']:.6g} (step {c['step']}; negative eigenvalues "
                     f"{c['negative_before']} -> {c['negative_after']})")
    return lines
