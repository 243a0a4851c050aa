"""Continue a run from a step saved in its HDF5 results file (``flexbody run SCENE --restart FILE.h5[:STEP]``).

The HDF5 writer of a run (:class:`flexbody.outputs.recording.RunRecorder`) stores with every step what a
continuation needs exactly (``/steps/fields``): the positions relative to the model origin at full precision
(``restart_positions``), the frames as matrices (``restart_frames``), and for a dynamic run the free-DoF
velocity, acceleration and generalized-alpha pseudo-acceleration (``restart_v``, ``restart_vdot``,
``restart_a``) and the dissipated work (``/steps/stats/dissipated_energy``); for an arc-length path the state
of the continuation (:class:`integrators.static.ArcLengthState`): the unit direction of the last step's
increment in scaled free DoFs (``restart_arc_direction``), and ``restart_arc`` = (the next step's arc length,
the first step's arc length, the sign of the last load change). :func:`read_restart` checks the file
against the scene and returns the :class:`flexbody.scenes.scene.RestartPoint` to pass to ``run_scene``.
"""

from __future__ import annotations

import os

import numpy as np

RESTART_FIELDS = ("restart_positions", "restart_frames")
DYNAMIC_RESTART_FIELDS = ("restart_v", "restart_vdot", "restart_a")
ARC_LENGTH_RESTART_FIELDS = ("restart_arc_direction", "restart_arc")


class RestartError(ValueError):
    """A restart file or step that cannot continue the scene; the message is one line."""


def parse_restart(spec: str) -> tuple[str, int | None]:
    """``FILE.h5[:STEP]`` -> (path, step or None for the last saved step)."""
    path, sep, tail = spec.rpartition(":")
    if sep and tail.strip().lstrip("-").isdigit():
        return path, int(tail)
    return spec, None


def restart_field_shapes(n_nodes: int, n_dof: int, dynamic: bool,
                         arc_length: bool = False) -> dict[str, tuple[int, ...]]:
    """The per-step restart fields of a run and their shapes (``arc_length``: a static arc-length path)."""
    shapes = {"restart_positions": (n_nodes, 3), "restart_frames": (n_nodes, 3, 3)}
    if dynamic:
        shapes.update({name: (n_dof,) for name in DYNAMIC_RESTART_FIELDS})
    elif arc_length:
        shapes.update({"restart_arc_direction": (n_dof,), "restart_arc": (3,)})
    return shapes


def arc_length_fields(continuation) -> dict[str, np.ndarray]:
    """The restart fields of an arc-length step (:class:`integrators.static.ArcLengthState`)."""
    return {"restart_arc_direction": continuation.direction,
            "restart_arc": np.array([continuation.arc_length, continuation.first_arc_length,
                                     continuation.load_sign], dtype=float)}


def _uses_arc_length(scene) -> bool:
    return scene.kind == "static" and getattr(scene.analysis, "method", None) == "arc_length"


def read_restart(spec: str, scene):
    """The :class:`flexbody.scenes.scene.RestartPoint` of ``FILE.h5[:STEP]`` for ``scene`` (raises
    :class:`RestartError` with one line: missing file, not a results file, another scene, kind or mesh, a
    file without restart data, a step not saved)."""
    from flexbody.body import ShellState
    from flexbody.outputs.hdf5 import read_hdf5
    from flexbody.scenes.analysis import RestartPoint
    path, step = parse_restart(spec)
    if not os.path.isfile(path):
        raise RestartError(f"--restart file {path!r} does not exist")
    try:
        d = read_hdf5(path)
    except (OSError, ValueError, KeyError) as exc:
        raise RestartError(f"--restart file {path!r} is not a flexbody results file "
                           f"({str(exc).splitlines()[0]})") from None
    body = scene.model.body
    if d["scene"] != scene.name or d["kind"] != scene.kind:
        raise RestartError(f"--restart file {path!r} holds a {d['kind']} run of scene {d['scene']!r}, not of "
                           f"this {scene.kind} scene {scene.name!r}")
    if d["nodes"].shape != body.mesh.nodes.shape or not np.array_equal(d["elements"], body.mesh.elements) \
            or not np.allclose(d["nodes"], body.mesh.nodes, rtol=0, atol=1e-12 * max(1.0, np.abs(body.mesh.nodes).max())):
        raise RestartError(f"--restart file {path!r} was written for another mesh ({len(d['nodes'])} nodes, "
                           f"{len(d['elements'])} elements; this scene: {body.n_nodes} nodes, "
                           f"{body.mesh.n_elements} elements)")
    arc = _uses_arc_length(scene)
    needed = RESTART_FIELDS + (DYNAMIC_RESTART_FIELDS if scene.kind == "dynamic" else ()) \
        + (ARC_LENGTH_RESTART_FIELDS if arc else ())
    missing = [k for k in needed if k not in d["fields"]]
    if missing:
        raise RestartError(f"--restart file {path!r} has no restart data ({', '.join(missing)}); it was written "
                           "by an older flexbody")
    steps = d["step"]
    if len(steps) == 0:
        raise RestartError(f"--restart file {path!r} holds no complete step")
    if step is None:
        k = len(steps) - 1
    else:
        found = np.flatnonzero(steps == step)
        if found.size == 0:
            raise RestartError(f"--restart step {step} is not in {path!r} (saved steps {int(steps[0])}.."
                               f"{int(steps[-1])}: {', '.join(map(str, steps[:8].tolist()))}"
                               f"{', ...' if len(steps) > 8 else ''})")
        k = int(found[-1])
    f = {name: d["fields"][name][k] for name in needed}
    if not all(np.all(np.isfinite(v)) for v in f.values()):
        raise RestartError(f"--restart step {int(steps[k])} of {path!r} has no restart data (not finite)")
    local = f["restart_positions"]
    state = ShellState(local + body.origin, f["restart_frames"].copy(), local=local.copy(), origin=body.origin)
    where = float(d["time" if scene.kind == "dynamic" else "load_factor"][k])
    n_dof = scene.model.n_dof
    if arc:
        return _arc_length_point(path, int(steps[k]), where, state, f, n_dof)
    if scene.kind != "dynamic":
        return RestartPoint(int(steps[k]), where, state)
    if f["restart_v"].shape != (n_dof,):
        raise RestartError(f"--restart file {path!r} was written for other supports ({f['restart_v'].size} "
                           f"free DoFs; this scene: {n_dof})")
    dissipated = float(d["stats"].get("dissipated_energy", np.zeros(k + 1))[k])
    return RestartPoint(int(steps[k]), where, state, f["restart_v"], f["restart_vdot"], f["restart_a"],
                        dissipated if np.isfinite(dissipated) else 0.0)


def _arc_length_point(path: str, step: int, lam: float, state, f: dict, n_dof: int):
    """The restart point of an arc-length path: the state and the continuation of the saved step."""
    from integrators.static import ArcLengthState
    from flexbody.scenes.analysis import RestartPoint
    direction = f["restart_arc_direction"]
    if direction.shape != (n_dof,):
        raise RestartError(f"--restart file {path!r} was written for other supports ({direction.size} free "
                           f"DoFs; this scene: {n_dof})")
    arc, first, sign = (float(v) for v in f["restart_arc"])
    try:
        continuation = ArcLengthState(lam, arc, first, direction.copy(), sign)
    except ValueError as exc:
        raise RestartError(f"--restart step {step} of {path!r}: {exc}") from None
    return RestartPoint(step, lam, state, continuation=continuation)
