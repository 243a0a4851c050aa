"""Mesh files: gmsh ``.msh`` (and anything meshio reads) in, VTU/XDMF/... out.

Import takes six-node triangles ("triangle6") as they are and upgrades three-node triangles ("triangle") to
six-node ones with straight-edged midside nodes. Physical groups of gmsh become named sets: a group of line
elements ("line" / "line3") becomes an edge set (and node set), a group of points a node set. Directors are
the nodal average of the adjacent element normals, oriented like the elements' corner order.

meshio is an optional dependency (``pip install flexbody[dev]`` or ``pip install meshio``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from flexbody.mesh.tri6 import ELEMENT_EDGES, MeshError, Tri6Mesh


def _meshio():
    try:
        import meshio
    except ImportError:  # pragma: no cover - depends on the installation
        raise MeshError("reading and writing mesh files needs meshio: python -m pip install meshio") from None
    return meshio


def upgrade_to_tri6(nodes: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Six-node triangles from three-node ones: one new node at the midpoint of each distinct edge.

    Returns (nodes (n + n_edges, 3), elements (m, 6)). The midside nodes of an edge shared by two triangles
    are the same node.
    """
    nodes = np.asarray(nodes, dtype=float)
    tri = np.asarray(triangles, dtype=np.int64)
    if tri.ndim != 2 or tri.shape[1] != 3:
        raise MeshError(f"triangles must have shape (m, 3), got {tri.shape}")
    if tri.size and (tri.min() < 0 or tri.max() >= len(nodes)):
        raise MeshError(f"a triangle refers to node {int(tri.max()) if tri.max() >= len(nodes) else int(tri.min())}, "
                        f"which does not exist ({len(nodes)} nodes)")
    pairs = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    keys = np.sort(pairs, axis=1)
    uniq, inverse = np.unique(keys, axis=0, return_inverse=True)
    mid = 0.5 * (nodes[uniq[:, 0]] + nodes[uniq[:, 1]])
    new = len(nodes) + inverse.ravel().reshape(3, -1).T
    return np.vstack([nodes, mid]), np.hstack([tri, new])


def averaged_directors(nodes: np.ndarray, elements: np.ndarray) -> np.ndarray:
    """Unit nodal directors: the average of the normals x_,r x x_,s of the elements that hold the node,
    each evaluated at that node."""
    from flexbody.shell.shape import shape_derivatives

    corners = [(0, 0), (1, 0), (0, 1), (0.5, 0), (0.5, 0.5), (0, 0.5)]
    acc = np.zeros((len(nodes), 3))
    X = nodes[elements]
    for k, (r, s) in enumerate(corners):
        g = np.einsum("ai,mij->maj", shape_derivatives(r, s), X)
        n = np.cross(g[:, 0], g[:, 1])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        np.add.at(acc, elements[:, k], n)
    norm = np.linalg.norm(acc, axis=1)
    bad = np.flatnonzero(norm < 1e-8)
    if bad.size:
        raise MeshError(f"the element normals around node {bad[0]} cancel: no director can be averaged there "
                        "(inconsistent orientation or a fold)")
    return acc / norm[:, None]


def read_mesh(path: str | Path) -> Tri6Mesh:
    """Read a shell mesh of six-node (or three-node, upgraded) triangles from a file meshio can read.

    Raises :class:`MeshError` naming the file for a missing, unreadable or truncated file, or a file with no
    triangles; the mesh itself is validated like any other (:func:`flexbody.mesh.validate`).
    """
    meshio = _meshio()
    path = Path(path)
    if not path.is_file():
        raise MeshError(f"mesh file {str(path)!r} does not exist")
    try:
        m = meshio.read(path)
    except Exception as exc:  # meshio raises many types for malformed files
        raise MeshError(f"cannot read mesh file {str(path)!r}: {type(exc).__name__}: {exc}") from None
    nodes = np.asarray(m.points, dtype=float)
    if nodes.ndim != 2 or nodes.shape[0] == 0:
        raise MeshError(f"mesh file {str(path)!r} has no nodes")
    if nodes.shape[1] == 2:
        nodes = np.column_stack([nodes, np.zeros(len(nodes))])
    blocks = {c.type: [] for c in m.cells}
    for i, c in enumerate(m.cells):
        blocks[c.type].append(i)
    tri6 = [m.cells[i].data for i in blocks.get("triangle6", [])]
    tri3 = [m.cells[i].data for i in blocks.get("triangle", [])]
    if tri6 and tri3:
        raise MeshError(f"mesh file {str(path)!r} mixes three- and six-node triangles")
    if not tri6 and not tri3:
        raise MeshError(f"mesh file {str(path)!r} has no triangles (cell types: {sorted(blocks) or 'none'})")
    n_file = len(nodes)
    if tri6:
        elements = np.vstack(tri6).astype(np.int64)
    else:
        nodes, elements = upgrade_to_tri6(nodes, np.vstack(tri3))
    if elements.min() < 0 or elements.max() >= len(nodes):
        raise MeshError(f"mesh file {str(path)!r} refers to node {int(elements.max())}, which is not in the file")
    node_sets, edge_sets = _physical_sets(m, elements, n_file)
    # drop nodes that no element uses (gmsh keeps geometry points), renumbering everything
    used = np.unique(elements)
    if len(used) < len(nodes):
        new = -np.ones(len(nodes), dtype=np.int64)
        new[used] = np.arange(len(used))
        nodes, elements = nodes[used], new[elements]
        node_sets = {k: new[v][new[v] >= 0] for k, v in node_sets.items()}
        edge_sets = {k: new[v] for k, v in edge_sets.items()}
    if "directors" in m.point_data and tri6 and len(used) == n_file:
        directors = np.asarray(m.point_data["directors"], dtype=float)
    else:
        directors = averaged_directors(nodes, elements)
    return Tri6Mesh(nodes, elements, directors, node_sets, edge_sets)


def _physical_sets(m, elements: np.ndarray, n_file: int):
    """Named sets from gmsh physical groups (field_data + cell_data['gmsh:physical'])."""
    node_sets: dict[str, np.ndarray] = {}
    edge_sets: dict[str, np.ndarray] = {}
    phys = m.cell_data.get("gmsh:physical")
    if not phys or not m.field_data:
        return node_sets, edge_sets
    names = {int(v[0]): k for k, v in m.field_data.items()}
    # element edges as (corner, corner) -> (corner, midside, corner) in element orientation
    triples = elements[:, ELEMENT_EDGES].reshape(-1, 3)
    lookup = {(int(a), int(b)): (int(a), int(mid), int(b)) for a, mid, b in triples}
    for block, tags in zip(m.cells, phys):
        for tag in np.unique(tags):
            name = names.get(int(tag))
            if name is None:
                continue
            data = block.data[np.asarray(tags) == tag]
            if block.type == "vertex":
                node_sets[name] = np.unique(np.concatenate([node_sets.get(name, np.array([], int)), data.ravel()]))
            elif block.type in ("line", "line3"):
                edges = []
                for row in data:
                    a, b = int(row[0]), int(row[1])
                    edge = lookup.get((a, b)) or (lookup[(b, a)][::-1] if (b, a) in lookup else None)
                    if edge is None:
                        raise MeshError(f"physical group {name!r} has the line ({a}, {b}), which is no element edge")
                    edges.append(edge)
                edge_sets[name] = np.array(edges, dtype=np.int64).reshape(-1, 3)
                node_sets[name] = np.unique(edge_sets[name])
    return node_sets, edge_sets


def write_mesh(mesh: Tri6Mesh, path: str | Path, point_data: dict[str, np.ndarray] | None = None) -> None:
    """Write the mesh (six-node triangles, directors as point data) to any format meshio writes by suffix
    (``.vtu`` for ParaView, ``.msh``, ``.xdmf``...). Extra nodal fields go in ``point_data``."""
    meshio = _meshio()
    path = Path(path)
    if not path.parent.exists():
        raise MeshError(f"cannot write {str(path)!r}: folder {str(path.parent)!r} does not exist")
    data = {"directors": np.asarray(mesh.directors)}
    for k, v in (point_data or {}).items():
        v = np.asarray(v)
        if len(v) != mesh.n_nodes:
            raise MeshError(f"point data {k!r} has {len(v)} rows, the mesh has {mesh.n_nodes} nodes")
        data[k] = v
    out = meshio.Mesh(np.asarray(mesh.nodes), [("triangle6", np.asarray(mesh.elements))], point_data=data)
    try:
        out.write(path)
    except Exception as exc:
        raise MeshError(f"cannot write {str(path)!r}: {type(exc).__name__}: {exc}") from None
