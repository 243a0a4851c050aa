"""Output files that stay sound (issue 14, "lost or corrupt output"): a full disk, a second writer, a damaged
file, an interrupted step write, load factors beyond rerun's timeline."""

import os
import subprocess
import sys
import textwrap
import time
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

from flexbody.outputs.files import DiskFullError, OutputLockedError
from flexbody.outputs.hdf5 import Hdf5Writer, read_hdf5
from tests.outputs.common import REPO, run_python, square_mesh


def state(mesh, k):
    return SimpleNamespace(x=mesh.nodes + 0.01 * k, frames=np.tile(np.eye(3), (len(mesh.nodes), 1, 1)))


def fine_mesh(n=12):
    """A larger stand-in mesh (n x n cells, 2 n^2 six-node triangles) so that a few hundred KiB fill quickly."""
    from flexbody.mesh import generators
    return generators.strip(1.0, 1.0, n, n)


def test_disk_full_stops_the_hdf5_file_at_a_complete_step(small_disk):
    """Before: the write hit ENOSPC inside HDF5, the run crashed (exit 139) and the file did not open."""
    mesh, path = fine_mesh(), small_disk / "run.h5"
    w = Hdf5Writer(path, mesh, "fill", {}, ["a"])
    written = 0
    with pytest.raises(DiskFullError, match=r"disk full after \d+ steps: HDF5 output .*run\.h5"):
        for k in range(10_000):
            w.write_step(k + 1, 0.1 * k, state(mesh, k), {"a": float(k)})
            written += 1
    w.close()
    d = read_hdf5(path)
    assert written > 3 and d["step"].tolist() == list(range(1, written + 1))
    assert np.all(np.isfinite(d["x"])) and np.allclose(d["x"][-1], mesh.nodes + 0.01 * (written - 1))
    with h5py.File(path, "r") as f:  # closed normally: any HDF5 reader opens it
        assert f["steps/index"].shape == (written,)


def test_disk_full_stops_the_rerun_recording_at_a_complete_step(small_disk):
    """Before: rerun's file sink failed in its own thread, its flush never returned, the file was truncated."""
    pytest.importorskip("rerun")
    from flexbody.outputs.rerun_log import RerunLogger
    from tests.test_cli import read_rrd
    mesh, path = fine_mesh(), small_disk / "run.rrd"
    w = RerunLogger(path, mesh, "fill")
    written = 0
    with pytest.raises(DiskFullError, match=r"disk full after \d+ steps: rerun recording .*run\.rrd"):
        for k in range(10_000):
            w.log_step(k + 1, 0.1 * k, state(mesh, k), {"a": float(k)})
            w.flush()
            written += 1
    w.close()
    assert written > 3 and read_rrd(path)["/body/mesh"] == {"static": 1, "steps": written}


HOLD = textwrap.dedent("""
    import sys, time
    from tests.outputs.common import square_mesh
    from tests.outputs.test_lost_output import state
    from flexbody.outputs.hdf5 import Hdf5Writer
    mesh = square_mesh()
    w = Hdf5Writer(sys.argv[1], mesh, "first", {}, ["a"])
    w.write_step(1, 0.5, state(mesh, 1), {"a": 1.0})
    print("ready", flush=True)
    time.sleep(60)
""")


def test_a_second_writer_is_refused_and_the_first_file_is_kept(tmp_path):
    """Before: the second writer truncated the file while the first was writing it (SWMR drops HDF5's lock)."""
    path = tmp_path / "shared.h5"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    first = subprocess.Popen([sys.executable, "-c", HOLD, str(path)], stdout=subprocess.PIPE, text=True, env=env,
                             cwd=REPO)
    try:
        assert first.stdout.readline().strip() == "ready"
        with pytest.raises(OutputLockedError, match=rf"HDF5 output .*shared\.h5.* is in use by process {first.pid}"):
            Hdf5Writer(path, square_mesh(), "second", {}, ["a"])
        d = read_hdf5(path)  # a reader may still open it while it is written
        assert d["scene"] == "first" and d["step"].tolist() == [1]
    finally:
        first.kill()
        first.wait()
    Hdf5Writer(path, square_mesh(), "third", {}, ["a"]).close()  # the lock went with the process


def test_reading_a_damaged_file_fails_after_a_bounded_wait(tmp_path):
    """Before: the SWMR reader retried a bad metadata checksum 100 times with doubling waits (hours)."""
    path = tmp_path / "damaged.h5"
    out = run_python(textwrap.dedent(f"""
        import os
        from tests.outputs.common import square_mesh
        from tests.outputs.test_lost_output import state
        from flexbody.outputs.hdf5 import Hdf5Writer
        mesh = square_mesh()
        w = Hdf5Writer({str(path)!r}, mesh, "crash", {{}}, ["a"])
        for k in range(5):
            w.write_step(k + 1, 0.1 * k, state(mesh, k), {{"a": float(k)}})
        os._exit(0)
    """))
    assert out.returncode == 0, out.stderr
    data = bytearray(path.read_bytes())
    header = data.index(b"EAHD")  # an extensible-array header (chunk index of a /steps data set)
    data[header + 20] ^= 0xFF
    path.write_bytes(bytes(data))
    t0 = time.perf_counter()
    code = f"from flexbody.outputs.hdf5 import read_hdf5\nread_hdf5({str(path)!r})"
    try:
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, cwd=REPO,
                             env=dict(os.environ, PYTHONPATH=str(REPO)))
    except subprocess.TimeoutExpired:
        pytest.fail("read_hdf5 of a damaged file still waiting after 60 s")
    assert time.perf_counter() - t0 < 30
    assert out.returncode == 1
    last = out.stderr.strip().splitlines()[-1]
    assert last.startswith(f"OSError: cannot read HDF5 output {str(path)!r}: ") and "checksum" in last


def test_an_interrupted_step_write_is_not_counted(tmp_path, monkeypatch):
    """Ctrl-C between extending /steps/index and writing it: before, that row read 0 and counted as a step."""
    mesh, path = square_mesh(), tmp_path / "cut.h5"
    w = Hdf5Writer(path, mesh, "cut", {}, ["a"])
    for k in range(2):
        w.write_step(k + 1, 0.1 * k, state(mesh, k), {"a": float(k)})
    setitem = h5py.Dataset.__setitem__

    def interrupted(ds, key, value):
        if ds.name == "/steps/index":
            raise KeyboardInterrupt
        setitem(ds, key, value)

    monkeypatch.setattr(h5py.Dataset, "__setitem__", interrupted)
    with pytest.raises(KeyboardInterrupt):
        w.write_step(3, 0.2, state(mesh, 2), {"a": 2.0})
    monkeypatch.undo()
    w.close()
    d = read_hdf5(path)
    assert d["step"].tolist() == [1, 2] and d["tracked"]["a"].tolist() == [0.0, 1.0]


def test_rerun_clamps_load_factors_beyond_its_timeline(tmp_path):
    """Before: a load factor above 9.2e9 overflowed rerun's int64 nanoseconds (OverflowError, run aborted)."""
    pytest.importorskip("rerun")
    from flexbody.outputs import rerun_log
    from tests.test_cli import read_rrd
    mesh, path = square_mesh(), tmp_path / "big.rrd"
    with rerun_log.RerunLogger(path, mesh, "big", reference={"a": ([1e9, 1e10, 1e12], [0.0, 1.0, 2.0])}) as w:
        for k, lf in enumerate([1.0, 1e10, -1e300]):
            w.log_step(k + 1, lf, state(mesh, k), {"a": float(k)})
    assert read_rrd(path)["/body/mesh"] == {"static": 1, "steps": 3}
    from rerun.chunk import RrdReader
    times = []
    for chunk in RrdReader(str(path)).stream().collect().stream():
        if chunk.entity_path == "/outputs/a":
            times += chunk.to_record_batch().column("load_factor").cast("int64").to_pylist()
    limit = int(rerun_log.TIMELINE_LIMIT * rerun_log.LOAD_FACTOR_UNIT)     # the load factor in millionths
    assert sorted(times) == [-limit, rerun_log.LOAD_FACTOR_UNIT, limit]
