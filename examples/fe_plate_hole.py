"""An independent reference for the meshed plate with a hole (issue #33 item 4, first step):
plane-stress linear elasticity (E = 1, nu = 1/3, the bond model's plane-stress Poisson ratio)
by scikit-fem with quadratic (P2) triangles on the same gmsh mesh as the PD model's nodes
(read by meshio), refined uniformly `REFINE` times (the same polygonal hole); u_x = 0 on the
left edge, u_y = 0 at the mesh node nearest (0, 0.25), traction 1 on the right edge (the
resultant 0.5 of data/plate-hole-mesh-2d.json).

    python3 examples/fe_plate_hole.py MESH.msh REFINE out/plate-hole-mesh-2d/result.json [...]

evaluates the FE displacement at the nodes of each linpd result.json and prints, one JSON object
a line, the largest |u - u_FE| / max |u_FE| and the mean u_x of the nodes beyond x = 0.98
against the FE's at the same points. Needs `pip install meshio scikit-fem==12.0.2` (the test
script installs them). On data/plate-hole-mesh-2d.msh (size 0.01), at the PD nodes, the right
edge's mean u_x is 1.219934, 1.219944, 1.219948 with 0, 1, 2 refinements: converged to 1e-5 at
1 (and 0.03 % below a fresh gmsh mesh of the true circle at size 0.004, 1.22033).
"""
import json
import sys

import meshio
import numpy as np
import skfem
from skfem.models.elasticity import lame_parameters, linear_elasticity


def mesh(path, refine):
    m = meshio.read(path)
    tri = np.concatenate([c.data for c in m.cells if c.type == "triangle"])
    used = np.unique(tri)
    renumber = np.full(len(m.points), -1)
    renumber[used] = np.arange(len(used))
    return skfem.MeshTri(m.points[used, :2].T, renumber[tri].T).refined(refine)


def solve(path, refine):
    m = mesh(path, refine)
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
    basis, u = solve(sys.argv[1], int(sys.argv[2]))
    for path in sys.argv[3:]:
        d = json.load(open(path))
        x, upd = np.array(d["x"]), np.array(d["u"])
        ufe = at(basis, u, x)
        end = x[:, 0] > 0.98
        err = np.abs(upd - ufe).max() / np.abs(ufe).max()
        pd, fe = upd[end, 0].mean(), ufe[end, 0].mean()
        print(json.dumps({"result": path, "nodes": len(x), "max_error": err, "edge_u_x": pd, "edge_u_x_fe": fe}))
