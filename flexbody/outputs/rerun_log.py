"""Rerun recording (.rrd) of a run, for the rerun viewer (``rerun run.rrd``); needs ``rerun-sdk`` (>= 0.41).

The rerun SDK is imported only when a :class:`RerunLogger` is created, never by importing this module.
The recording is written to a file only: no viewer is spawned, nothing goes over the network.

Timelines
    ``step``         sequence: the solver's step number
    ``load_factor``  (kind "static") sequence timeline: the load factor in millionths (rerun has no
                     floating-point timelines; 1 000 000 is the full load, 350 000 a load factor of 0.35).
                     The exact value is the ``stats/load_factor`` plot and the legend's text. On a
                     snap-back path (arc length) it is not monotonic: use ``step`` to replay in order.
                     Values beyond +-:data:`TIMELINE_LIMIT` are clamped to it; the ``step`` timeline and the
                     logged outputs are exact.
    ``time``         (kind "dynamic") duration timeline: the simulated time in seconds.
    (rerun also adds its own ``log_time``, the wall-clock time of logging.)

Entity paths
    ``body/mesh``            Mesh3D. Static: ``triangle_indices`` (each six-node triangle is drawn as four
                             linear triangles: c0-m01-m20, m01-c1-m12, m20-m12-c2, m01-m12-m20, wound so that
                             their front faces are on the side of the reference directors). Per step:
                             ``vertex_positions`` (the nodal positions x, one vertex per node),
                             ``vertex_normals`` (the current directors) and ``vertex_colors`` (colour map of
                             ``color_by``: "deformation" (default) the displacement without the rigid motion,
                             |x - c - Q (X0 - C)| with the best-fit rotation Q and centroids c, C (Kabsch);
                             "displacement" |x - X0|; None a uniform colour).
    ``body/legend``          TextDocument, per step: what the colours show and the values of both ends of the
                             scale. The scale is fixed: ``color_range`` if given, else [0, the largest value
                             of all steps so far] (it never shrinks).
    ``body/directors``       Arrows3D, per step, if ``directors=True``: the directors at the nodes, drawn with
                             half the mean element edge length.
    ``outputs/<name>``       Scalars, per step: the tracked outputs.
    ``reference/<name>``     Scalars on the ``load_factor`` (or ``time``) timeline only, at the reference's own
                             load factors (styled as points), logged once at creation.
    ``stats/max_displacement``  Scalars, per step: the largest |x - X0|; ``stats/max_deformation`` the largest
                             displacement without the rigid motion; ``stats/load_factor`` (static) the load
                             factor; ``stats/<name>`` (dynamic) the energies and their drift, as given.

Blueprint
    The 3D view of ``body`` takes three quarters of the window; beside it one plot per tracked output with
    its reference overlaid (``outputs/<name>`` and ``reference/<name>``), and for a dynamic run a plot of the
    energies and one of the energy drift (:func:`blueprint`); every plot shows the whole run on its x axis.
    The legend (``body/legend``) above the plots starts with the step's load factor or time and the colour
    scale.

The recording is locked against a second writer (:mod:`flexbody.outputs.files`), and a step that the disk
cannot hold is refused before anything of it is logged (:class:`flexbody.outputs.files.DiskFullError`):
rerun's file sink, once it meets a full disk, leaves a truncated file and its flush never returns.
"""

from __future__ import annotations

import os

import numpy as np

from flexbody.outputs.files import check_free_space, lock_output, release

# viridis at 0, 1/4, 1/2, 3/4, 1 (sRGB)
_VIRIDIS = np.array([[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]], dtype=float)
COLOR_BY = ("deformation", "displacement", "stress", None)
COLOR_TEXT = {"deformation": "displacement without the rigid motion (Kabsch fit)",
              "displacement": "displacement |x - X0|",
              "stress": "von Mises fibre stress, the larger of top and bottom (nodal average)"}
#: the energy plots of a dynamic run: ``stats/<name>`` entities
ENERGY_STATS = ("kinetic_energy", "strain_energy", "gravity_energy", "total_energy")
DRIFT_STATS = ("energy_drift",)
LOAD_FACTOR_UNIT = 1_000_000        # the load_factor timeline counts millionths of the load factor
UNIFORM_COLOR = (180, 180, 190)
TIMELINES = {"static": "load_factor", "dynamic": "time"}
#: the largest magnitude of a timeline value (seconds of a duration: int64 nanoseconds end at 9.22e9 s; load
#: factors: int64 millionths end at 9.22e12, clamped at the same 9.2e9 for one rule)
TIMELINE_LIMIT = 9.2e9


def timeline_seconds(values):
    """Load factors or times as durations in seconds rerun can store: clamped to +-TIMELINE_LIMIT."""
    return np.clip(values, -TIMELINE_LIMIT, TIMELINE_LIMIT)


def load_factor_sequence(values) -> np.ndarray:
    """Load factors as the ``load_factor`` sequence timeline: millionths, int64, clamped to +-TIMELINE_LIMIT."""
    return np.rint(timeline_seconds(np.asarray(values, dtype=float)) * LOAD_FACTOR_UNIT).astype(np.int64)


def rigid_fit(X: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The best-fit rigid motion x ~ c + Q (X - C) in the least-squares sense (Kabsch: the SVD of the
    cross-covariance, with the sign that makes Q a rotation). Returns Q (3, 3), C (3,), c (3,)."""
    C, c = X.mean(axis=0), x.mean(axis=0)
    H = (X - C).T @ (x - c)
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0])
    return Vt.T @ D @ U.T, C, c


def deformation(X: np.ndarray, x: np.ndarray) -> np.ndarray:
    """|x - c - Q (X - C)| (n,): each node's displacement without the body's best-fit rigid motion."""
    Q, C, c = rigid_fit(X, x)
    return np.linalg.norm(x - c - (X - C) @ Q.T, axis=1)


def blueprint(outputs, kind: str = "static", references=()):
    """The viewer layout (rerun.blueprint.Blueprint): the 3D view large, one plot per tracked output with its
    reference overlaid, and for a dynamic run the energies and their drift."""
    import rerun as rr
    import rerun.blueprint as rrb
    everything = rrb.TimeRangeBoundary.infinite()

    def plot(name: str, contents: list[str]):
        # the whole path on the x axis (the viewer's default on the load-factor timeline is a window of a few
        # thousand millionths around the cursor: the curve looked like a point)
        return rrb.TimeSeriesView(name=name, origin="/", contents=contents,
                                  axis_x=rrb.TimeAxis(view_range=rr.TimeRange(start=everything, end=everything)))

    plots = []
    for name in outputs:
        part = rr.escape_entity_path_part(str(name))
        contents = [f"/outputs/{part}"] + ([f"/reference/{part}"] if name in references else [])
        plots.append(plot(str(name), contents))
    if kind == "dynamic":
        plots.append(plot("energies", [f"/stats/{k}" for k in ENERGY_STATS]))
        plots.append(plot("energy drift", [f"/stats/{k}" for k in DRIFT_STATS]))
    else:
        plots.append(plot("load factor", ["/stats/load_factor"]))
    view = rrb.Spatial3DView(name="body", origin="/body")
    side = rrb.Vertical(rrb.TextDocumentView(name="legend", origin="/body/legend"), *plots,
                        row_shares=[1.5] + [2] * len(plots))
    return rrb.Blueprint(rrb.Horizontal(view, side, column_shares=[3, 1]), collapse_panels=True)


def colormap(values: np.ndarray, vmin: float, vmax: float) -> np.ndarray:
    """RGB colours (n, 3) uint8 of ``values`` mapped linearly from [vmin, vmax] through a 5-point viridis."""
    values = np.asarray(values, dtype=float)
    span = vmax - vmin
    t = np.zeros_like(values) if not span > 0 else np.clip((values - vmin) / span, 0.0, 1.0)
    t = np.nan_to_num(t, nan=0.0)
    s = t * (len(_VIRIDIS) - 1)
    i = np.minimum(s.astype(int), len(_VIRIDIS) - 2)
    w = (s - i)[..., None]
    rgb = (1.0 - w) * _VIRIDIS[i] + w * _VIRIDIS[i + 1]
    return np.rint(rgb).astype(np.uint8)


def display_triangles(elements: np.ndarray) -> np.ndarray:
    """The four linear display triangles (4m, 3) of six-node triangles (m, 6) (corners, then midsides
    (0,1), (1,2), (2,0)), in the winding of the six-node triangle."""
    e = np.asarray(elements)
    c0, c1, c2, m01, m12, m20 = (e[:, j] for j in range(6))
    tri = np.stack([np.stack([c0, m01, m20], -1), np.stack([m01, c1, m12], -1),
                    np.stack([m20, m12, c2], -1), np.stack([m01, m12, m20], -1)], axis=1)
    return tri.reshape(-1, 3)


def _orient(tri: np.ndarray, nodes: np.ndarray, directors: np.ndarray) -> np.ndarray:
    """Flip the display triangles whose winding normal points away from the mean director of their nodes."""
    p = nodes[tri]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    flip = np.einsum("ij,ij->i", normal, directors[tri].sum(axis=1)) < 0
    tri = tri.copy()
    tri[flip] = tri[flip][:, ::-1]
    return tri


class RerunLogger:
    """Log a run to a rerun recording file (layout in the module docstring).

    Parameters
    ----------
    path : the .rrd file to write (overwritten)
    mesh : anything with ``.nodes`` (n, 3), ``.elements`` (m, 6) and ``.directors`` (n, 3)
    scene_name : the recording's name
    color_by : "deformation" (the displacement without the rigid motion, :func:`deformation`),
        "displacement" (|x - X0|), "stress" (a nodal field given to :meth:`log_step`, e.g. the von Mises fibre
        stress of :func:`flexbody.results.stress_resultants`), through a viridis colour map, or None (uniform)
    directors : also log the directors as arrows
    reference : reference curves {name: (load_factors, values)} (or times, for kind "dynamic")
    kind : "static" (``load_factor`` timeline) or "dynamic" (``time`` timeline)
    color_range : (vmin, vmax) of the colour scale; None: [0, the largest value of the steps so far]
    outputs : the names of the tracked outputs, for the blueprint's plots (None: no blueprint)
    """

    def __init__(self, path, mesh, scene_name: str, color_by: str | None = "deformation",
                 directors: bool = False, reference: dict | None = None, *, kind: str = "static",
                 color_range: tuple[float, float] | None = None, outputs=None):
        if color_by not in COLOR_BY:
            raise ValueError(f"color_by must be one of {COLOR_BY}, got {color_by!r}")
        if kind not in TIMELINES:
            raise ValueError(f"kind must be 'static' or 'dynamic', got {kind!r}")
        try:
            import rerun as rr
        except ImportError as exc:
            raise ImportError("rerun output needs the rerun SDK: pip install 'flexbody[rerun]' "
                              f"(or rerun-sdk) ({exc})") from None
        self._rr = rr
        self.path = os.fspath(path)
        self.kind = kind
        self.timeline = TIMELINES[kind]
        self.color_by = color_by
        self.directors = bool(directors)
        self.color_range = None if color_range is None else (float(color_range[0]), float(color_range[1]))
        self._scale_max = 0.0            # the automatic colour scale's top: the largest value so far
        self.outputs = None if outputs is None else [str(o) for o in outputs]
        self.nodes = np.asarray(mesh.nodes, dtype=float)
        elements = np.asarray(mesh.elements)
        ref_directors = np.asarray(mesh.directors, dtype=float)
        if self.nodes.ndim != 2 or self.nodes.shape[1] != 3:
            raise ValueError(f"mesh.nodes must have shape (n, 3), got {self.nodes.shape}")
        if elements.ndim != 2 or elements.shape[1] != 6:
            raise ValueError(f"mesh.elements must have shape (m, 6), got {elements.shape}")
        if ref_directors.shape != self.nodes.shape:
            raise ValueError(f"mesh.directors must have shape {self.nodes.shape}, got {ref_directors.shape}")
        self.triangles = _orient(display_triangles(elements), self.nodes, ref_directors).astype(np.uint32)
        corners = self.nodes[elements[:, :3]]
        edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=-1)
        self.arrow_length = 0.5 * float(edges.mean()) if edges.size else 1.0

        curves = {}
        for name, curve in (reference or {}).items():
            try:
                params, values = curve
            except (TypeError, ValueError):
                raise ValueError(f"reference {name!r} must be a pair (load_factors, values)") from None
            params = np.asarray(params, dtype=float).ravel()
            values = np.asarray(values, dtype=float).ravel()
            if params.shape != values.shape:
                raise ValueError(f"reference {name!r}: {params.size} load factors but {values.size} values")
            curves[str(name)] = (params, values)

        parent = os.path.dirname(os.path.abspath(self.path))
        if not os.path.isdir(parent):
            raise FileNotFoundError(f"cannot create rerun recording {self.path!r}: directory {parent!r} does not exist")
        if os.path.exists(self.path) and not os.path.isfile(self.path):
            raise OSError(f"cannot create rerun recording {self.path!r}: it is not a regular file")
        check_free_space(self.path, self._step_bytes(), "rerun recording", 0)
        self._lock = lock_output(self.path, "rerun recording")
        self._rec = rr.RecordingStream("flexbody")
        try:
            self._rec.save(self.path)
        except (RuntimeError, OSError) as exc:
            self._rec.disconnect()
            release(self._lock)
            raise OSError(f"cannot create rerun recording {self.path!r}: {exc}") from None
        self._closed = False
        self.steps_logged = 0
        try:
            self._log_static(scene_name, curves)
        except BaseException:
            self.close()
            raise

    def _log_static(self, scene_name: str, curves: dict) -> None:
        rr, rec = self._rr, self._rec
        rec.send_recording_name(str(scene_name))
        if self.outputs is not None:
            rec.send_blueprint(blueprint(self.outputs, self.kind, tuple(curves)))
        # topology once, static; the positions are per step (static positions would shadow them)
        rec.log("body/mesh", rr.Mesh3D.from_fields(triangle_indices=self.triangles), static=True)
        for name, (params, values) in curves.items():
            entity = f"reference/{rr.escape_entity_path_part(name)}"
            rec.log(entity, rr.SeriesPoints(names=f"{name} (reference)"), static=True)
            rec.send_columns(entity, indexes=[self._time_column(params)], columns=rr.Scalars.columns(scalars=values))

    def _time_column(self, params):
        """The reference's own load factors (sequence, millionths) or times (duration, s) as a time column."""
        if self.kind == "static":
            return self._rr.TimeColumn(self.timeline, sequence=load_factor_sequence(params))
        return self._rr.TimeColumn(self.timeline, duration=timeline_seconds(params))

    def _set_time(self, value: float) -> None:
        if self.kind == "static":
            self._rec.set_time(self.timeline, sequence=int(load_factor_sequence(value)))
        else:
            self._rec.set_time(self.timeline, duration=float(timeline_seconds(float(value))))

    # -- context manager --------------------------------------------------------------------------------------
    def __enter__(self) -> "RerunLogger":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def log_step(self, step: int, load_factor_or_time: float, state, tracked: dict[str, float] | None = None,
                 stats: dict[str, float] | None = None, field: np.ndarray | None = None) -> None:
        """Log one step: ``state`` has ``.x`` (n, 3) and ``.frames`` (n, 3, 3); ``tracked`` {name: value};
        ``stats`` {name: value} (e.g. the energies of a dynamic step) go to ``stats/<name>``; ``field`` (n,)
        the nodal values the colours show when ``color_by="stress"``."""
        if self._closed:
            raise ValueError(f"rerun recording {self.path!r} is closed")
        rr, rec = self._rr, self._rec
        x = np.asarray(state.x, dtype=float)
        if x.shape != self.nodes.shape:
            raise ValueError(f"state.x must have shape {self.nodes.shape}, got {x.shape}")
        d = np.asarray(state.frames, dtype=float)[:, :, 2]
        check_free_space(self.path, self._step_bytes(), "rerun recording", self.steps_logged)
        rec.set_time("step", sequence=int(step))
        self._set_time(load_factor_or_time)
        u = np.linalg.norm(x - self.nodes, axis=1)
        umax = float(u.max()) if u.size else 0.0
        w = deformation(self.nodes, x) if len(x) >= 3 else u
        wmax = float(w.max()) if w.size else 0.0
        if self.color_by is None:
            colors = np.broadcast_to(np.array(UNIFORM_COLOR, np.uint8), x.shape)
        else:
            values = {"deformation": w, "displacement": u}.get(self.color_by)
            if values is None:
                values = np.asarray(field, dtype=float) if field is not None else None
                if values is None or values.shape != (len(x),):
                    raise ValueError(f"color_by='stress' needs a nodal field of shape ({len(x)},) per step, got "
                                     f"{None if field is None else np.shape(field)}")
            if np.isfinite(values).all():
                self._scale_max = max(self._scale_max, float(values.max()) if values.size else 0.0)
            vmin, vmax = self.color_range if self.color_range is not None else (0.0, self._scale_max)
            colors = colormap(values, vmin, vmax)
            where = (f"load factor {load_factor_or_time:.6g}" if self.kind == "static"
                     else f"time {load_factor_or_time:.6g} s")
            rec.log("body/legend", rr.TextDocument(
                f"**{where}**\n\nscale: {vmin:.4g} (dark purple) .. {vmax:.4g} (yellow), fixed; largest now "
                f"{float(values.max()) if values.size else 0.0:.4g}\n\ncolour: {COLOR_TEXT[self.color_by]}",
                media_type="text/markdown"))
        rec.log("body/mesh", rr.Mesh3D.from_fields(vertex_positions=x, vertex_normals=d, vertex_colors=colors))
        if self.directors:
            rec.log("body/directors", rr.Arrows3D(origins=x, vectors=self.arrow_length * d))
        rec.log("stats/max_displacement", rr.Scalars(umax))
        rec.log("stats/max_deformation", rr.Scalars(wmax))
        if self.kind == "static":
            rec.log("stats/load_factor", rr.Scalars(float(load_factor_or_time)))
        for name, value in (stats or {}).items():
            rec.log(f"stats/{rr.escape_entity_path_part(str(name))}", rr.Scalars(float(value)))
        for name, value in (tracked or {}).items():
            rec.log(f"outputs/{rr.escape_entity_path_part(str(name))}", rr.Scalars(float(value)))
        self.steps_logged += 1

    def _step_bytes(self) -> int:
        """A generous bound on the bytes one step adds to the file (positions, normals, colours, arrows)."""
        return 64 * len(self.nodes) + 4096

    def flush(self) -> None:
        """Write everything logged so far to the file (a run stopped later leaves it readable)."""
        if not self._closed:
            self._rec.flush()

    def close(self) -> None:
        """Flush everything to the file and close it (idempotent)."""
        if not self._closed:
            self._closed = True
            try:
                self._rec.flush()
                self._rec.disconnect()
            finally:
                release(self._lock)
