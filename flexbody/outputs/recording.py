"""The output files of one run (HDF5 and/or rerun), fed step by step from ``run_scene``'s ``on_step`` hook.

Each writer is imported only when its file is asked for: a run without ``--rerun`` never imports rerun.
Every step is flushed to both files, and :meth:`RunRecorder.close` runs whatever ends the run (a finished
or diverged analysis, an exception, Ctrl-C), so what was written stays readable.

When a writer fails: the HDF5 file holds the results that were asked for, so a step it cannot take (a full
disk, an I/O error) stops the run with :class:`OutputStopped` (the file keeps every complete step); the
rerun recording is for looking only, so its failure is reported once through ``warn`` and the recording is
closed where it stands, while the solve and the HDF5 file go on.
"""

from __future__ import annotations

from collections.abc import Callable
import os
import warnings


class OutputPathError(ValueError):
    """An output file that cannot be written; the message is one line naming the option and the path."""


class OutputStopped(Exception):
    """The HDF5 output could not take a step: the run stops; the message is one line naming the file."""


def check_output_path(path: str, option: str, regular: bool = True) -> None:
    """Raise :class:`OutputPathError` if ``path`` cannot be created as a file (checked before a run starts).

    ``regular``: the path must be (or become) a regular file; a device, pipe or socket (``/dev/null``) is
    refused (an HDF5 file or a recording cannot be written there).
    """
    if not path:
        raise OutputPathError(f"{option} needs a file name")
    full = os.path.abspath(path)
    parent = os.path.dirname(full)
    if os.path.isdir(full):
        raise OutputPathError(f"cannot write {option} file {path!r}: it is a directory")
    if regular and os.path.exists(full) and not os.path.isfile(full):
        raise OutputPathError(f"cannot write {option} file {path!r}: it is not a regular file")
    if not os.path.isdir(parent):
        raise OutputPathError(f"cannot write {option} file {path!r}: directory {parent!r} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputPathError(f"cannot write {option} file {path!r}: directory {parent!r} is not writable")
    if os.path.exists(full) and not os.access(full, os.W_OK):
        raise OutputPathError(f"cannot write {option} file {path!r}: the file exists and is read-only")


def check_distinct(paths: dict[str, str | None]) -> None:
    """Raise :class:`OutputPathError` if two output options name the same file."""
    seen: dict[str, str] = {}
    for option, path in paths.items():
        if not path:
            continue
        key = os.path.realpath(path)
        if key in seen:
            raise OutputPathError(f"{seen[key]} and {option} name the same file {path!r}")
        seen[key] = option


def _same_file(a: str, b: str) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet)
        return os.path.realpath(a) == os.path.realpath(b)


def check_not_inputs(outputs: dict[str, str | None], inputs: dict[str, str]) -> None:
    """Raise :class:`OutputPathError` if an output option names an input file (the scene file, its mesh or
    reference file): ``outputs`` {option: path}, ``inputs`` {what: path}. Hard and symbolic links count."""
    for option, path in outputs.items():
        if not path:
            continue
        for what, source in inputs.items():
            if _same_file(path, source):
                raise OutputPathError(f"{option} {path!r} is the {what} {source!r}; refusing to overwrite an "
                                      "input (choose another output file)")


#: the statistics a dynamic run adds to the HDF5 file, per step
DYNAMIC_STATS = ("refreshes", "kinetic_energy", "strain_energy", "gravity_energy", "total_energy",
                 "dissipated_energy", "linear_momentum_x", "linear_momentum_y", "linear_momentum_z",
                 "angular_momentum_x", "angular_momentum_y", "angular_momentum_z")


#: the statistics a static run adds to the HDF5 file, per step: the number of negative eigenvalues of the
#: tangent at the converged state (NaN: not counted) and the critical point passed since the previous step
#: (:data:`CRITICAL_CODES`)
STATIC_STATS = ("negative_eigenvalues", "critical_point")
#: the ``critical_point`` codes: 0 none, 1 a limit point, 2 a bifurcation point
CRITICAL_CODES = {None: 0, "limit point": 1, "bifurcation": 2}


def static_stats(rec) -> dict[str, float]:
    """The :data:`STATIC_STATS` of a static step record (``integrators.static.StepRecord``)."""
    count = getattr(rec, "negative_eigenvalues", None)
    critical = getattr(rec, "critical", None)
    return {"negative_eigenvalues": float("nan") if count is None else float(count),
            "critical_point": float(CRITICAL_CODES[None if critical is None else critical.kind])}


def dynamic_stats(rec) -> dict[str, float]:
    """The :data:`DYNAMIC_STATS` of a dynamic step record (``integrators.generalized_alpha.DynamicStepRecord``)."""
    out = {"refreshes": float(rec.refreshed), "kinetic_energy": float(rec.kinetic_energy),
           "strain_energy": float(rec.strain_energy), "gravity_energy": float(rec.potential_energy),
           "total_energy": float(rec.total_energy), "dissipated_energy": float(rec.dissipated_energy)}
    for name, vec in (("linear_momentum", rec.linear_momentum), ("angular_momentum", rec.angular_momentum)):
        for axis, value in zip("xyz", vec):
            out[f"{name}_{axis}"] = float(value)
    return out


class RunRecorder:
    """Open the requested output files for a scene and write one record per converged step.

    Parameters
    ----------
    scene : the :class:`flexbody.scenes.scene.Scene` being run
    h5 : path of the HDF5 results file, or None
    rerun : path of the rerun recording (.rrd), or None
    directors : also log the directors as arrows in the recording
    warn : called with a one-line message when the recording fails and is closed (default: a warning)

    Use as a context manager; pass :meth:`on_step` to ``run_scene``.

    A dynamic scene (``scene.kind == "dynamic"``) writes files of kind "dynamic": the steps carry the time
    (``/steps/time``, the rerun ``time`` timeline), the initial state is step 0, and the HDF5 statistics add
    the energies and momenta of every step (:data:`DYNAMIC_STATS`).
    """

    def __init__(self, scene, h5: str | None = None, rerun: str | None = None, directors: bool = False,
                 warn: Callable[[str], None] | None = None):
        self.scene = scene
        self._warn = warn or (lambda message: warnings.warn(message, RuntimeWarning, stacklevel=3))
        self.kind = getattr(scene, "kind", "static")
        self.names = [o.name for o in scene.outputs]
        self.steps_written = 0
        self._h5 = self._rrd = None
        mesh = scene.model.body.mesh
        try:
            if h5:
                from flexbody.outputs.hdf5 import DEFAULT_STATS, Hdf5Writer
                stats = DEFAULT_STATS + (DYNAMIC_STATS if self.kind == "dynamic" else STATIC_STATS)
                self._h5 = Hdf5Writer(h5, mesh, scene.name, scene.parameters, self.names, kind=self.kind,
                                      stats=stats)
            if rerun:
                from flexbody.outputs.rerun_log import RerunLogger
                reference = None
                if scene.reference is not None:
                    reference = {k: (scene.reference.load_factors, v) for k, v in scene.reference.values.items()}
                self._rrd = RerunLogger(rerun, mesh, scene.name, directors=directors, reference=reference,
                                        kind=self.kind)
        except BaseException:
            self.close()
            raise

    @property
    def paths(self) -> list[str]:
        """The files being written."""
        return [w.path for w in (self._h5, self._rrd) if w is not None]

    def on_step(self, rec, state, history) -> None:
        """``run_scene`` hook: write the step to every open file and flush them; the step counts as written
        once both files have it. Raises :class:`OutputStopped` if the HDF5 file cannot take it."""
        tracked = {k: history[k][-1] for k in self.names}
        where = rec.time if self.kind == "dynamic" else rec.load_factor
        if self._h5 is not None:
            from flexbody.outputs.hdf5 import record_stats
            stats = record_stats(rec)
            stats.update(dynamic_stats(rec) if self.kind == "dynamic" else static_stats(rec))
            try:
                self._h5.write_step(rec.step, where, state, tracked, stats)
            except OSError as exc:
                raise OutputStopped(str(exc)) from None
        if self._rrd is not None:
            try:
                self._rrd.log_step(rec.step, where, state, tracked)
                self._rrd.flush()
            except Exception as exc:  # a recording is for looking: it never stops the solve
                self._drop_recording(exc)
        self.steps_written += 1

    def _drop_recording(self, exc: Exception) -> None:
        """Close the recording where it stands (its complete steps stay readable) and say so once."""
        rrd, self._rrd = self._rrd, None
        try:
            rrd.close()
        except Exception:
            pass
        self._warn(f"rerun recording {rrd.path!r} stopped after {self.steps_written} steps "
                   f"({str(exc).splitlines()[0]}); the run goes on")

    def close(self) -> None:
        """Flush and close every file (idempotent)."""
        for writer in (self._h5, self._rrd):
            if writer is not None:
                writer.close()

    def __enter__(self) -> "RunRecorder":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
