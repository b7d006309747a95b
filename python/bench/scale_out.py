"""The measurements of docs/scale-out.md, in one run:

    python3 python/bench/scale_out.py [--spacing-cells 47] [--ranks 1 2 4] [--out DIR]
        [--model bond|lps] [--horizon-cells 2] [--linpd-solvers multigrid jacobi auto]

A 3D bond scene (the unit cube, `spacing = 1 / cells`, `horizon = 2 spacing`, clamped below, a
resultant load on top; 345,600 DOFs and 324,864 unknowns for 47 cells) is solved by linpd's own
solvers (`linpd solve`: CG with linpd's multigrid, CG with Jacobi) and by the PETSc driver
(`mpiexec -n P python -m linpd.petsc`, CG + GAMG) at each P; printed as a Markdown table with
iterations, phase times, relative residuals, per-rank peak RSS, and the agreement of every
`u` with the multigrid solve's. `--model lps`: the same cube of an LPS solid (K = 13/6, G = 1,
Poisson ratio 0.3). `--linpd-solvers auto` adds `linpd solve` with `auto` (matrix-free
multigrid-CG on these lattices). Environment as for python/tests/check_petsc.py (`LINPD_BIN`,
`LINPD_PETSC_PYTHON`, `PYTHONPATH` with petsc4py and the linpd wheel).
"""

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def scene(cells: int, solver: dict, model: str = "bond", m: int = 2, length: int = 1) -> dict:
    h = 1.0 / cells
    if model == "lps":
        physics = {"type": "lps", "horizon": m * h, "bulk_modulus": 13.0 / 6.0, "shear_modulus": 1.0}
    else:
        physics = {"type": "bond", "horizon": m * h,
                   "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0, "normalize": "continuum"}}
    return {
        "name": "cube-scale-out-3d",
        "dimension": 3,
        "grid": {"min": [0, 0, 0], "max": [1, 1, length], "spacing": h, "layer": {"z-": m * h}},
        "model": physics,
        "constraints": [{"region": {"box": {"min": [-1, -1, -1], "max": [2, 2, 0]}},
                         "displacement": {"value": [0, 0, 0]}}],
        "loads": [{"type": "resultant", "region": {"box": {"min": [-1, -1, length], "max": [2, 2, length + 1]}},
                   "force": [1e-3, 0, -1e-3]}],
        "solver": solver,
        "output": {"plot": False},
    }


def cloud_scene(cells: int, solver: dict, model: str, m: int, length: int, directory: Path) -> dict:
    """:func:`scene` on a point cloud: the lattice's nodes (its ``z-`` layer flagged ``layer``)
    each moved by up to ``0.1 h`` along every axis (numpy's generator, seed 34), volume ``h^3``,
    written to ``directory/cube-<cells>-<length>.csv``; held where ``z <= 0.5 h``, loaded where
    ``z >= length - 0.5 h``."""
    h = 1.0 / cells
    doc = scene(cells, solver, model, m, length)
    axes = [np.arange(cells + 1) * h, np.arange(cells + 1) * h, np.arange(-m, cells * length + 1) * h]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    xyz = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    xyz += np.random.default_rng(34).uniform(-0.1 * h, 0.1 * h, size=xyz.shape)
    layer = (z.ravel() < -0.5 * h).astype(int)
    path = directory / f"cube-{cells}-{length}.csv"
    with path.open("w") as f:
        f.write("x,y,z,volume,layer\n")
        for (a, b, c), k in zip(xyz, layer):
            f.write(f"{float(a)!r},{float(b)!r},{float(c)!r},{h ** 3!r},{k}\n")
    del doc["grid"]
    doc["name"] = "cloud-scale-out-3d"
    doc["nodes"] = {"csv": str(path.resolve())}
    doc["constraints"][0]["region"]["box"]["max"][2] = 0.5 * h
    doc["loads"][0]["region"]["box"]["min"][2] = length - 0.5 * h
    return doc


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--spacing-cells", type=int, default=47)
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2, 4])
    ap.add_argument("--out", default=str(ROOT / "target" / "scale-out"))
    ap.add_argument("--linpd-solvers", nargs="*", default=["multigrid", "jacobi"])
    ap.add_argument("--model", choices=["bond", "lps"], default="bond")
    ap.add_argument("--horizon-cells", type=int, default=2,
                    help="delta / h (3 puts linpd's geometric multigrid level on bond lattices)")
    ap.add_argument("--weak", action="store_true",
                    help="weak scaling: P ranks solve a box of height P (the same unknowns per rank)")
    ap.add_argument("--gather", action="store_true", help="the driver's --gather (every rank builds the whole scene)")
    ap.add_argument("--cloud", action="store_true",
                    help="the cube as a CSV point cloud (the lattice's nodes moved by up to 0.1 h)")
    ap.add_argument("--parallel-petsc-options", default="",
                    help="PETSc options for the driver on more than one rank, e.g. '-matptap_via allatonce' "
                         "(an MPIAIJ option: one rank's SeqAIJ refuses it)")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    binary = os.environ.get("LINPD_BIN", str(ROOT / "target" / "release" / "linpd"))
    rows, u_ref, x_ref = [], None, None

    def make(solver: dict, length: int) -> dict:
        if args.cloud:
            return cloud_scene(args.spacing_cells, solver, args.model, args.horizon_cells, length, out)
        return scene(args.spacing_cells, solver, args.model, args.horizon_cells, length)

    for pre in args.linpd_solvers:
        path = out / f"scene-{pre}.json"
        solver = {"type": "auto"} if pre == "auto" else {"type": "cg", "preconditioner": pre}
        path.write_text(json.dumps(make(solver, 1)))
        t = time.perf_counter()
        p = subprocess.run([binary, "solve", str(path), "--out", str(out / pre), "-q"], capture_output=True, text=True)
        wall = time.perf_counter() - t
        assert p.returncode == 0, p.stderr
        doc = json.loads((out / pre / "result.json").read_text())
        s = doc["stats"]["solve"]
        u = np.asarray(doc["u"], dtype=float)
        u_ref = u if u_ref is None else u_ref
        x_ref = np.asarray(doc["x"], dtype=float) if x_ref is None else x_ref
        rows.append((f"linpd {s['solver']}", 1, s["n"], s["iterations"], s["timings"]["assemble"],
                     s["timings"]["setup"], s["timings"]["solve"], wall, s["rel_residual"],
                     [s["peak_rss_bytes"]], np.max(np.abs(u - u_ref)) / np.max(np.abs(u_ref))))
    py = os.environ.get("LINPD_PETSC_PYTHON", "/usr/bin/python3")
    memory = []
    for ranks in args.ranks:
        length = ranks if args.weak else 1
        path = out / f"scene-petsc-{length}.json"
        path.write_text(json.dumps(make({"type": "auto"}, length)))
        cmd = ["mpiexec", "-n", str(ranks)] + (["--allow-run-as-root"] if os.geteuid() == 0 else [])
        cmd += ["--oversubscribe", py, "-m", "linpd.petsc", str(path), "--out", str(out / f"petsc-{ranks}")]
        cmd += ["--gather"] if args.gather else []
        cmd += args.parallel_petsc_options.split() if ranks > 1 else []
        t = time.perf_counter()
        p = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t
        assert p.returncode == 0, p.stdout + p.stderr
        doc = json.loads((out / f"petsc-{ranks}" / "result.json").read_text())
        s = doc["stats"]["solve"]
        if "pieces" in doc:
            from linpd.petsc import read_pieces

            x, arrays = read_pieces(out / f"petsc-{ranks}")
            u = arrays["u"]
            if x_ref is not None and len(x) == len(x_ref):
                # the pieces' nodes in the reference's order, matched by position
                where = {tuple(np.round(p * 1e9).astype(np.int64)): k for k, p in enumerate(x)}
                u = u[[where[tuple(np.round(p * 1e9).astype(np.int64))] for p in x_ref]]
            memory.append((ranks, s["n"], s["rss_baseline_bytes_per_rank"], s["rss_model_bytes_per_rank"],
                           s["rss_assembled_bytes_per_rank"], s["peak_rss_bytes_per_rank"]))
        else:
            u = np.asarray(doc["u"], dtype=float)
        same = u_ref is not None and u.shape == u_ref.shape
        rel = np.max(np.abs(u - u_ref)) / np.max(np.abs(u_ref)) if same else float("nan")
        tm = s["timings"]
        rows.append((f"{s['solver']} ({s['geometry']})", ranks, s["n"], s["iterations"], tm["model"] + tm["assemble"],
                     tm["setup"], tm["solve"], wall, s["rel_residual"], s["peak_rss_bytes_per_rank"], rel))
    print("| solver | ranks | unknowns | iterations | model + assembly (s) | setup (s) | solve (s) | wall (s) "
          "| rel. residual | peak RSS per rank (MiB) | max|du|/max|u| vs first |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        rss = ", ".join(f"{m / 2**20:.0f}" for m in r[9])
        print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]:.2f} | {r[5]:.2f} | {r[6]:.2f} | {r[7]:.1f} | "
              f"{r[8]:.1e} | {rss} | {r[10]:.1e} |")
    if memory:
        print()
        print("| ranks | unknowns | per rank: baseline (MiB) | less baseline: model | + matrix | peak |")
        print("|---|---|---|---|---|---|")
        for ranks, n, base, model, assembled, peak in memory:
            mib = lambda v: ", ".join(f"{x / 2**20:.0f}" for x in v)  # noqa: E731
            less = lambda v: mib([x - b for x, b in zip(v, base)])  # noqa: E731
            print(f"| {ranks} | {n} | {mib(base)} | {less(model)} | {less(assembled)} | {less(peak)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
