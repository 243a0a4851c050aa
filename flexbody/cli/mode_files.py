"""The mode shapes of ``flexbody modes`` in files: an animated rerun recording and an HDF5 file
(docs/output_formats.md, format ``flexbody-modes``)."""

from __future__ import annotations

#: frames per period of a mode shape in the rerun recording
MODE_FRAMES = 24


def _mode_animation_amplitude(problem) -> float:
    """The amplitude of the animated mode shapes: a tenth of the body's largest extent."""
    import numpy as np
    x = problem.dynamic.model.body.mesh.nodes
    return 0.1 * float(np.ptp(x, axis=0).max() or 1.0)


def write_modes_rerun(path: str, scene_name: str, modes) -> None:
    """Animated mode shapes in a rerun recording: mode k over one period on the ``time`` timeline from k to
    k + 1 (``MODE_FRAMES`` frames), amplitude a tenth of the body size; ``outputs/frequency_hz`` per mode."""
    import numpy as np

    from flexbody.outputs.rerun_log import RerunLogger
    p = modes.problem
    mesh = p.dynamic.model.body.mesh
    amp = _mode_animation_amplitude(p)
    step = 0
    with RerunLogger(path, mesh, scene_name, kind="dynamic", color_range=(0.0, amp)) as log:
        for k, w in enumerate(modes.frequencies):
            for j in range(MODE_FRAMES):
                phase = 2 * np.pi * j / MODE_FRAMES
                shown = p.state.copy()
                shown.x = p.state.x + amp * modes.nodal_displacements(k, phase)
                log.log_step(step, k + j / MODE_FRAMES, shown, {"mode": k + 1, "frequency_hz": w / (2 * np.pi)})
                step += 1


def write_modes_hdf5(path: str, scene_name: str, record: dict, modes) -> None:
    """The modes in an HDF5 file (docs/output_formats.md, format ``flexbody-modes``): the mesh as in
    ``flexbody-hdf5``, the equilibrium state, and per mode its frequency and complex nodal translations."""
    import h5py
    import numpy as np

    from flexbody.outputs.hdf5 import quaternions_from_matrices
    p = modes.problem
    mesh = p.dynamic.model.body.mesh
    shapes = np.stack([modes.nodal_displacements(k) + 1j * modes.nodal_displacements(k, -np.pi / 2)
                       for k in range(len(modes.frequencies))])
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "flexbody-modes"
        f.attrs["format_version"] = 1
        f.attrs["scene"] = scene_name
        f.attrs["frame"] = record["frame"]
        f.attrs["omega"] = np.asarray(record["omega_vector"])
        g = f.create_group("mesh")
        g.create_dataset("nodes", data=mesh.nodes)
        g.create_dataset("elements", data=mesh.elements.astype(np.int64))
        g.create_dataset("directors", data=mesh.directors)
        e = f.create_group("equilibrium")
        e.create_dataset("x", data=p.state.x)
        e.create_dataset("frames", data=quaternions_from_matrices(p.state.frames))
        m = f.create_group("modes")
        m.create_dataset("frequency_rad_s", data=np.asarray(record["frequencies_rad_s"]))
        m.create_dataset("shape_real", data=shapes.real)
        m.create_dataset("shape_imag", data=shapes.imag)
        for key in ("nodal_diameters", "nodal_circles"):
            m.create_dataset(key, data=np.array([-1 if r[key] is None else r[key] for r in record["modes"]]))
