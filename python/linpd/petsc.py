"""Distributed static solve of a linpd scene on PETSc.

Usage (under the site's MPI; as root OpenMPI also needs ``--allow-run-as-root``)::

    mpiexec -n P python -m linpd.petsc SCENE.json [--out DIR] [PETSc options]

Each rank

1. reads and validates the scene and builds its model (bonds, constraints, right-hand side),
   with the checks of ``linpd solve`` (and a free DOF whose diagonal entry is zero, a mechanism
   such as the out-of-plane motion of a plate one node thick, is refused by name: ``linpd
   solve`` finds it when it factorizes, a KSP might not). Then every rank learns every other rank's outcome
   (one ``allgather``): a bad scene stops **all** ranks with linpd's message and exit code 1,
   and none of them is left waiting in a collective;
2. owns a contiguous range of nodes (the lattice's nodes are numbered with x fastest, so the
   range is a slab; a point cloud's file order should be locality-preserving) and assembles
   **only its rows** of the reduced stiffness ``A_ff`` with :meth:`linpd.Scene.assemble_rows`
   into a PETSc MPIAIJ matrix of block size ``d``;
3. attaches the rigid-body modes (``MatNullSpaceCreateRigidBody`` of the nodes' coordinates)
   as the near-null space GAMG builds its coarse spaces from;
4. solves with ``-ksp_type cg -pc_type gamg -ksp_rtol 1e-10 -ksp_norm_type unpreconditioned``
   when ``A_ff`` is symmetric (:meth:`linpd.Scene.is_symmetric`: bond and LPS models, pure CE,
   symmetric coarsened levels), and with ``-ksp_type gmres -ksp_gmres_restart 100 -ksp_pc_side
   right`` when it is not (the 1D blended PD/CE model, coarsened levels with an unsymmetric
   ``K``): GMRES minimizes the true residual with the preconditioner on the right, so ``rtol``
   bounds ``||f - A u|| / ||f||`` as for CG (linpd's own CG checks the same quantity). Every PETSc
   option on the command line is passed through and overrides these defaults (``-ksp_monitor``,
   ``-pc_type hypre``, ``-log_view``, ...; a GMRES-family ``-ksp_type`` gets the right side unless
   ``-ksp_pc_side`` is given).

The preconditioner is GAMG (with the rigid-body near-null space in 2D/3D), except for
unsymmetric 1D scenes (the blended model), which get BoomerAMG (``-pc_type hypre``) when PETSc
has hypre. Measured here (PETSc 3.18.5, 2 ranks, ``-ksp_rtol 1e-12``, GMRES iterations, GAMG vs
BoomerAMG): ``data/blend-point-load.json`` 40 vs 8, ``data/blend-bar-crack.json`` 42 vs 9, and
``data/blend-coarse-ce.json`` (PD spacing 1e-4 beside CE elements of 0.0256) 1374 iterations and
31 s (restart 200; 3197 iterations with restart 1000) vs 10 iterations and 0.2 s: GAMG's
aggregation does not cope with that graded, unsymmetric 1D operator. The unsymmetric coarsened plate levels of
``data/coarsen-plate-2d.pipeline.json`` need 18 and 12 GMRES + GAMG iterations, so a restart of
100 leaves a margin of five while bounding GMRES's memory to 100 vectors. Without hypre the 1D
blend falls back to GAMG (slow but convergent on the bundled scenes).

A KSP that did not converge (a negative converged reason) or a non-finite residual is an
error on every rank (exit 1) and nothing is written. Otherwise rank 0 gathers ``u`` and writes
``result.json``, ``u.csv`` and ``result.vtu`` into the scene's output directory (or ``--out
DIR``), as ``linpd solve`` does (no plots), with ``stats.solve``
holding the KSP's type, iterations, converged reason, the relative residual
``||f - A u|| / ||f||`` recomputed after the solve, the timings, every rank's peak resident
memory and whether ``A_ff`` is symmetric.

Every static model assembles its own rows (bond, LPS, coarsened levels, 1D blend/CE; see
``docs/scale-out.md`` for what each costs per rank).
"""

from __future__ import annotations

import json
import os
import resource
import sys
import time
from typing import List, Optional, Tuple

import numpy as np

USAGE = "usage: python -m linpd.petsc SCENE.json [--out DIR] [PETSc options]"

# The KSP types that take -ksp_gmres_restart and need the preconditioner on the right for an
# unpreconditioned norm.
GMRES_FAMILY = ("gmres", "lgmres", "dgmres", "pgmres")
# GMRES's restart for unsymmetric scenes (see the module docstring).
GMRES_RESTART = 100


# PETSc's negative KSPConvergedReason values (KSP_DIVERGED_*), for the error message.
_REASONS = {
    -2: "null",
    -3: "the iteration limit",
    -4: "the residual grew past dtol: diverged",
    -5: "breakdown",
    -6: "breakdown of BiCG",
    -7: "nonsymmetric operator or preconditioner",
    -8: "indefinite preconditioner",
    -9: "NaN or infinity",
    -10: "indefinite matrix",
    -11: "the preconditioner failed",
}


def _split_args(argv: List[str]) -> Tuple[Optional[str], Optional[str], List[str]]:
    """``(scene, out, petsc_args)`` from the command line (PETSc options are everything else)."""
    scene, out, rest = None, None, []
    k = 0
    while k < len(argv):
        a = argv[k]
        if a == "--out" and k + 1 < len(argv):
            out = argv[k + 1]
            k += 2
            continue
        if a.startswith("--out="):
            out = a[len("--out="):]
        elif scene is None and not a.startswith("-"):
            scene = a
        else:
            rest.append(a)
        k += 1
    return scene, out, rest


def _peak_rss_bytes() -> int:
    # Linux reports ru_maxrss in KiB
    return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss) * 1024


def _node_range(n_blocks: int, size: int, rank: int) -> Tuple[int, int]:
    """Contiguous, balanced split of ``n_blocks`` blocks over ``size`` ranks (PETSc's own split)."""
    q, r = divmod(n_blocks, size)
    first = rank * q + min(rank, r)
    return first, first + q + (1 if rank < r else 0)


def _default_pc(PETSc, symmetric: bool, d: int) -> str:
    """GAMG, except BoomerAMG (hypre) for unsymmetric 1D scenes when PETSc has hypre (see the
    module docstring for the measurements)."""
    if not symmetric and d == 1 and PETSc.Sys.hasExternalPackage("hypre"):
        return "hypre"
    return "gamg"


def main(argv: Optional[List[str]] = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    scene_path, out, petsc_args = _split_args(argv)

    import petsc4py

    petsc4py.init([sys.argv[0]] + petsc_args)
    from petsc4py import PETSc

    comm = PETSc.COMM_WORLD
    if comm.getSize() > 1:
        # the ranks are the parallelism: one rayon thread each (linpd's pool starts at its first
        # parallel call, after this), unless the user says otherwise
        os.environ.setdefault("RAYON_NUM_THREADS", "1")
    import linpd

    mpi = comm.tompi4py()
    rank, size = comm.getRank(), comm.getSize()
    t0 = time.perf_counter()

    # 1. every rank validates; nobody enters a PETSc collective before all have succeeded
    error = None
    scene = None
    if scene_path is None:
        error = USAGE
    else:
        try:
            scene = linpd.Scene(scene_path)
            n, bs, free_dofs, rhs = scene.row_info()
            symmetric = scene.is_symmetric()
            if n >= 2**31 and PETSc.IntType == np.int32:
                error = f"{n} unknowns need a PETSc built with 64-bit indices (docs/scale-out.md)"
        except linpd.LinpdError as e:
            error = f"{scene_path}: {e}"
        except OSError as e:
            error = f"{scene_path}: {e}"
    errors = mpi.allgather(error)
    failed = [(r, e) for r, e in enumerate(errors) if e is not None]
    if failed:
        r, e = failed[0]
        where = "" if all(x == e for x in errors) else f" (rank {r})"
        print(f"error{where}: {e}", file=sys.stderr, flush=True)
        return 1

    d = scene.dim
    t_model = time.perf_counter() - t0

    # 2. own rows only: a contiguous range of blocks (nodes when bs == d)
    n_blocks = n // bs
    b0, b1 = _node_range(n_blocks, size, rank)
    first, last = bs * b0, bs * b1
    t1 = time.perf_counter()
    indptr, indices, data = scene.assemble_rows(first, last)
    A = PETSc.Mat().createAIJ(size=((last - first, n), (last - first, n)), bsize=bs, comm=comm)
    A.setPreallocationCSR((indptr.astype(PETSc.IntType), indices.astype(PETSc.IntType), data))
    A.assemble()
    del indptr, indices, data
    b = PETSc.Vec().createMPI((last - first, n), bsize=bs, comm=comm)
    b.setArray(rhs[first:last])
    x = b.duplicate()
    t_assemble = time.perf_counter() - t1

    # 3. rigid-body modes from the coordinates of the owned rows (whole nodes only)
    positions = scene.positions()
    near_null = bs == d and d > 1
    if near_null:
        rows = free_dofs[first:last]
        coords = PETSc.Vec().createMPI((last - first, n), bsize=d, comm=comm)
        coords.setArray(positions[rows // d, rows % d])
        A.setNearNullSpace(PETSc.NullSpace().createRigidBody(coords))
    del positions

    # 4. the KSP: defaults first, then the command line's options override them
    ksp = PETSc.KSP().create(comm=comm)
    ksp.setOperators(A)
    default_type = "cg" if symmetric else "gmres"
    ksp.setType(default_type)
    ksp.getPC().setType(_default_pc(PETSc, symmetric, d))
    opts = PETSc.Options()
    if opts.getString("ksp_type", default_type) in GMRES_FAMILY:
        ksp.setGMRESRestart(GMRES_RESTART)
        # GMRES minimizes the unpreconditioned residual only with the preconditioner on the right
        if not opts.hasName("ksp_pc_side"):
            ksp.setPCSide(PETSc.PC.Side.RIGHT)
    # rtol on the true residual ||f - A u|| / ||f||, as linpd's own CG (PETSc's CG default is
    # the preconditioned residual, which stops earlier or later depending on the preconditioner)
    ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
    ksp.setTolerances(rtol=1e-10, max_it=10000)
    ksp.setFromOptions()
    t2 = time.perf_counter()
    ksp.setUp()
    t_setup = time.perf_counter() - t2
    t3 = time.perf_counter()
    ksp.solve(b, x)
    t_solve = time.perf_counter() - t3
    reason = ksp.getConvergedReason()
    iterations = ksp.getIterationNumber()
    r = b.duplicate()
    A.mult(x, r)
    r.aypx(-1.0, b)  # r = b - A x
    b_norm = b.norm()
    rel_residual = r.norm() / b_norm if b_norm > 0 else r.norm()
    nnz = int(A.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_used"])
    pc_type = ksp.getPC().getType()
    ksp_type = ksp.getType()

    # gather u to rank 0
    scatter, x0 = PETSc.Scatter.toZero(x)
    scatter.scatter(x, x0, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    rss = mpi.gather(_peak_rss_bytes(), root=0)
    status = 0
    if reason < 0 or not np.isfinite(rel_residual):
        # a diverged or failed KSP (negative converged reason: -3 max_it, -4 dtol, -5 breakdown,
        # -9 nan or inf, ...) or a non-finite residual: an error, nothing written
        if rank == 0:
            why = _REASONS.get(int(reason), "")
            print(
                f"error: solver: the KSP ({ksp_type}, {pc_type}) did not converge: reason {reason}"
                f"{f' ({why})' if why else ''}, {iterations} iterations, relative residual {rel_residual:.3e}; "
                f"nothing written",
                file=sys.stderr,
                flush=True,
            )
        status = 1
    elif rank == 0:
        report = {
            "solver": f"petsc-{ksp_type}-{pc_type}",
            "n": n,
            "nnz_a": nnz,
            "iterations": iterations,
            "rel_residual": rel_residual,
            "ksp_converged_reason": int(reason),
            "ranks": size,
            "block_size": bs,
            "symmetric": bool(symmetric),
            "asymmetry": float(scene.asymmetry()),
            "near_null_space": "rigid-body modes" if near_null else None,
            "timings": {
                "model": t_model,
                "assemble": t_assemble,
                "setup": t_setup,
                "solve": t_solve,
                "total": time.perf_counter() - t0,
            },
            "peak_rss_bytes": max(rss),
            "peak_rss_bytes_per_rank": rss,
            "petsc_version": ".".join(map(str, PETSc.Sys.getVersion())),
            "petsc_options": petsc_args,
        }
        u = scene.expand(x0.getArray())
        dest = out if out is not None else scene.output_dir
        try:
            files = scene.write_result(u, report, dest)
        except linpd.LinpdError as e:
            print(f"error: {e}", file=sys.stderr, flush=True)
            status = 1
        else:
            print(
                f"{scene.name}: {n} unknowns on {size} ranks, {ksp_type} + {pc_type}: {iterations} iterations, "
                f"relative residual {rel_residual:.3e}, assemble {t_assemble:.3f} s, setup {t_setup:.3f} s, "
                f"solve {t_solve:.3f} s, peak memory per rank {', '.join(f'{m / 2**20:.0f}' for m in rss)} MiB; "
                f"wrote {len(files)} files into {dest}",
                flush=True,
            )
    # every rank returns the same status (rank 0's writing may have failed)
    return int(mpi.bcast(status, root=0))


if __name__ == "__main__":
    sys.exit(main())
