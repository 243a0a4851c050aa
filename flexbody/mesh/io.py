"""Mesh files: gmsh ``.msh`` (and anything meshio reads) in, ``.msh``/VTU/XDMF/... out.

Import takes six-node triangles ("triangle6") as they are and upgrades three-node triangles ("triangle") to
six-node ones with straight-edged midside nodes. Physical groups of gmsh become named sets: a group of
triangles (a physical surface) an element set, a group of line elements ("line" / "line3") an edge set (and
node set), a group of points a node set. Directors are
read from the point data "directors" when the file has them (files written by :func:`write_mesh`), else
they are the nodal average of the adjacent element normals, oriented like the elements' corner order.

Every failure -- a missing, unreadable, malformed or truncated file, cells flexbody cannot use, a mesh that
fails validation -- is a :class:`MeshError` whose message names the file.

meshio is an optional dependency (``pip install flexbody[dev]`` or ``pip install meshio``).
"""

from __future__ import annotations

import contextlib
import re
import io as _io
from pathlib import Path
import warnings

import numpy as np

from flexbody.mesh.tri6 import ELEMENT_EDGES, MeshError, Tri6Mesh

#: cell types a surface mesh file may hold: the triangles, and points and lines of physical groups
_USABLE_CELLS = {"vertex", "line", "line3", "triangle", "triangle6"}
_CELL_DIM = {"vertex": 0, "line": 1, "line3": 1, "triangle": 2, "triangle6": 2}
#: meshio guesses ANSYS for ".msh"; flexbody means gmsh
_FORMAT_BY_SUFFIX = {".msh": "gmsh"}


def _meshio():
    try:
        import meshio
    except ImportError:  # pragma: no cover - depends on the installation
        raise MeshError("reading and writing mesh files needs meshio: python -m pip install meshio") from None
    return meshio


def _quiet_meshio(action, describe: str):
    """Run a meshio call; turn whatever it raises (or prints, or its sys.exit) into a MeshError.

    meshio prints its warnings to stderr, prints read errors to stdout and calls ``sys.exit(1)`` when no
    reader accepts a file; a library must not let any of that through.
    """
    out, err = _io.StringIO(), _io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = action()
    except (Exception, SystemExit) as exc:
        said = " ".join((out.getvalue() + " " + err.getvalue()).split())
        detail = f"{type(exc).__name__}: {exc}" if not isinstance(exc, SystemExit) else "no reader accepts it"
        if said:
            detail += f" ({said[:300]})"
        raise MeshError(f"{describe}: {detail}") from None
    return result, " ".join((out.getvalue() + " " + err.getvalue()).split())


def upgrade_to_tri6(nodes: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Six-node triangles from three-node ones: one new node at the midpoint of each distinct edge.

    Returns (nodes (n + n_edges, 3), elements (m, 6)). The midside nodes of an edge shared by two triangles
    are the same node.
    """
    nodes = np.asarray(nodes, dtype=float)
    tri = np.asarray(triangles)
    if tri.ndim != 2 or tri.shape[1] != 3:
        raise MeshError(f"triangles must have shape (m, 3), got {tri.shape}")
    if nodes.ndim != 2 or nodes.shape[1] != 3:
        raise MeshError(f"nodes must have shape (n, 3), got {nodes.shape}")
    tri = tri.astype(np.int64)
    if tri.size and (tri.min() < 0 or tri.max() >= len(nodes)):
        bad = int(tri.max()) if tri.max() >= len(nodes) else int(tri.min())
        raise MeshError(f"a triangle refers to node {bad}, which does not exist ({len(nodes)} nodes)")
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
    with np.errstate(invalid="ignore", over="ignore"):
        for k, (r, s) in enumerate(corners):
            g = np.einsum("ai,mij->maj", shape_derivatives(r, s), X)
            n = np.cross(g[:, 0], g[:, 1])
            length = np.linalg.norm(n, axis=1)
            size = np.linalg.norm(g[:, 0], axis=1) * np.linalg.norm(g[:, 1], axis=1)
            flat = np.flatnonzero(~(length > 1e-12 * size))
            if flat.size:
                e = int(flat[0])
                raise MeshError(f"element {e} is degenerate (zero area at its node {int(elements[e, k])}): no "
                                "director can be averaged there")
            n /= length[:, None]
            np.add.at(acc, elements[:, k], n)
        norm = np.linalg.norm(acc, axis=1)
    bad = np.flatnonzero(~(norm >= 1e-8))
    if bad.size:
        raise MeshError(f"the element normals around node {bad[0]} cancel: no director can be averaged there "
                        "(a degenerate element, inconsistent orientation or a fold)")
    return acc / norm[:, None]


def read_mesh(path: str | Path, allow_coincident_nodes: bool = False) -> Tri6Mesh:
    """Read a shell mesh of six-node (or three-node, upgraded) triangles from a file meshio can read.

    ``.msh`` files are read as gmsh files (ASCII or binary, format 2.2 or 4.1). Raises :class:`MeshError`
    naming the file for a missing, unreadable, malformed or truncated file, a file with no triangles or
    with cells other than triangles, lines and points; the mesh itself is validated like any other
    (:func:`flexbody.mesh.validate`) and a failure names the file too. ``allow_coincident_nodes`` admits a
    deliberate slit (distinct nodes at one place, as in the slit annular plate).
    """
    meshio = _meshio()
    path = Path(path)
    where = f"mesh file {str(path)!r}"
    if not path.exists():
        raise MeshError(f"{where} does not exist")
    if not path.is_file():
        raise MeshError(f"{where} is not a file")
    fmt = _FORMAT_BY_SUFFIX.get(path.suffix.lower())
    if fmt == "gmsh":
        _check_gmsh_sections(path, where)
    m, said = _quiet_meshio(lambda: meshio.read(path, file_format=fmt), f"cannot read {where}")
    if "not closed by" in said:
        raise MeshError(f"{where} is truncated or malformed: {said[:300]}")
    try:
        return _mesh_from_meshio(m, where, allow_coincident_nodes)
    except MeshError as exc:
        msg = str(exc)
        raise MeshError(msg if msg.startswith(where) else f"{where}: {msg}") from None
    except (ValueError, TypeError, IndexError, KeyError) as exc:  # odd shapes or types that meshio let through
        raise MeshError(f"{where} is malformed: {type(exc).__name__}: {exc}") from None


_SECTION = re.compile(rb"^\$(End)?([A-Za-z][A-Za-z0-9_]*)\s*$")


def _check_gmsh_sections(path: Path, where: str) -> None:
    """Every gmsh section $Name must be closed by $EndName: meshio only warns about an unclosed one, and
    reads a file cut off between two sections as if it were whole."""
    try:
        lines = path.read_bytes().splitlines()
    except OSError as exc:
        raise MeshError(f"cannot read {where}: {exc}") from None
    open_section = None
    for number, line in enumerate(lines, 1):
        match = _SECTION.match(line)
        if match is None:
            continue
        name = match.group(2).decode()
        if match.group(1) is None:
            if open_section is not None:
                raise MeshError(f"{where} is malformed: section ${name} starts at line {number} inside "
                                f"${open_section}")
            open_section = name
        elif open_section != name:
            raise MeshError(f"{where} is malformed: $End{name} at line {number} closes no ${name} section")
        else:
            open_section = None
    if open_section is not None:
        raise MeshError(f"{where} is truncated: section ${open_section} is not closed by $End{open_section}")


def _mesh_from_meshio(m, where: str, allow_coincident_nodes: bool) -> Tri6Mesh:
    nodes = np.asarray(m.points, dtype=float)
    if nodes.ndim != 2 or nodes.shape[0] == 0:
        raise MeshError(f"{where} has no nodes")
    if nodes.shape[1] == 2:
        nodes = np.column_stack([nodes, np.zeros(len(nodes))])
    if nodes.shape[1] != 3:
        raise MeshError(f"{where} has {nodes.shape[1]}-dimensional points (need 2 or 3)")
    bad = np.flatnonzero(~np.all(np.isfinite(nodes), axis=1))
    if bad.size:
        raise MeshError(f"{where}: node {bad[0]} has non-finite coordinates {nodes[bad[0]].tolist()}")
    types = sorted({c.type for c in m.cells})
    unusable = [t for t in types if t not in _USABLE_CELLS]
    if unusable:
        raise MeshError(f"{where} has cells of type {unusable}, which a shell mesh cannot use (flexbody reads "
                        "surface meshes of triangle6 or triangle cells, with line and vertex cells for sets)")
    tri6 = [np.asarray(c.data) for c in m.cells if c.type == "triangle6"]
    tri3 = [np.asarray(c.data) for c in m.cells if c.type == "triangle"]
    if tri6 and tri3:
        raise MeshError(f"{where} mixes three- and six-node triangles")
    if not tri6 and not tri3:
        if any(t in ("line", "line3") for t in types) and m.cell_data.get("gmsh:physical"):
            raise MeshError(f"{where} has no triangles, only line/point physical groups: gmsh saves only the "
                            "elements of physical groups once one exists; add a physical surface group "
                            "(Physical Surface, gmsh.model.addPhysicalGroup(2, ...)) or set Mesh.SaveAll = 1")
        raise MeshError(f"{where} has no triangles (cell types: {types or 'none'})")
    n_file = len(nodes)
    cells = np.vstack(tri6 or tri3)
    if cells.size and (cells.min() < 0 or cells.max() >= n_file):
        bad = int(cells.max()) if cells.max() >= n_file else int(cells.min())
        raise MeshError(f"{where} refers to node {bad}, which is not in the file ({n_file} nodes)")
    if tri6:
        elements = cells.astype(np.int64)
    else:
        nodes, elements = upgrade_to_tri6(nodes, cells)
    node_sets, edge_sets, element_sets = _physical_sets(m, elements, where)
    # drop nodes that no element uses (gmsh keeps geometry points), renumbering everything
    used = np.unique(elements)
    keep = np.arange(len(nodes))
    if len(used) < len(nodes):
        new = -np.ones(len(nodes), dtype=np.int64)
        new[used] = np.arange(len(used))
        nodes, elements, keep = nodes[used], new[elements], used
        node_sets = {k: new[v][new[v] >= 0] for k, v in node_sets.items()}
        edge_sets = {k: new[v] for k, v in edge_sets.items()}
    directors = None
    if tri6 and "directors" in m.point_data:
        d = np.asarray(m.point_data["directors"], dtype=float)
        if d.shape != (n_file, 3):
            raise MeshError(f"{where} has point data 'directors' of shape {d.shape}, expected ({n_file}, 3)")
        directors = d[keep]
    if directors is None:
        directors = averaged_directors(nodes, elements)
    return Tri6Mesh(nodes, elements, directors, node_sets, edge_sets, allow_coincident_nodes, element_sets)


def _physical_sets(m, elements: np.ndarray, where: str):
    """Named sets from gmsh physical groups (field_data name -> [tag, dim], cell_data['gmsh:physical']).

    gmsh numbers physical groups per dimension, so a group is identified by (tag, dimension). A group of
    triangles becomes an element set (indices into the file's triangles, in their order).
    """
    node_sets: dict[str, np.ndarray] = {}
    edge_sets: dict[str, np.ndarray] = {}
    element_sets: dict[str, np.ndarray] = {}
    phys = m.cell_data.get("gmsh:physical")
    if not phys or not m.field_data:
        return node_sets, edge_sets, element_sets
    names = {}
    for k, v in m.field_data.items():
        v = np.asarray(v).ravel()
        if v.size >= 2:
            names[(int(v[0]), int(v[1]))] = k
    # element edges as (corner, corner) -> (corner, midside, corner) in element orientation
    triples = elements[:, ELEMENT_EDGES].reshape(-1, 3)
    lookup = {(int(a), int(b)): (int(a), int(mid), int(b)) for a, mid, b in triples}
    tri_type = "triangle6" if any(c.type == "triangle6" for c in m.cells) else "triangle"
    first = 0                                            # the index of the block's first element
    for block, tags in zip(m.cells, phys):
        tags = np.asarray(tags).ravel()
        if block.type == tri_type:
            if len(tags) == len(block.data):
                for tag in np.unique(tags):
                    name = names.get((int(tag), 2))
                    if name is not None:
                        idx = first + np.flatnonzero(tags == tag)
                        element_sets[name] = np.concatenate([element_sets.get(name, np.array([], int)), idx])
            first += len(block.data)
            continue
        if block.type not in ("vertex", "line", "line3") or len(tags) != len(block.data):
            continue
        for tag in np.unique(tags):
            name = names.get((int(tag), _CELL_DIM[block.type]))
            if name is None:
                continue
            data = np.asarray(block.data)[tags == tag]
            if data.size and (data.min() < 0 or data.max() >= len(m.points)):
                raise MeshError(f"{where}: physical group {name!r} refers to a node that does not exist")
            if block.type == "vertex":
                node_sets[name] = np.unique(np.concatenate([node_sets.get(name, np.array([], int)), data.ravel()]))
            else:
                edges = []
                for row in data:
                    a, b = int(row[0]), int(row[1])
                    edge = lookup.get((a, b)) or (lookup[(b, a)][::-1] if (b, a) in lookup else None)
                    if edge is None:
                        raise MeshError(f"{where}: physical group {name!r} has the line ({a}, {b}), which is "
                                        "no element edge")
                    edges.append(edge)
                prev = edge_sets.get(name, np.zeros((0, 3), np.int64))
                edge_sets[name] = np.vstack([prev, np.array(edges, dtype=np.int64).reshape(-1, 3)])
                node_sets[name] = np.unique(edge_sets[name])
    return node_sets, edge_sets, element_sets


def write_mesh(mesh: Tri6Mesh, path: str | Path, point_data: dict[str, np.ndarray] | None = None) -> None:
    """Write the mesh (six-node triangles, directors as point data) to any format meshio writes by suffix
    (``.vtu`` for ParaView, ``.msh``, ``.xdmf``...). Extra nodal fields go in ``point_data``.

    ``.msh`` is written as gmsh 2.2 ASCII with the element sets as physical surface groups, the edge sets as
    physical line groups (line3 cells) and the other node sets as physical point groups, so :func:`read_mesh` gives back the mesh, its directors and
    its sets.
    """
    meshio = _meshio()
    path = Path(path)
    where = f"cannot write {str(path)!r}"
    if not path.parent.exists():
        raise MeshError(f"{where}: folder {str(path.parent)!r} does not exist")
    if path.is_dir():
        raise MeshError(f"{where}: it is a folder")
    data = {"directors": np.asarray(mesh.directors, dtype=float)}
    for k, v in (point_data or {}).items():
        v = np.asarray(v, dtype=float)
        if v.ndim == 0 or len(v) != mesh.n_nodes:
            raise MeshError(f"point data {k!r} has {v.shape[0] if v.ndim else 0} rows, the mesh has "
                            f"{mesh.n_nodes} nodes")
        data[k] = v
    if _FORMAT_BY_SUFFIX.get(path.suffix.lower()) == "gmsh":
        _write_gmsh(meshio, mesh, path, data, where)
        return
    out = meshio.Mesh(np.asarray(mesh.nodes), [("triangle6", np.asarray(mesh.elements))], point_data=data)
    _quiet_meshio(lambda: out.write(path), where)


def _write_gmsh(meshio, mesh: Tri6Mesh, path: Path, data: dict[str, np.ndarray], where: str) -> None:
    """gmsh 2.2 ASCII: the mesh and its sets through meshio, the nodal fields as $NodeData blocks.

    (meshio 5.3's own $NodeData writer prints numpy scalars as 'np.float64(...)' under numpy 2.)
    """
    for k, v in data.items():
        ncomp = 1 if v.ndim == 1 else int(np.prod(v.shape[1:]))
        if ncomp not in (1, 3, 9):
            raise MeshError(f"{where}: gmsh stores nodal fields of 1, 3 or 9 components; {k!r} has {ncomp}")
        if '"' in k or "\n" in k:
            raise MeshError(f"{where}: the field name {k!r} cannot be written to gmsh")
    cells = [("triangle6", np.asarray(mesh.elements))]
    physical, geometrical = [np.zeros(mesh.n_elements, dtype=int)], [np.zeros(mesh.n_elements, dtype=int)]
    field_data = {}
    tag = 0
    for name, elems in mesh.element_sets.items():        # physical surfaces: one tag per triangle
        if _bad_name(name):
            raise MeshError(f"{where}: the set name {name!r} cannot be written to gmsh")
        tag += 1
        if np.any(physical[0][elems] != 0):
            raise MeshError(f"{where}: element set {name!r} overlaps another element set, which gmsh physical "
                            "surfaces (one per triangle) cannot express")
        physical[0][elems] = tag
        geometrical[0][elems] = tag
        field_data[name] = np.array([tag, 2])
    for name, edges in mesh.edge_sets.items():
        tag += 1
        cells.append(("line3", np.asarray(edges)[:, [0, 2, 1]]))   # gmsh line3: end, end, middle
        physical.append(np.full(len(edges), tag))
        geometrical.append(np.full(len(edges), tag))
        field_data[name] = np.array([tag, 1])
    for name, nodes in mesh.node_sets.items():
        if name in mesh.edge_sets:
            if not np.array_equal(np.unique(nodes), np.unique(mesh.edge_sets[name])):
                raise MeshError(f"{where}: node set {name!r} differs from the edge set of the same name, which "
                                "gmsh physical names cannot express")
            continue
        if _bad_name(name):
            raise MeshError(f"{where}: the set name {name!r} cannot be written to gmsh")
        tag += 1
        cells.append(("vertex", np.asarray(nodes).reshape(-1, 1)))
        physical.append(np.full(len(nodes), tag))
        geometrical.append(np.full(len(nodes), tag))
        field_data[name] = np.array([tag, 0])
    for name in mesh.edge_sets:
        if _bad_name(name):
            raise MeshError(f"{where}: the set name {name!r} cannot be written to gmsh")
    out = meshio.Mesh(np.asarray(mesh.nodes), cells, field_data=field_data,
                      cell_data={"gmsh:physical": physical, "gmsh:geometrical": geometrical})
    _quiet_meshio(lambda: meshio.write(path, out, file_format="gmsh22", binary=False), where)
    try:
        with open(path, "a", encoding="ascii") as fh:
            for name, v in data.items():
                v = v.reshape(mesh.n_nodes, -1)
                fh.write(f'$NodeData\n1\n"{name}"\n1\n0.0\n3\n0\n{v.shape[1]}\n{mesh.n_nodes}\n')
                for i, row in enumerate(v):
                    fh.write(f"{i + 1} " + " ".join(f"{float(c):.17g}" for c in row) + "\n")
                fh.write("$EndNodeData\n")
    except OSError as exc:
        raise MeshError(f"{where}: {exc}") from None


def _bad_name(name: str) -> bool:
    return not name or '"' in name or "\n" in name
