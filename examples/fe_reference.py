"""An independent finite-element reference for the two meshed bodies (E = 1), on a fresh gmsh
mesh of the true geometry (not the PD mesh), by scikit-fem with quadratic Lagrange elements:

* plate: plane stress, nu = 1/3 (Lame lam* = 2 lam mu / (lam + 2 mu)), the 1 x 0.5 plate minus
  the disk of radius 0.1 at (0.5, 0.25) (straight-sided P2 triangles, so the hole is the
  inscribed polygon); u_x = 0 on x = 0, u_y = 0 at the mesh node nearest (0, 0.25), traction
  (1, 0) on x = 1. Direct solve (scipy's spsolve). Tip: mean u_x over x = 1 (integral / 0.5).
* bracket: 3D, nu = 1/4, the union of the leg [0,0.1]x[0,0.3]x[0,0.1] and the arm
  [0,0.4]x[0.2,0.3]x[0,0.1] (P2 tetrahedra); u = 0 on y = 0, traction (0, -0.01, 0) on x = 0.4.
  CG to a relative residual of 1e-8 (the tip changes by < 1e-10 from 1e-6 on; 1e-10 is near
  round-off and can stall), preconditioned by one V-cycle of pyamg's smoothed aggregation
  (energy-minimising prolongation) on 3 x 3 node blocks with the six rigid-body modes as
  near-null space: 3x faster than jacobi prolongation, and than SuperLU from ~50k DOFs. Tip: mean
  u_y over x = 0.4 (integral / 0.01).

Both solve -div sigma(u) = 0, sigma = lam tr(eps) I + 2 mu eps, sigma n = t on the loaded face
and zero traction elsewhere; intorder 2 integrates the P2 stiffness and loads exactly.

    python3 examples/fe_reference.py CASE --size S [--points POINTS.csv --out OUT.csv]

prints one JSON line (case, size, elements, dofs, solver, setup_s, solve_s, tip [, eval_s]);
with --points (a header line, then x,y[,z] a line) writes the FE displacement at those points to
--out (header u_x,u_y[,u_z]). The geometry repeats examples/make_meshes.py's gmsh calls. Needs
`pip install gmsh==4.15.2 scikit-fem==12.0.2 pyamg==5.3.0`.
"""
import argparse
import json
import time

import gmsh
import numpy as np
import pyamg
import skfem
from scipy.spatial import cKDTree
from skfem.models.elasticity import lame_parameters, linear_elasticity

NU = {"plate": 1.0 / 3.0, "bracket": 0.25}


def mesh(case, size, edge_size=None):
    """A fresh gmsh mesh (linear triangles or tetrahedra) of the case's geometry: of uniform
    size, or (bracket) graded linearly from edge_size at the singular edges to size at 0.05."""
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    occ = gmsh.model.occ
    if case == "plate":
        occ.cut([(2, occ.addRectangle(0.0, 0.0, 0.0, 1.0, 0.5))], [(2, occ.addDisk(0.5, 0.25, 0.0, 0.1, 0.1))])
    else:
        occ.fuse([(3, occ.addBox(0.0, 0.0, 0.0, 0.1, 0.3, 0.1))], [(3, occ.addBox(0.0, 0.2, 0.0, 0.4, 0.1, 0.1))])
    occ.synchronize()
    if edge_size is None:
        gmsh.option.setNumber("Mesh.MeshSizeMin", size)
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    else:
        box = {c: np.array(gmsh.model.getBoundingBox(1, c)) for _, c in gmsh.model.getEntities(1)}
        clamp = [c for c, b in box.items() if np.allclose(b[[1, 4]], 0.0, atol=1e-6)]
        corner = [c for c, b in box.items() if np.allclose(b[[0, 1, 3, 4]], [0.1, 0.2, 0.1, 0.2], atol=1e-6)]
        field = gmsh.model.mesh.field
        distance = field.add("Distance")
        field.setNumbers(distance, "CurvesList", clamp + corner)
        field.setNumber(distance, "Sampling", int(0.2 / edge_size))
        grade = field.add("Threshold")
        field.setNumber(grade, "InField", distance)
        for name, value in [("SizeMin", edge_size), ("SizeMax", size), ("DistMin", 0.0), ("DistMax", 0.05)]:
            field.setNumber(grade, name, value)
        field.setAsBackgroundMesh(grade)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    dim = 2 if case == "plate" else 3
    gmsh.model.mesh.generate(dim)
    tags, x, _ = gmsh.model.mesh.getNodes()
    _, nodes = gmsh.model.mesh.getElementsByType(2 if dim == 2 else 4)
    gmsh.finalize()
    index = np.zeros(tags.max() + 1, dtype=np.int64)
    index[tags] = np.arange(len(tags))
    t = index[nodes].reshape(-1, dim + 1)
    used, t = np.unique(t, return_inverse=True)
    x = x.reshape(-1, 3)[used, :dim]
    return (skfem.MeshTri if dim == 2 else skfem.MeshTet)(np.ascontiguousarray(x.T), np.ascontiguousarray(t.reshape(-1, dim + 1).T))


def solve(case, size, edge_size=None):
    start = time.perf_counter()
    m = mesh(case, size, edge_size)
    dim = m.dim()
    e = skfem.ElementVector(skfem.ElementTriP2() if dim == 2 else skfem.ElementTetP2())
    basis = skfem.Basis(m, e, intorder=2)
    lam, mu = lame_parameters(1.0, NU[case])
    if dim == 2:
        lam = 2 * lam * mu / (lam + 2 * mu)
    K = linear_elasticity(lam, mu).assemble(basis)
    end, area, t = (1.0, 0.5, [1.0, 0.0]) if dim == 2 else (0.4, 0.01, [0.0, -0.01, 0.0])
    face = skfem.FacetBasis(m, e, facets=m.facets_satisfying(lambda x: np.isclose(x[0], end)), intorder=2)
    f = skfem.LinearForm(lambda v, w: sum(t[i] * v[i] for i in range(dim))).assemble(face)
    if dim == 2:
        pin = np.argmin(m.p[0] ** 2 + (m.p[1] - 0.25) ** 2)
        held = np.concatenate([basis.get_dofs(lambda x: np.isclose(x[0], 0.0)).all("u^1"), [basis.nodal_dofs[1, pin]]])
    else:
        held = basis.get_dofs(lambda x: np.isclose(x[1], 0.0)).all()
    A, b, u, free = skfem.condense(K, f, D=held)
    setup = time.perf_counter() - start
    start = time.perf_counter()
    if dim == 2:
        u[free] = skfem.solve(A, b)
        solver = "spsolve"
    else:
        u[free], solver = amg_cg(basis, A.tobsr(blocksize=(3, 3)), b, free)
    solved = time.perf_counter() - start
    tip = skfem.Functional(lambda w: w.u[0 if dim == 2 else 1]).assemble(face, u=face.interpolate(u)) / area
    info = {"case": case, "size": size, "elements": int(m.nelements), "dofs": int(basis.N), "edge_size": edge_size, "solver": solver,
            "setup_s": round(setup, 2), "solve_s": round(solved, 2), "tip": float(tip)}
    return basis, u, info


def amg_cg(basis, A, b, free):
    """CG preconditioned by smoothed aggregation with the rigid-body modes as near-null space.
    The clamp holds whole nodes, so the free DOFs keep skfem's x, y, z blocks per node."""
    x, y, z = basis.doflocs
    comp = np.zeros(basis.N, dtype=np.int64)
    for k, ix in enumerate(basis.split_indices()):
        comp[ix] = k
    o, l = np.zeros(basis.N), np.ones(basis.N)
    modes = [(l, o, o), (o, l, o), (o, o, l), (-y, x, o), (o, -z, y), (z, o, -x)]
    B = np.array([np.choose(comp, mode) for mode in modes]).T[free]
    np.random.seed(0)  # pyamg's spectral radius estimates start from random vectors
    ml = pyamg.smoothed_aggregation_solver(A, B=B, smooth=("energy", {"krylov": "cg", "maxiter": 2}))
    residuals = []
    u = ml.solve(b, tol=1e-8, maxiter=500, accel="cg", residuals=residuals)
    return u, f"pcg(sa-amg) {len(residuals) - 1} it"


def evaluate(basis, u, x, k=16):
    """u at the points x (n x dim): each point goes to the candidate cell (among those with the
    k nearest centroids) whose smallest barycentric coordinate is largest, so points within
    round-off outside the mesh still land in their nearest cell."""
    m = basis.mesh
    _, cand = cKDTree(m.p[:, m.t].mean(axis=1).T).query(x, k)
    X = basis.mapping.invF(np.repeat(x, k, axis=0).T[:, :, None], tind=cand.ravel())[:, :, 0]
    score = np.minimum(X.min(axis=0), 1.0 - X.sum(axis=0)).reshape(-1, k)
    best = score.argmax(axis=1)
    if score.max(axis=1).min() < -1e-9:
        raise ValueError("a point lies outside the mesh (or outside its k nearest cells)")
    cells = cand[np.arange(len(x)), best]
    X = X.reshape(m.dim(), -1, k)[:, np.arange(len(x)), best][:, :, None]
    out = np.zeros((m.dim(), len(x)))
    for j in range(basis.Nbfun):
        phi = basis.elem.gbasis(basis.mapping, X, j, tind=cells)[0].value[:, :, 0]
        out += u[basis.element_dofs[j, cells]] * phi
    return out.T


if __name__ == "__main__":
    p = argparse.ArgumentParser()
    p.add_argument("case", choices=sorted(NU))
    p.add_argument("--size", type=float, required=True)
    p.add_argument("--edge-size", type=float, help="bracket: the size at its singular edges")
    p.add_argument("--points")
    p.add_argument("--out")
    a = p.parse_args()
    if a.edge_size and a.case == "plate" or bool(a.points) != bool(a.out):
        p.error("--edge-size is for the bracket; --points and --out go together")
    basis, u, info = solve(a.case, a.size, a.edge_size)
    if a.points:
        start = time.perf_counter()
        x = np.loadtxt(a.points, delimiter=",", skiprows=1, ndmin=2)
        ufe = evaluate(basis, u, x)
        header = ",".join(["u_x", "u_y", "u_z"][: x.shape[1]])
        np.savetxt(a.out, ufe, delimiter=",", header=header, comments="", fmt="%.12e")
        info["eval_s"] = round(time.perf_counter() - start, 2)
    print(json.dumps(info))
