"""Distributed static solve of a linpd scene on PETSc.

Usage (under the site's MPI; as root OpenMPI also needs ``--allow-run-as-root``)::

    mpiexec -n P python -m linpd.petsc SCENE.json [--out DIR] [--gather] [PETSc options]

Each rank

1. reads and validates **its part** of a lattice or point-cloud scene (bond or LPS, 2D or 3D):
   the slab of lattice planes (of a cloud's bins along its longest axis) it owns plus a halo,
   the only nodes it ever builds (docs/scale-out.md, "Per-rank geometry"); what no part decides
   alone (a region holding a node, a resultant load's volume, the support) is settled by
   reductions. With ``--gather``, and for scenes without per-rank geometry (blends, coarsened
   levels, 1D, node-numbered files, a cloud's ``discrete`` normalization or a surface correction
   on a cloud with ``layer`` nodes: rank 0 prints a note naming why), every rank builds the
   whole scene instead. The
   checks are those of ``linpd solve`` (and a free DOF whose diagonal entry is zero, a mechanism
   such as the out-of-plane motion of a plate one node thick, is refused by name: ``linpd
   solve`` finds it when it factorizes, a KSP might not). After each stage that can fail every
   rank learns every other rank's outcome (one ``allgather``): a bad scene stops **all** ranks
   with linpd's message and exit code 1, and none of them is left waiting in a collective;
2. owns a contiguous range of rows (per rank: its planes' free DOFs in the whole scene's
   numbering, from one ``allgather`` of per-plane counts; a cloud's are numbered bin by bin,
   then in file order; ``--gather``: PETSc's balanced split of the nodes) and hands **only its rows** of the reduced stiffness ``A_ff`` to a PETSc MPIAIJ
   matrix of block size ``d`` (per rank: preallocated from its rows' lengths and filled 16384
   rows at a time, so it never holds them twice);
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
error on every rank (exit 1) and nothing is written. Otherwise, into the scene's output
directory (or ``--out DIR``), all or none: per rank, every rank writes ``result-<rank>.vtu``
with its owned nodes' displacements and fields (which read its halo's displacements), and rank 0
``result.pvtu`` over the pieces and ``result.json`` with the aggregates (the force balance from
the ranks' shares, nodes, unknowns, the pieces); :func:`read_pieces` reads them back. With
``--gather`` rank 0 gathers ``u`` and writes ``result.json``, ``u.csv`` and ``result.vtu`` as
``linpd solve`` does (no plots). ``stats.solve`` holds the KSP's type, iterations, converged
reason, the relative residual ``||f - A u|| / ||f||`` recomputed after the solve, the timings,
every rank's peak resident memory (per rank also after the imports, the model and the matrix),
the slabs, the width of PETSc's integers and whether ``A_ff`` is symmetric. A PETSc built with
64-bit indices works as it is (``petsc_int_bits: 64``).

Every static model assembles its own rows (bond, LPS, coarsened levels, 1D blend/CE; see
``docs/scale-out.md`` for what each costs per rank).
"""

from __future__ import annotations

import json
import os
import resource
import sys
import time
from typing import Dict, List, Optional, Tuple

import numpy as np

USAGE = "usage: python -m linpd.petsc SCENE.json [--out DIR] [--gather] [PETSc options]"

# The KSP types that take -ksp_gmres_restart and need the preconditioner on the right for an
# unpreconditioned norm.
GMRES_FAMILY = ("gmres", "lgmres", "dgmres", "pgmres")
# GMRES's restart for unsymmetric scenes (see the module docstring).
GMRES_RESTART = 100
# Rows a rank hands to PETSc at a time (per-rank geometry): at most about 16384 x 370 entries x
# 24 bytes = 145 MB of linpd's arrays beside PETSc's matrix (a 3D bond lattice at delta = 3h).
ROW_CHUNK = 16384


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


def _split_args(argv: List[str]) -> Tuple[Optional[str], Optional[str], bool, List[str]]:
    """``(scene, out, gather, petsc_args)`` from the command line (PETSc options are everything
    else)."""
    scene, out, gather, rest = None, None, False, []
    k = 0
    while k < len(argv):
        a = argv[k]
        if a == "--out" and k + 1 < len(argv):
            out = argv[k + 1]
            k += 2
            continue
        if a.startswith("--out="):
            out = a[len("--out="):]
        elif a == "--gather":
            gather = True
        elif scene is None and not a.startswith("-"):
            scene = a
        else:
            rest.append(a)
        k += 1
    return scene, out, gather, rest


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


def read_pieces(directory) -> Tuple[np.ndarray, Dict[str, np.ndarray]]:
    """``(x, arrays)`` of a per-rank result directory: the nodes' positions ``(n, 3)`` and the
    point arrays (``u``: ``(n, 3)``, ``strain``: ``(n, 9)``, ...) of all pieces of ``result.json``
    in piece order (each piece's nodes in lattice order; a point cloud's bin by bin, with
    ``file_node``: each node's 0-based number in the cloud's file, so ``u[argsort(file_node)]``
    is in the file's order). Reads linpd's own ASCII pieces."""
    import xml.etree.ElementTree as ET
    from pathlib import Path

    directory = Path(directory)
    doc = json.loads((directory / "result.json").read_text())
    xs, arrays = [], {}
    for piece in doc["pieces"]:
        for a in ET.parse(directory / piece).getroot().iter("DataArray"):
            name = a.get("Name")
            if name in ("connectivity", "offsets", "types"):
                continue
            k = int(a.get("NumberOfComponents", "1"))
            values = np.array((a.text or "").split(), dtype=float).reshape(-1, k)
            if name == "points":
                xs.append(values)
            else:
                arrays.setdefault(name, []).append(values)
    return np.concatenate(xs), {k: np.concatenate(v) for k, v in arrays.items()}


class _Stop(Exception):
    """Every rank stops with this status (the message was printed)."""

    def __init__(self, status: int):
        super().__init__(status)
        self.status = status


def _agree(mpi, rank: int, error: Optional[str], what: str = "error") -> None:
    """One ``allgather`` of every rank's outcome: if any rank failed, every rank prints the
    first failure (naming the rank when the ranks differ) and stops with status 1, so no rank is
    left waiting in a later collective."""
    errors = mpi.allgather(error)
    failed = [(r, e) for r, e in enumerate(errors) if e is not None]
    if failed:
        r, e = failed[0]
        where = "" if all(x == e for x in errors) else f" (rank {r})"
        print(f"{what}{where}: {e}", file=sys.stderr, flush=True)
        raise _Stop(1)


def _attempt(fn, prefix: str = ""):
    """``(value, None)`` or ``(None, message)`` of ``fn()`` (linpd's, the OS's, PETSc's errors and
    running out of memory: what one rank may meet alone)."""
    import linpd
    from petsc4py import PETSc

    try:
        return fn(), None
    except (linpd.LinpdError, OSError, MemoryError, PETSc.Error) as e:
        return None, f"{prefix}{e}"


def _solve(PETSc, comm, A, b, symmetric: bool, d: int, coords) -> dict:
    """CG or GMRES with GAMG (see the module docstring) on ``A x = b``; ``coords`` (or None)
    the owned rows' coordinates for the rigid-body near-null space. Returns the solution and
    the KSP's figures."""
    if coords is not None:
        A.setNearNullSpace(PETSc.NullSpace().createRigidBody(coords))
    x = b.duplicate()
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
    r = b.duplicate()
    A.mult(x, r)
    r.aypx(-1.0, b)  # r = b - A x
    b_norm = b.norm()
    return {
        "x": x,
        "reason": ksp.getConvergedReason(),
        "iterations": ksp.getIterationNumber(),
        "rel_residual": r.norm() / b_norm if b_norm > 0 else r.norm(),
        "nnz": int(A.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_used"]),
        "pc_type": ksp.getPC().getType(),
        "ksp_type": ksp.getType(),
        "setup": t_setup,
        "solve": t_solve,
    }


def _check_converged(rank: int, k: dict) -> None:
    """A diverged or failed KSP (negative converged reason: -3 max_it, -4 dtol, -5 breakdown,
    -9 nan or inf, ...) or a non-finite residual: an error on every rank, nothing written."""
    if k["reason"] < 0 or not np.isfinite(k["rel_residual"]):
        if rank == 0:
            why = _REASONS.get(int(k["reason"]), "")
            print(
                f"error: solver: the KSP ({k['ksp_type']}, {k['pc_type']}) did not converge: reason {k['reason']}"
                f"{f' ({why})' if why else ''}, {k['iterations']} iterations, relative residual "
                f"{k['rel_residual']:.3e}; nothing written",
                file=sys.stderr,
                flush=True,
            )
        raise _Stop(1)


def _report(PETSc, k: dict, n: int, size: int, bs: int, symmetric: bool, asymmetry: float, near_null: bool,
            timings: dict, rss: List[int], petsc_args: List[str], geometry: str) -> dict:
    """``stats.solve`` of ``result.json``."""
    return {
        "solver": f"petsc-{k['ksp_type']}-{k['pc_type']}",
        "n": n,
        "nnz_a": k["nnz"],
        "iterations": k["iterations"],
        "rel_residual": k["rel_residual"],
        "ksp_converged_reason": int(k["reason"]),
        "ranks": size,
        "block_size": bs,
        "symmetric": bool(symmetric),
        "asymmetry": float(asymmetry),
        "near_null_space": "rigid-body modes" if near_null else None,
        "geometry": geometry,
        "timings": timings,
        "peak_rss_bytes": max(rss),
        "peak_rss_bytes_per_rank": rss,
        "petsc_version": ".".join(map(str, PETSc.Sys.getVersion())),
        "petsc_int_bits": np.dtype(PETSc.IntType).itemsize * 8,
        "petsc_options": petsc_args,
    }


def _summary(name: str, n: int, size: int, k: dict, timings: dict, rss: List[int], files: int, dest: str) -> str:
    return (
        f"{name}: {n} unknowns on {size} ranks, {k['ksp_type']} + {k['pc_type']}: {k['iterations']} iterations, "
        f"relative residual {k['rel_residual']:.3e}, assemble {timings['assemble']:.3f} s, setup "
        f"{timings['setup']:.3f} s, solve {timings['solve']:.3f} s, peak memory per rank "
        f"{', '.join(f'{m / 2**20:.0f}' for m in rss)} MiB; wrote {files} files into {dest}"
    )


def _whole(PETSc, comm, mpi, scene_path: str, out: Optional[str], petsc_args: List[str], t0: float) -> int:
    """Every rank builds the whole scene and assembles its rows; rank 0 gathers ``u`` and writes
    ``linpd solve``'s files (``--gather``, and scenes without per-rank geometry)."""
    import linpd

    rank, size = comm.getRank(), comm.getSize()

    def validate():
        scene = linpd.Scene(scene_path)
        n, bs, free_dofs, rhs = scene.row_info()
        if n >= 2**31 and PETSc.IntType == np.int32:
            raise linpd.LinpdError(f"{n} unknowns need a PETSc built with 64-bit indices (docs/scale-out.md)")
        return scene, n, bs, free_dofs, rhs, scene.is_symmetric()

    got, error = _attempt(validate, f"{scene_path}: ")
    _agree(mpi, rank, error)
    scene, n, bs, free_dofs, rhs, symmetric = got
    d = scene.dim
    t_model = time.perf_counter() - t0

    # own rows only: a contiguous range of blocks (nodes when bs == d)
    b0, b1 = _node_range(n // bs, size, rank)
    first, last = bs * b0, bs * b1
    t1 = time.perf_counter()
    indptr, indices, data = scene.assemble_rows(first, last)
    A = PETSc.Mat().createAIJ(size=((last - first, n), (last - first, n)), bsize=bs, comm=comm)
    A.setPreallocationCSR((indptr.astype(PETSc.IntType), indices.astype(PETSc.IntType), data))
    A.assemble()
    del indptr, indices, data
    b = PETSc.Vec().createMPI((last - first, n), bsize=bs, comm=comm)
    b.setArray(rhs[first:last])
    t_assemble = time.perf_counter() - t1

    # rigid-body modes from the coordinates of the owned rows (whole nodes only)
    near_null = bs == d and d > 1
    coords = None
    if near_null:
        positions = scene.positions()
        rows = free_dofs[first:last]
        coords = PETSc.Vec().createMPI((last - first, n), bsize=d, comm=comm)
        coords.setArray(positions[rows // d, rows % d])
        del positions
    k = _solve(PETSc, comm, A, b, symmetric, d, coords)

    scatter, x0 = PETSc.Scatter.toZero(k["x"])
    scatter.scatter(k["x"], x0, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    rss = mpi.gather(_peak_rss_bytes(), root=0)
    _check_converged(rank, k)
    status = 0
    if rank == 0:
        timings = {"model": t_model, "assemble": t_assemble, "setup": k["setup"], "solve": k["solve"],
                   "total": time.perf_counter() - t0}
        report = _report(PETSc, k, n, size, bs, symmetric, scene.asymmetry(), near_null, timings, rss, petsc_args,
                         "whole")
        u = scene.expand(x0.getArray())
        dest = out if out is not None else scene.output_dir
        try:
            files = scene.write_result(u, report, dest)
        except linpd.LinpdError as e:
            print(f"error: {e}", file=sys.stderr, flush=True)
            status = 1
        else:
            print(_summary(scene.name, n, size, k, timings, rss, len(files), dest), flush=True)
    # every rank returns the same status (rank 0's writing may have failed)
    return int(mpi.bcast(status, root=0))


def _parts(PETSc, comm, mpi, part, scene_path: str, out: Optional[str], petsc_args: List[str], t0: float,
           rss_baseline: int) -> int:
    """Every rank builds only its slab of the lattice or cloud (``part``, see the module docstring);
    the ranks write one piece each and rank 0 the index and ``result.json``."""
    from ._linpd import NativeOutput

    rank, size = comm.getRank(), comm.getSize()
    # what no window decides alone: the presence checks (an or; every rank records the same
    # checks in the same order, which the count checks), the resultant volumes (a sum)
    found = np.array(part.presences(), dtype=np.int64)
    counts = mpi.allgather(len(found))
    _agree(mpi, rank, None if len(set(counts)) == 1 else
           f"{scene_path}: the ranks recorded {sorted(set(counts))} checks: every rank must read the same scene")
    found_any = mpi.allreduce(found, op=_mpi_sum()) > 0
    _, error = _attempt(lambda: part.settle([bool(f) for f in found_any]), f"{scene_path}: ")
    _agree(mpi, rank, error, "error")
    volumes = mpi.allreduce(np.array(part.resultant_volumes(), dtype=float), op=_mpi_sum())
    _, error = _attempt(lambda: part.build([float(v) for v in np.atleast_1d(volumes)]), f"{scene_path}: ")
    _agree(mpi, rank, error)
    # the numbering: every plane's count of free DOFs, gathered in rank order
    counts = [c for rank_counts in mpi.allgather(part.plane_free_counts()) for c in rank_counts]
    _, error = _attempt(lambda: part.number(counts), f"{scene_path}: ")
    _agree(mpi, rank, error)
    all_, held = part.support_gram()
    all_ = mpi.allreduce(np.array(all_), op=_mpi_sum())
    held = mpi.allreduce(np.array(held), op=_mpi_sum())
    _, error = _attempt(lambda: part.check_support(list(all_), list(held)), f"{scene_path}: ")
    _agree(mpi, rank, error)
    first, last, n = part.row_range()
    rss_model = _peak_rss_bytes()
    symmetric, asymmetry, whole_nodes = part.row_kind()
    symmetric = mpi.allreduce(int(symmetric), op=_mpi_min()) == 1
    asymmetry = mpi.allreduce(asymmetry, op=_mpi_max())
    d = part.dim
    bs = d if mpi.allreduce(int(whole_nodes), op=_mpi_min()) == 1 else 1
    error = None
    if n >= 2**31 and PETSc.IntType == np.int32:
        error = f"{scene_path}: {n} unknowns need a PETSc built with 64-bit indices (docs/scale-out.md)"
    _agree(mpi, rank, error)
    t_model = time.perf_counter() - t0

    t1 = time.perf_counter()
    # chunked insertion into the preallocated matrix: a rank holds its rows once (PETSc's), plus
    # one chunk of linpd's
    lengths, error = _attempt(lambda: part.row_lengths(), f"{scene_path}: ")
    entries = 0 if lengths is None else int(lengths[0].sum(dtype=np.int64) + lengths[1].sum(dtype=np.int64))
    if error is None and PETSc.IntType == np.int32 and entries >= 2**31:
        error = (f"{scene_path}: this rank's {entries} stored entries need a PETSc built with 64-bit indices "
                 f"(docs/scale-out.md), or more ranks")
    _agree(mpi, rank, error)
    d_nnz, o_nnz = lengths
    A = PETSc.Mat().createAIJ(size=((last - first, n), (last - first, n)), bsize=bs, comm=comm)
    # (a rank without rows passes counts, not empty arrays: with empty arrays there, PETSc 3.18.5's
    # assembly never returned on 6 ranks over 5 lattice planes)
    A.setPreallocationNNZ((d_nnz.astype(PETSc.IntType), o_nnz.astype(PETSc.IntType)) if len(d_nnz) else (0, 0))
    del d_nnz, o_nnz

    def insert():
        for lo in range(0, last - first, ROW_CHUNK):
            hi = min(lo + ROW_CHUNK, last - first)
            indptr, indices, data = part.assemble_rows(lo, hi)
            A.setValuesIJV(indptr.astype(PETSc.IntType), indices.astype(PETSc.IntType), data,
                           rowmap=np.arange(first + lo, first + hi, dtype=PETSc.IntType))

    _, error = _attempt(insert, f"{scene_path}: ")
    _agree(mpi, rank, error)
    A.assemble()
    rss_assembled = _peak_rss_bytes()
    b = PETSc.Vec().createMPI((last - first, n), bsize=bs, comm=comm)
    b.setArray(part.rhs())
    t_assemble = time.perf_counter() - t1
    near_null = bs == d and d > 1
    coords = None
    if near_null:
        coords = PETSc.Vec().createMPI((last - first, n), bsize=d, comm=comm)
        coords.setArray(part.row_coordinates())
    k = _solve(PETSc, comm, A, b, symmetric, d, coords)
    _check_converged(rank, k)

    # the window's values (owned rows and the halo's) for the piece's fields
    rows = part.window_rows().astype(PETSc.IntType)
    where = PETSc.IS().createGeneral(rows, comm=PETSc.COMM_SELF)
    u_window = PETSc.Vec().createSeq(len(rows), comm=PETSc.COMM_SELF)
    PETSc.Scatter().create(k["x"], where, u_window, None).scatter(
        k["x"], u_window, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    u_window = u_window.getArray().copy()

    # output: rank 0 stages the directory, every rank writes its piece, rank 0 commits
    dest = out if out is not None else part.output_dir
    staged, error = (None, None)
    if rank == 0:
        staged, error = _attempt(lambda: NativeOutput.begin(dest, [scene_path]))
    _agree(mpi, rank, error)
    path = mpi.bcast(staged.path() if rank == 0 else None, root=0)
    pieces = [f"result-{r}.vtu" for r in range(size)]
    # the moments' reference point and scale: the mean position of all nodes and the diagonal
    # of their bounding box, as linpd solve's balance has them
    sums, count, lo, hi = part.owned_frame()
    total = mpi.allreduce(count, op=_mpi_sum())
    reference = list(mpi.allreduce(np.array(sums), op=_mpi_sum())[:d] / max(total, 1))
    lo, hi = np.min(mpi.allgather(np.array(lo)), axis=0), np.max(mpi.allgather(np.array(hi)), axis=0)
    diagonal = float(np.sqrt(np.sum((hi[:d] - lo[:d]) ** 2)))
    share, error = _attempt(lambda: part.balance(u_window, reference))
    owned_nodes = 0
    if error is None:
        owned_nodes, error = _attempt(lambda: part.write_piece(u_window, path, pieces[rank],
                                                               "result.pvtu" if rank == 0 else None, pieces))
    try:
        _agree(mpi, rank, error)
    except _Stop:
        if staged is not None:
            staged.discard()
        raise
    nodes = mpi.gather(owned_nodes, root=0)
    shares = mpi.gather(share, root=0)
    slabs = mpi.gather(part.slab(), root=0)
    rss = mpi.gather(_peak_rss_bytes(), root=0)
    rss_stages = mpi.gather((rss_baseline, rss_model, rss_assembled), root=0)
    status = 0
    if rank == 0:
        timings = {"model": t_model, "assemble": t_assemble, "setup": k["setup"], "solve": k["solve"],
                   "total": time.perf_counter() - t0}
        report = _report(PETSc, k, n, size, bs, symmetric, asymmetry, near_null, timings, rss, petsc_args, "per-rank")
        report["slabs"] = [{"owned_planes": [s[1], s[2]], "window_planes": [s[3], s[4]], "window_nodes": s[5],
                            "owned_nodes": m} for s, m in zip(slabs, nodes)]
        # peak RSS per rank after the imports (the runtime), after the model and its rows
        # (before PETSc's matrix), after the matrix's assembly, and at the end
        report["rss_baseline_bytes_per_rank"] = [s[0] for s in rss_stages]
        report["rss_model_bytes_per_rank"] = [s[1] for s in rss_stages]
        report["rss_assembled_bytes_per_rank"] = [s[2] for s in rss_stages]
        doc = {
            "name": part.name,
            "dimension": d,
            "nodes": int(sum(nodes)),
            "unknowns": n,
            "pieces": pieces,
            "index": "result.pvtu",
            "balance": _balance(d, shares, reference, diagonal),
            "stats": {"solve": report},
        }
        from pathlib import Path

        missing = [p for p in pieces if not (Path(path) / p).exists()]
        try:
            if missing:
                # the output directory must be one file system for all ranks
                staged.discard()
                raise OSError(f"{dest}: the pieces {missing} are not in {path}: the output directory must be on a "
                              f"file system every rank shares")
            files = staged.commit("result.json", json.dumps(doc))
        except Exception as e:  # noqa: BLE001 (linpd's and the OS's errors)
            print(f"error: {e}", file=sys.stderr, flush=True)
            status = 1
        else:
            print(_summary(part.name, n, size, k, timings, rss, len(files), dest), flush=True)
    return int(mpi.bcast(status, root=0))


def _balance(d: int, shares, reference: List[float], diagonal: float) -> dict:
    """The force balance from the ranks' shares ``(loads, load_moments, reactions,
    reaction_moments, held_dofs)``: per load its force and moment, per constraint its reaction
    and held DOFs, the totals, ``max_a |applied_a + reaction_a| / (largest force)`` and the
    moments' ``max |applied + reaction| / (largest force x diagonal)`` about ``reference``, as in
    ``linpd solve``'s ``result.json`` (whose balance also has the load kinds, node counts and
    each constraint's centroid and moment about it: not summed here)."""
    m = {2: 1, 3: 3}.get(d, 0)
    loads = np.sum([np.array(s[0], dtype=float).reshape(-1, d) for s in shares], axis=0)
    load_moments = np.sum([np.array(s[1], dtype=float).reshape(-1, m) for s in shares], axis=0)
    reactions = np.sum([np.array(s[2], dtype=float).reshape(-1, d) for s in shares], axis=0)
    reaction_moments = np.sum([np.array(s[3], dtype=float).reshape(-1, m) for s in shares], axis=0)
    held = np.sum([np.array(s[4], dtype=np.int64) for s in shares], axis=0)
    applied, reaction = loads.sum(axis=0), reactions.sum(axis=0)
    applied_moment, reaction_moment = load_moments.sum(axis=0), reaction_moments.sum(axis=0)
    scale = max([0.0] + [abs(v) for v in np.concatenate([applied, loads.ravel(), reactions.ravel()])])
    worst = float(np.max(np.abs(applied + reaction)))
    worst_moment = float(np.max(np.abs(applied_moment + reaction_moment))) if m else 0.0
    return {
        "loads": [{"force": list(map(float, f)), "moment": list(map(float, t))} for f, t in zip(loads, load_moments)],
        "constraints": [{"reaction": list(map(float, r)), "dofs": int(h)} for r, h in zip(reactions, held)],
        "applied": list(map(float, applied)),
        "reaction": list(map(float, reaction)),
        "relative_imbalance": worst / scale if scale > 0 else 0.0,
        "reference": list(map(float, reference)),
        "applied_moment": list(map(float, applied_moment)),
        "reaction_moment": list(map(float, reaction_moment)),
        "relative_moment_imbalance": worst_moment / (scale * diagonal) if scale * diagonal > 0 else 0.0,
    }


def _mpi_sum():
    from mpi4py import MPI

    return MPI.SUM


def _mpi_min():
    from mpi4py import MPI

    return MPI.MIN


def _mpi_max():
    from mpi4py import MPI

    return MPI.MAX


# A model without per-rank geometry says so with this phrase (linpd_scene::validate::window).
_NO_PARTS = "has no per-rank geometry yet"


def main(argv: Optional[List[str]] = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    scene_path, out, gather, petsc_args = _split_args(argv)

    import petsc4py

    petsc4py.init([sys.argv[0]] + petsc_args)
    from petsc4py import PETSc

    comm = PETSc.COMM_WORLD
    if comm.getSize() > 1:
        # the ranks are the parallelism: one rayon thread each (linpd's pool starts at its first
        # parallel call, after this), unless the user says otherwise
        os.environ.setdefault("RAYON_NUM_THREADS", "1")
    from ._linpd import NativePart

    mpi = comm.tompi4py()
    rank, size = comm.getRank(), comm.getSize()
    t0 = time.perf_counter()
    rss_baseline = _peak_rss_bytes()
    try:
        if scene_path is None:
            _agree(mpi, rank, USAGE, "error")
        if gather:
            return _whole(PETSc, comm, mpi, scene_path, out, petsc_args, t0)
        part, error = _attempt(lambda: NativePart.from_path(scene_path, rank, size), f"{scene_path}: ")
        # a model without per-rank geometry (any rank may be the one that finds out, e.g. the
        # others' windows failed first on something else): the whole scene on every rank, said once
        whole = mpi.allgather(error if error is not None and _NO_PARTS in error else None)
        refusal = next((w for w in whole if w is not None), None)
        if refusal is not None:
            if rank == 0:
                print(f"note: {refusal.split(': ', 1)[-1]}", file=sys.stderr, flush=True)
            return _whole(PETSc, comm, mpi, scene_path, out, petsc_args, t0)
        _agree(mpi, rank, error)
        return _parts(PETSc, comm, mpi, part, scene_path, out, petsc_args, t0, rss_baseline)
    except _Stop as stop:
        return stop.status
    except BaseException as e:  # noqa: BLE001 (a bug, or a panic in linpd's module, on one rank)
        # the other ranks may wait in a collective: abort them all rather than hang
        print(f"error (rank {rank}): {type(e).__name__}: {e}", file=sys.stderr, flush=True)
        mpi.Abort(1)
        return 1


if __name__ == "__main__":
    sys.exit(main())
