"""The mesh type and its validation: every bad mesh fails with a MeshError that names the culprit."""

import numpy as np
import pytest

from flexbody.mesh import MeshError, Tri6Mesh, generators, validate
from flexbody.mesh.tri6 import MIDSIDE_TOLERANCE

Z = [0.0, 0.0, 1.0]


def square():
    """Unit square split along (0,0)-(1,1) into two six-node triangles; director +z."""
    nodes = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                      [0.5, 0, 0], [1, 0.5, 0], [0.5, 0.5, 0], [0.5, 1, 0], [0, 0.5, 0]], dtype=float)
    elements = np.array([[0, 1, 2, 4, 5, 6], [0, 2, 3, 6, 7, 8]])
    return nodes, elements, np.tile(Z, (9, 1))


def make(nodes=None, elements=None, directors=None, **kw):
    n0, e0, d0 = square()
    return Tri6Mesh(n0 if nodes is None else nodes, e0 if elements is None else elements,
                    d0 if directors is None else directors, **kw)


def test_the_square_is_valid_and_its_queries_work():
    m = make(node_sets={"corner": [0]}, edge_sets={"bottom": [[0, 4, 1]]})
    validate(m)
    assert m.n_nodes == 9 and m.n_elements == 2
    assert m.area() == pytest.approx(1.0, rel=1e-14)
    np.testing.assert_allclose(m.element_normals(), [Z, Z])
    assert {tuple(sorted((a, b))) for a, _, b in m.boundary_edges().tolist()} == {(0, 1), (1, 2), (2, 3), (0, 3)}
    np.testing.assert_array_equal(m.node_set("bottom"), [0, 1, 4])   # an edge set counts as a node set
    np.testing.assert_array_equal(m.edge_set("bottom"), [[0, 4, 1]])
    assert m.nearest_node([0.9, 0.1, 0]) == 1
    with pytest.raises(MeshError, match="finite 3-vector"):
        m.nearest_node([0, np.nan, 0])


def test_zero_area_element_is_named():
    nodes = np.array([[0, 0, 0], [1, 0, 0], [3, 0, 0], [0.5, 0, 0], [2, 0, 0], [1.5, 0, 0]], dtype=float)
    with pytest.raises(MeshError, match=r"element 0 has zero area \(corners \[0, 1, 2\] are collinear\)"):
        Tri6Mesh(nodes, [[0, 1, 2, 3, 4, 5]], np.tile(Z, (6, 1)))
    # a needle: nearly collinear (height 1e-14 of the length) counts as zero area too
    nodes[2, 1] = 1e-14
    with pytest.raises(MeshError, match=r"element 0 has zero area"):
        Tri6Mesh(nodes, [[0, 1, 2, 3, 4, 5]], np.tile(Z, (6, 1)))


def test_inverted_element_is_named():
    nodes, elements, d = square()
    elements[1] = [0, 3, 2, 8, 7, 6]     # clockwise seen from +z
    with pytest.raises(MeshError, match=r"element 1 is inverted or oriented against the directors.*corners "
                                        r"\[0, 3, 2\] counter-clockwise"):
        make(nodes, elements, d)


def test_all_elements_against_the_directors_is_inverted():
    nodes, elements, d = square()
    with pytest.raises(MeshError, match="element 0 is inverted"):
        make(nodes, elements, -d)


def test_midside_node_far_from_its_edge_is_named():
    nodes, elements, d = square()
    nodes[4] = [0.5, 0.0, 0.3]            # 0.3 edge lengths off the chord (out of plane: no fold)
    with pytest.raises(MeshError, match=r"midside node 4 of element 0 lies 0\.3 edge lengths from the middle "
                                        r"of edge \(0, 1\) \(at most 0\.25\)"):
        make(nodes, elements, d)


def test_midside_node_that_folds_the_element_is_named():
    nodes, elements, d = square()
    nodes[4] = [0.5 - 0.26, 0, 0]         # slid along its edge past a quarter: the Jacobian flips at node 0
    with pytest.raises(MeshError, match=r"element 0 folds at \(r, s\) = \(0, 0\).*midside node 4 lies 0\.26"):
        make(nodes, elements, d)


@pytest.mark.parametrize("shift", [0.2, -0.2])
def test_skewed_midside_node_inside_the_range_is_accepted(shift):
    nodes, elements, d = square()
    nodes[4] = [0.5 + shift, 0, 0]
    nodes[6] = [0.5 + shift / 2, 0.5 + shift / 2, 0]  # shared diagonal node, 0.1 off along the diagonal
    m = make(nodes, elements, d)
    assert m.area() == pytest.approx(1.0, rel=1e-12)  # an isoparametric remap of the same straight edges
    assert 0.2 < MIDSIDE_TOLERANCE


def test_coincident_nodes_are_duplicates():
    nodes, elements, d = square()
    nodes = np.vstack([nodes, nodes[2]])   # node 9 is a copy of node 2, used by element 1
    elements[1] = [0, 9, 3, 6, 7, 8]
    with pytest.raises(MeshError, match=r"nodes 2 and 9 coincide at \[1\.0, 1\.0, 0\.0\] \(duplicate nodes"):
        make(nodes, elements, np.tile(Z, (10, 1)))
    # a deliberate slit is allowed
    make(nodes, elements, np.tile(Z, (10, 1)), allow_coincident_nodes=True)


def test_node_used_twice_in_an_element():
    nodes, elements, d = square()
    elements[0] = [0, 1, 2, 4, 5, 4]
    with pytest.raises(MeshError, match=r"element 0 uses a node twice: \[0, 1, 2, 4, 5, 4\]"):
        make(nodes, elements, d)


def test_unused_node_is_named():
    nodes, elements, d = square()
    nodes = np.vstack([nodes, [5, 5, 0]])
    with pytest.raises(MeshError, match=r"node 9 belongs to no element \(1 unused node"):
        make(nodes, elements, np.tile(Z, (10, 1)))


def _fins():
    """Edge 0-1 along x with fins: 'floor' y > 0 (normal +z), 'wall' z > 0, 'floor' y < 0."""
    nodes = np.array([[0, 0, 0], [1, 0, 0], [0.5, 0, 0],            # edge 0 - 2 - 1
                      [0.5, 1, 0], [0.25, 0.5, 0], [0.75, 0.5, 0],  # floor y > 0
                      [0.5, 0, 1], [0.25, 0, 0.5], [0.75, 0, 0.5],  # wall z > 0
                      [0.5, -1, 0], [0.25, -0.5, 0], [0.75, -0.5, 0]], dtype=float)
    floor = [0, 1, 3, 2, 5, 4]
    d = np.zeros((12, 3))
    d[[3, 4, 5, 9, 10, 11]] = Z
    return nodes, floor, d


def test_non_manifold_edge_is_named():
    nodes, floor, d = _fins()
    wall = [1, 0, 6, 2, 7, 8]            # normal +y
    floor2 = [1, 0, 9, 2, 10, 11]        # normal +z
    d[[6, 7, 8]] = [0, 1, 0]
    d[[0, 1, 2]] = np.array([0, 1, 2.0]) / np.sqrt(5)
    with pytest.raises(MeshError, match=r"edge \[0, 1\] is shared by 3 elements \[0, 1, 2\] \(non-manifold\)"):
        Tri6Mesh(nodes, [floor, wall, floor2], d)


def test_inconsistent_orientation_is_named():
    """Floor with normal +z and wall with normal -y: each element agrees with its (averaged) directors,
    but the two run along their common edge in the same direction."""
    nodes, floor, d = _fins()
    wall = [0, 1, 6, 2, 8, 7]            # normal -y
    d[[6, 7, 8]] = [0, -1, 0]
    d[[0, 1, 2]] = np.array([0, -1, 1.0]) / np.sqrt(2)
    with pytest.raises(MeshError, match=r"elements 0 and 1 have opposite orientations .*common edge \[0, 1\]"):
        Tri6Mesh(nodes[:9], [floor, wall], d[:9])
    # the consistent version (wall normal +y) is a valid folded surface
    d[[6, 7, 8]] = [0, 1, 0]
    d[[0, 1, 2]] = np.array([0, 1, 1.0]) / np.sqrt(2)
    Tri6Mesh(nodes[:9], [floor, [1, 0, 6, 2, 7, 8]], d[:9])


def test_neighbours_with_different_midside_nodes_on_an_edge():
    nodes, elements, d = square()
    nodes = np.vstack([nodes, [0.5, 0.5, 0]])
    elements[1] = [0, 2, 3, 9, 7, 8]
    with pytest.raises(MeshError, match=r"elements 0 and 1 share the edge \[0, 2\] but not its midside node "
                                        r"\(6 vs 9\)"):
        make(nodes, elements, np.tile(Z, (10, 1)), allow_coincident_nodes=True)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_coordinates_are_named(bad):
    nodes, elements, d = square()
    nodes[7, 1] = bad
    with pytest.raises(MeshError, match=r"node 7 has non-finite coordinates"):
        make(nodes, elements, d)


def test_non_finite_directors_are_named():
    nodes, elements, d = square()
    d[5] = [np.nan, 0, 1]
    with pytest.raises(MeshError, match="node 5 has non-finite director"):
        make(nodes, elements, d)


def test_non_unit_director_is_named():
    nodes, elements, d = square()
    d[3] = [0, 0, 1.001]
    with pytest.raises(MeshError, match=r"the director of node 3 is not a unit vector \(length 1\.001\)"):
        make(nodes, elements, d)


@pytest.mark.parametrize("index", [9, 100, -1])
def test_out_of_range_indices_are_named(index):
    nodes, elements, d = square()
    elements[1, 4] = index
    with pytest.raises(MeshError, match=rf"element 1 refers to node {index}, which does not exist \(mesh has 9"):
        make(nodes, elements, d)


@pytest.mark.parametrize("kwargs, match", [
    (dict(nodes=np.zeros((9, 2))), r"nodes must have shape \(n, 3\)"),
    (dict(elements=np.zeros((2, 3), int)), r"elements must have shape \(m, 6\) \(six-node triangles\)"),
    (dict(directors=np.ones((8, 3))), r"directors must have the shape of nodes"),
    (dict(elements=[[0, 1, 2, 4, 5, 6.5], [0, 2, 3, 6, 7, 8]]), "elements must hold integer indices"),
    (dict(elements=[[0, 1, 2, 4, 5, np.nan], [0, 2, 3, 6, 7, 8]]), r"elements has a non-finite entry at \[0, 5\]"),
    (dict(nodes=[["a", "b", "c"]] * 9), "nodes must be numeric"),
    (dict(nodes=np.zeros((0, 3)), elements=np.zeros((0, 6)), directors=np.zeros((0, 3))),
     "a mesh needs nodes and elements, got 0 nodes and 0 elements"),
])
def test_malformed_arrays_are_named(kwargs, match):
    with pytest.raises(MeshError, match=match):
        make(**kwargs)


def test_sets_are_checked_and_unknown_names_list_the_known_ones():
    with pytest.raises(MeshError, match="node set 'tip' refers to node 12, which does not exist"):
        make(node_sets={"tip": [1, 12]})
    with pytest.raises(MeshError, match=r"edge set 'side' has \[0, 5, 1\], which is not an element edge"):
        make(edge_sets={"side": [[0, 5, 1]]})
    make(edge_sets={"side": [[1, 4, 0]]})   # either direction is an element edge
    m = generators.strip(2, 1, 2, 1)
    with pytest.raises(MeshError, match=r"unknown node set 'clamp'; this mesh has node sets: bottom, clamped, "
                                        "tip, top$"):
        m.node_set("clamp")
    with pytest.raises(MeshError, match=r"unknown edge set 'free'; this mesh has edge sets: bottom, clamped, "
                                        "tip, top$"):
        m.edge_set("free")


def test_validation_of_a_large_mesh_is_fast():
    """The topology checks are vectorised: 20 000 elements validate in well under a second."""
    import time
    m = generators.strip(10, 1, 100, 100)
    t0 = time.perf_counter()
    validate(m)
    assert time.perf_counter() - t0 < 1.5
