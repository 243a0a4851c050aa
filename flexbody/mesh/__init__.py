"""Six-node triangle meshes: the mesh type and its validation, generators, file import and export."""

from flexbody.mesh.tri6 import ELEMENT_EDGES, MeshError, Tri6Mesh, validate

__all__ = ["ELEMENT_EDGES", "MeshError", "Tri6Mesh", "validate"]
