"""Rerun recording: read the .rrd back and check its content; rerun is never imported unless requested."""

import textwrap
from types import SimpleNamespace

import numpy as np
import pytest

from flexbody.lie import so3
from flexbody.outputs.rerun_log import colormap, display_triangles
from tests.outputs.common import run_python, square_mesh


def states(mesh, k):
    rng = np.random.default_rng(3)
    n = len(mesh.nodes)
    return [SimpleNamespace(x=mesh.nodes + 0.1 * (i + 1) * rng.normal(size=(n, 3)),
                            frames=np.array([so3.exp(v) for v in 0.3 * rng.normal(size=(n, 3))]))
            for i in range(k)]


def no_rerun_after(code: str) -> None:
    script = code + "\nimport sys\nassert 'rerun' not in sys.modules, sorted(m for m in sys.modules if 'rerun' in m)\n"
    out = run_python(script)
    assert out.returncode == 0, out.stderr


def test_output_modules_and_hdf5_writing_do_not_import_rerun(tmp_path):
    no_rerun_after(textwrap.dedent(f"""
        from types import SimpleNamespace
        import numpy as np
        import flexbody, flexbody.outputs, flexbody.outputs.hdf5, flexbody.outputs.rerun_log
        from flexbody.outputs.hdf5 import Hdf5Writer
        mesh = SimpleNamespace(nodes=np.eye(3), elements=np.array([[0, 1, 2, 0, 1, 2]]), directors=np.eye(3))
        with Hdf5Writer({str(tmp_path / "a.h5")!r}, mesh, "s", {{}}, ["w"]) as w:
            w.write_step(1, 1.0, SimpleNamespace(x=np.eye(3), frames=np.tile(np.eye(3), (3, 1, 1))), {{"w": 0.0}}, {{}})
    """))


def test_scenes_and_cli_do_not_import_rerun():
    try:
        from flexbody.mesh import Tri6Mesh  # noqa: F401  (the scenes need the mesh package)
    except ImportError:
        pytest.skip("flexbody.mesh.Tri6Mesh not available yet")
    no_rerun_after("import flexbody.scenes, flexbody.scenes.scene, flexbody.scenes.builtin, flexbody.cli")


def test_display_triangles_and_colormap():
    tri = display_triangles(np.array([[0, 1, 2, 3, 4, 5]]))
    np.testing.assert_array_equal(tri, [[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]])
    c = colormap(np.array([0.0, 0.5, 1.0, 2.0, -1.0, np.nan]), 0.0, 1.0)
    np.testing.assert_array_equal(c[0], [68, 1, 84])
    np.testing.assert_array_equal(c[1], [33, 145, 140])
    np.testing.assert_array_equal(c[2], [253, 231, 37])
    np.testing.assert_array_equal(c[3], c[2])  # clipped
    np.testing.assert_array_equal(c[4], c[0])
    np.testing.assert_array_equal(c[5], c[0])
    assert c.dtype == np.uint8 and np.all(colormap(np.ones(3), 1.0, 1.0) == c[0])  # empty range


def read_chunks(path):
    """{entity path: [(is_static, pyarrow record batch), ...]} of a .rrd file, read with rerun's own reader."""
    from rerun.chunk import RrdReader
    store = RrdReader(str(path)).store()
    chunks = {}
    for chunk in store.stream().collect().stream():
        chunks.setdefault(chunk.entity_path, []).append((chunk.is_static, chunk.to_record_batch()))
    return chunks


def column(batches, name, static):
    import pyarrow as pa
    parts = [rb.column(name) for s, rb in batches if s == static and name in rb.schema.names]
    if not parts:
        return []
    col = pa.concat_arrays([p.cast(pa.int64()) if pa.types.is_duration(p.type) else p for p in parts])
    return col.to_pylist()


def test_recording_read_back(tmp_path):
    pytest.importorskip("rerun")
    from flexbody.outputs.rerun_log import RerunLogger

    mesh, path = square_mesh(), tmp_path / "run.rrd"
    sts = states(mesh, 3)
    ref = {"W_A": ([0.1, 0.5, 1.0, 1.5], [0.0, 1.0, 2.0, 3.0])}
    with RerunLogger(path, mesh, "square", directors=True, reference=ref) as log:
        for i, st in enumerate(sts):
            log.log_step(i + 1, 0.25 * (i + 1), st, {"W_A": float(i), "tip rot": 2.0 * i})
    assert path.stat().st_size > 0
    chunks = read_chunks(path)

    mesh_chunks = chunks["/body/mesh"]
    # topology: static, 4 display triangles per element, front faces on the director side (+z)
    tris = column(mesh_chunks, "Mesh3D:triangle_indices", static=True)
    assert len(tris) == 1 and len(tris[0]) == 8
    t = np.array(tris[0])
    assert sorted(map(sorted, t.tolist())) == sorted(map(sorted, display_triangles(mesh.elements).tolist()))
    p = mesh.nodes[t]
    assert np.all(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])[:, 2] > 0)
    assert column(mesh_chunks, "Mesh3D:vertex_positions", static=True) == []  # positions are never static
    # positions, colors, normals: one row per step on the step and load_factor timelines
    assert column(mesh_chunks, "step", static=False) == [1, 2, 3]
    assert column(mesh_chunks, "load_factor", static=False) == [250_000, 500_000, 750_000]  # millionths
    pos = column(mesh_chunks, "Mesh3D:vertex_positions", static=False)
    assert len(pos) == 3
    for rows, st in zip(pos, sts):
        np.testing.assert_allclose(np.array(rows), st.x, rtol=1e-6, atol=1e-6)  # stored as float32
    normals = column(mesh_chunks, "Mesh3D:vertex_normals", static=False)
    np.testing.assert_allclose(np.array(normals[2]), sts[2].frames[:, :, 2], atol=1e-6)
    colors = column(mesh_chunks, "Mesh3D:vertex_colors", static=False)
    assert len(colors) == 3 and all(len(c) == 9 for c in colors)

    arrows = column(chunks["/body/directors"], "Arrows3D:vectors", static=False)
    assert len(arrows) == 3 and len(arrows[0]) == 9

    out = chunks["/outputs/W_A"]
    assert column(out, "Scalars:scalars", static=False) == [[0.0], [1.0], [2.0]]
    assert column(out, "step", static=False) == [1, 2, 3]
    assert column(chunks["/outputs/tip\\ rot"], "Scalars:scalars", static=False) == [[0.0], [2.0], [4.0]]

    refc = chunks["/reference/W_A"]
    assert column(refc, "Scalars:scalars", static=False) == [[0.0], [1.0], [2.0], [3.0]]
    assert column(refc, "load_factor", static=False) == [100_000, 500_000, 1_000_000, 1_500_000]
    assert column(refc, "step", static=False) == []  # the reference lives on the load_factor timeline only
    assert column(refc, "SeriesPoints:names", static=True) == [["W_A (reference)"]]
    assert len(column(chunks["/stats/max_displacement"], "Scalars:scalars", static=False)) == 3


def test_dynamic_kind_uses_the_time_timeline(tmp_path):
    pytest.importorskip("rerun")
    from flexbody.outputs.rerun_log import RerunLogger

    mesh, path = square_mesh(), tmp_path / "dyn.rrd"
    with RerunLogger(path, mesh, "square", color_by=None, kind="dynamic") as log:
        for i, st in enumerate(states(mesh, 2)):
            log.log_step(i, 0.5 * i, st, {})
    chunks = read_chunks(path)
    assert column(chunks["/body/mesh"], "time", static=False) == [0, 500_000_000]
    assert "/body/directors" not in chunks
    colors = column(chunks["/body/mesh"], "Mesh3D:vertex_colors", static=False)
    assert len(set(colors[0])) == 1  # uniform


def test_bad_arguments(tmp_path):
    pytest.importorskip("rerun")
    from flexbody.outputs.rerun_log import RerunLogger

    mesh = square_mesh()
    with pytest.raises(OSError, match="no/such/dir"):
        RerunLogger(tmp_path / "no" / "such" / "dir" / "r.rrd", mesh, "square")
    with pytest.raises(ValueError, match="color_by"):
        RerunLogger(tmp_path / "r.rrd", mesh, "square", color_by="strain")
    with pytest.raises(ValueError, match="reference"):
        RerunLogger(tmp_path / "r.rrd", mesh, "square", reference={"W": ([0.1, 0.2], [1.0])})


def test_deformation_removes_the_rigid_motion():
    from flexbody.outputs.rerun_log import deformation, rigid_fit
    rng = np.random.default_rng(4)
    X = rng.normal(size=(30, 3))
    Q = so3.exp([0.4, -1.9, 2.6])                           # a large rotation and a translation
    x = X @ Q.T + [3.0, -1.0, 7.0]
    assert np.allclose(rigid_fit(X, x)[0], Q, atol=1e-12) and deformation(X, x).max() < 1e-12
    bump = np.zeros_like(X)
    bump[5] = [0.0, 0.0, 1e-4]                               # plus a small deformation: it is what remains
    w = deformation(X, x + bump)
    others = np.delete(w, 5)
    assert 0.8e-4 < w[5] < 1e-4 and others.max() < 0.15 * w[5]  # against a rigid displacement of ~9


def test_blueprint_legend_energies_and_a_fixed_colour_scale(tmp_path):
    pytest.importorskip("rerun")
    import rerun.blueprint as rrb
    from flexbody.outputs.rerun_log import RerunLogger, blueprint

    assert isinstance(blueprint(["W_A"], "static", ("W_A",)), rrb.Blueprint)
    assert isinstance(blueprint(["u"], "dynamic"), rrb.Blueprint)
    for kind, count in (("static", 2), ("dynamic", 3)):     # every plot shows the whole run on its x axis
        side = blueprint(["u"], kind).root_container.contents[1]
        plots = [v for v in side.contents if isinstance(v, rrb.TimeSeriesView)]
        assert len(plots) == count
        assert all(v.properties["TimeAxis"].view_range.as_arrow_array().to_pylist() == [{"start": None, "end": None}]
                   for v in plots)
    mesh, path = square_mesh(), tmp_path / "bp.rrd"
    ref = {"W_A": ([0.5, 1.0], [1.0, 2.0])}
    sts = states(mesh, 3)
    sts[2].x = mesh.nodes + 1e-3 * (sts[0].x - mesh.nodes)      # the last step deforms 1000x less
    with RerunLogger(path, mesh, "square", reference=ref, outputs=["W_A"]) as log:
        for i, st in enumerate(sts):
            log.log_step(i + 1, 0.25 * (i + 1), st, {"W_A": float(i)})
    chunks = read_chunks(path)
    legend = column(chunks["/body/legend"], "TextDocument:text", static=False)
    assert len(legend) == 3 and "load factor 0.75" in legend[2][0] and "without the rigid motion" in legend[0][0]
    assert legend[0][0].index("scale:") < legend[0][0].index("colour:")   # the scale first, in view
    top = [float(t[0].split(" .. ")[1].split()[0]) for t in legend]
    assert top[0] <= top[1] == top[2] > 0                    # the scale grows, never shrinks
    assert column(chunks["/stats/load_factor"], "Scalars:scalars", static=False) == [[0.25], [0.5], [0.75]]
    assert len(column(chunks["/stats/max_deformation"], "Scalars:scalars", static=False)) == 3
    from rerun.chunk import RrdReader                         # the blueprint went into the file
    assert [b.kind for b in RrdReader(str(path)).blueprints()] == ["blueprint"]


def test_a_run_coloured_by_the_von_mises_stress(tmp_path, capsys):
    pytest.importorskip("rerun")
    from flexbody.cli import main
    from flexbody.outputs.rerun_log import RerunLogger
    path = tmp_path / "s.rrd"
    assert main(["run", "cantilever_end_shear", "--set", "nx=4", "--set", "ny=1", "--set", "steps=2",
                 "--rerun", str(path), "--rerun-color", "stress", "--quiet"]) == 0
    legend = column(read_chunks(path)["/body/legend"], "TextDocument:text", static=False)
    assert len(legend) == 2 and "von Mises" in legend[-1][0]
    top = float(legend[-1][0].split(" .. ")[1].split()[0])
    assert top > 0
    mesh = square_mesh()
    with RerunLogger(tmp_path / "f.rrd", mesh, "square", color_by="stress") as log:
        with pytest.raises(ValueError, match="needs a nodal field of shape"):
            log.log_step(1, 0.5, states(mesh, 1)[0], {})
