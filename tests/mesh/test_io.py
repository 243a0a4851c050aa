"""Mesh files: gmsh round trip, three-node upgrade, physical groups as sets, and errors that name the file."""

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from flexbody.mesh import MeshError, generators
from flexbody.mesh.io import read_mesh, upgrade_to_tri6, write_mesh

pytest.importorskip("meshio")

# A unit square of two three-node triangles, an unused geometry point (node 5), a physical line "clamped"
# (x = 0), a physical point "corner" (the origin) and a physical surface. Physical tag 1 is used by both
# the point and the line group: gmsh numbers groups per dimension.
SQUARE_TRI3 = """$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
3
0 1 "corner"
1 1 "clamped"
2 7 "plate"
$EndPhysicalNames
$Nodes
5
1 0 0 0
2 1 0 0
3 1 1 0
4 0 1 0
5 5 5 0
$EndNodes
$Elements
5
1 15 2 1 1 1
2 1 2 1 4 4 1
3 2 2 7 1 1 2 3
4 2 2 7 1 1 3 4
5 15 2 0 9 5
$EndElements
"""

# the same square as two six-node triangles (gmsh type 9) with a three-node line group (type 8)
SQUARE_TRI6 = """$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
1
1 3 "bottom"
$EndPhysicalNames
$Nodes
9
1 0 0 0
2 1 0 0
3 1 1 0
4 0 1 0
5 0.5 0 0
6 1 0.5 0
7 0.5 0.5 0
8 0.5 1 0
9 0 0.5 0
$EndNodes
$Elements
3
1 8 2 3 1 1 2 5
2 9 2 0 1 1 2 3 5 6 7
3 9 2 0 1 1 3 4 7 8 9
$EndElements
"""


def _write(tmp_path, text, name="m.msh"):
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.mark.parametrize("make, coincident", [
    (lambda: generators.strip(3.0, 1.0, 3, 2, "alternate"), False),
    (lambda: generators.spherical_cap(10.0, 18.0, 3, 3, angle=math.pi / 2), False),
    (lambda: generators.cylinder(2.0, 1.0, 6, 2), False),
    (lambda: generators.slit_annulus(6.0, 10.0, 2, 6), True),
    (lambda: generators.regular_polygon(6, 1.0, 2), False),
])
def test_gmsh_round_trip_keeps_nodes_elements_directors_and_sets(tmp_path, make, coincident):
    m = make()
    path = tmp_path / "mesh.msh"
    write_mesh(m, path, point_data={"u": 2 * m.nodes, "s": m.nodes[:, 0]})
    assert path.read_text().startswith("$MeshFormat\n2.2 0 8")   # gmsh, not meshio's ANSYS guess
    r = read_mesh(path, allow_coincident_nodes=coincident)
    np.testing.assert_array_equal(r.nodes, m.nodes)
    np.testing.assert_array_equal(r.elements, m.elements)
    np.testing.assert_array_equal(r.directors, m.directors)   # exact directors kept, not re-averaged
    assert sorted(r.edge_sets) == sorted(m.edge_sets)
    for k, e in m.edge_sets.items():
        np.testing.assert_array_equal(r.edge_sets[k], e)
    assert sorted(r.node_sets) == sorted(m.node_sets)
    for k, v in m.node_sets.items():
        np.testing.assert_array_equal(r.node_sets[k], np.unique(v))


def test_vtu_round_trip_for_paraview(tmp_path):
    m = generators.cylinder(2.0, 1.0, 6, 2, angle=math.pi / 2)
    write_mesh(m, tmp_path / "m.vtu", point_data={"u": m.nodes})
    r = read_mesh(tmp_path / "m.vtu")
    np.testing.assert_array_equal(r.nodes, m.nodes)
    np.testing.assert_array_equal(r.elements, m.elements)
    np.testing.assert_allclose(r.directors, m.directors, atol=1e-15)


def test_three_node_triangles_are_upgraded_and_groups_become_sets(tmp_path):
    m = read_mesh(_write(tmp_path, SQUARE_TRI3))
    assert m.n_elements == 2 and m.n_nodes == 9          # the unused point is dropped, 5 midside nodes added
    assert m.area() == pytest.approx(1.0, rel=1e-14)
    np.testing.assert_allclose(m.directors, np.tile([0, 0, 1.0], (9, 1)))  # averaged element normals
    X = m.nodes[m.elements]
    np.testing.assert_allclose(X[:, 3], 0.5 * (X[:, 0] + X[:, 1]))
    np.testing.assert_allclose(X[:, 4], 0.5 * (X[:, 1] + X[:, 2]))
    np.testing.assert_allclose(X[:, 5], 0.5 * (X[:, 2] + X[:, 0]))
    # the line group of tag 1 and the point group of tag 1 are different groups
    clamped = m.edge_set("clamped")
    assert clamped.shape == (1, 3)
    np.testing.assert_allclose(m.nodes[clamped[0]], [[0, 1, 0], [0, 0.5, 0], [0, 0, 0]])
    np.testing.assert_allclose(m.nodes[m.node_set("clamped"), 0], 0.0)
    assert len(m.node_set("clamped")) == 3
    np.testing.assert_allclose(m.nodes[m.node_set("corner")], [[0, 0, 0]])
    assert "plate" not in m.node_sets        # a surface group is no node or edge set


def test_six_node_file_with_a_line3_group(tmp_path):
    m = read_mesh(_write(tmp_path, SQUARE_TRI6))
    np.testing.assert_array_equal(m.elements, [[0, 1, 2, 4, 5, 6], [0, 2, 3, 6, 7, 8]])
    np.testing.assert_array_equal(m.edge_set("bottom"), [[0, 4, 1]])
    np.testing.assert_array_equal(m.node_set("bottom"), [0, 1, 4])


def test_upgrade_shares_midside_nodes():
    nodes = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    x, e = upgrade_to_tri6(nodes, [[0, 1, 2], [0, 2, 3]])
    assert len(x) == 4 + 5
    assert e[0, 5] == e[1, 3]                 # the diagonal's midside node is one node
    np.testing.assert_allclose(x[e[0, 5]], [0.5, 0.5, 0])
    with pytest.raises(MeshError, match="a triangle refers to node 7, which does not exist"):
        upgrade_to_tri6(nodes, [[0, 1, 7]])
    with pytest.raises(MeshError, match=r"triangles must have shape \(m, 3\)"):
        upgrade_to_tri6(nodes, [[0, 1, 2, 3]])


def _replace(text, old, new):
    assert old in text
    return text.replace(old, new)


@pytest.mark.parametrize("text, match", [
    ("", "cannot read mesh file"),
    ("hello world\n", "cannot read mesh file"),
    ("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n5\n1 0 0 0\n", "is truncated: section \\$Nodes is not closed"),
    (SQUARE_TRI3[:SQUARE_TRI3.index("$EndElements")], "is truncated: section \\$Elements is not closed"),
    (_replace(SQUARE_TRI3, "$Nodes\n5\n", "$Nodes\n6\n"), "cannot read mesh file"),
    (_replace(SQUARE_TRI3, "2 7 1 1 3 4", "2 7 1 1 3 44"), "cannot read mesh file"),
    (_replace(SQUARE_TRI3, "$EndPhysicalNames", "$EndNodes"), "is malformed"),
    (_replace(SQUARE_TRI3, "4 2 2 7 1 1 3 4", "4 3 2 7 1 1 3 4 2"), r"cells of type \['quad'\]"),
    (_replace(_replace(SQUARE_TRI3, "3 2 2 7 1 1 2 3", "3 1 2 0 1 1 2"), "4 2 2 7 1 1 3 4", "4 1 2 0 1 3 4"),
     "has no triangles"),
    (_replace(SQUARE_TRI3, "2 1 2 1 4 4 1", "2 1 2 1 4 2 4"), r"physical group 'clamped' has the line \(1, 3\), "
                                                              "which is no element edge"),
    (_replace(SQUARE_TRI3, "4 2 2 7 1 1 3 4", "4 2 2 7 1 1 4 3"), "normals around node 0 cancel"),
    (_replace(SQUARE_TRI3, "3 1 1 0", "3 nan 1 0"), "node 2 has non-finite coordinates"),
    (_replace(SQUARE_TRI3, "4 0 1 0\n", "4 0 0 0\n"), r"element 1 is degenerate \(zero area at its node"),
])
def test_malformed_files_raise_a_mesh_error_naming_the_file(tmp_path, text, match):
    path = _write(tmp_path, text, "bad.msh")
    with pytest.raises(MeshError, match=match) as info:
        read_mesh(path)
    assert str(path) in str(info.value)


def test_missing_file_folder_and_unwritable_paths(tmp_path):
    with pytest.raises(MeshError, match=r"mesh file '.*nothere\.msh' does not exist"):
        read_mesh(tmp_path / "nothere.msh")
    with pytest.raises(MeshError, match="is not a file"):
        read_mesh(tmp_path)
    m = generators.strip(1, 1, 1, 1)
    with pytest.raises(MeshError, match="folder .* does not exist"):
        write_mesh(m, tmp_path / "no" / "m.msh")
    with pytest.raises(MeshError, match="point data 'u' has 3 rows, the mesh has 9 nodes"):
        write_mesh(m, tmp_path / "m.vtu", point_data={"u": np.zeros((3, 3))})
    with pytest.raises(MeshError, match="gmsh stores nodal fields of 1, 3 or 9 components; 'u' has 2"):
        write_mesh(m, tmp_path / "m.msh", point_data={"u": np.zeros((9, 2))})


def test_every_truncation_of_a_written_file_fails_or_is_a_whole_mesh(tmp_path):
    """Cut the file anywhere: either a MeshError naming the file, or (cut between sections) a valid mesh."""
    m = generators.strip(2, 1, 2, 1)
    good = tmp_path / "good.msh"
    write_mesh(m, good)
    data = good.read_bytes()
    cut = tmp_path / "cut.msh"
    whole = 0
    for n in range(0, len(data), 7):
        cut.write_bytes(data[:n])
        try:
            r = read_mesh(cut)
        except MeshError as exc:
            assert str(cut) in str(exc)
            continue
        whole += 1
        np.testing.assert_array_equal(r.elements, m.elements)
    assert whole <= 3


_GOOD = {}


def _good_bytes(suffix):
    if suffix not in _GOOD:
        import tempfile
        with tempfile.TemporaryDirectory() as d:
            p = Path(d) / ("g" + suffix)
            write_mesh(generators.strip(2, 1, 2, 1), p)
            _GOOD[suffix] = p.read_bytes()
    return _GOOD[suffix]


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(suffix=st.sampled_from([".msh", ".vtu"]), kind=st.sampled_from(["random", "truncate", "flip"]),
       raw=st.binary(max_size=300), where=st.integers(0, 10**6), byte=st.integers(0, 255))
def test_fuzzed_files_give_nothing_but_mesh_errors(tmp_path, suffix, kind, raw, where, byte):
    if kind == "random":
        data = raw
    else:
        good = _good_bytes(suffix)
        k = where % len(good)
        data = good[:k] if kind == "truncate" else good[:k] + bytes([byte]) + good[k + 1:]
    path = tmp_path / ("fuzz" + suffix)
    path.write_bytes(data)
    try:
        read_mesh(path)
    except MeshError as exc:
        assert str(path) in str(exc)


def test_physical_group_on_a_missing_node_is_named(tmp_path):
    text = _replace(SQUARE_TRI3, "1 15 2 1 1 1", "1 15 2 1 1 9")
    # gmsh node 9 does not exist: meshio cannot map it, or flexbody names the group
    with pytest.raises(MeshError, match="bad.msh"):
        read_mesh(_write(tmp_path, text, "bad.msh"))
