"""Writes the bundled Gmsh meshes (MSH 4.1) that `data/plate-hole-mesh-2d.json` and
`data/bracket-mesh-3d.json` read, with gmsh's Python API (`pip install gmsh==4.15.2`):

* data/plate-hole-mesh-2d.msh: the plate with a hole of data/plate-hole-2d.json (1 x 0.5,
  a hole of radius 0.1 at its centre), linear triangles of size 0.01; physical groups: the
  surface "plate", the curves "left" (x = 0) and "right" (x = 1).
* data/bracket-mesh-3d.msh: an L-bracket, a 0.1 x 0.3 x 0.1 leg standing on y = 0 and a
  0.4 x 0.1 x 0.1 arm along x at its top, linear tetrahedra of size 0.02; physical groups: the
  volume "bracket", the surfaces "clamp" (y = 0) and "load" (x = 0.4).

* data/bracket-mesh-3d.e: the same tetrahedra as Exodus II ([`exodus_from_gmsh`]).
* data/bracket-mesh-3d.vtu: the same mesh as VTU, written by meshio (sets by tag: "2" the
  clamp, "3" the load).

Run from the repository root: `python3 examples/make_meshes.py`. The files are committed;
gmsh's meshes depend on its version, so the script pins nothing but documents how they were
made.
"""
import gmsh


def plate_hole(path, size=0.01):
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
    gmsh.option.setNumber("Mesh.MeshSizeMin", size)
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.model.mesh.generate(2)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(path)
    gmsh.finalize()


def bracket(path, size=0.02):
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
    gmsh.option.setNumber("Mesh.MeshSizeMin", size)
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.model.mesh.generate(3)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(path)
    gmsh.finalize()




def exodus_from_gmsh(msh_path, exo_path):
    """Writes the tetrahedra of a Gmsh mesh as an Exodus II file (classic netCDF, written by
    scipy.io.netcdf_file, no Exodus library): one element block "bracket" (id 1), the node set
    "clamp" (id 1: the mesh nodes on y = 0) and the side set "load" (id 2: the faces on
    x = 0.4, as element and local side numbers in Exodus' tetrahedron side order)."""
    import meshio
    import numpy as np
    from scipy.io import netcdf_file

    m = meshio.read(msh_path)
    tets = np.concatenate([c.data for c in m.cells if c.type == "tetra"])
    used = np.unique(tets)
    renumber = -np.ones(len(m.points), dtype=np.int64)
    renumber[used] = np.arange(len(used))
    x = m.points[used]
    conn = renumber[tets] + 1
    clamp = np.nonzero(np.abs(x[:, 1]) < 1e-9)[0] + 1
    # Exodus' tetrahedron sides (1-based): (1 2 4), (2 3 4), (1 4 3), (1 3 2)
    sides = [(0, 1, 3), (1, 2, 3), (0, 3, 2), (0, 2, 1)]
    elem_ss, side_ss = [], []
    for e, c in enumerate(conn):
        for s, face in enumerate(sides):
            if all(abs(x[c[v] - 1, 0] - 0.4) < 1e-9 for v in face):
                elem_ss.append(e + 1)
                side_ss.append(s + 1)
    len_name = 33

    def names(strings):
        a = np.zeros((len(strings), len_name), dtype="S1")
        for i, s in enumerate(strings):
            a[i, : len(s)] = list(s)
        return a

    f = netcdf_file(exo_path, "w", version=2)
    f.title = "linpd bracket (examples/make_meshes.py)"
    f.api_version = np.float32(8.1)
    f.version = np.float32(8.1)
    f.floating_point_word_size = np.int32(8)
    f.file_size = np.int32(1)
    f.createDimension("time_step", None)
    f.createDimension("len_string", 33)
    f.createDimension("len_name", len_name)
    f.createDimension("num_dim", 3)
    f.createDimension("num_nodes", len(x))
    f.createDimension("num_elem", len(conn))
    f.createDimension("num_el_blk", 1)
    f.createDimension("num_node_sets", 1)
    f.createDimension("num_side_sets", 1)
    f.createDimension("num_el_in_blk1", len(conn))
    f.createDimension("num_nod_per_el1", 4)
    f.createDimension("num_nod_ns1", len(clamp))
    f.createDimension("num_side_ss1", len(elem_ss))
    for a, name in enumerate(["coordx", "coordy", "coordz"]):
        v = f.createVariable(name, "d", ("num_nodes",))
        v[:] = x[:, a]
    v = f.createVariable("connect1", "i", ("num_el_in_blk1", "num_nod_per_el1"))
    v[:] = conn
    v.elem_type = "TETRA4"
    v = f.createVariable("eb_prop1", "i", ("num_el_blk",))
    v[:] = [1]
    v.name = "ID"
    v = f.createVariable("eb_names", "c", ("num_el_blk", "len_name"))
    v[:] = names(["bracket"])
    v = f.createVariable("node_ns1", "i", ("num_nod_ns1",))
    v[:] = clamp
    v = f.createVariable("ns_prop1", "i", ("num_node_sets",))
    v[:] = [1]
    v.name = "ID"
    v = f.createVariable("ns_names", "c", ("num_node_sets", "len_name"))
    v[:] = names(["clamp"])
    v = f.createVariable("elem_ss1", "i", ("num_side_ss1",))
    v[:] = elem_ss
    v = f.createVariable("side_ss1", "i", ("num_side_ss1",))
    v[:] = side_ss
    v = f.createVariable("ss_prop1", "i", ("num_side_sets",))
    v[:] = [2]
    v.name = "ID"
    v = f.createVariable("ss_names", "c", ("num_side_sets", "len_name"))
    v[:] = names(["load"])
    f.close()


if __name__ == "__main__":
    import sys

    if len(sys.argv) == 1:
        plate_hole("data/plate-hole-mesh-2d.msh")
        bracket("data/bracket-mesh-3d.msh")
        exodus_from_gmsh("data/bracket-mesh-3d.msh", "data/bracket-mesh-3d.e")
        import meshio

        # the same mesh as VTU: meshio writes the physical tags as the cell array gmsh:physical
        meshio.write("data/bracket-mesh-3d.vtu", meshio.read("data/bracket-mesh-3d.msh"))
    elif len(sys.argv) == 4 and sys.argv[1] in ("plate", "bracket"):
        {"plate": plate_hole, "bracket": bracket}[sys.argv[1]](sys.argv[3], float(sys.argv[2]))
    else:
        sys.exit("usage: make_meshes.py [plate|bracket SIZE OUT.msh]")
