#!/usr/bin/env python3
"""Write a small synthetic case in the ``linpd bench --export`` format.

This lets ``peer_bench.py`` be exercised without the Rust tool.  The case is a
1D peridynamics-like bar: nodes ``0 .. n + 2 * horizon - 1`` on a line, bonds
between nodes at most ``horizon`` apart with micro-modulus ``1 / distance``,
and ``horizon`` clamped nodes at each end (the free DOFs are the ``n`` interior
nodes).  Every bond is assembled from *both* of its end points with half its
stiffness, exactly as a bond-based assembly emits it, so the triplet list is
unsummed and full of duplicates (the summed matrix is symmetric positive
definite).

Files written to ``DIR`` (all little-endian):

``NAME.coo.bin``
    u64 nrows, u64 ncols, u64 nnz_triplets, then nnz_triplets u64 row
    indices, nnz_triplets u64 column indices, nnz_triplets f64 values.
``NAME.rhs.bin``
    u64 n, then n f64.
``NAME.json``
    ``{"name", "n", "nnz", "cg_rtol", "cg_maxiter"}`` where ``nnz`` counts
    entries after summing duplicates.

Usage: ``python3 make_test_case.py DIR [--n 2000] [--horizon 3]
[--name synthetic_1d]``
"""

import argparse
import json
import pathlib

import numpy as np

U64 = np.dtype("<u8")
F64 = np.dtype("<f8")


def assemble_triplets(n, horizon):
    """Return unsummed ``(rows, cols, vals)`` of the reduced bar stiffness.

    Parameters
    ----------
    n : int
        Number of free DOFs (interior nodes).
    horizon : int
        Bond reach in nodes; also the number of clamped nodes at each end.
    """
    n_nodes = n + 2 * horizon
    # Free DOF index of each node, -1 for the clamped boundary layers.
    dof = np.full(n_nodes, -1, dtype=np.int64)
    dof[horizon:horizon + n] = np.arange(n)

    rows, cols, vals = [], [], []
    for node in range(n_nodes):
        # Each bond is visited from both end points (node -> other) and
        # contributes half its stiffness each time: duplicates on purpose.
        for dist in range(1, horizon + 1):
            for other in (node - dist, node + dist):
                if not 0 <= other < n_nodes:
                    continue
                half_k = 0.5 / dist
                p, q = dof[node], dof[other]
                # 2x2 bond block [[k, -k], [-k, k]], restricted to free DOFs.
                for a, b, sign in ((p, p, 1.0), (p, q, -1.0),
                                   (q, p, -1.0), (q, q, 1.0)):
                    if a >= 0 and b >= 0:
                        rows.append(a)
                        cols.append(b)
                        vals.append(sign * half_k)
    return (np.asarray(rows, dtype=U64), np.asarray(cols, dtype=U64),
            np.asarray(vals, dtype=F64))


def write_case(out_dir, name, n, horizon):
    """Write ``name``'s three files into ``out_dir``; return the JSON dict."""
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rows, cols, vals = assemble_triplets(n, horizon)

    with open(out_dir / f"{name}.coo.bin", "wb") as fh:
        np.array([n, n, vals.size], dtype=U64).tofile(fh)
        rows.tofile(fh)
        cols.tofile(fh)
        vals.tofile(fh)

    # Smooth load so the solution is non-trivial.
    x = np.linspace(0.0, 1.0, n, dtype=F64)
    rhs = np.sin(np.pi * x) + 0.1
    with open(out_dir / f"{name}.rhs.bin", "wb") as fh:
        np.array([n], dtype=U64).tofile(fh)
        rhs.astype(F64).tofile(fh)

    keys = rows.astype(np.int64) * n + cols.astype(np.int64)
    meta = {
        "name": name,
        "n": n,
        "nnz": int(np.unique(keys).size),
        "cg_rtol": 1e-8,
        "cg_maxiter": 10 * n,
    }
    (out_dir / f"{name}.json").write_text(json.dumps(meta, indent=2) + "\n")
    meta["nnz_triplets"] = int(vals.size)
    return meta


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("dir", help="output directory")
    parser.add_argument("--n", type=int, default=2000,
                        help="number of free DOFs (default 2000)")
    parser.add_argument("--horizon", type=int, default=3,
                        help="bond reach in nodes (default 3)")
    parser.add_argument("--name", default="synthetic_1d",
                        help="case name (default synthetic_1d)")
    args = parser.parse_args()
    meta = write_case(args.dir, args.name, args.n, args.horizon)
    print(json.dumps(meta))


if __name__ == "__main__":
    main()
