"""The output files of one run (HDF5 and/or rerun), fed step by step from ``run_scene``'s ``on_step`` hook.

Each writer is imported only when its file is asked for: a run without ``--rerun`` never imports rerun.
Every step is flushed to both files, and :meth:`RunRecorder.close` runs whatever ends the run (a finished
or diverged analysis, an exception, Ctrl-C), so what was written stays readable.
"""

from __future__ import annotations

import os


class OutputPathError(ValueError):
    """An output file that cannot be written; the message is one line naming the option and the path."""


def check_output_path(path: str, option: str) -> None:
    """Raise :class:`OutputPathError` if ``path`` cannot be created as a file (checked before a run starts)."""
    if not path:
        raise OutputPathError(f"{option} needs a file name")
    full = os.path.abspath(path)
    parent = os.path.dirname(full)
    if os.path.isdir(full):
        raise OutputPathError(f"cannot write {option} file {path!r}: it is a directory")
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


class RunRecorder:
    """Open the requested output files for a scene and write one record per converged step.

    Parameters
    ----------
    scene : the :class:`flexbody.scenes.scene.Scene` being run
    h5 : path of the HDF5 results file, or None
    rerun : path of the rerun recording (.rrd), or None
    directors : also log the directors as arrows in the recording

    Use as a context manager; pass :meth:`on_step` to ``run_scene``.
    """

    def __init__(self, scene, h5: str | None = None, rerun: str | None = None, directors: bool = False):
        self.scene = scene
        self.names = [o.name for o in scene.outputs]
        self.steps_written = 0
        self._h5 = self._rrd = None
        mesh = scene.model.body.mesh
        try:
            if h5:
                from flexbody.outputs.hdf5 import Hdf5Writer
                self._h5 = Hdf5Writer(h5, mesh, scene.name, scene.parameters, self.names)
            if rerun:
                from flexbody.outputs.rerun_log import RerunLogger
                reference = None
                if scene.reference is not None:
                    reference = {k: (scene.reference.load_factors, v) for k, v in scene.reference.values.items()}
                self._rrd = RerunLogger(rerun, mesh, scene.name, directors=directors, reference=reference)
        except BaseException:
            self.close()
            raise

    @property
    def paths(self) -> list[str]:
        """The files being written."""
        return [w.path for w in (self._h5, self._rrd) if w is not None]

    def on_step(self, rec, state, history) -> None:
        """``run_scene`` hook: write the step to every open file and flush them."""
        tracked = {k: history[k][-1] for k in self.names}
        if self._h5 is not None:
            from flexbody.outputs.hdf5 import record_stats
            self._h5.write_step(rec.step, rec.load_factor, state, tracked, record_stats(rec))
        if self._rrd is not None:
            self._rrd.log_step(rec.step, rec.load_factor, state, tracked)
            self._rrd.flush()
        self.steps_written += 1

    def close(self) -> None:
        """Flush and close every file (idempotent)."""
        for writer in (self._h5, self._rrd):
            if writer is not None:
                writer.close()

    def __enter__(self) -> "RunRecorder":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
