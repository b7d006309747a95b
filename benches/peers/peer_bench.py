#!/usr/bin/env python3
"""Time the Python peers (SciPy, CHOLMOD) on cases exported by ``linpd bench``.

``linpd bench --export DIR`` writes, for every benchmark case ``NAME``
(all binary files little-endian):

``NAME.coo.bin``
    u64 nrows, u64 ncols, u64 nnz_triplets, then nnz_triplets u64 row
    indices, nnz_triplets u64 column indices, nnz_triplets f64 values: the
    *unsummed* assembly triplets (duplicates present) of the full symmetric
    reduced (free-DOF) SPD matrix.
``NAME.rhs.bin``
    u64 n, then n f64: the right-hand side of the reduced system.
``NAME.json``
    ``{"name", "n", "nnz", "cg_rtol", "cg_maxiter"}``; ``nnz`` counts the
    entries after summing duplicates.  Optional keys: ``"peers"``, the list
    of peers to run (default ``["cholmod", "matvec", "cg"]``; ``"pyamg"``
    is run only when listed), and ``"near_null_space"``, the file of the
    near-null space for pyamg.
``NAME.B.bin`` (``linpd bench --statics --peers``)
    u64 n, u64 k, then n rows of k f64: the rigid-body modes of the free
    DOFs, the near-null space linpd's multigrid uses.

For each case this script times (best of ``--repeat`` runs, wall clock via
``time.perf_counter``, in seconds):

* ``coo_to_csr``: ``coo_matrix((v, (r, c)), shape).tocsr()``, which sums the
  duplicates (the SciPy triplet-build baseline);
* ``cholmod_analyze``, ``cholmod_factor``, ``cholmod_solve``: scikit-sparse's
  ``cholmod.analyze(A)``, ``factor.cholesky(A)`` and ``factor(b)``, with the
  default ordering; also nnz(L), the ordering CHOLMOD picked and the relative
  residual ``||A x - b|| / ||b||``;
* ``matvec``: mean time of ``A @ x`` over enough products to last >= 0.2 s;
* ``cg``: ``scipy.sparse.linalg.cg`` with a Jacobi preconditioner, plus its
  iteration count and final relative residual;
* ``pyamg_setup``, ``pyamg_solve``: pyamg's ``smoothed_aggregation_solver``
  with the case's near-null space ``B`` (defaults otherwise: symmetric
  strength, standard aggregation, symmetric block Gauss-Seidel smoothing)
  and its ``solve(..., accel="cg")`` to ``cg_rtol``; iterations, relative
  residual, levels and operator complexity (one run each: the setup alone
  takes seconds on the 3D cases);

and the peak resident set size.  By default each case runs in a fresh
subprocess so that ``peak_rss_bytes`` belongs to that case alone.

Usage::

    python3 peer_bench.py DIR [--out results.json] [--repeat 3] [--max-n N]
"""

import argparse
import fnmatch
import importlib.metadata
import inspect
import json
import math
import multiprocessing
import os
import pathlib
import platform
import resource
import sys
import time
import traceback
import warnings

import numpy as np
import scipy
import scipy.sparse
import scipy.sparse.linalg

try:
    import pyamg
    PYAMG_IMPORT_ERROR = None
except ImportError as exc:  # pragma: no cover - depends on the machine
    pyamg = None
    PYAMG_IMPORT_ERROR = f"pyamg not importable: {exc}"

try:
    import sksparse.cholmod as cholmod
    CHOLMOD_IMPORT_ERROR = None
except ImportError as exc:  # pragma: no cover - depends on the machine
    cholmod = None
    CHOLMOD_IMPORT_ERROR = f"scikit-sparse not importable: {exc}"

U64 = np.dtype("<u8")
F64 = np.dtype("<f8")
MATVEC_MIN_SECONDS = 0.2
# Orderings tried, in this order, to identify the permutation CHOLMOD chose
# under its "default" strategy (AMD, falling back to METIS when AMD fills
# badly); scikit-sparse does not expose cholmod_factor.ordering itself.
ORDERING_CANDIDATES = ("amd", "metis", "nesdis", "colamd", "natural")


# --------------------------------------------------------------------------
# Input
# --------------------------------------------------------------------------

def _read_exact(fh, dtype, count, path):
    """Read ``count`` items of ``dtype`` from ``fh``; raise if truncated."""
    arr = np.fromfile(fh, dtype=dtype, count=count)
    if arr.size != count:
        raise ValueError(f"{path}: truncated (wanted {count} x {dtype}, "
                         f"got {arr.size})")
    return arr


def load_triplets(path):
    """Load ``NAME.coo.bin``; return ``(shape, rows, cols, vals)``.

    Indices are returned as int64 views of the stored u64 (no copy).
    """
    path = pathlib.Path(path)
    with open(path, "rb") as fh:
        nrows, ncols, nnz_t = (int(v) for v in _read_exact(fh, U64, 3, path))
        expected = 8 * 3 + nnz_t * (8 + 8 + 8)
        actual = path.stat().st_size
        if actual != expected:
            raise ValueError(f"{path}: size {actual} != expected {expected} "
                             f"for nnz_triplets={nnz_t}")
        rows = _read_exact(fh, U64, nnz_t, path).view(np.int64)
        cols = _read_exact(fh, U64, nnz_t, path).view(np.int64)
        vals = _read_exact(fh, F64, nnz_t, path)
    if nnz_t and (rows.max() >= nrows or cols.max() >= ncols
                  or rows.min() < 0 or cols.min() < 0):
        raise ValueError(f"{path}: index out of range for shape "
                         f"({nrows}, {ncols})")
    return (nrows, ncols), rows, cols, vals


def load_modes(path):
    """Load ``NAME.B.bin``; return the ``(n, k)`` f64 array."""
    path = pathlib.Path(path)
    with open(path, "rb") as fh:
        n, k = (int(v) for v in _read_exact(fh, U64, 2, path))
        if path.stat().st_size != 16 + 8 * n * k:
            raise ValueError(f"{path}: size {path.stat().st_size} != "
                             f"expected {16 + 8 * n * k} for n={n}, k={k}")
        return _read_exact(fh, F64, n * k, path).reshape(n, k)


def load_rhs(path):
    """Load ``NAME.rhs.bin``; return the f64 vector."""
    path = pathlib.Path(path)
    with open(path, "rb") as fh:
        (n,) = (int(v) for v in _read_exact(fh, U64, 1, path))
        expected = 8 + 8 * n
        if path.stat().st_size != expected:
            raise ValueError(f"{path}: size {path.stat().st_size} != "
                             f"expected {expected} for n={n}")
        return _read_exact(fh, F64, n, path)


# --------------------------------------------------------------------------
# Timing helpers
# --------------------------------------------------------------------------

def best_of(repeat, fn):
    """Run ``fn`` ``repeat`` times; return ``(best_seconds, last_result)``."""
    best = math.inf
    result = None
    for _ in range(max(1, repeat)):
        result = None  # free the previous result before the next run
        start = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - start)
    return best, result


def mean_over(min_seconds, fn):
    """Call ``fn`` until ``min_seconds`` have elapsed; return (mean, calls)."""
    fn()  # warm-up
    calls = 0
    start = time.perf_counter()
    while True:
        fn()
        calls += 1
        elapsed = time.perf_counter() - start
        if elapsed >= min_seconds:
            return elapsed / calls, calls


def rel_residual(a, x, b):
    """Return ``||A x - b|| / ||b||``."""
    return float(np.linalg.norm(a @ x - b) / np.linalg.norm(b))


def peak_rss_bytes():
    """Peak RSS of this process so far (``ru_maxrss`` is KiB on Linux)."""
    scale = 1 if sys.platform == "darwin" else 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * scale


def blas_libraries():
    """Shared libraries mapped into this process whose name mentions BLAS."""
    libs = set()
    try:
        with open("/proc/self/maps") as fh:
            for line in fh:
                path = line.split()[-1]
                if "blas" in os.path.basename(path).lower():
                    libs.add(path)
    except OSError:
        pass
    return sorted(libs)


# --------------------------------------------------------------------------
# Peers
# --------------------------------------------------------------------------

def identify_ordering(a_csc, perm):
    """Name the ordering whose permutation equals ``perm`` (untimed).

    Returns ``(name, how)``; ``name`` is None when nothing matched.
    """
    for method in ORDERING_CANDIDATES:
        try:
            probe = cholmod.analyze(a_csc, ordering_method=method)
        except Exception:  # a method may be unavailable in this build
            continue
        if np.array_equal(probe.P(), perm):
            return method, "matched permutation of explicit ordering"
    return None, "no explicit ordering reproduced the permutation"


def bench_cholmod(a_csc, b, repeat, probe_ordering):
    """Time CHOLMOD analyze / factor / solve on ``a_csc``."""
    out = {}
    t, analysis = best_of(repeat, lambda: cholmod.analyze(a_csc))
    out["cholmod_analyze"] = t
    t, factor = best_of(repeat, lambda: analysis.cholesky(a_csc))
    out["cholmod_factor"] = t
    t, x = best_of(repeat, lambda: factor(b))
    out["cholmod_solve"] = t
    out["cholmod_rel_residual"] = rel_residual(a_csc, x, b)
    # The peak RSS of the timed work, before L() builds an extra copy.
    out["cholmod_peak_rss_bytes"] = peak_rss_bytes()
    out["cholmod_nnz_l"] = int(factor.L().nnz)
    if probe_ordering:
        name, how = identify_ordering(a_csc, analysis.P())
        out["cholmod_ordering"] = name
        out["cholmod_ordering_note"] = how
    else:
        out["cholmod_ordering"] = None
        out["cholmod_ordering_note"] = "probe disabled"
    return out


def cg_tolerance_kwargs(rtol):
    """Tolerance kwargs for ``cg``: ``rtol`` (SciPy >= 1.12), else ``tol``."""
    params = inspect.signature(scipy.sparse.linalg.cg).parameters
    if "rtol" in params:
        return {"rtol": rtol, "atol": 0.0}
    return {"tol": rtol, "atol": 0.0}


def bench_cg(a_csr, b, rtol, maxiter, repeat):
    """Time Jacobi-preconditioned CG; return timing, iterations, residual."""
    n = a_csr.shape[0]
    inv_diag = 1.0 / a_csr.diagonal()
    jacobi = scipy.sparse.linalg.LinearOperator(
        (n, n), matvec=lambda r: inv_diag * r.ravel(), dtype=np.float64)
    kwargs = cg_tolerance_kwargs(rtol)
    iterations = [0]

    def count(_xk):
        iterations[0] += 1

    def run():
        iterations[0] = 0
        return scipy.sparse.linalg.cg(a_csr, b, M=jacobi, maxiter=maxiter,
                                      callback=count, **kwargs)

    t, (x, info) = best_of(repeat, run)
    return {
        "cg": t,
        "cg_iterations": iterations[0],
        "cg_info": int(info),
        "cg_converged": info == 0,
        "cg_rel_residual": rel_residual(a_csr, x, b),
    }


def bench_pyamg(a_csr, b, modes, rtol, maxiter):
    """pyamg smoothed aggregation with near-null space ``modes``, as a CG
    preconditioner: setup and solve timed once each."""
    if pyamg is None:
        return {"pyamg_skip_reason": PYAMG_IMPORT_ERROR}
    t0 = time.perf_counter()
    ml = pyamg.smoothed_aggregation_solver(a_csr, B=modes)
    setup = time.perf_counter() - t0
    residuals = []
    t0 = time.perf_counter()
    x = ml.solve(b, tol=rtol, maxiter=maxiter, accel="cg",
                 residuals=residuals)
    solve = time.perf_counter() - t0
    return {
        "pyamg_setup": setup,
        "pyamg_solve": solve,
        # ``residuals`` holds the initial residual and one per iteration.
        "pyamg_iterations": len(residuals) - 1,
        "pyamg_rel_residual": rel_residual(a_csr, x, b),
        "pyamg_levels": len(ml.levels),
        "pyamg_operator_complexity": float(ml.operator_complexity()),
    }


def run_case(meta_path, repeat, probe_ordering):
    """Benchmark one case; return its result dict (errors are recorded)."""
    meta_path = pathlib.Path(meta_path)
    result = {"peak_rss_baseline_bytes": peak_rss_bytes()}
    try:
        meta = json.loads(meta_path.read_text())
        name = meta["name"]
        base = meta_path.parent / name
        shape, rows, cols, vals = load_triplets(f"{base}.coo.bin")
        b = load_rhs(f"{base}.rhs.bin")
        n = int(meta["n"])
        if shape != (n, n) or b.size != n:
            raise ValueError(f"shape {shape} / rhs {b.size} disagree with "
                             f"n={n} in {meta_path}")
        result.update(n=n, nnz_triplets=int(vals.size))
        result["peak_rss_after_load_bytes"] = peak_rss_bytes()

        t, a_csr = best_of(repeat, lambda: scipy.sparse.coo_matrix(
            (vals, (rows, cols)), shape=shape).tocsr())
        result["coo_to_csr"] = t
        result["nnz"] = int(a_csr.nnz)
        if "nnz" in meta and int(meta["nnz"]) != a_csr.nnz:
            raise ValueError(f"summed nnz {a_csr.nnz} != nnz {meta['nnz']} "
                             f"in {meta_path}")
        del rows, cols, vals
        peers = meta.get("peers", ["cholmod", "matvec", "cg"])

        if "pyamg" in peers:
            modes = load_modes(meta_path.parent / meta["near_null_space"])
            if modes.shape[0] != n:
                raise ValueError(f"{meta['near_null_space']}: {modes.shape[0]}"
                                 f" rows, need {n}")
            result.update(bench_pyamg(a_csr, b, modes,
                                      float(meta.get("cg_rtol", 1e-8)),
                                      int(meta.get("cg_maxiter", 10 * n))))

        if "cholmod" not in peers:
            pass
        elif cholmod is None:
            result.update(cholmod_analyze=None, cholmod_factor=None,
                          cholmod_solve=None, cholmod_nnz_l=None,
                          cholmod_ordering=None, cholmod_rel_residual=None,
                          cholmod_skip_reason=CHOLMOD_IMPORT_ERROR)
        else:
            a_csc = a_csr.tocsc()
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                result.update(bench_cholmod(a_csc, b, repeat, probe_ordering))
            # E.g. CholmodTypeConversionWarning: a copy inside the timings.
            result["cholmod_warnings"] = sorted({str(w.message)
                                                 for w in caught})
            del a_csc

        if "matvec" in peers:
            x = np.ones(n)
            result["matvec"], result["matvec_calls"] = mean_over(
                MATVEC_MIN_SECONDS, lambda: a_csr @ x)

        if "cg" in peers:
            result.update(bench_cg(a_csr, b,
                                   float(meta.get("cg_rtol", 1e-8)),
                                   int(meta.get("cg_maxiter", 10 * n)),
                                   repeat))
    except Exception as exc:
        result["error"] = f"{type(exc).__name__}: {exc}"
        result["traceback"] = traceback.format_exc()
    result["peak_rss_bytes"] = peak_rss_bytes()
    return result


# --------------------------------------------------------------------------
# Driver
# --------------------------------------------------------------------------

def versions():
    """Versions of the peers (None when not installed)."""
    out = {"python": platform.python_version(), "numpy": np.__version__,
           "scipy": scipy.__version__,
           "pyamg": None if pyamg is None else pyamg.__version__}
    try:
        out["sksparse"] = importlib.metadata.version("scikit-sparse")
    except importlib.metadata.PackageNotFoundError:
        out["sksparse"] = None
    return out


def environment():
    """Facts that affect the timings (threads, BLAS actually loaded)."""
    env = {k: os.environ.get(k) for k in
           ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    return {"cpu_count": os.cpu_count(), "machine": platform.machine(),
            "thread_env": env, "blas_libraries": blas_libraries()}


def case_metas(directory, patterns):
    """Sorted ``(n, path)`` of the case descriptions in ``directory``."""
    found = []
    for path in sorted(pathlib.Path(directory).glob("*.json")):
        try:
            meta = json.loads(path.read_text())
        except (OSError, ValueError):
            continue
        if not isinstance(meta, dict) or "name" not in meta:
            continue  # e.g. a results file written into the same folder
        if not (pathlib.Path(directory) / f"{meta['name']}.coo.bin").exists():
            continue
        if patterns and not any(fnmatch.fnmatch(meta["name"], p)
                                for p in patterns):
            continue
        found.append((int(meta.get("n", 0)), meta["name"], path))
    return sorted(found)


def parse_args(argv=None):
    """Parse the command line."""
    parser = argparse.ArgumentParser(
        description="Time SciPy/CHOLMOD on cases from `linpd bench --export`.")
    parser.add_argument("dir",
                        help="directory written by linpd bench --export")
    parser.add_argument("--out", help="results JSON (default: stdout)")
    parser.add_argument("--repeat", type=int, default=3,
                        help="runs per timing, best is kept (default 3)")
    parser.add_argument("--max-n", type=int, default=None,
                        help="skip cases with more unknowns than this")
    parser.add_argument("--case", action="append", default=[],
                        metavar="GLOB", help="only cases matching GLOB "
                        "(repeatable)")
    parser.add_argument("--no-isolate", action="store_true",
                        help="run all cases in this process (peak RSS is "
                        "then cumulative)")
    parser.add_argument("--no-ordering-probe", action="store_true",
                        help="do not identify the ordering CHOLMOD picked")
    return parser.parse_args(argv)


def main(argv=None):
    """Run every case in the export directory; return the exit status."""
    args = parse_args(argv)
    metas = case_metas(args.dir, args.case)
    if not metas:
        sys.exit(f"error: no cases (NAME.json + NAME.coo.bin) in {args.dir}")

    results = {
        "peer": "python",
        "versions": versions(),
        "settings": {"repeat": args.repeat, "max_n": args.max_n,
                     "isolated": not args.no_isolate,
                     "matvec_min_seconds": MATVEC_MIN_SECONDS,
                     "cholmod_skip_reason": CHOLMOD_IMPORT_ERROR},
        "cases": {},
    }
    # "spawn" gives every case a fresh interpreter, hence its own peak RSS.
    pool = None
    if not args.no_isolate:
        pool = multiprocessing.get_context("spawn").Pool(1,
                                                         maxtasksperchild=1)
    try:
        for n, name, path in metas:
            if args.max_n is not None and n > args.max_n:
                results["cases"][name] = {
                    "n": n, "skipped": f"n={n} > --max-n {args.max_n}"}
                print(f"{name}: skipped (n={n})", file=sys.stderr)
                continue
            print(f"{name}: n={n} ...", file=sys.stderr, flush=True)
            task = (str(path), args.repeat, not args.no_ordering_probe)
            if pool is None:
                res = run_case(*task)
            else:
                res = pool.apply(run_case, task)
            results["cases"][name] = res
            if "error" in res:
                print(f"{name}: ERROR {res['error']}", file=sys.stderr)
            else:
                print(f"{name}: " + ", ".join(
                    f"{k}={res[k]:.3g}" for k in
                    ("coo_to_csr", "cholmod_factor", "cholmod_solve",
                     "matvec", "cg", "pyamg_setup", "pyamg_solve")
                    if res.get(k) is not None),
                    file=sys.stderr)
    finally:
        if pool is not None:
            pool.close()
            pool.join()
    # CHOLMOD (imported above) has its BLAS mapped into this process too.
    results["environment"] = environment()

    text = json.dumps(results, indent=2) + "\n"
    if args.out:
        pathlib.Path(args.out).write_text(text)
    else:
        sys.stdout.write(text)
    # The JSON is written either way; a failed case still fails the run.
    return 1 if any("error" in c for c in results["cases"].values()) else 0


if __name__ == "__main__":
    sys.exit(main())
