"""Writes the bundled Gmsh meshes (MSH 4.1) that `data/plate-hole-mesh-2d.json` and
`data/bracket-mesh-3d.json` read, with gmsh's Python API (`pip install gmsh==4.15.2`):

* data/plate-hole-mesh-2d.msh: the plate with a hole of data/plate-hole-2d.json (1 x 0.5,
  a hole of radius 0.1 at its centre), linear triangles of size 0.01; physical groups: the
  surface "plate", the curves "left" (x = 0) and "right" (x = 1).
* data/bracket-mesh-3d.msh: an L-bracket, a 0.1 x 0.3 x 0.1 leg standing on y = 0 and a
  0.4 x 0.1 x 0.1 arm along x at its top, linear tetrahedra of size 0.02; physical groups: the
  volume "bracket", the surfaces "clamp" (y = 0) and "load" (x = 0.4).

Run from the repository root: `python3 examples/make_meshes.py`. The files are committed;
gmsh's meshes depend on its version, so the script pins nothing but documents how they were
made.
"""
import gmsh


def plate_hole(path):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("plate-hole")
    occ = gmsh.model.occ
    plate = occ.addRectangle(0.0, 0.0, 0.0, 1.0, 0.5)
    hole = occ.addDisk(0.5, 0.25, 0.0, 0.1, 0.1)
    occ.cut([(2, plate)], [(2, hole)])
    occ.synchronize()
    surfaces = [t for _, t in gmsh.model.getEntities(2)]
    left, right = [], []
    for _, c in gmsh.model.getEntities(1):
        x0, y0, _, x1, y1, _ = gmsh.model.getBoundingBox(1, c)
        if abs(x0) < 1e-6 and abs(x1) < 1e-6:
            left.append(c)
        if abs(x0 - 1.0) < 1e-6 and abs(x1 - 1.0) < 1e-6:
            right.append(c)
    gmsh.model.addPhysicalGroup(2, surfaces, 1, "plate")
    gmsh.model.addPhysicalGroup(1, left, 2, "left")
    gmsh.model.addPhysicalGroup(1, right, 3, "right")
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.01)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.01)
    gmsh.model.mesh.generate(2)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(path)
    gmsh.finalize()


def bracket(path):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("bracket")
    occ = gmsh.model.occ
    # a leg 0.1 x 0.3 x 0.1 standing on y = 0, an arm 0.4 x 0.1 x 0.1 at its top along x
    leg = occ.addBox(0.0, 0.0, 0.0, 0.1, 0.3, 0.1)
    arm = occ.addBox(0.0, 0.2, 0.0, 0.4, 0.1, 0.1)
    occ.fuse([(3, leg)], [(3, arm)])
    occ.synchronize()
    volumes = [t for _, t in gmsh.model.getEntities(3)]
    clamp, load = [], []
    for _, s in gmsh.model.getEntities(2):
        x0, y0, _, x1, y1, _ = gmsh.model.getBoundingBox(2, s)
        if abs(y0) < 1e-6 and abs(y1) < 1e-6:
            clamp.append(s)
        if abs(x0 - 0.4) < 1e-6 and abs(x1 - 0.4) < 1e-6:
            load.append(s)
    gmsh.model.addPhysicalGroup(3, volumes, 1, "bracket")
    gmsh.model.addPhysicalGroup(2, clamp, 2, "clamp")
    gmsh.model.addPhysicalGroup(2, load, 3, "load")
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.02)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.02)
    gmsh.model.mesh.generate(3)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(path)
    gmsh.finalize()


if __name__ == "__main__":
    plate_hole("data/plate-hole-mesh-2d.msh")
    bracket("data/bracket-mesh-3d.msh")
