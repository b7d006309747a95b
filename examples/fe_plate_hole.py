"""An independent reference for the meshed plate with a hole (issue #33 item 4, first step):
plane-stress linear elasticity (E = 1, nu = 1/3, the bond model's plane-stress Poisson ratio)
by scikit-fem with quadratic (P2) triangles on a gmsh mesh of the same geometry (1 x 0.5, a
hole of radius 0.1 at its centre); u_x = 0 on the left edge, u_y = 0 at the mesh node nearest
(0, 0.25), traction 1 on the right edge (the resultant 0.5 of data/plate-hole-mesh-2d.json).

    python3 examples/fe_plate_hole.py FE_SIZE out/plate-hole-mesh-2d/result.json [...]

evaluates the FE displacement at the nodes of each linpd result.json and prints the largest
|u - u_FE| / max |u_FE| and the mean u_x of the nodes beyond x = 0.98 against the FE's at the
same points. Needs `pip install gmsh==4.15.2 scikit-fem==12.0.2`. FE_SIZE 0.004 gives the right
edge's mean u_x to 3e-4 (0.008: 1.22010, 0.004: 1.22033, 0.003: 1.22036 at the same points).
"""
import json
import sys

import gmsh
import numpy as np
import skfem
from skfem.models.elasticity import lame_parameters, linear_elasticity


def mesh(size):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    occ = gmsh.model.occ
    plate = occ.addRectangle(0, 0, 0, 1, 0.5)
    hole = occ.addDisk(0.5, 0.25, 0, 0.1, 0.1)
    occ.cut([(2, plate)], [(2, hole)])
    occ.synchronize()
    gmsh.option.setNumber("Mesh.MeshSizeMin", size)
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.model.mesh.generate(2)
    tags, x, _ = gmsh.model.mesh.getNodes()
    _, nodes = gmsh.model.mesh.getElementsByType(2)
    index = {t: i for i, t in enumerate(tags)}
    tri = np.array([index[v] for v in nodes]).reshape(-1, 3)
    gmsh.finalize()
    return skfem.MeshTri(x.reshape(-1, 3)[:, :2].T, tri.T)


def solve(size):
    m = mesh(size)
    e = skfem.ElementVector(skfem.ElementTriP2())
    basis = skfem.Basis(m, e, intorder=4)
    lam, mu = lame_parameters(1.0, 1.0 / 3.0)
    lam = 2 * lam * mu / (lam + 2 * mu)  # plane stress
    K = linear_elasticity(lam, mu).assemble(basis)
    right = skfem.FacetBasis(m, e, facets=m.facets_satisfying(lambda x: np.isclose(x[0], 1.0)), intorder=4)

    @skfem.LinearForm
    def traction(v, w):
        return v[0] * 1.0

    f = traction.assemble(right)
    pin = np.argmin(m.p[0] ** 2 + (m.p[1] - 0.25) ** 2)
    held = np.concatenate([basis.get_dofs(lambda x: np.isclose(x[0], 0.0)).all("u^1"), [basis.nodal_dofs[1, pin]]])
    return basis, skfem.solve(*skfem.condense(K, f, D=held))


def at(basis, u, x):
    """u at the points x (n x 2), in chunks: scikit-fem's point finder is brute force."""
    parts = [(basis.probes(x[k : k + 500].T) @ u).reshape(2, -1).T for k in range(0, len(x), 500)]
    return np.concatenate(parts)


if __name__ == "__main__":
    basis, u = solve(float(sys.argv[1]))
    for path in sys.argv[2:]:
        d = json.load(open(path))
        x, upd = np.array(d["x"]), np.array(d["u"])
        ufe = at(basis, u, x)
        end = x[:, 0] > 0.98
        err = np.abs(upd - ufe).max() / np.abs(ufe).max()
        pd, fe = upd[end, 0].mean(), ufe[end, 0].mean()
        print(f"{path}: {len(x)} nodes, max |u - u_FE| / max |u_FE| = {err:.3e}, "
              f"right edge mean u_x {pd:.5f} against {fe:.5f} ({100 * (pd / fe - 1):+.2f} %)")
