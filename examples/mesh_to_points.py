#!/usr/bin/env python3
"""Turns a finite-element mesh into a linpd point cloud: one node per element, at its
centroid, with the element's area (2D) or volume (3D) as the node volume.

    python3 examples/mesh_to_points.py data/bracket.msh data/bracket-nodes.csv --dim 2

Any mesh meshio reads (Gmsh .msh, Abaqus .inp, Exodus, VTK/VTU, ...) works; the element types
used are triangles and quadrilaterals in 2D, tetrahedra and hexahedra in 3D (a quadrilateral
is split into two triangles, a hexahedron into five tetrahedra: exact for planar faces).
Elements of other types (lines, points, the boundary facets) are skipped and counted. The
output is the CSV of `"nodes": {"csv": ...}` (docs/problem-format.md, "Point clouds"):
header `x,y[,z],volume`, 17 significant digits.
"""
import argparse
import sys

import meshio
import numpy as np


def simplex_measures(p):
    """Centroids and measures of simplices given as an array (cells, d + 1, d)."""
    d = p.shape[2]
    edges = p[:, 1:, :] - p[:, :1, :]
    measure = np.abs(np.linalg.det(edges)) / (2.0 if d == 2 else 6.0)
    return p.mean(axis=1), measure


# Each non-simplex cell as simplices (indices into its own vertex list).
SPLIT = {
    "triangle": [[0, 1, 2]],
    "quad": [[0, 1, 2], [0, 2, 3]],
    "tetra": [[0, 1, 2, 3]],
    "hexahedron": [[0, 1, 3, 4], [1, 2, 3, 6], [1, 4, 5, 6], [3, 4, 6, 7], [1, 3, 4, 6]],
}
DIM = {"triangle": 2, "quad": 2, "tetra": 3, "hexahedron": 3}


def cloud(mesh, dim):
    centres, volumes, skipped = [], [], {}
    points = mesh.points[:, :dim]
    for block in mesh.cells:
        if DIM.get(block.type) != dim:
            skipped[block.type] = skipped.get(block.type, 0) + len(block.data)
            continue
        xs = points[block.data]  # (cells, vertices, dim)
        total = np.zeros(len(xs))
        moment = np.zeros((len(xs), dim))
        for simplex in SPLIT[block.type]:
            c, m = simplex_measures(xs[:, simplex, :])
            total += m
            moment += c * m[:, None]
        centres.append(moment / total[:, None])
        volumes.append(total)
    if not centres:
        sys.exit(f"no {dim}D elements in the mesh (cell types: {[b.type for b in mesh.cells]})")
    return np.vstack(centres), np.concatenate(volumes), skipped


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mesh")
    ap.add_argument("out")
    ap.add_argument("--dim", type=int, choices=(2, 3), required=True)
    a = ap.parse_args()
    x, v, skipped = cloud(meshio.read(a.mesh), a.dim)
    if np.any(v <= 0.0):
        sys.exit(f"{int(np.sum(v <= 0))} degenerate elements (zero measure)")
    names = ["x", "y", "z"][: a.dim]
    with open(a.out, "w") as f:
        f.write(f"# {len(v)} element centroids of {a.mesh} (examples/mesh_to_points.py)\n")
        f.write(",".join(names + ["volume"]) + "\n")
        for xi, vi in zip(x, v):
            f.write(",".join(f"{c:.17g}" for c in list(xi) + [vi]) + "\n")
    print(f"{a.out}: {len(v)} nodes, total volume {v.sum():.12g}; skipped {skipped or 'nothing'}")


if __name__ == "__main__":
    main()
