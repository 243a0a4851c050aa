"""HDF5 results file: the mesh once, then one row per converged step, flushed after every step.

Layout (format ``flexbody-hdf5``, version 1; ``n`` nodes, ``m`` elements, ``k`` steps written)::

    /                          attrs: format = "flexbody-hdf5", format_version = 1,
                                      flexbody_version, scene (name), kind ("static" | "dynamic"),
                                      parameters (JSON string of the scene parameters),
                                      outputs (JSON list of tracked names), stats (JSON list of stat names)
    /mesh/nodes                (n, 3)  float64   reference nodal positions X0
    /mesh/elements             (m, 6)  int64     six-node triangles: corners 0, 1, 2, then the midside
                                                 nodes of edges (0,1), (1,2), (2,0); 0-based node indices
    /mesh/directors            (n, 3)  float64   reference unit directors
    /steps/index               (k,)    int64     step number as reported by the solver
    /steps/load_factor         (k,)    float64   load factor (kind = "static")
      or /steps/time           (k,)    float64   time (kind = "dynamic")
    /steps/x                   (k, n, 3) float64 nodal positions x (not displacements: u = x - X0)
    /steps/frames              (k, n, 4) float64 nodal frames R as unit quaternions (w, x, y, z), w >= 0
    /steps/tracked/<name>      (k,)    float64   tracked scalar outputs (NaN where a step did not give one)
    /steps/stats/<name>        (k,)    float64   solver statistics, by default iterations, residual,
                                                 wall_time (integers stored exactly as float64; NaN = missing);
                                                 a static run adds negative_eigenvalues (of the tangent at the
                                                 step's equilibrium, 0 = stable) and critical_point (0 none,
                                                 1 limit point, 2 bifurcation passed since the previous step)
    /steps/fields/<name>       (k, ...) float64  per-step arrays declared at creation (velocities, stresses,
                                                 restart data: docs/output_formats.md)

Lengths are in the unit of the mesh coordinates, time in seconds, everything else as the scene defines it.
The quaternion ``q = (w, x, y, z)`` of a frame ``R`` (columns: the frame axes, third column the director)
satisfies ``R = (w^2 - v.v) I + 2 v v^T + 2 w hat(v)`` with ``v = (x, y, z)``, i.e. ``R`` rotates vectors
by the angle ``2 atan2(|v|, w)`` about ``v`` (active, Hamilton convention, scalar first).

Crash safety: the file is created with ``libver="latest"`` and switched to SWMR (single writer, multiple
readers) mode once its datasets exist. A step writes its values into every other ``/steps`` data set and
flushes the file, then extends ``/steps/index`` (fill value -1) and flushes again: a step is complete once
``/steps/index`` holds its (non-negative) number, and no interruption can leave a complete-looking row of
zeros. Readers take the leading rows with ``index >= 0`` of the shortest ``/steps`` data set. A reader may
open the file while the run is going or after a crash with ``h5py.File(path, "r", swmr=True)`` (what
:func:`read_hdf5` does, with a bounded number of metadata read attempts, so that a damaged file fails with
an error instead of being retried for hours). Note: after a crash, tools that do not open in SWMR mode
report "file is already open for write"; ``h5clear -s FILE`` clears that flag. A file closed normally
opens with any HDF5 tool.

One writer: the writer holds a lock on the file (:mod:`flexbody.outputs.files`); a second writer is
refused before it truncates anything. Disk space: a step that the file system cannot hold (with a margin)
is refused before any of it is written (:class:`flexbody.outputs.files.DiskFullError`), so the file stays
readable up to the last complete step.
"""

from __future__ import annotations

from collections.abc import Sequence
import ctypes
import json
import math
import os

import h5py
import numpy as np

from flexbody.outputs.files import DiskFullError, check_free_space, lock_output, release

FORMAT = "flexbody-hdf5"
FORMAT_VERSION = 1
DEFAULT_STATS = ("iterations", "residual", "wall_time")
KINDS = {"static": "load_factor", "dynamic": "time"}
#: rows per chunk of the one-dimensional ``/steps`` data sets
SCALAR_CHUNK = 256
#: metadata read attempts of :func:`read_hdf5` (HDF5's default for SWMR readers is 100, with waits that
#: double from 1 ns: on a damaged file that is hours; 32 attempts wait about 4 s in all)
READ_ATTEMPTS = 32


# ----------------------------------------------------------------------------------------------------------
# Quaternions (w, x, y, z) <-> rotation matrices, vectorised
# ----------------------------------------------------------------------------------------------------------

def quaternions_from_matrices(R: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(..., 4)`` as ``(w, x, y, z)`` with ``w >= 0`` of rotation matrices ``(..., 3, 3)``.

    Shepperd's method: the largest of ``4w^2, 4x^2, 4y^2, 4z^2`` is taken from the diagonal and the other
    components from off-diagonal sums/differences divided by it, so the result is accurate at every angle,
    including at and near pi. The result is normalised.
    """
    R = np.asarray(R, dtype=float)
    if R.shape[-2:] != (3, 3):
        raise ValueError(f"rotation matrices must have shape (..., 3, 3), got {R.shape}")
    shape = R.shape[:-2]
    r = R.reshape(-1, 3, 3)
    r00, r11, r22 = r[:, 0, 0], r[:, 1, 1], r[:, 2, 2]
    t = r00 + r11 + r22
    case = np.argmax(np.stack([t, r00, r11, r22], axis=-1), axis=-1)
    q = np.empty((len(r), 4))
    s21, s02, s10 = r[:, 2, 1] - r[:, 1, 2], r[:, 0, 2] - r[:, 2, 0], r[:, 1, 0] - r[:, 0, 1]
    a01, a02, a12 = r[:, 0, 1] + r[:, 1, 0], r[:, 0, 2] + r[:, 2, 0], r[:, 1, 2] + r[:, 2, 1]

    c = case == 0  # w largest
    f = 2.0 * np.sqrt(np.maximum(1.0 + t[c], 0.0))  # 4 w
    q[c] = np.stack([0.25 * f, s21[c] / f, s02[c] / f, s10[c] / f], axis=-1)
    c = case == 1  # x largest
    f = 2.0 * np.sqrt(np.maximum(1.0 + 2.0 * r00[c] - t[c], 0.0))
    q[c] = np.stack([s21[c] / f, 0.25 * f, a01[c] / f, a02[c] / f], axis=-1)
    c = case == 2  # y largest
    f = 2.0 * np.sqrt(np.maximum(1.0 + 2.0 * r11[c] - t[c], 0.0))
    q[c] = np.stack([s02[c] / f, a01[c] / f, 0.25 * f, a12[c] / f], axis=-1)
    c = case == 3  # z largest
    f = 2.0 * np.sqrt(np.maximum(1.0 + 2.0 * r22[c] - t[c], 0.0))
    q[c] = np.stack([s10[c] / f, a02[c] / f, a12[c] / f, 0.25 * f], axis=-1)

    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    q[q[:, 0] < 0] *= -1.0  # q and -q are the same rotation; w >= 0 gives the angle in [0, pi]
    return q.reshape(shape + (4,))


def matrices_from_quaternions(q: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of quaternions ``(..., 4)`` given as ``(w, x, y, z)`` (normalised first)."""
    q = np.asarray(q, dtype=float)
    if q.shape[-1] != 4:
        raise ValueError(f"quaternions must have shape (..., 4), got {q.shape}")
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(norm == 0.0):
        raise ValueError("a zero quaternion is not a rotation")
    w, x, y, z = np.moveaxis(q / norm, -1, 0)
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = 1.0 - 2.0 * (y * y + z * z)
    R[..., 0, 1] = 2.0 * (x * y - w * z)
    R[..., 0, 2] = 2.0 * (x * z + w * y)
    R[..., 1, 0] = 2.0 * (x * y + w * z)
    R[..., 1, 1] = 1.0 - 2.0 * (x * x + z * z)
    R[..., 1, 2] = 2.0 * (y * z - w * x)
    R[..., 2, 0] = 2.0 * (x * z - w * y)
    R[..., 2, 1] = 2.0 * (y * z + w * x)
    R[..., 2, 2] = 1.0 - 2.0 * (x * x + y * y)
    return R


# ----------------------------------------------------------------------------------------------------------
# Writer
# ----------------------------------------------------------------------------------------------------------

def record_stats(rec) -> dict[str, float]:
    """The default statistics of a solver step record (``.iterations``, ``.residuals``: the last finite one,
    ``.wall_time``)."""
    residuals = [float(r) for r in (getattr(rec, "residuals", None) or []) if math.isfinite(r)]
    return {"iterations": int(rec.iterations),
            "residual": residuals[-1] if residuals else math.nan,
            "wall_time": float(rec.wall_time)}


def _json_default(obj):
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, (set, frozenset)):
        return sorted(obj, key=repr)
    return repr(obj)


def _check_names(names: Sequence[str], what: str) -> list[str]:
    names = list(names)
    for name in names:
        if not isinstance(name, str) or not name or "/" in name or name in (".", ".."):
            raise ValueError(f"{what} name {name!r} is not usable as an HDF5 data set name "
                             "(a non-empty string without '/')")
    if len(set(names)) != len(names):
        raise ValueError(f"duplicate {what} names: {names}")
    return names


class Hdf5Writer:
    """Write a run to an HDF5 file (layout in the module docstring); use as a context manager.

    Parameters
    ----------
    path : the file to create (overwritten if it exists)
    mesh : anything with ``.nodes`` (n, 3), ``.elements`` (m, 6) and ``.directors`` (n, 3)
    scene_name : stored as the ``scene`` attribute
    parameters : the scene parameters, stored as a JSON string (numpy values converted, others repr'd)
    outputs : names of the tracked scalars (one data set each under ``/steps/tracked``)
    kind : "static" (steps carry a load factor) or "dynamic" (steps carry a time)
    stats : names of the solver statistics (one data set each under ``/steps/stats``)
    fields : per-step arrays {name: shape of one step} (one data set each under ``/steps/fields``, (k,) +
        shape, float64): velocities, stress resultants, the restart data (docs/output_formats.md)
    """

    def __init__(self, path, mesh, scene_name: str, parameters: dict, outputs: list[str], *,
                 kind: str = "static", stats: Sequence[str] = DEFAULT_STATS,
                 fields: dict[str, tuple[int, ...]] | None = None):
        if kind not in KINDS:
            raise ValueError(f"kind must be 'static' or 'dynamic', got {kind!r}")
        self.path = os.fspath(path)
        self.kind = kind
        self.outputs = _check_names(outputs, "output")
        self.stats = _check_names(stats, "stat")
        self.fields = {name: tuple(int(v) for v in shape)
                       for name, shape in zip(_check_names(list(fields or {}), "field"), (fields or {}).values())}
        nodes = np.asarray(mesh.nodes, dtype=float)
        elements = np.asarray(mesh.elements)
        directors = np.asarray(mesh.directors, dtype=float)
        if nodes.ndim != 2 or nodes.shape[1] != 3:
            raise ValueError(f"mesh.nodes must have shape (n, 3), got {nodes.shape}")
        if elements.ndim != 2 or elements.shape[1] != 6:
            raise ValueError(f"mesh.elements must have shape (m, 6), got {elements.shape}")
        if directors.shape != nodes.shape:
            raise ValueError(f"mesh.directors must have shape {nodes.shape}, got {directors.shape}")
        self.n_nodes = n = len(nodes)
        self.n_steps = 0
        try:
            params_json = json.dumps(parameters or {}, default=_json_default, sort_keys=True)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"parameters cannot be stored as JSON: {exc}") from None

        parent = os.path.dirname(os.path.abspath(self.path))
        if not os.path.isdir(parent):
            raise FileNotFoundError(f"cannot create HDF5 output {self.path!r}: directory {parent!r} does not exist")
        if os.path.isdir(self.path):
            raise IsADirectoryError(f"cannot create HDF5 output {self.path!r}: it is a directory")
        if os.path.exists(self.path) and not os.path.isfile(self.path):
            raise OSError(f"cannot create HDF5 output {self.path!r}: it is not a regular file")
        check_free_space(self.path, nodes.nbytes + directors.nbytes + 6 * elements.size * 8, "HDF5 output", 0)
        self._lock = lock_output(self.path, "HDF5 output")
        try:  # HDF5's own lock is off: it would clash with ours, and it drops it in SWMR mode anyway
            self._file = h5py.File(self.path, "w", libver="latest", locking=False)
        except OSError as exc:
            release(self._lock)
            raise OSError(f"cannot create HDF5 output {self.path!r}: {exc}") from None
        self._failed = False

        from flexbody import __version__
        f = self._file
        try:
            f.attrs["format"] = FORMAT
            f.attrs["format_version"] = FORMAT_VERSION
            f.attrs["flexbody_version"] = __version__
            f.attrs["scene"] = str(scene_name)
            f.attrs["kind"] = kind
            f.attrs["parameters"] = params_json
            f.attrs["outputs"] = json.dumps(self.outputs)
            f.attrs["stats"] = json.dumps(self.stats)
            f.attrs["fields"] = json.dumps(list(self.fields))
            g = f.create_group("mesh")
            g.create_dataset("nodes", data=nodes)
            g.create_dataset("elements", data=elements.astype(np.int64))
            g.create_dataset("directors", data=directors)
            s = f.create_group("steps")

            def series(group, name, dtype="f8", tail=(), fill=math.nan):
                return group.create_dataset(name, shape=(0,) + tail, maxshape=(None,) + tail, dtype=dtype,
                                            chunks=(1,) + tail if tail else (SCALAR_CHUNK,), fillvalue=fill)

            # order of extension within a step: data first, the index last
            self._data = [("x", series(s, "x", tail=(n, 3))), ("frames", series(s, "frames", tail=(n, 4)))]
            tg, sg = s.create_group("tracked"), s.create_group("stats")
            self._tracked = {name: series(tg, name) for name in self.outputs}
            self._stats = {name: series(sg, name) for name in self.stats}
            fg = s.create_group("fields")
            self._fields = {name: series(fg, name, tail=shape) for name, shape in self.fields.items()}
            self._param = series(s, KINDS[kind])
            self._index = series(s, "index", dtype="i8", fill=-1)
            f.swmr_mode = True
            f.flush()
        except BaseException:
            f.close()
            release(self._lock)
            raise

    # -- context manager --------------------------------------------------------------------------------------
    def __enter__(self) -> "Hdf5Writer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def closed(self) -> bool:
        return not self._file.id.valid

    def write_step(self, step: int, load_factor_or_time: float, state, tracked: dict[str, float] | None = None,
                   stats: dict[str, float | int] | None = None, fields: dict[str, np.ndarray] | None = None) -> None:
        """Append one step (``state`` has ``.x`` (n, 3) and ``.frames`` (n, 3, 3)) and flush the file.

        Tracked outputs or stats not given for this step are stored as NaN; names not declared at creation
        raise ``KeyError``.
        """
        if self.closed:
            raise ValueError(f"HDF5 output {self.path!r} is closed")
        tracked = tracked or {}
        stats = stats or {}
        for given, declared, what in ((tracked, self._tracked, "output"), (stats, self._stats, "stat")):
            unknown = [k for k in given if k not in declared]
            if unknown:
                raise KeyError(f"{what}(s) {unknown} were not declared when {self.path!r} was created "
                               f"(declared: {list(declared)})")
        x = np.asarray(state.x, dtype=float)
        frames = np.asarray(state.frames, dtype=float)
        if x.shape != (self.n_nodes, 3):
            raise ValueError(f"state.x must have shape ({self.n_nodes}, 3), got {x.shape}")
        if frames.shape != (self.n_nodes, 3, 3):
            raise ValueError(f"state.frames must have shape ({self.n_nodes}, 3, 3), got {frames.shape}")
        rows = [(self._data[0][1], x), (self._data[1][1], quaternions_from_matrices(frames))]
        rows += [(ds, float(tracked.get(name, math.nan))) for name, ds in self._tracked.items()]
        rows += [(ds, float(stats.get(name, math.nan))) for name, ds in self._stats.items()]
        fields = fields or {}
        unknown = [k for k in fields if k not in self._fields]
        if unknown:
            raise KeyError(f"field(s) {unknown} were not declared when {self.path!r} was created "
                           f"(declared: {list(self._fields)})")
        for name, ds in self._fields.items():
            value = np.asarray(fields.get(name, np.full(self.fields[name], math.nan)), dtype=float)
            if value.shape != self.fields[name]:
                raise ValueError(f"field {name!r} must have shape {self.fields[name]}, got {value.shape}")
            rows.append((ds, value))
        rows.append((self._param, float(load_factor_or_time)))
        if int(step) < 0:
            raise ValueError(f"step numbers must be >= 0, got {step!r}")
        k = self.n_steps
        check_free_space(self.path, self._step_bytes(k), "HDF5 output", k)
        try:
            self._append(rows, k)
            self._file.flush()  # the values on disk before the index says that the step is there
            self._append([(self._index, int(step))], k)
            self._file.flush()
        except (OSError, RuntimeError) as exc:
            self._failed = True
            raise _write_error(exc, self.path, k) from None
        self.n_steps = k + 1

    @staticmethod
    def _append(rows: list, k: int) -> None:
        for ds, value in rows:
            ds.resize(k + 1, axis=0)
            ds[k] = value

    def _step_bytes(self, k: int) -> int:
        """Bytes that step ``k`` adds to the file: positions and frames, and new chunks every SCALAR_CHUNK steps."""
        scalars = len(self._tracked) + len(self._stats) + 2
        extra = sum(8 * math.prod(shape) for shape in self.fields.values())
        return self.n_nodes * 7 * 8 + extra + (scalars * SCALAR_CHUNK * 8 if k % SCALAR_CHUNK == 0 else 0)

    def flush(self) -> None:
        if not self.closed and not self._failed:
            self._file.flush()

    def close(self) -> None:
        """Flush and close the file and give up its lock (idempotent). After a failed write the close is
        best effort: what the failed step left is not counted by readers (``/steps/index`` comes last)."""
        if not self.closed:
            try:
                if not self._failed:
                    self._file.flush()
                self._file.close()
            except (OSError, RuntimeError):
                if not self._failed:
                    raise
            finally:
                release(self._lock)
                self._lock = None


def _write_error(exc: BaseException, path: str, steps: int) -> OSError:
    """One-line OSError for an HDF5 write that failed (a full disk says so)."""
    text = str(exc)
    if "errno = 28" in text or "No space left" in text:
        return DiskFullError(f"disk full after {steps} steps: HDF5 output {path!r} cannot take more")
    return OSError(f"cannot write step {steps + 1} to HDF5 output {path!r}: {text.splitlines()[0]}")


# ----------------------------------------------------------------------------------------------------------
# Reader
# ----------------------------------------------------------------------------------------------------------

def read_hdf5(path) -> dict:
    """Read a flexbody HDF5 file (complete, still being written, or left by a crash) into numpy arrays.

    Returns a dict with ``scene``, ``kind``, ``parameters`` (dict), ``flexbody_version``, ``nodes``,
    ``elements``, ``directors``, ``step`` (k,), ``load_factor`` or ``time`` (k,), ``x`` (k, n, 3),
    ``quaternions`` (k, n, 4), ``frames`` (k, n, 3, 3) rotation matrices, ``tracked`` and ``stats``
    (dicts of (k,) arrays), ``fields`` (dict of (k, ...) arrays). Only complete steps are returned.
    """
    path = os.fspath(path)
    try:
        f = _open_for_reading(path)
    except (OSError, RuntimeError) as exc:
        raise OSError(f"cannot read HDF5 output {path!r}: {str(exc).splitlines()[0]}") from None
    try:
        return _read_open_file(f, path)
    except (OSError, RuntimeError) as exc:  # damaged metadata (after the bounded read attempts)
        raise OSError(f"cannot read HDF5 output {path!r}: {str(exc).splitlines()[0]}") from None
    finally:
        f.close()


def _set_read_attempts(fapl, attempts: int) -> bool:
    """``H5Pset_metadata_read_attempts`` on a file access property list (h5py does not wrap it; it is
    looked up through h5py's own extension module, so the call reaches the HDF5 library h5py uses)."""
    try:
        func = ctypes.CDLL(h5py.h5p.__file__).H5Pset_metadata_read_attempts
    except (OSError, AttributeError):  # pragma: no cover - a platform where the symbol is not reachable
        return False
    func.argtypes, func.restype = [ctypes.c_int64, ctypes.c_uint], ctypes.c_int
    return func(fapl.id, attempts) >= 0


def _open_for_reading(path: str) -> h5py.File:
    """The file opened read-only in SWMR mode, with at most :data:`READ_ATTEMPTS` metadata read attempts."""
    fapl = h5py.h5p.create(h5py.h5p.FILE_ACCESS)
    if not _set_read_attempts(fapl, READ_ATTEMPTS):  # pragma: no cover
        return h5py.File(path, "r", swmr=True)
    fid = h5py.h5f.open(os.fsencode(path), h5py.h5f.ACC_RDONLY | h5py.h5f.ACC_SWMR_READ, fapl=fapl)
    return h5py.File(fid)


def _complete_steps(series: dict) -> int:
    """The number of complete steps: the leading rows of the shortest data set whose index is written."""
    k = min(ds.shape[0] for ds in series.values())
    index = series["index"][:k]
    unwritten = np.flatnonzero(index < 0)
    return int(unwritten[0]) if unwritten.size else k


def _read_open_file(f: h5py.File, path: str) -> dict:
    """The contents of an open flexbody HDF5 file (see :func:`read_hdf5`)."""
    if f.attrs.get("format") != FORMAT:
        raise ValueError(f"{path!r} is not a {FORMAT} file (format attribute {f.attrs.get('format')!r})")
    kind = str(f.attrs["kind"])
    s = f["steps"]
    series = {"x": s["x"], "frames": s["frames"], "param": s[KINDS[kind]], "index": s["index"]}
    series.update({("tracked", k): v for k, v in s["tracked"].items()})
    series.update({("stats", k): v for k, v in s["stats"].items()})
    field_names = json.loads(f.attrs.get("fields", "[]"))
    series.update({("fields", k): s["fields"][k] for k in field_names})
    for ds in series.values():
        ds.refresh()
    k = _complete_steps(series)
    q = series["frames"][:k]
    out = {
        "scene": str(f.attrs["scene"]), "kind": kind, "flexbody_version": str(f.attrs["flexbody_version"]),
        "parameters": json.loads(f.attrs["parameters"]),
        "nodes": f["mesh/nodes"][()], "elements": f["mesh/elements"][()], "directors": f["mesh/directors"][()],
        "step": series["index"][:k], KINDS[kind]: series["param"][:k],
        "x": series["x"][:k], "quaternions": q, "frames": matrices_from_quaternions(q),
        "tracked": {name: s["tracked"][name][:k] for name in json.loads(f.attrs["outputs"])},
        "stats": {name: s["stats"][name][:k] for name in json.loads(f.attrs["stats"])},
        "fields": {name: s["fields"][name][:k] for name in field_names},
    }
    return out
