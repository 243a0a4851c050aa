"""Make examples/gmsh_two_part_plate.msh with gmsh's Python API (pip install gmsh).

A 2 x 1 plate of two surfaces, "left" (x < 1) and "right" (x > 1), meshed with second-order (six-node)
triangles; physical groups: the surfaces "left" and "right" (element sets in flexbody), the line "clamped"
(x = 0, an edge set) and the point "tip" (2, 1). examples/gmsh_two_part_plate.toml runs it: clamped on the
left edge, a follower pressure on the right part only. Run

    python examples/gmsh_two_part_plate.py [--size 0.25] [--out examples/gmsh_two_part_plate.msh]
    flexbody run examples/gmsh_two_part_plate.toml

(The .msh file is in examples/ too, so the scene runs without gmsh.)
"""

import argparse
from pathlib import Path

import gmsh


def make(out: Path, size: float = 0.25) -> None:
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("two_part_plate")
        occ = gmsh.model.occ
        left = occ.addRectangle(0.0, 0.0, 0.0, 1.0, 1.0)
        right = occ.addRectangle(1.0, 0.0, 0.0, 1.0, 1.0)
        occ.fragment([(2, left)], [(2, right)])             # one shared edge at x = 1, conforming meshes
        occ.synchronize()
        surfaces = {}
        for dim, tag in gmsh.model.getEntities(2):
            x = gmsh.model.occ.getCenterOfMass(dim, tag)[0]
            surfaces.setdefault("left" if x < 1.0 else "right", []).append(tag)
        for name, tags in surfaces.items():
            gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, tags), name)
        clamped = [tag for dim, tag in gmsh.model.getEntities(1)
                   if abs(gmsh.model.occ.getCenterOfMass(dim, tag)[0]) < 1e-9]
        gmsh.model.setPhysicalName(1, gmsh.model.addPhysicalGroup(1, clamped), "clamped")
        tip = [tag for dim, tag in gmsh.model.getEntities(0)
               if max(abs(a - b) for a, b in zip(gmsh.model.getValue(0, tag, []), (2.0, 1.0, 0.0))) < 1e-9]
        gmsh.model.setPhysicalName(0, gmsh.model.addPhysicalGroup(0, tip), "tip")
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.option.setNumber("Mesh.ElementOrder", 2)      # six-node triangles
        gmsh.option.setNumber("Mesh.MshFileVersion", 2.2)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(out))
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=float, default=0.25, help="largest element size")
    ap.add_argument("--out", type=Path, default=Path(__file__).with_suffix(".msh"))
    args = ap.parse_args()
    make(args.out, args.size)
    print(f"written {args.out}")
