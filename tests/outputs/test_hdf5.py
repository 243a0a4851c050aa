"""HDF5 results file: layout, round trip, quaternions at every angle, a crashed run's file, bad paths."""

import json
from pathlib import Path
import re
import textwrap
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

from flexbody.lie import so3
from flexbody.outputs.hdf5 import (Hdf5Writer, matrices_from_quaternions, quaternions_from_matrices,
                                   read_hdf5, record_stats)
from tests.outputs.common import run_python, square_mesh


def random_rotations(rng, n):
    return np.array([so3.exp(v) for v in rng.normal(size=(n, 3))])


def states(mesh, k, seed=0):
    rng = np.random.default_rng(seed)
    n = len(mesh.nodes)
    return [SimpleNamespace(x=mesh.nodes + 0.1 * (i + 1) * rng.normal(size=(n, 3)),
                            frames=random_rotations(rng, n)) for i in range(k)]


def write_run(path, mesh, sts, close=True, kind="static"):
    w = Hdf5Writer(path, mesh, "square", {"nx": 2, "E": 1e6, "axis": np.array([0.0, 1.0, 0.0]), "name": "sq"},
                   ["W_A", "U_B"], kind=kind)
    for i, st in enumerate(sts):
        w.write_step(i + 1, 0.25 * (i + 1), st, {"W_A": float(i), "U_B": -float(i)},
                     {"iterations": 3 + i, "residual": 10.0 ** -(8 + i), "wall_time": 0.01 * i})
    if close:
        w.close()
    return w


def test_layout_and_round_trip(tmp_path):
    mesh, path = square_mesh(), tmp_path / "run.h5"
    sts = states(mesh, 3)
    write_run(path, mesh, sts)
    with h5py.File(path, "r") as f:  # a closed file opens with plain h5py
        assert f.attrs["format"] == "flexbody-hdf5" and f.attrs["scene"] == "square"
        assert f.attrs["kind"] == "static" and f.attrs["flexbody_version"]
        assert json.loads(f.attrs["parameters"]) == {"nx": 2, "E": 1e6, "axis": [0.0, 1.0, 0.0], "name": "sq"}
        assert f["mesh/nodes"].shape == (9, 3) and f["mesh/elements"].shape == (2, 6)
        assert f["mesh/directors"].shape == (9, 3)
        assert f["steps/x"].shape == (3, 9, 3) and f["steps/frames"].shape == (3, 9, 4)
        for name in ("index", "load_factor", "tracked/W_A", "tracked/U_B", "stats/iterations",
                     "stats/residual", "stats/wall_time"):
            assert f["steps"][name].shape == (3,)
        q = f["steps/frames"][()]
        assert np.allclose(np.linalg.norm(q, axis=-1), 1.0) and np.all(q[..., 0] >= 0)
    d = read_hdf5(path)
    assert d["scene"] == "square" and d["kind"] == "static" and d["parameters"]["nx"] == 2
    np.testing.assert_array_equal(d["nodes"], mesh.nodes)
    np.testing.assert_array_equal(d["elements"], mesh.elements)
    np.testing.assert_array_equal(d["step"], [1, 2, 3])
    np.testing.assert_allclose(d["load_factor"], [0.25, 0.5, 0.75])
    np.testing.assert_array_equal(d["x"], np.array([s.x for s in sts]))
    np.testing.assert_allclose(d["frames"], np.array([s.frames for s in sts]), atol=1e-14)
    np.testing.assert_array_equal(d["tracked"]["W_A"], [0.0, 1.0, 2.0])
    np.testing.assert_array_equal(d["stats"]["iterations"], [3, 4, 5])
    np.testing.assert_allclose(d["stats"]["residual"], [1e-8, 1e-9, 1e-10])


def test_dynamic_kind_writes_time_and_missing_values_are_nan(tmp_path):
    mesh, path = square_mesh(), tmp_path / "dyn.h5"
    with Hdf5Writer(path, mesh, "square", {}, ["W_A"], kind="dynamic") as w:
        w.write_step(0, 0.001, states(mesh, 1)[0], {}, {"iterations": 2})
        with pytest.raises(KeyError, match="not declared"):
            w.write_step(1, 0.002, states(mesh, 1)[0], {"nope": 1.0}, {})
    d = read_hdf5(path)
    assert "time" in d and "load_factor" not in d
    np.testing.assert_allclose(d["time"], [0.001])
    assert np.isnan(d["tracked"]["W_A"][0]) and np.isnan(d["stats"]["residual"][0])
    assert d["stats"]["iterations"][0] == 2


def test_record_stats_reads_a_step_record():
    rec = SimpleNamespace(step=1, load_factor=0.5, iterations=4, residuals=[1.0, 1e-3, 1e-9], wall_time=0.2)
    assert record_stats(rec) == {"iterations": 4, "residual": 1e-9, "wall_time": 0.2}


def test_quaternion_round_trip_at_every_angle_including_near_pi():
    rng = np.random.default_rng(1)
    axes = rng.normal(size=(400, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = np.concatenate([rng.uniform(0, np.pi, 100), np.pi - np.logspace(-12, -1, 100), np.full(100, np.pi),
                             np.logspace(-12, -1, 100)])
    R = np.array([so3.exp(a * ax) for a, ax in zip(angles, axes)])
    q = quaternions_from_matrices(R)
    # the exact quaternion (cos a/2, sin a/2 axis), up to sign at a = pi
    q_exact = np.concatenate([np.cos(angles / 2)[:, None], np.sin(angles / 2)[:, None] * axes], axis=1)
    sign = np.where(np.sum(q * q_exact, axis=1) < 0, -1.0, 1.0)[:, None]
    np.testing.assert_allclose(sign * q, q_exact, atol=2e-15)
    assert np.all(q[:, 0] >= 0)
    np.testing.assert_allclose(matrices_from_quaternions(q), R, atol=2e-15)
    # batched shapes and the identity
    assert quaternions_from_matrices(np.tile(np.eye(3), (2, 5, 1, 1))).shape == (2, 5, 4)
    np.testing.assert_array_equal(quaternions_from_matrices(np.eye(3)), [1.0, 0.0, 0.0, 0.0])
    # agrees with flexbody.lie.so3's scalar version
    for Ri in R[::37]:
        np.testing.assert_allclose(quaternions_from_matrices(Ri), so3._quaternion(Ri), atol=2e-15)


def test_unclosed_file_is_readable_by_another_process(tmp_path):
    """Three steps written and flushed, writer still open (as after a crash): another process reads them."""
    mesh, path = square_mesh(), tmp_path / "partial.h5"
    w = write_run(path, mesh, states(mesh, 3), close=False)
    try:
        code = textwrap.dedent(f"""
            from flexbody.outputs.hdf5 import read_hdf5
            d = read_hdf5({str(path)!r})
            print(len(d["step"]), d["x"].shape, d["tracked"]["W_A"].tolist())
        """)
        out = run_python(code)
        assert out.returncode == 0, out.stderr
        assert out.stdout.split("\n")[0] == "3 (3, 9, 3) [0.0, 1.0, 2.0]"
    finally:
        w.close()


def test_file_left_by_a_killed_writer_is_readable(tmp_path):
    path = tmp_path / "crashed.h5"
    code = textwrap.dedent(f"""
        import os, sys
        sys.path.insert(0, {str(Path(__file__).parent)!r})
        from test_hdf5 import square_mesh, states, write_run
        mesh = square_mesh()
        write_run({str(path)!r}, mesh, states(mesh, 3), close=False)
        os._exit(0)  # no close, no cleanup
    """)
    out = run_python(code)
    assert out.returncode == 0, out.stderr
    d = read_hdf5(path)
    np.testing.assert_array_equal(d["step"], [1, 2, 3])
    assert d["frames"].shape == (3, 9, 3, 3)


def test_unwritable_path_gives_a_clear_error(tmp_path):
    mesh = square_mesh()
    bad = tmp_path / "no" / "such" / "dir" / "run.h5"
    with pytest.raises(OSError, match="no/such/dir"):
        Hdf5Writer(bad, mesh, "square", {}, [])
    with pytest.raises(OSError, match=re.escape(str(tmp_path))):
        Hdf5Writer(tmp_path, mesh, "square", {}, [])  # a directory
    with pytest.raises(ValueError, match="kind"):
        Hdf5Writer(tmp_path / "a.h5", mesh, "square", {}, [], kind="quasi")
    with pytest.raises(ValueError, match="name"):
        Hdf5Writer(tmp_path / "b.h5", mesh, "square", {}, ["a/b"])


def test_write_after_close_and_wrong_shapes_are_errors(tmp_path):
    mesh = square_mesh()
    w = Hdf5Writer(tmp_path / "c.h5", mesh, "square", {}, [])
    with pytest.raises(ValueError, match="state.x"):
        w.write_step(0, 0.1, SimpleNamespace(x=np.zeros((3, 3)), frames=np.tile(np.eye(3), (3, 1, 1))), {}, {})
    w.close()
    w.close()  # idempotent
    with pytest.raises(ValueError, match="closed"):
        w.write_step(0, 0.1, states(mesh, 1)[0], {}, {})
