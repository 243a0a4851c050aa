"""Mesh generators for the benchmark geometries, with nodes on the exact surface and exact directors.

A "2 x nu x nv" mesh splits each of nu x nv parametric quadrilateral cells into two six-node triangles.
The cell's nine grid points (corners, edge midpoints, centre) are the triangles' nodes, so every node,
midside nodes included, lies on the exact surface. ``diagonal`` chooses the split: "right" (from the cell's
(0, 0) corner to (1, 1)), "left" ((1, 0) to (0, 1)) or "alternate" (a checkerboard of both).

Every generator names the node and edge sets a user needs for boundary conditions and loads; they are
listed in each docstring.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from flexbody.mesh.tri6 import MeshError, Tri6Mesh

_DIAGONALS = ("right", "left", "alternate")


def _check_count(value, name: str, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise MeshError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _check_length(value, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise MeshError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise MeshError(f"{name} must be positive and finite, got {value!r}")
    return v


def _curved_mesh(what: str, hint: str, *args, **kwargs) -> Tri6Mesh:
    """Tri6Mesh(*args, **kwargs); a midside node that validation finds too far off its chord means cells too
    coarse for the curvature (a quadratic edge over more than ~106 degrees of arc): say so."""
    try:
        return Tri6Mesh(*args, **kwargs)
    except MeshError as exc:
        if "midside node" not in str(exc):
            raise
        raise MeshError(f"{what}: the cells are too coarse for the curvature ({exc}); {hint}") from None


def _sector_angle(angle, n_circ: int, what: str) -> tuple[float, bool]:
    """The opening angle of a surface of revolution, checked, and whether it closes (2 pi)."""
    angle = _check_length(angle, "angle")
    if angle > 2 * math.pi + 1e-12:
        raise MeshError(f"angle must be at most 2 pi, got {angle}")
    full = abs(angle - 2 * math.pi) < 1e-12
    if full and n_circ < 2:
        raise MeshError(f"a full {what} needs n_circ >= 2")
    return angle, full


def _grid_triangles(nu: int, nv: int, diagonal: str, periodic_v: bool) -> np.ndarray:
    """Connectivity (2 nu nv, 6) on the (2 nu + 1) x (2 nv + 1) point grid, index = i (2 nv + 1) + j."""
    if diagonal not in _DIAGONALS:
        raise MeshError(f"diagonal must be one of {_DIAGONALS}, got {diagonal!r}")
    mv = 2 * nv if periodic_v else 2 * nv + 1

    def g(i, j):
        return i * mv + (j % (2 * nv) if periodic_v else j)

    tris = []
    for a in range(nu):
        for b in range(nv):
            i, j = 2 * a, 2 * b
            p00, p10, p11, p01 = g(i, j), g(i + 2, j), g(i + 2, j + 2), g(i, j + 2)
            m_bot, m_right, m_top, m_left, c = g(i + 1, j), g(i + 2, j + 1), g(i + 1, j + 2), g(i, j + 1), g(i + 1, j + 1)
            right = diagonal == "right" or (diagonal == "alternate" and (a + b) % 2 == 0)
            if right:   # diagonal p00 - p11
                tris.append([p00, p10, p11, m_bot, m_right, c])
                tris.append([p00, p11, p01, c, m_top, m_left])
            else:       # diagonal p10 - p01
                tris.append([p00, p10, p01, m_bot, c, m_left])
                tris.append([p10, p11, p01, m_right, m_top, c])
    return np.array(tris, dtype=np.int64)


def _structured(surface: Callable, u_range, v_range, nu: int, nv: int, diagonal: str,
                periodic_v: bool = False, **mesh_kw):
    """Nodes, directors and connectivity of a parametric surface (u, v) -> (x (k, 3), normal (k, 3)).

    Returns the mesh pieces and a helper ``index(i, j)`` of grid point (i, j), 0 <= i <= 2 nu, 0 <= j <= 2 nv.
    """
    u = np.linspace(*u_range, 2 * nu + 1)
    v = np.linspace(*v_range, 2 * nv + 1)
    if periodic_v:
        v = v[:-1]
    U, V = np.meshgrid(u, v, indexing="ij")
    x, normal = surface(U.ravel(), V.ravel())
    normal = normal / np.linalg.norm(normal, axis=1, keepdims=True)
    conn = _grid_triangles(nu, nv, diagonal, periodic_v)
    mv = len(v)

    def index(i, j):
        return np.asarray(i) * mv + (np.asarray(j) % (2 * nv) if periodic_v else np.asarray(j))

    return x, normal, conn, index


def _line(index, i, j) -> np.ndarray:
    """Edge triples (k, 3) along a grid line given by index arrays i, j of length 2k + 1."""
    nodes = index(i, j)
    return np.stack([nodes[0:-1:2], nodes[1::2], nodes[2::2]], axis=1)


def _side_sets(index, nu: int, nv: int, names: dict[str, str], periodic_v: bool = False):
    """Node and edge sets of the parametric sides u_min, u_max, v_min, v_max under the given names."""
    iu = np.arange(2 * nu + 1)
    jv = np.arange(2 * nv + 1)
    sides = {"u_min": (np.zeros_like(jv), jv), "u_max": (np.full_like(jv, 2 * nu), jv)}
    if not periodic_v:
        sides.update({"v_min": (iu, np.zeros_like(iu)), "v_max": (iu, np.full_like(iu, 2 * nv))})
    edge_sets = {names[k]: _line(index, *ij) for k, ij in sides.items() if k in names}
    node_sets = {name: np.unique(e) for name, e in edge_sets.items()}
    return node_sets, edge_sets


def strip(length: float, width: float, nx: int, ny: int, diagonal: str = "right") -> Tri6Mesh:
    """Flat rectangle [0, length] x [0, width] in the plane z = 0, director +z; 2 x nx x ny elements.

    Sets (node and edge): "clamped" (x = 0), "tip" (x = length), "bottom" (y = 0), "top" (y = width).
    """
    length, width = _check_length(length, "length"), _check_length(width, "width")
    nx, ny = _check_count(nx, "nx"), _check_count(ny, "ny")

    def surface(u, v):
        x = np.stack([u, v, np.zeros_like(u)], axis=1)
        return x, np.tile([0.0, 0.0, 1.0], (len(u), 1))

    x, d, conn, index = _structured(surface, (0, length), (0, width), nx, ny, diagonal)
    ns, es = _side_sets(index, nx, ny, {"u_min": "clamped", "u_max": "tip", "v_min": "bottom", "v_max": "top"})
    return Tri6Mesh(x, conn, d, ns, es)


def slit_annulus(inner_radius: float, outer_radius: float, n_radial: int, n_circ: int,
                 diagonal: str = "right") -> Tri6Mesh:
    """Flat annulus in z = 0 with a slit along the +x axis (Sze et al. 2004, 3.3); director +z.

    The slit's two lips are distinct coincident nodes: the lip at angle 0 is "clamped", the lip at angle
    2 pi is "loaded". Node sets "A" (inner radius) and "B" (outer radius) on the loaded lip; edge sets
    "clamped", "loaded", "inner", "outer".
    """
    ri, ro = _check_length(inner_radius, "inner_radius"), _check_length(outer_radius, "outer_radius")
    if ro <= ri:
        raise MeshError(f"outer_radius must exceed inner_radius, got {ri} and {ro}")
    nr, nc = _check_count(n_radial, "n_radial"), _check_count(n_circ, "n_circ")

    def surface(r, t):
        x = np.stack([r * np.cos(t), r * np.sin(t), np.zeros_like(r)], axis=1)
        return x, np.tile([0.0, 0.0, 1.0], (len(r), 1))

    x, d, conn, index = _structured(surface, (ri, ro), (0.0, 2 * math.pi), nr, nc, diagonal)
    ns, es = _side_sets(index, nr, nc, {"v_min": "clamped", "v_max": "loaded", "u_min": "inner", "u_max": "outer"})
    ns["A"] = np.array([index(0, 2 * nc)])
    ns["B"] = np.array([index(2 * nr, 2 * nc)])
    return _curved_mesh("slit_annulus", "use more cells around (n_circ >= 5)", x, conn, d, ns, es,
                        allow_coincident_nodes=True)


def annulus(inner_radius: float, outer_radius: float, n_radial: int, n_circ: int,
            diagonal: str = "right") -> Tri6Mesh:
    """Full flat annulus in z = 0 (closed in the circumferential direction); director +z.

    Sets: "inner" (r = inner_radius) and "outer" (r = outer_radius).
    """
    ri, ro = _check_length(inner_radius, "inner_radius"), _check_length(outer_radius, "outer_radius")
    if ro <= ri:
        raise MeshError(f"outer_radius must exceed inner_radius, got {ri} and {ro}")
    nr, nc = _check_count(n_radial, "n_radial"), _check_count(n_circ, "n_circ", 2)

    def surface(r, t):
        x = np.stack([r * np.cos(t), r * np.sin(t), np.zeros_like(r)], axis=1)
        return x, np.tile([0.0, 0.0, 1.0], (len(r), 1))

    x, d, conn, index = _structured(surface, (ri, ro), (0.0, 2 * math.pi), nr, nc, diagonal, periodic_v=True)
    ns, es = _side_sets(index, nr, nc, {"u_min": "inner", "u_max": "outer"}, periodic_v=True)
    return _curved_mesh("annulus", "use more cells around (n_circ >= 5)", x, conn, d, ns, es)


def cylinder(radius: float, length: float, n_circ: int, n_axial: int, angle: float = 2 * math.pi,
             diagonal: str = "right") -> Tri6Mesh:
    """Open cylinder sector about the z axis: angle in [0, ``angle``], z in [0, ``length``]; outward directors.

    x = (R cos a, R sin a, z). ``angle`` = pi/2 gives the octant or quarter model, 2 pi the full cylinder
    (closed seam). Sets: "bottom" (z = 0), "top" (z = length), and for a sector "start" (a = 0, the x-z
    plane) and "end" (a = angle).
    """
    R, length = _check_length(radius, "radius"), _check_length(length, "length")
    nc, na = _check_count(n_circ, "n_circ"), _check_count(n_axial, "n_axial")
    angle, full = _sector_angle(angle, nc, "cylinder")

    def surface(z, a):
        x = np.stack([R * np.cos(a), R * np.sin(a), z], axis=1)
        return x, np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], axis=1)

    # u = z, v = angle: (x_,z x x_,a) points inward, so parametrise by (a, z) instead
    def surface_az(a, z):
        return surface(z, a)

    if full:
        # periodic direction must be v: use (z, a) and flip orientation by reversing the angle
        def surface_za(z, a):
            return surface(z, -a)
        x, d, conn, index = _structured(surface_za, (0, length), (0, 2 * math.pi), na, nc, diagonal, periodic_v=True)
        ns, es = _side_sets(index, na, nc, {"u_min": "bottom", "u_max": "top"}, periodic_v=True)
        return _curved_mesh("cylinder", "use more cells around (n_circ)", x, conn, d, ns, es)
    x, d, conn, index = _structured(surface_az, (0, angle), (0, length), nc, na, diagonal)
    ns, es = _side_sets(index, nc, na, {"u_min": "start", "u_max": "end", "v_min": "bottom", "v_max": "top"})
    return _curved_mesh("cylinder", "use more cells around (n_circ)", x, conn, d, ns, es)


def spherical_cap(radius: float, hole_deg: float, n_meridian: int, n_circ: int, angle: float = 2 * math.pi,
                  polar_max_deg: float = 90.0, diagonal: str = "right") -> Tri6Mesh:
    """Spherical shell about the z axis between polar angles ``hole_deg`` and ``polar_max_deg``.

    x = R (sin p cos a, sin p sin a, cos p), outward directors; a in [0, ``angle``]. With hole 18 deg,
    polar_max 90 deg and angle pi/2 this is the quarter hemisphere of Sze et al. (2004) 3.4. Sets: "hole"
    (p = hole), "equator" (p = polar_max), and for a sector "start" (a = 0) and "end" (a = angle).
    """
    R = _check_length(radius, "radius")
    hole = _check_length(hole_deg, "hole_deg")
    pmax = _check_length(polar_max_deg, "polar_max_deg")
    if not hole < pmax < 180.0:
        raise MeshError(f"need 0 < hole_deg < polar_max_deg < 180, got {hole_deg} and {polar_max_deg}")
    nm, nc = _check_count(n_meridian, "n_meridian"), _check_count(n_circ, "n_circ")
    angle, full = _sector_angle(angle, nc, "spherical cap")

    def surface(p, a):
        n = np.stack([np.sin(p) * np.cos(a), np.sin(p) * np.sin(a), np.cos(p)], axis=1)
        return R * n, n

    x, d, conn, index = _structured(surface, (math.radians(hole), math.radians(pmax)), (0, angle), nm, nc,
                                    diagonal, periodic_v=full)
    names = {"u_min": "hole", "u_max": "equator"}
    if not full:
        names.update({"v_min": "start", "v_max": "end"})
    ns, es = _side_sets(index, nm, nc, names, periodic_v=full)
    return _curved_mesh("spherical_cap", "use more cells (n_meridian, n_circ)", x, conn, d, ns, es)


def regular_polygon(n_sides: int, radius: float, n_rings: int) -> Tri6Mesh:
    """Flat regular polygon in z = 0 (a hexagonal membrane for n_sides = 6), centred at the origin.

    Each of the n_sides triangular sectors (centre, vertex k, vertex k + 1) is split into n_rings^2 six-node
    triangles. ``radius`` is the circumradius; vertex 0 lies on +x. Sets: "center" (the centre node),
    "corners" (the polygon's vertices), "boundary" (node and edge set of the rim).
    """
    ns_ = _check_count(n_sides, "n_sides", 3)
    R = _check_length(radius, "radius")
    nr = _check_count(n_rings, "n_rings")
    k = 2 * nr  # lattice points per sector side (six-node resolution)
    verts = [np.array([R * math.cos(2 * math.pi * i / ns_), R * math.sin(2 * math.pi * i / ns_)]) for i in range(ns_)]
    index: dict[tuple[int, int, int], int] = {}
    points: list[np.ndarray] = []

    def node(sector: int, i: int, j: int) -> int:
        """Lattice point i steps out from the centre, j steps towards vertex sector+1 (0 <= j <= i <= k)."""
        if j == i and sector >= 0:               # on the sector's second ray: it is the next sector's first ray
            return node((sector + 1) % ns_ if i else 0, i, 0) if i else node(-1, 0, 0)
        key = (sector if i else -1, i, j)
        if key not in index:
            a, b = verts[sector], verts[(sector + 1) % ns_]
            p = (i / k) * a + (j / k) * (b - a) if i else np.zeros(2)
            index[key] = len(points)
            points.append(p)
        return index[key]

    tris = []
    for s in range(ns_):
        for I in range(0, k, 2):
            for J in range(0, I + 1, 2):
                # upward triangle (I, J), (I+2, J), (I+2, J+2)
                tris.append([node(s, I, J), node(s, I + 2, J), node(s, I + 2, J + 2),
                             node(s, I + 1, J), node(s, I + 2, J + 1), node(s, I + 1, J + 1)])
                if J + 2 <= I:  # downward triangle (I, J), (I+2, J+2), (I, J+2)
                    tris.append([node(s, I, J), node(s, I + 2, J + 2), node(s, I, J + 2),
                                 node(s, I + 1, J + 1), node(s, I + 1, J + 2), node(s, I, J + 1)])
    x = np.column_stack([np.array(points), np.zeros(len(points))])
    rim = np.array([[node(s, k, j), node(s, k, j + 1), node(s, k, j + 2)] for s in range(ns_) for j in range(0, k, 2)])
    sets = {"center": np.array([node(-1, 0, 0)]), "corners": np.array([node(s, k, 0) for s in range(ns_)]),
            "boundary": np.unique(rim)}
    return Tri6Mesh(x, np.array(tris), np.tile([0.0, 0.0, 1.0], (len(x), 1)), sets, {"boundary": rim})
