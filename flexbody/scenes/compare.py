"""A run against its reference (:func:`compare`): a static path at its converged steps
(:func:`compare_with_reference`) and a motion at the reference's times (:func:`compare_in_time`). Each
returns one dict per compared value, with the quantity, the value, the reference, ``rel_error`` and the
``measure`` used."""

from __future__ import annotations

import numpy as np

from flexbody.scenes.reference import Reference


def level_tolerance(*levels: np.ndarray) -> float:
    """Two load factors closer than this are the same level (round-off of the step targets)."""
    return 1e-9 * max([1.0, *(float(np.abs(v).max(initial=0.0)) for v in levels)])


def nearest_on_polyline(points: np.ndarray, polyline: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distance of each point (m, 2) to a polyline (k, 2), and the nearest point of the polyline (m, 2)."""
    a, d = polyline[:-1], np.diff(polyline, axis=0)               # the segments a + t d, t in [0, 1]
    if len(d) == 0:
        return np.linalg.norm(points - polyline[0], axis=1), np.repeat(polyline[:1], len(points), axis=0)
    length2 = np.einsum("ij,ij->i", d, d)
    t = np.einsum("msj,sj->ms", points[:, None, :] - a[None], d) / np.where(length2 > 0, length2, 1.0)
    foot = a[None] + np.clip(t, 0.0, 1.0)[..., None] * d[None]
    dist = np.linalg.norm(points[:, None, :] - foot, axis=2)
    k = np.argmin(dist, axis=1)
    rows = np.arange(len(points))
    return dist[rows, k], foot[rows, k]


def _steps_on_levels(lam: np.ndarray, ref_lam: np.ndarray, tol: float) -> np.ndarray:
    """For each step, the index of the tabulated level it lies on (within ``tol``), or -1."""
    nearest = np.abs(lam[:, None] - ref_lam[None, :]).argmin(axis=1)
    return np.where(np.abs(ref_lam[nearest] - lam) <= tol, nearest, -1)


def compare_with_reference(history: dict[str, list[float]], reference: Reference) -> list[dict]:
    """Relative errors of the tracked outputs against the reference, at converged steps only.

    Nothing is interpolated between steps, neither the path nor the table (linear interpolation across a
    coarse step of a strongly curved path, the strip rolled twice into a circle in 0.2 M_max steps, reported
    8.3 % for a path within 7e-5 at its steps):

    * ``measure = "load_level"``: the load factor increases along the path and in the table, and some steps
      lie on tabulated levels: at those steps (only), |value - reference| / s_q, with s_q = max |reference|
      of that quantity over the table (so that values near zero at small loads do not blow up the measure);
      ``load_factor`` is the tabulated level;
    * ``measure = "path"``: otherwise (no step on a tabulated level, or a path whose load factor is not
      monotonic: snap-through, snap-back, arc length), at every step within the table's load range, the
      distance of the point (value / s_q, lambda / s_l) to the reference polyline in that normalised plane,
      s_l = max |reference load factor|; ``reference`` and ``reference_load_factor`` are the nearest point
      of the reference path. It does not depend on where the steps fall or on the direction the path takes,
      so it measures a path through a snap, where the value at a load factor is not unique (comparing at
      the first crossing of each load level reported 33 % for a path that lies on its reference). Where the
      path is flat in load (a soft response) it is the load error rather than the displacement error.
    """
    lam = np.asarray(history["load_factor"], dtype=float)
    ref_lam = np.asarray(reference.load_factors, dtype=float)
    if lam.size == 0 or ref_lam.size == 0:
        return []
    tol = level_tolerance(lam, ref_lam)
    s_lam = float(np.abs(ref_lam).max()) or 1.0
    levels = _steps_on_levels(lam, ref_lam, tol)
    at_levels = bool(np.all(np.diff(lam) > 0) and np.all(np.diff(ref_lam) > 0) and np.any(levels >= 0))
    inside = np.flatnonzero((lam >= ref_lam.min() - tol) & (lam <= ref_lam.max() + tol) & (lam > 0))
    errors = []
    for name, ref_vals in reference.values.items():
        if name not in history:
            continue
        ref_vals = np.asarray(ref_vals, dtype=float)
        s_q = float(np.abs(ref_vals).max()) or 1.0
        vals = np.asarray(history[name], dtype=float)
        if at_levels:
            errors += [{"quantity": name, "value": float(vals[i]), "load_factor": float(ref_lam[k]),
                        "reference": float(ref_vals[k]), "rel_error": float(abs(vals[i] - ref_vals[k]) / s_q),
                        "measure": "load_level"} for i, k in enumerate(levels) if k >= 0 and lam[i] > 0]
            continue
        dist, foot = nearest_on_polyline(np.column_stack([vals[inside] / s_q, lam[inside] / s_lam]),
                                         np.column_stack([ref_vals / s_q, ref_lam / s_lam]))
        errors += [{"quantity": name, "value": float(vals[i]), "load_factor": float(lam[i]),
                    "reference": float(fq * s_q), "reference_load_factor": float(fl * s_lam),
                    "rel_error": float(d), "measure": "path"} for i, d, (fq, fl) in zip(inside, dist, foot)]
    return errors


def compare_in_time(history: dict[str, list[float]], reference: Reference) -> list[dict]:
    """Relative errors at every reference time inside the recorded interval.

    The relative error is |value - reference| / max|reference| of that quantity over the table. A reference
    time that is a recorded instant is compared there (``measure`` "recorded"); any other (a reference
    between the recorded steps of ``output_every`` > 1) with the recorded values interpolated linearly
    (``measure`` "interpolated": it adds the interpolation's error to the run's).
    """
    t = np.asarray(history["time"], dtype=float)
    errors = []
    if t.size == 0:
        return errors
    for name, ref_vals in reference.values.items():
        if name not in history:
            continue
        vals = np.asarray(history[name], dtype=float)
        scale = float(np.abs(ref_vals).max()) or 1.0
        for tr, rv in zip(reference.times, ref_vals):
            if tr < t[0] - 1e-12 or tr > t[-1] + 1e-12 * max(1.0, abs(t[-1])):
                continue
            v = float(np.interp(tr, t, vals))
            recorded = float(np.min(np.abs(t - tr))) <= 1e-9 * max(1.0, abs(t[-1]))
            errors.append({"quantity": name, "time": float(tr), "value": v, "reference": float(rv),
                           "rel_error": abs(v - float(rv)) / scale,
                           "measure": "recorded" if recorded else "interpolated"})
    return errors


def compare(history: dict[str, list[float]], reference: Reference) -> list[dict]:
    """The errors of a run's history against its reference: along the path (:func:`compare_with_reference`)
    for a static run's history (abscissa ``load_factor``), in time (:func:`compare_in_time`) for a dynamic
    run's (abscissa ``time``)."""
    if "load_factor" in history:
        return compare_with_reference(history, reference)
    return compare_in_time(history, reference)
