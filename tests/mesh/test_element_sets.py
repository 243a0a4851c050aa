"""gmsh physical surfaces as element sets: read, written back, used by a TOML pressure load; a file with
only line groups (so no triangles) says why and how to fix it."""

from pathlib import Path

import numpy as np
import pytest

from flexbody.mesh import MeshError, generators
from flexbody.mesh.io import read_mesh, write_mesh
from tests.mesh.test_io import SQUARE_TRI3, SQUARE_TRI6

pytest.importorskip("meshio")
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

# SQUARE_TRI6 with its two triangles in two physical surfaces, "a" (tag 4) and "b" (tag 5)
TWO_SURFACES = SQUARE_TRI6.replace('1\n1 3 "bottom"', '3\n1 3 "bottom"\n2 4 "a"\n2 5 "b"') \
    .replace("2 9 2 0 1 1 2 3 5 6 7", "2 9 2 4 1 1 2 3 5 6 7").replace("3 9 2 0 1 1 3 4 7 8 9", "3 9 2 5 1 1 3 4 7 8 9")

ONLY_LINES = """$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
1
1 1 "clamped"
$EndPhysicalNames
$Nodes
3
1 0 0 0
2 0 1 0
3 0 0.5 0
$EndNodes
$Elements
1
1 8 2 1 1 1 2 3
$EndElements
"""


def test_physical_surfaces_become_element_sets(tmp_path):
    (tmp_path / "a.msh").write_text(TWO_SURFACES)
    m = read_mesh(tmp_path / "a.msh")
    np.testing.assert_array_equal(m.element_set("a"), [0])
    np.testing.assert_array_equal(m.element_set("b"), [1])
    (tmp_path / "b.msh").write_text(SQUARE_TRI3)
    np.testing.assert_array_equal(read_mesh(tmp_path / "b.msh").element_set("plate"), [0, 1])
    with pytest.raises(MeshError, match="unknown element set 'c'; this mesh has element sets: a, b"):
        m.element_set("c")


def test_element_sets_survive_a_gmsh_round_trip(tmp_path):
    strip = generators.strip(2.0, 1.0, 4, 2)
    left = np.flatnonzero(strip.nodes[strip.elements].mean(axis=1)[:, 0] < 1.0)
    m = strip.with_sets()
    m = type(m)(m.nodes, m.elements, m.directors, m.node_sets, m.edge_sets, False,
                {"left": left, "right": np.setdiff1d(np.arange(m.n_elements), left)})
    write_mesh(m, tmp_path / "s.msh")
    r = read_mesh(tmp_path / "s.msh")
    np.testing.assert_array_equal(r.element_set("left"), left)
    assert len(r.element_set("right")) == m.n_elements - len(left) and sorted(r.edge_sets) == sorted(m.edge_sets)
    with pytest.raises(MeshError, match="element set 'bad' refers to element 99"):
        type(m)(m.nodes, m.elements, m.directors, element_sets={"bad": [99]})


def test_a_file_with_only_line_groups_says_how_to_get_triangles(tmp_path):
    (tmp_path / "l.msh").write_text(ONLY_LINES)
    with pytest.raises(MeshError, match=r"no triangles, only line/point physical groups.*Mesh.SaveAll = 1"):
        read_mesh(tmp_path / "l.msh")


def test_the_gmsh_example_loads_the_right_part_only():
    from flexbody.scenes import open_scene
    scene = open_scene(str(EXAMPLES / "gmsh_two_part_plate.toml")).build()
    mesh = scene.model.body.mesh
    assert (mesh.elements.shape[1], sorted(mesh.element_sets)) == (6, ["left", "right"])
    (pressure,) = scene.model.pressures
    np.testing.assert_array_equal(pressure.elements, mesh.element_set("right"))
    assert np.all(mesh.nodes[mesh.elements[pressure.elements]].mean(axis=1)[:, 0] > 1.0)


def test_a_pressure_on_an_unknown_element_set_is_one_line(tmp_path):
    from flexbody.scenes import open_scene
    from flexbody.scenes.sources import SceneError
    text = (EXAMPLES / "gmsh_two_part_plate.toml").read_text().replace('set = "right"', 'set = "middle"')
    (tmp_path / "p.toml").write_text(text)
    (tmp_path / "gmsh_two_part_plate.msh").write_bytes((EXAMPLES / "gmsh_two_part_plate.msh").read_bytes())
    with pytest.raises(SceneError, match="names element set 'middle'; the mesh has element sets: left, right"):
        open_scene(str(tmp_path / "p.toml")).build()
