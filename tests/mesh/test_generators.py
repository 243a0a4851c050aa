"""Mesh generators: nodes on the exact surface, exact unit directors, analytic areas, documented sets."""

import math

import numpy as np
import pytest

from flexbody.mesh import MeshError, Tri6Mesh, generators, validate

DIAGONALS = ("right", "left", "alternate")


def _assert_unit_directors(mesh):
    np.testing.assert_allclose(np.linalg.norm(mesh.directors, axis=1), 1.0, atol=1e-14)


def _assert_outward(mesh):
    """Element normals (corner order) agree with the directors: counter-clockwise seen from them."""
    normals = mesh.element_normals()
    mean_dir = mesh.directors[mesh.elements].mean(axis=1)
    assert np.all(np.einsum("ij,ij->i", normals, mean_dir) > 0.5)


def _boundary_pairs(mesh):
    return {tuple(sorted((a, b))) for a, _, b in mesh.boundary_edges().tolist()}


def _set_pairs(mesh, names):
    return {tuple(sorted((a, b))) for n in names for a, _, b in mesh.edge_set(n).tolist()}


@pytest.mark.parametrize("diagonal", DIAGONALS)
def test_strip_is_exact_and_its_sets_are_the_sides(diagonal):
    L, b = 12.0, 1.5
    m = generators.strip(L, b, 5, 3, diagonal)
    validate(m)
    assert m.n_elements == 2 * 5 * 3 and m.n_nodes == 11 * 7
    assert np.all(m.nodes[:, 2] == 0.0)
    assert np.all((m.nodes[:, 0] >= 0) & (m.nodes[:, 0] <= L) & (m.nodes[:, 1] >= 0) & (m.nodes[:, 1] <= b))
    np.testing.assert_array_equal(m.directors, np.tile([0, 0, 1.0], (m.n_nodes, 1)))
    assert m.area() == pytest.approx(L * b, rel=1e-14)
    _assert_outward(m)
    for name, axis, value, count in (("clamped", 0, 0.0, 7), ("tip", 0, L, 7), ("bottom", 1, 0.0, 11),
                                     ("top", 1, b, 11)):
        nodes = m.node_set(name)
        assert len(nodes) == count
        np.testing.assert_allclose(m.nodes[nodes, axis], value, atol=1e-14)
        # exactly the nodes on that side
        on_side = np.flatnonzero(np.abs(m.nodes[:, axis] - value) < 1e-12)
        np.testing.assert_array_equal(np.sort(nodes), on_side)
        assert m.edge_set(name).shape == ((count - 1) // 2, 3)
    assert _set_pairs(m, ("clamped", "tip", "bottom", "top")) == _boundary_pairs(m)


def test_diagonal_choice_changes_the_split():
    right, left, alt = (generators.strip(2, 2, 2, 2, d) for d in DIAGONALS)
    # the cell (0, 0) is split along (0,0)-(1,1) by "right" and along (1,0)-(0,1) by "left"
    p00, p11 = right.nearest_node([0, 0, 0]), right.nearest_node([1, 1, 0])
    p10, p01 = right.nearest_node([1, 0, 0]), right.nearest_node([0, 1, 0])
    edges = lambda m: {tuple(sorted((a, b))) for a, _, b in m.elements[:, [[0, 3, 1], [1, 4, 2], [2, 5, 0]]]
                       .reshape(-1, 3).tolist()}
    assert (min(p00, p11), max(p00, p11)) in edges(right) and (min(p10, p01), max(p10, p01)) not in edges(right)
    assert (min(p10, p01), max(p10, p01)) in edges(left) and (min(p00, p11), max(p00, p11)) not in edges(left)
    # alternate: the neighbouring cell (1, 0) takes the other diagonal
    q10, q21 = alt.nearest_node([1, 0, 0]), alt.nearest_node([2, 1, 0])
    q20, q11 = alt.nearest_node([2, 0, 0]), alt.nearest_node([1, 1, 0])
    assert (min(p00, p11), max(p00, p11)) in edges(alt)
    assert (min(q20, q11), max(q20, q11)) in edges(alt) and (min(q10, q21), max(q10, q21)) not in edges(alt)


@pytest.mark.parametrize("diagonal", DIAGONALS)
@pytest.mark.parametrize("angle", [math.pi / 2, math.pi, 2 * math.pi])
def test_cylinder_nodes_and_directors_are_exact(diagonal, angle):
    R, L = 4.953, 5.175
    m = generators.cylinder(R, L, 8, 3, angle=angle, diagonal=diagonal)
    x = m.nodes
    np.testing.assert_allclose(np.hypot(x[:, 0], x[:, 1]), R, rtol=1e-14)
    assert np.all((x[:, 2] >= -1e-14) & (x[:, 2] <= L + 1e-14))
    np.testing.assert_allclose(m.directors, np.column_stack([x[:, 0] / R, x[:, 1] / R, np.zeros(len(x))]),
                               atol=1e-14)
    _assert_unit_directors(m)
    _assert_outward(m)
    a = np.mod(np.arctan2(x[:, 1], x[:, 0]), 2 * math.pi)
    a[a > 2 * math.pi - 1e-12] = 0.0
    if angle < 2 * math.pi:
        assert a.max() <= angle + 1e-12
        np.testing.assert_allclose(x[m.node_set("start"), 1], 0.0, atol=1e-12)
        np.testing.assert_allclose(a[m.node_set("end")], angle, atol=1e-12)
        assert _set_pairs(m, ("start", "end", "bottom", "top")) == _boundary_pairs(m)
    else:
        assert "start" not in m.node_sets
        # the seam is closed: only the two rims are boundary
        assert _set_pairs(m, ("bottom", "top")) == _boundary_pairs(m)
        assert m.n_nodes == 17 * 7 - 7
    np.testing.assert_allclose(x[m.node_set("bottom"), 2], 0.0, atol=1e-14)
    np.testing.assert_allclose(x[m.node_set("top"), 2], L, atol=1e-14)


def _area_converges(make, exact):
    """Area error of the quadratic geometry: small, and falling like h^4 (ratio ~16 per halving)."""
    e1, e2 = (abs(make(n).area() / exact - 1) for n in (4, 8))
    assert e2 < 1e-3 and e1 / e2 > 12, (e1, e2)


def test_curved_areas_match_the_analytic_areas():
    R, L = 2.0, 3.0
    _area_converges(lambda n: generators.cylinder(R, L, n, 2), 2 * math.pi * R * L)
    _area_converges(lambda n: generators.cylinder(R, L, n, 2, angle=math.pi / 2), math.pi / 2 * R * L)
    cap = 2 * math.pi * 10.0**2 * (math.cos(math.radians(18)) - math.cos(math.radians(90)))
    _area_converges(lambda n: generators.spherical_cap(10.0, 18.0, n, n), cap)
    _area_converges(lambda n: generators.spherical_cap(10.0, 18.0, n, n, angle=math.pi / 2), cap / 4)
    _area_converges(lambda n: generators.annulus(1.0, 2.0, 2, 2 * n), math.pi * 3)
    _area_converges(lambda n: generators.slit_annulus(6.0, 10.0, 2, 2 * n), math.pi * 64)


@pytest.mark.parametrize("diagonal", DIAGONALS)
@pytest.mark.parametrize("angle", [math.pi / 2, 2 * math.pi])
def test_spherical_cap_nodes_and_directors_are_exact(diagonal, angle):
    R, hole, pmax = 10.0, 18.0, 80.0
    m = generators.spherical_cap(R, hole, 5, 6, angle=angle, polar_max_deg=pmax, diagonal=diagonal)
    x = m.nodes
    np.testing.assert_allclose(np.linalg.norm(x, axis=1), R, rtol=1e-14)
    np.testing.assert_allclose(m.directors, x / R, atol=1e-14)
    _assert_unit_directors(m)
    _assert_outward(m)
    polar = np.degrees(np.arccos(np.clip(x[:, 2] / R, -1, 1)))
    assert polar.min() == pytest.approx(hole) and polar.max() == pytest.approx(pmax)
    np.testing.assert_allclose(polar[m.node_set("hole")], hole, atol=1e-10)
    np.testing.assert_allclose(polar[m.node_set("equator")], pmax, atol=1e-10)
    if angle < 2 * math.pi:
        np.testing.assert_allclose(x[m.node_set("start"), 1], 0.0, atol=1e-12)
        np.testing.assert_allclose(x[m.node_set("end"), 0], 0.0, atol=1e-12)
        assert _set_pairs(m, ("hole", "equator", "start", "end")) == _boundary_pairs(m)
    else:
        assert _set_pairs(m, ("hole", "equator")) == _boundary_pairs(m)


@pytest.mark.parametrize("diagonal", DIAGONALS)
def test_annulus_is_flat_closed_and_exact(diagonal):
    m = generators.annulus(1.0, 2.0, 3, 8, diagonal)
    r = np.hypot(m.nodes[:, 0], m.nodes[:, 1])
    assert np.all(m.nodes[:, 2] == 0) and r.min() == pytest.approx(1.0) and r.max() == pytest.approx(2.0)
    np.testing.assert_array_equal(m.directors, np.tile([0, 0, 1.0], (m.n_nodes, 1)))
    _assert_outward(m)
    # every grid point lies on its exact circle r_i (midside nodes too)
    radii = np.linspace(1.0, 2.0, 7)
    assert np.all(np.min(np.abs(r[:, None] - radii[None]), axis=1) < 1e-14)
    np.testing.assert_allclose(r[m.node_set("inner")], 1.0, rtol=1e-14)
    np.testing.assert_allclose(r[m.node_set("outer")], 2.0, rtol=1e-14)
    assert _set_pairs(m, ("inner", "outer")) == _boundary_pairs(m)


@pytest.mark.parametrize("diagonal", DIAGONALS)
def test_slit_annulus_has_two_distinct_lips_and_the_points_a_b(diagonal):
    m = generators.slit_annulus(6.0, 10.0, 2, 8, diagonal)
    assert m.allow_coincident_nodes
    r = np.hypot(m.nodes[:, 0], m.nodes[:, 1])
    assert r.min() == pytest.approx(6.0) and r.max() == pytest.approx(10.0)
    _assert_outward(m)
    clamped, loaded = m.node_set("clamped"), m.node_set("loaded")
    assert len(clamped) == len(loaded) == 5 and not set(clamped) & set(loaded)
    # the lips coincide in space (the slit along +x) but are different nodes
    np.testing.assert_allclose(m.nodes[clamped], m.nodes[loaded], atol=1e-12)
    np.testing.assert_allclose(m.nodes[clamped, 1], 0.0, atol=1e-12)
    assert np.all(m.nodes[clamped, 0] > 0)
    a, b = int(m.node_set("A")[0]), int(m.node_set("B")[0])
    assert a in loaded and b in loaded
    np.testing.assert_allclose(m.nodes[a], [6.0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(m.nodes[b], [10.0, 0, 0], atol=1e-12)
    # no element holds nodes of both lips (the slit is open)
    both = np.isin(m.elements, clamped).any(axis=1) & np.isin(m.elements, loaded).any(axis=1)
    assert not both.any()
    assert _set_pairs(m, ("clamped", "loaded", "inner", "outer")) == _boundary_pairs(m)


@pytest.mark.parametrize("n_sides", [3, 6, 8])
def test_regular_polygon_area_rim_and_centre(n_sides):
    R = 1.3
    m = generators.regular_polygon(n_sides, R, 3)
    assert m.n_elements == n_sides * 9
    assert m.area() == pytest.approx(0.5 * n_sides * R**2 * math.sin(2 * math.pi / n_sides), rel=1e-13)
    _assert_outward(m)
    np.testing.assert_allclose(m.nodes[m.node_set("center")], [[0, 0, 0]], atol=1e-15)
    corners = m.nodes[m.node_set("corners")]
    np.testing.assert_allclose(np.linalg.norm(corners, axis=1), R, rtol=1e-14)
    assert len(corners) == n_sides
    # rim nodes lie on the polygon's sides: distance from centre along the side normal = apothem
    rim = m.nodes[m.node_set("boundary")]
    ang = np.arctan2(rim[:, 1], rim[:, 0])
    sector = np.floor(np.mod(ang, 2 * math.pi) / (2 * math.pi / n_sides) + 1e-12) % n_sides
    mid = (sector + 0.5) * 2 * math.pi / n_sides
    apothem = rim[:, 0] * np.cos(mid) + rim[:, 1] * np.sin(mid)
    np.testing.assert_allclose(apothem, R * math.cos(math.pi / n_sides), rtol=1e-12)
    assert _set_pairs(m, ("boundary",)) == _boundary_pairs(m)


@pytest.mark.parametrize("call, match", [
    (lambda: generators.strip(1, 1, 0, 1), "nx must be an integer >= 1"),
    (lambda: generators.strip(1, 1, 2.0, 1), "nx must be an integer"),
    (lambda: generators.strip(-1, 1, 1, 1), "length must be positive"),
    (lambda: generators.strip(float("nan"), 1, 1, 1), "length must be positive and finite"),
    (lambda: generators.strip(1, "wide", 1, 1), "width must be a number"),
    (lambda: generators.strip(1, 1, 1, 1, "diagonal"), "diagonal must be one of"),
    (lambda: generators.slit_annulus(2, 1, 1, 8), "outer_radius must exceed inner_radius"),
    (lambda: generators.annulus(1, 2, 1, 1), "n_circ must be an integer >= 2"),
    (lambda: generators.annulus(1, 2, 1, 3), "annulus: the cells are too coarse"),
    (lambda: generators.cylinder(1, 1, 4, 1, angle=7.0), "angle must be at most 2 pi"),
    (lambda: generators.cylinder(1, 1, 1, 1), "a full cylinder needs n_circ >= 2"),
    (lambda: generators.cylinder(1, 1, 3, 1), "cylinder: the cells are too coarse"),
    (lambda: generators.spherical_cap(1, 18, 2, 1), "a full spherical cap needs n_circ >= 2"),
    (lambda: generators.spherical_cap(1, 90, 2, 4, polar_max_deg=60), "need 0 < hole_deg < polar_max_deg"),
    (lambda: generators.spherical_cap(1, 18, 2, 3), "spherical_cap: the cells are too coarse"),
    (lambda: generators.regular_polygon(2, 1, 1), "n_sides must be an integer >= 3"),
])
def test_bad_generator_arguments_are_named(call, match):
    with pytest.raises(MeshError, match=match):
        call()


def test_generated_meshes_are_immutable_and_validated_on_copy():
    m = generators.strip(2, 1, 2, 1)
    with pytest.raises(ValueError):
        m.nodes[0, 0] = 1.0
    assert isinstance(m.with_sets(node_sets={"corner": [0]}), Tri6Mesh)
    with pytest.raises(MeshError, match="node set 'far' refers to node 999"):
        m.with_sets(node_sets={"far": [999]})
