"""The output files of one run (HDF5 and/or rerun), fed step by step from ``run_scene``'s ``on_step`` hook.

Each writer is imported only when its file is asked for: a run without ``--rerun`` never imports rerun.
Every step is flushed to both files, and :meth:`RunRecorder.close` runs whatever ends the run (a finished
or diverged analysis, an exception, Ctrl-C), so what was written stays readable.

When a writer fails: the HDF5 file holds the results that were asked for, so a step it cannot take (a full
disk, an I/O error) stops the run with :class:`OutputStopped` (the file keeps every complete step); the
rerun recording and the XDMF series are for looking only, so their failure is reported once through ``warn``
and the file is closed where it stands, while the solve and the HDF5 file go on.

The HDF5 ``residual`` of a static step is the work norm of the residual r(q, lambda) of the state written
(evaluated for the file: the solver's last residual is NaN when it stopped on the increment); of a dynamic
step, the solver's last residual norm.
"""

from __future__ import annotations

from collections.abc import Callable
import os
import warnings

import numpy as np


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


#: the nodal motion fields of a dynamic run (global components), in the HDF5 file and the XDMF series
MOTION_FIELDS = ("velocity", "angular_velocity", "acceleration", "angular_acceleration")


class RunRecorder:
    """Open the requested output files for a scene and write one record per converged step.

    Parameters
    ----------
    scene : the :class:`flexbody.scenes.scene.Scene` being run
    h5 : path of the HDF5 results file, or None
    rerun : path of the rerun recording (.rrd), or None
    directors : also log the directors as arrows in the recording
    warn : called with a one-line message when the recording fails and is closed (default: a warning)
    xdmf : path of an XDMF time series for ParaView (:mod:`flexbody.outputs.xdmf`, needs meshio), or None
    stresses : also write the stress resultants and reactions of every step to the HDF5 file
    rerun_color : what the recording's colours show: "deformation" (default), "displacement" or "stress" (the
        von Mises fibre stress, :func:`flexbody.results.stress_resultants`) (:mod:`flexbody.outputs.rerun_log`)

    Use as a context manager; pass :meth:`on_step` to ``run_scene``.

    A dynamic scene (``scene.kind == "dynamic"``) writes files of kind "dynamic": the steps carry the time
    (``/steps/time``, the rerun ``time`` timeline), the initial state is step 0, and the HDF5 statistics add
    the energies and momenta of every step (:data:`DYNAMIC_STATS`).
    """

    def __init__(self, scene, h5: str | None = None, rerun: str | None = None, directors: bool = False,
                 warn: Callable[[str], None] | None = None, xdmf: str | None = None, stresses: bool = False,
                 rerun_color: str = "deformation"):
        self.scene = scene
        self.rerun_color = rerun_color
        self.stresses = bool(stresses)
        self._xdmf = None
        self._gravity = None
        self._energy0 = None           # T + W + V_g + D of the first logged dynamic step (the drift's origin)
        self._warn = warn or (lambda message: warnings.warn(message, RuntimeWarning, stacklevel=3))
        self.kind = getattr(scene, "kind", "static")
        self.names = [o.name for o in scene.outputs]
        self.steps_written = 0
        self._h5 = self._rrd = None
        mesh = scene.model.body.mesh
        try:
            if h5:
                from flexbody.outputs.hdf5 import DEFAULT_STATS, Hdf5Writer
                from flexbody.outputs.fields import stress_field_shapes
                from flexbody.outputs.restart import restart_field_shapes
                stats = DEFAULT_STATS + (DYNAMIC_STATS if self.kind == "dynamic" else STATIC_STATS)
                n, m = mesh.n_nodes, mesh.n_elements
                arc = getattr(scene.analysis, "method", None) == "arc_length"
                fields = restart_field_shapes(n, scene.model.n_dof, self.kind == "dynamic", arc)
                if self.kind == "dynamic":
                    fields.update({name: (n, 3) for name in MOTION_FIELDS})
                if self.stresses:
                    fields.update(stress_field_shapes(n, m))
                self._h5 = Hdf5Writer(h5, mesh, scene.name, scene.parameters, self.names, kind=self.kind,
                                      stats=stats, fields=fields)
            if xdmf:
                from flexbody.outputs.xdmf import XdmfWriter
                self._xdmf = XdmfWriter(xdmf, mesh)
            if xdmf or self.stresses:
                from flexbody.outputs.fields import gravity_forces
                self._gravity = gravity_forces(scene)
            if rerun:
                from flexbody.outputs.rerun_log import RerunLogger
                reference = None
                if scene.reference is not None:
                    reference = {k: (scene.reference.load_factors, v) for k, v in scene.reference.values.items()}
                self._rrd = RerunLogger(rerun, mesh, scene.name, directors=directors, reference=reference,
                                        kind=self.kind, outputs=self.names, color_by=rerun_color)
        except BaseException:
            self.close()
            raise

    @property
    def paths(self) -> list[str]:
        """The files being written."""
        return [w.path for w in (self._h5, self._rrd, self._xdmf) if w is not None]

    def on_step(self, rec, state, history) -> None:
        """``run_scene`` hook: write the step to every open file and flush them; the step counts as written
        once both files have it. Raises :class:`OutputStopped` if the HDF5 file cannot take it."""
        tracked = {k: history[k][-1] for k in self.names}
        where = rec.time if self.kind == "dynamic" else rec.load_factor
        if self._h5 is not None:
            from flexbody.outputs.hdf5 import record_stats
            stats = record_stats(rec)
            if self.kind == "dynamic":
                stats.update(dynamic_stats(rec))
            else:                              # the out-of-balance force of the state written (module docstring)
                stats.update(static_stats(rec))
                stats["residual"] = self._residual(state, where)
            fields = self._fields(rec, state, where)
            try:
                self._h5.write_step(rec.step, where, state, tracked, stats, fields)
            except OSError as exc:
                raise OutputStopped(str(exc)) from None
        if self._xdmf is not None:
            try:
                from flexbody.outputs.fields import load_level, step_fields
                point, cell = step_fields(self.scene.model, state, load_level(self.scene, where), self._gravity)
                if self.kind == "dynamic" and rec.motion is not None:
                    point.update({k: rec.motion[k] for k in MOTION_FIELDS if k in rec.motion})
                self._xdmf.write_step(where, point, cell)
            except Exception as exc:  # a ParaView file is for looking: it never stops the solve
                self._drop_xdmf(exc)
        if self._rrd is not None:
            try:
                self._rrd.log_step(rec.step, where, state, tracked, self._energy_stats(rec), self._colour_field(state))
                self._rrd.flush()
            except Exception as exc:  # a recording is for looking: it never stops the solve
                self._drop_recording(exc)
        self.steps_written += 1

    def _colour_field(self, state) -> np.ndarray | None:
        """The nodal von Mises fibre stress (the larger of top and bottom) when the recording is coloured by it."""
        if self.rerun_color != "stress":
            return None
        from flexbody.results import stress_resultants
        r = stress_resultants(self.scene.model.body, state)
        return np.maximum(r.von_mises_top, r.von_mises_bottom)

    def _energy_stats(self, rec) -> dict[str, float] | None:
        """The energies of a dynamic step and the drift of T + W + V_g + D from its first value (rerun plots)."""
        if self.kind != "dynamic":
            return None
        stats = {k: v for k, v in dynamic_stats(rec).items() if k.endswith("_energy")}
        balance = float(rec.total_energy + rec.dissipated_energy)
        if self._energy0 is None:
            self._energy0 = balance
        stats["energy_drift"] = balance - self._energy0
        return stats

    def _residual(self, state, lam: float) -> float:
        """The work norm of the static residual r(q, lam) on the free DoFs of the state written."""
        from integrators.newton import work_norm
        model = self.scene.model
        try:
            return work_norm(model.residual(state, lam), model.dof_scale)
        except (FloatingPointError, ValueError):
            return float("nan")

    def _fields(self, rec, state, where: float) -> dict:
        """The HDF5 per-step fields: restart data, a dynamic run's nodal motion, the stresses on request."""
        fields = {"restart_positions": self.scene.model.body.relative_positions(state), "restart_frames": state.frames}
        motion = getattr(rec, "motion", None)
        if self.kind == "dynamic" and motion is not None:
            fields.update({"restart_v": motion["v"], "restart_vdot": motion["vdot"], "restart_a": motion["a"]})
            fields.update({k: motion[k] for k in MOTION_FIELDS if k in motion})
        continuation = getattr(rec, "continuation", None)
        if continuation is not None:
            from flexbody.outputs.restart import arc_length_fields
            fields.update(arc_length_fields(continuation))
        if self.stresses:
            from flexbody.outputs.fields import load_level, stress_field_values
            fields.update(stress_field_values(self.scene.model, state, load_level(self.scene, where), self._gravity))
        return fields

    def _drop_xdmf(self, exc: Exception) -> None:
        """Close the XDMF series where it stands (its steps stay readable) and say so once."""
        writer, self._xdmf = self._xdmf, None
        try:
            writer.close()
        except Exception:
            pass
        self._warn(f"XDMF output {writer.path!r} stopped after {self.steps_written} steps "
                   f"({str(exc).splitlines()[0]}); the run goes on")

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
        for writer in (self._h5, self._rrd, self._xdmf):
            if writer is not None:
                writer.close()

    def __enter__(self) -> "RunRecorder":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
