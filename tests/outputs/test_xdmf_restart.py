"""ParaView (XDMF) output read back with meshio, the HDF5 stress/motion fields, and restarts from an HDF5
file against the uninterrupted run (static load control and dynamic generalized-alpha)."""

import json

import numpy as np
import pytest

meshio = pytest.importorskip("meshio")

from flexbody.cli import main
from flexbody.outputs.hdf5 import read_hdf5

pytestmark = pytest.mark.usefixtures("one_numba_thread")

STATIC = ["cantilever_end_shear", "--set", "nx=4", "--set", "steps=4", "--quiet"]
DYNAMIC = ["swinging_strip", "--set", "nx=4", "--set", "end_time=0.0168", "--set", "output_every=2",
           "--set", "policy='full'", "--quiet"]


def _run(args, capsys=None):
    code = main(["run", *args])
    assert code == 0
    return code


def _read_xdmf(path):
    reader = meshio.xdmf.TimeSeriesReader(str(path))
    points, cells = reader.read_points_cells()
    steps = [reader.read_data(k) for k in range(reader.num_steps)]
    return points, cells, steps


@pytest.mark.parametrize("args", [STATIC, DYNAMIC], ids=["static", "dynamic"])
def test_xdmf_series_reads_back_with_meshio(tmp_path, args):
    h5, xdmf = tmp_path / "run.h5", tmp_path / "run.xdmf"
    _run([*args, "--h5", str(h5), "--xdmf", str(xdmf), "--stresses"])
    d = read_hdf5(h5)
    points, cells, steps = _read_xdmf(xdmf)
    np.testing.assert_array_equal(points, d["nodes"])
    assert cells[0].type == "triangle6"
    np.testing.assert_array_equal(cells[0].data, d["elements"])
    where = d["time"] if d["kind"] == "dynamic" else d["load_factor"]
    assert len(steps) == len(where)
    np.testing.assert_allclose([t for t, _, _ in steps], where, rtol=1e-12)
    for k, (_, point, cell) in enumerate(steps):
        np.testing.assert_allclose(point["displacement"], d["x"][k] - d["nodes"], rtol=0, atol=1e-14)
        np.testing.assert_allclose(point["director"], d["frames"][k][:, :, 2], atol=1e-12)
        np.testing.assert_array_equal(point["bending_moment"], d["fields"]["resultants_nodal"][k][:, 3:6])
        np.testing.assert_array_equal(point["reaction_force"], d["fields"]["reaction_force"][k])
        np.testing.assert_array_equal(cell["strain_energy"][0], d["fields"]["element_strain_energy"][k])
        for name in ("membrane_force", "shear_force", "principal_membrane_force", "principal_direction",
                     "von_mises_top", "von_mises_bottom", "reaction_moment"):
            assert name in point and np.all(np.isfinite(point[name]))
        for name in ("membrane_force", "bending_moment", "von_mises_top_max", "von_mises_bottom_max"):
            assert cell[name][0].shape[0] == len(d["elements"])
        if d["kind"] == "dynamic":
            np.testing.assert_array_equal(point["velocity"], d["fields"]["velocity"][k])
            assert "angular_acceleration" in point
    if d["kind"] == "static":       # a real residual: finite and within the Newton tolerance of the loads
        assert np.all(np.isfinite(d["stats"]["residual"]))
        # the clamp carries the end shear P = lam P_max (P_max = 4) at the last step
        np.testing.assert_allclose(d["fields"]["reaction_force"][-1].sum(axis=0), [0, 0, -4.0], rtol=1e-7, atol=1e-7)
    else:                           # gravity: the clamp carries the strip's weight less its inertia
        assert np.all(np.isfinite(d["fields"]["velocity"])) and np.abs(d["fields"]["velocity"][-1]).max() > 0


def test_static_restart_continues_the_path(tmp_path):
    full, part = tmp_path / "full.h5", tmp_path / "part.h5"
    _run([*STATIC, "--h5", str(full)])
    _run([*STATIC, "--h5", str(part), "--restart", f"{full}:2"])
    a, b = read_hdf5(full), read_hdf5(part)
    np.testing.assert_array_equal(b["step"], [3, 4])
    np.testing.assert_array_equal(b["load_factor"], a["load_factor"][2:])
    size = np.ptp(a["x"][-1] - a["nodes"])
    assert np.abs(b["x"] - a["x"][2:]).max() <= 1e-8 * size


def test_dynamic_restart_gives_the_uninterrupted_run(tmp_path):
    """Positions, frames, v, vdot and the pseudo-acceleration a saved at step 8 of 14: the continuation
    matches the uninterrupted run ("full" policy, fresh matrices in both: measured bit for bit)."""
    full, part = tmp_path / "full.h5", tmp_path / "part.h5"
    _run([*DYNAMIC, "--h5", str(full)])
    _run([*DYNAMIC, "--h5", str(part), "--restart", f"{full}:8"])
    a, b = read_hdf5(full), read_hdf5(part)
    k = int(np.flatnonzero(a["step"] == 8)[0])
    np.testing.assert_array_equal(b["step"], a["step"][k:])
    np.testing.assert_allclose(b["time"], a["time"][k:], rtol=1e-13)
    size = np.ptp(a["x"][-1] - a["nodes"])
    assert np.abs(b["x"] - a["x"][k:]).max() <= 1e-9 * size
    v = np.abs(a["fields"]["velocity"]).max()
    assert np.abs(b["fields"]["velocity"] - a["fields"]["velocity"][k:]).max() <= 1e-8 * v
    np.testing.assert_allclose(b["stats"]["total_energy"], a["stats"]["total_energy"][k:], rtol=1e-9)


@pytest.mark.parametrize("spec, message", [
    ("missing.h5", "does not exist"), ("{full}:5", "is not in"), ("{full}:99", "is not in")])
def test_restart_refuses_a_bad_file_or_step(tmp_path, capsys, spec, message):
    full = tmp_path / "full.h5"
    _run([*STATIC, "--h5", str(full)])
    with pytest.raises(SystemExit) as exc:
        main(["run", *STATIC, "--restart", spec.format(full=full)])
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_restart_refuses_another_mesh_or_scene(tmp_path):
    full = tmp_path / "full.h5"
    _run([*STATIC, "--h5", str(full)])
    with pytest.raises(SystemExit, match="another mesh"):
        main(["run", "cantilever_end_shear", "--set", "nx=6", "--quiet", "--restart", str(full)])
    with pytest.raises(SystemExit, match="not of this"):
        main(["run", "cantilever_end_moment", "--set", "nx=4", "--quiet", "--restart", str(full)])
    with pytest.raises(SystemExit, match="--stresses writes"):
        main(["run", *STATIC, "--stresses"])


ARC = ["pullout_cylinder", "--set", "n_circ=4", "--set", "n_axial=4", "--quiet"]


def test_arc_length_restart_gives_the_uninterrupted_path(tmp_path):
    """The pulled cylinder (arc length, 41 steps, two limit points at steps 17 and 19) restarted at step 15
    from its HDF5 file (the arc length of the next step, the first one, the direction of the last step and
    its load sign saved with every step): the same steps, Newton iterations and limit points; load factors
    and positions to 1e-6 of their ranges, ten times the corrector's tolerance (rtol 1e-7 in this scene): the
    first predictor solves on a fresh tangent where the uninterrupted run reused its last factorization, so
    each point is the same intersection of the path with the arc, up to where the corrector stops. Measured:
    5e-13 on this mesh, 1.3e-7 of the displacement range on the default 12 x 8 mesh. A lost direction or arc
    length would put the points elsewhere on the path (steps of 0.026 in the load factor here)."""
    full, part = tmp_path / "full.h5", tmp_path / "part.h5"
    _run([*ARC, "--h5", str(full)])
    _run([*ARC, "--h5", str(part), "--restart", f"{full}:15", "--json", str(tmp_path / "part.json")])
    a, b = read_hdf5(full), read_hdf5(part)
    summary = json.loads((tmp_path / "part.json").read_text())
    assert [c["step"] for c in summary["stability"]["critical_points"]] == [17, 19]   # numbered on
    np.testing.assert_array_equal(b["step"], a["step"][15:])
    np.testing.assert_array_equal(b["stats"]["iterations"], a["stats"]["iterations"][15:])
    np.testing.assert_array_equal(b["stats"]["critical_point"], a["stats"]["critical_point"][15:])
    assert np.count_nonzero(b["stats"]["critical_point"]) == 2       # both limit points lie after the restart
    assert np.abs(b["load_factor"] - a["load_factor"][15:]).max() <= 1e-6 * np.ptp(a["load_factor"])
    size = np.ptp(a["x"][-1] - a["nodes"])
    assert np.abs(b["x"] - a["x"][15:]).max() <= 1e-6 * size
    np.testing.assert_allclose(b["fields"]["restart_arc"], a["fields"]["restart_arc"][15:], rtol=1e-6)


def test_arc_length_restart_at_the_end_of_the_path_is_refused(tmp_path, capsys):
    full = tmp_path / "full.h5"
    _run([*ARC, "--h5", str(full)])
    assert main(["run", *ARC, "--restart", str(full)]) != 0
    err = capsys.readouterr().err
    assert "the path ended there" in err


def test_turning_frame_restart_gives_the_uninterrupted_run(tmp_path):
    """The kicked spinning annulus (a steady-spin start: solved in the turning frame, saved in the inertial one)
    restarted at step 3 of 6: the saved inertial state maps back into the frame."""
    from pathlib import Path
    example = str(Path(__file__).resolve().parents[2] / "examples" / "kicked_spinning_annulus.toml")
    args = [example, "--set", "end_time=0.018849555921538", "--set", "output_every=1", "--set", "policy='full'",
            "--quiet"]
    full, part = tmp_path / "full.h5", tmp_path / "part.h5"
    _run([*args, "--h5", str(full), "--json", str(tmp_path / "full.json")])
    assert json.loads((tmp_path / "full.json").read_text())["frame"] == "turning"
    _run([*args, "--h5", str(part), "--restart", f"{full}:3"])
    a, b = read_hdf5(full), read_hdf5(part)
    k = int(np.flatnonzero(a["step"] == 3)[0])
    np.testing.assert_array_equal(b["step"], a["step"][k:])
    size = np.ptp(a["nodes"])
    assert np.abs(b["x"] - a["x"][k:]).max() <= 1e-9 * size
    v = np.abs(a["fields"]["velocity"]).max()
    assert np.abs(b["fields"]["velocity"] - a["fields"]["velocity"][k:]).max() <= 1e-8 * v
