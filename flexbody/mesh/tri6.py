"""The six-node triangle mesh: nodes, connectivity, reference directors, named node and edge sets.

Connectivity follows :mod:`flexbody.shell.shape`: corners 1, 2, 3 first, then the midside nodes
4 = (1, 2), 5 = (2, 3), 6 = (3, 1), counter-clockwise seen from the reference director. An edge of an edge set
is a node triple (corner, midside, corner).

Every mesh is validated when it is made (:func:`validate`): a bad mesh fails with a :class:`MeshError` that
names the element or node, never later inside a numba kernel.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from flexbody.shell.shape import gauss_triangle_7, shape_derivatives, shape_functions

#: local node triples (corner, midside, corner) of the three element edges
ELEMENT_EDGES = np.array([[0, 3, 1], [1, 4, 2], [2, 5, 0]])

#: a point whose nearest node is asked for lies at most this many model sizes away from the mesh
NEAR_LIMIT = 1e6

#: a midside node may sit at most this fraction of its edge's chord away from the chord's midpoint
MIDSIDE_TOLERANCE = 0.25

# points at which the Jacobian sign is checked: corners, midside nodes and the 7 Gauss points
_CHECK_POINTS = np.vstack([[[0, 0], [1, 0], [0, 1], [0.5, 0], [0.5, 0.5], [0, 0.5]], gauss_triangle_7()[0]])
_CHECK_DN = np.array([shape_derivatives(r, s) for r, s in _CHECK_POINTS])  # (13, 2, 6)


class MeshError(ValueError):
    """An invalid mesh; the message names the offending element, node, set or file."""


@dataclass(frozen=True, eq=False)
class Tri6Mesh:
    """A six-node triangle mesh of a shell's reference surface.

    Parameters
    ----------
    nodes : (n, 3) node coordinates
    elements : (m, 6) node indices per element (corners, then midside nodes 4=(1,2), 5=(2,3), 6=(3,1))
    directors : (n, 3) unit reference directors (shell normals) at the nodes
    node_sets : named sets of node indices
    edge_sets : named sets of element edges, each a (k, 3) array of (corner, midside, corner) triples
    allow_coincident_nodes : a deliberate slit or crack (the slit annular plate) has distinct coincident
        nodes on its two lips; otherwise coincident nodes are reported as duplicates.
    element_sets : named sets of element indices (e.g. gmsh's physical surface groups)
    """

    nodes: np.ndarray
    elements: np.ndarray
    directors: np.ndarray
    node_sets: Mapping[str, np.ndarray] = field(default_factory=dict)
    edge_sets: Mapping[str, np.ndarray] = field(default_factory=dict)
    allow_coincident_nodes: bool = False
    element_sets: Mapping[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        nodes = _as_array(self.nodes, float, "nodes")
        elements = _as_array(self.elements, int, "elements")
        directors = _as_array(self.directors, float, "directors")
        if nodes.ndim != 2 or nodes.shape[1] != 3:
            raise MeshError(f"nodes must have shape (n, 3), got {nodes.shape}")
        if elements.ndim != 2 or elements.shape[1] != 6:
            raise MeshError(f"elements must have shape (m, 6) (six-node triangles), got {elements.shape}")
        if directors.shape != nodes.shape:
            raise MeshError(f"directors must have the shape of nodes {nodes.shape}, got {directors.shape}")
        node_sets = {str(k): _as_array(v, int, f"node set {k!r}").ravel() for k, v in self.node_sets.items()}
        edge_sets = {str(k): _as_array(v, int, f"edge set {k!r}").reshape(-1, 3) for k, v in self.edge_sets.items()}
        element_sets = {str(k): _as_array(v, int, f"element set {k!r}").ravel()
                        for k, v in self.element_sets.items()}
        for arr in (nodes, elements, directors, *node_sets.values(), *edge_sets.values(), *element_sets.values()):
            arr.flags.writeable = False
        object.__setattr__(self, "nodes", nodes)
        object.__setattr__(self, "elements", elements)
        object.__setattr__(self, "directors", directors)
        object.__setattr__(self, "node_sets", node_sets)
        object.__setattr__(self, "edge_sets", edge_sets)
        object.__setattr__(self, "element_sets", element_sets)
        validate(self)

    # -- sizes ------------------------------------------------------------------------------------------
    @property
    def n_nodes(self) -> int:
        """The number of nodes."""
        return len(self.nodes)

    @property
    def n_elements(self) -> int:
        """The number of elements (six-node triangles)."""
        return len(self.elements)

    # -- sets -------------------------------------------------------------------------------------------
    def node_set(self, name: str) -> np.ndarray:
        """The node indices of a named node set (an edge set's nodes count as a node set too)."""
        if name in self.node_sets:
            return self.node_sets[name]
        if name in self.edge_sets:
            return np.unique(self.edge_sets[name])
        raise MeshError(f"unknown node set {name!r}; this mesh has {_names(self.node_sets, self.edge_sets)}")

    def edge_set(self, name: str) -> np.ndarray:
        """The (k, 3) edge triples of a named edge set."""
        if name not in self.edge_sets:
            known = ", ".join(sorted(self.edge_sets)) or "none"
            raise MeshError(f"unknown edge set {name!r}; this mesh has edge sets: {known}")
        return self.edge_sets[name]

    def element_set(self, name: str) -> np.ndarray:
        """The element indices of a named element set."""
        if name not in self.element_sets:
            known = ", ".join(sorted(self.element_sets)) or "none"
            raise MeshError(f"unknown element set {name!r}; this mesh has element sets: {known}")
        return self.element_sets[name]

    def nearest_node(self, point) -> int:
        """Index of the node nearest to ``point`` (3,), which must lie within ``NEAR_LIMIT`` model sizes of
        the mesh (farther away the distances overflow or round to one value, and any node could win)."""
        p = np.asarray(point, dtype=float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise MeshError(f"point must be a finite 3-vector, got {point!r}")
        size = float(np.ptp(self.nodes, axis=0).max())
        low, high = self.nodes.min(axis=0), self.nodes.max(axis=0)
        outside = np.abs(p - np.clip(p, low, high)).max()          # no overflow: no squares
        if outside > NEAR_LIMIT * size:
            raise MeshError(f"point {p.tolist()} lies {outside / size:.3g} model sizes away from the mesh (at most "
                            f"{NEAR_LIMIT:g}); give a point near the node you mean")
        return int(np.argmin(np.linalg.norm(self.nodes - p, axis=1)))

    def with_sets(self, node_sets: Mapping[str, np.ndarray] | None = None,
                  edge_sets: Mapping[str, np.ndarray] | None = None) -> "Tri6Mesh":
        """A copy with more named sets (existing names are replaced)."""
        return Tri6Mesh(self.nodes, self.elements, self.directors, {**self.node_sets, **(node_sets or {})},
                        {**self.edge_sets, **(edge_sets or {})}, self.allow_coincident_nodes, self.element_sets)

    # -- topology ---------------------------------------------------------------------------------------
    def connected_components(self) -> tuple[int, np.ndarray]:
        """The separate pieces of the mesh: their number and each node's piece label (n,), 0, 1, ...

        Two elements are in one piece when a chain of elements sharing nodes joins them. Pieces are
        numbered in the order of their lowest node index.
        """
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

        conn = self.elements
        graph = coo_matrix((np.ones(conn[:, 1:].size), (np.repeat(conn[:, 0], 5), conn[:, 1:].ravel())),
                           shape=(self.n_nodes, self.n_nodes))
        count, labels = connected_components(graph, directed=False)
        _, first = np.unique(labels, return_index=True)          # renumber by lowest node
        order = np.empty(count, dtype=np.int64)
        order[np.argsort(first)] = np.arange(count)
        return int(count), order[labels]

    def boundary_edges(self) -> np.ndarray:
        """All boundary edges (k, 3) as (corner, midside, corner), oriented as in their element."""
        triples = self.elements[:, ELEMENT_EDGES].reshape(-1, 3)
        keys = np.sort(triples[:, [0, 2]], axis=1)
        _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
        return triples[counts[inverse.ravel()] == 1]

    def element_normals(self) -> np.ndarray:
        """Unit normals (m, 3) of the elements at their centroid, x_,r x x_,s."""
        dN = shape_derivatives(1 / 3, 1 / 3)
        X = self.nodes[self.elements]                       # (m, 6, 3)
        g = np.einsum("ai,mij->maj", dN, X)
        n = np.cross(g[:, 0], g[:, 1])
        return n / np.linalg.norm(n, axis=1, keepdims=True)

    def area(self) -> float:
        """The reference surface area (7-point rule)."""
        pts, wts = gauss_triangle_7()
        X = self.nodes[self.elements]
        total = 0.0
        for (r, s), w in zip(pts, wts):
            g = np.einsum("ai,mij->maj", shape_derivatives(r, s), X)
            total += w * np.linalg.norm(np.cross(g[:, 0], g[:, 1]), axis=1).sum()
        return float(total)


def _as_array(value, dtype, name: str) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise MeshError(f"{name} must be numeric: {exc}") from None
    if dtype is int:
        if arr.size and not np.all(np.isfinite(arr)):
            bad = np.argwhere(~np.isfinite(arr))[0].tolist()
            raise MeshError(f"{name} has a non-finite entry at {bad}")
        if arr.size and np.any(arr != np.round(arr)):
            raise MeshError(f"{name} must hold integer indices")
        return arr.astype(np.int64)
    return arr


def _names(node_sets, edge_sets) -> str:
    names = sorted(set(node_sets) | set(edge_sets))   # an edge set's nodes are a node set too
    return "node sets: " + (", ".join(names) or "none")


def validate(mesh: Tri6Mesh) -> None:
    """Check a mesh; raise :class:`MeshError` naming the first bad element, node or set.

    Checks: finite coordinates and directors; unit directors; indices in range; six distinct nodes per
    element; no unused nodes; no coincident nodes (unless allowed); a positive Jacobian
    (x_,r x x_,s) . director > 0 at the corners, midside and Gauss points of every element (this catches
    zero-area, inverted and wrongly oriented elements and midside nodes that fold the element); midside nodes
    close to the middle of their edge; no edge shared by more than two elements (non-manifold); consistent
    orientation of neighbours; set indices in range and edge triples that are element edges.
    """
    x, conn, d = mesh.nodes, mesh.elements, mesh.directors
    n, m = len(x), len(conn)
    if n == 0 or m == 0:
        raise MeshError(f"a mesh needs nodes and elements, got {n} nodes and {m} elements")
    for arr, what in ((x, "coordinates"), (d, "director components")):
        bad = np.flatnonzero(~np.all(np.isfinite(arr), axis=1))
        if bad.size:
            raise MeshError(f"node {bad[0]} has non-finite {what}: {arr[bad[0]].tolist()}")
    with np.errstate(over="ignore", invalid="ignore"):
        _validate_finite_mesh(mesh)


def _validate_finite_mesh(mesh: Tri6Mesh) -> None:
    x, conn, d = mesh.nodes, mesh.elements, mesh.directors
    n = len(x)
    norms = np.linalg.norm(d, axis=1)
    bad = np.flatnonzero(np.abs(norms - 1.0) > 1e-8)
    if bad.size:
        raise MeshError(f"the director of node {bad[0]} is not a unit vector (length {norms[bad[0]]:.6g})")
    out = np.argwhere((conn < 0) | (conn >= n))
    if out.size:
        e, k = out[0]
        raise MeshError(f"element {e} refers to node {conn[e, k]}, which does not exist (mesh has {n} nodes)")
    srt = np.sort(conn, axis=1)
    rep = np.flatnonzero(np.any(srt[:, 1:] == srt[:, :-1], axis=1))
    if rep.size:
        raise MeshError(f"element {rep[0]} uses a node twice: {conn[rep[0]].tolist()}")
    used = np.zeros(n, dtype=bool)
    used[conn.ravel()] = True
    unused = np.flatnonzero(~used)
    if unused.size:
        raise MeshError(f"node {unused[0]} belongs to no element ({unused.size} unused node(s))")
    if not mesh.allow_coincident_nodes:
        _check_coincident(x)
    _check_jacobians(x, conn, d)
    _check_midside(x, conn)
    _check_topology(conn)
    _check_sets(mesh)


def _check_coincident(x: np.ndarray) -> None:
    from scipy.spatial import cKDTree

    tol = 1e-10 * max(float(np.ptp(x, axis=0).max()), 1e-300)
    pairs = cKDTree(x).query_pairs(tol, output_type="ndarray")
    if len(pairs):
        a, b = sorted(int(i) for i in pairs[np.lexsort(pairs.T[::-1])[0]])
        raise MeshError(f"nodes {a} and {b} coincide at {x[a].tolist()} (duplicate nodes; merge them, or "
                        "pass allow_coincident_nodes=True for a deliberate slit)")


def _check_jacobians(x: np.ndarray, conn: np.ndarray, d: np.ndarray) -> None:
    X = x[conn]                                            # (m, 6, 3)
    D = d[conn]
    size = np.linalg.norm(X[:, 1] - X[:, 0], axis=1) + np.linalg.norm(X[:, 2] - X[:, 0], axis=1)
    for p, dN in zip(_CHECK_POINTS, _CHECK_DN):
        g = np.einsum("ai,mij->maj", dN, X)
        normal = np.cross(g[:, 0], g[:, 1])
        director = np.einsum("i,mij->mj", shape_functions(*p), D)
        jac = np.einsum("mj,mj->m", normal, director)
        bad = np.flatnonzero(jac <= 1e-10 * size**2)
        if bad.size:
            e = int(bad[0])
            flat = np.cross(X[e, 1] - X[e, 0], X[e, 2] - X[e, 0])
            area = 0.5 * np.linalg.norm(flat)
            if area <= 1e-12 * size[e] ** 2:
                raise MeshError(f"element {e} has zero area (corners {conn[e, :3].tolist()} are collinear)")
            where = f"at (r, s) = ({p[0]:.3g}, {p[1]:.3g}): Jacobian . director = {jac[e]:.3g}"
            if flat @ D[e, :3].sum(axis=0) <= 0:
                raise MeshError(f"element {e} is inverted or oriented against the directors {where}; list its "
                                f"corners {conn[e, :3].tolist()} counter-clockwise seen from the director")
            # the corner triangle is fine: a midside node folds the element
            off = [np.linalg.norm(X[e, 3 + k] - 0.5 * (X[e, a] + X[e, b])) / np.linalg.norm(X[e, b] - X[e, a])
                   for k, (a, _, b) in enumerate(ELEMENT_EDGES)]
            k = int(np.argmax(off))
            raise MeshError(f"element {e} folds {where}: its midside node {conn[e, 3 + k]} lies {off[k]:.3g} edge "
                            f"lengths from the middle of its edge; keep midside nodes near the middle of their "
                            "edges")


def _check_midside(x: np.ndarray, conn: np.ndarray) -> None:
    for k, (a, mid, b) in enumerate(ELEMENT_EDGES):
        chord = x[conn[:, b]] - x[conn[:, a]]
        off = x[conn[:, mid]] - 0.5 * (x[conn[:, a]] + x[conn[:, b]])
        ratio = np.linalg.norm(off, axis=1) / np.linalg.norm(chord, axis=1)
        bad = np.flatnonzero(ratio > MIDSIDE_TOLERANCE)
        if bad.size:
            e = int(bad[0])
            raise MeshError(f"midside node {conn[e, mid]} of element {e} lies {ratio[e]:.3g} edge lengths from "
                            f"the middle of edge ({conn[e, a]}, {conn[e, b]}) (at most {MIDSIDE_TOLERANCE})")


def _check_topology(conn: np.ndarray) -> None:
    """Non-manifold edges, neighbours that disagree on an edge's midside node or on the orientation.

    Sort-based (no loop over the edges): the mesh check must stay cheap next to the assembly.
    """
    triples = conn[:, ELEMENT_EDGES].reshape(-1, 3)
    keys = np.sort(triples[:, [0, 2]], axis=1)
    key = _row_keys(keys, int(conn.max()) + 1)
    order = np.argsort(key, kind="stable")                  # edge occurrences grouped by edge
    sk = key[order]
    starts = np.flatnonzero(np.concatenate([[True], sk[1:] != sk[:-1]]))
    counts = np.diff(np.append(starts, len(sk)))
    uniq = keys[order[starts]]
    many = np.flatnonzero(counts > 2)
    if many.size:
        k = many[0]
        owners = sorted(set((order[starts[k]:starts[k] + counts[k]] // 3).tolist()))
        raise MeshError(f"edge {uniq[k].tolist()} is shared by {counts[k]} elements {owners} (non-manifold)")
    two = np.flatnonzero(counts == 2)
    i, j = order[starts[two]], order[starts[two] + 1]
    bad_mid = triples[i, 1] != triples[j, 1]
    bad_orient = triples[i, 0] == triples[j, 0]
    bad = np.flatnonzero(bad_mid | bad_orient)
    if bad.size:
        b = bad[0]
        k, i, j = two[b], i[b], j[b]
        if bad_mid[b]:
            raise MeshError(f"elements {i // 3} and {j // 3} share the edge {uniq[k].tolist()} but not its "
                            f"midside node ({triples[i, 1]} vs {triples[j, 1]})")
        raise MeshError(f"elements {i // 3} and {j // 3} have opposite orientations (they run along their "
                        f"common edge {uniq[k].tolist()} in the same direction)")


def _check_sets(mesh: Tri6Mesh) -> None:
    n = mesh.n_nodes
    for name, idx in mesh.node_sets.items():
        bad = idx[(idx < 0) | (idx >= n)]
        if bad.size:
            raise MeshError(f"node set {name!r} refers to node {bad[0]}, which does not exist")
    for name, idx in mesh.element_sets.items():
        bad = idx[(idx < 0) | (idx >= mesh.n_elements)]
        if bad.size:
            raise MeshError(f"element set {name!r} refers to element {bad[0]}, which does not exist "
                            f"({mesh.n_elements} elements)")
    if not mesh.edge_sets:
        return
    triples = mesh.elements[:, ELEMENT_EDGES].reshape(-1, 3)
    known = np.sort(_row_keys(np.vstack([triples, triples[:, ::-1]]), n))
    for name, edges in mesh.edge_sets.items():
        k = _row_keys(edges, n)
        missing = np.flatnonzero(known[np.minimum(np.searchsorted(known, k), len(known) - 1)] != k)
        if missing.size:
            raise MeshError(f"edge set {name!r} has {edges[missing[0]].tolist()}, which is not an element edge "
                            "(corner, midside, corner)")


def _row_keys(rows: np.ndarray, n: int) -> np.ndarray:
    """One comparable scalar per row of node indices in [0, n) (for set membership and grouping)."""
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    if float(n) ** rows.shape[1] < 2.0**62:
        key = np.zeros(len(rows), dtype=np.int64)
        for c in range(rows.shape[1]):
            key = key * n + rows[:, c]
        return key
    return rows.view(np.dtype((np.void, rows.dtype.itemsize * rows.shape[1]))).ravel()
