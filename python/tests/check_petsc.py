"""The distributed solve on PETSc against linpd's own solve (issue #16, items 3 and 4).

    python3 python/tests/check_petsc.py [--ranks P] SCENE.json [SCENE.json ...] [PETSc options]

1. For every scene, ``linpd solve SCENE`` (``$LINPD_BIN``) and ``mpiexec -n P
   $LINPD_PETSC_PYTHON -m linpd.petsc SCENE -ksp_rtol 1e-12`` (plus the given options) write
   ``result.json``; their ``u`` must agree to ``max|u_petsc - u_linpd| <= 1e-8 max|u_linpd|``.
   Why 1e-8 is reachable: the KSP stops at ``||r|| <= 1e-12 ||f||`` (CG, and GMRES with the
   preconditioner on the right: both on the true residual), and the error is at most
   ``kappa(A_ff)`` times that (``kappa`` of the bundled cantilever is about 1e4-1e6 by its
   Cholesky-vs-Cholesky agreement in tests/export.rs; the 1D blend's at most about ``N^2`` = 1e5
   with ``N`` = 300 nodes, its CE rows being a Laplacian); a wrong row, sign or a rank's missing block changes ``u``
   by O(1). The KSP must be CG exactly when ``A_ff`` is symmetric (GMRES otherwise), and the
   rest of ``result.json`` (nodes, bonds, the run's keys) must be ``linpd solve``'s.
2. The driver on a bad scene (the first one with a negative horizon) exits non-zero on every
   rank with linpd's message, within a timeout (a rank stuck in a collective would hang until
   killed).

The interpreter that runs ``linpd.petsc`` is ``$LINPD_PETSC_PYTHON`` (Debian's /usr/bin/python3,
whose petsc4py is on ``PYTHONPATH``), not necessarily the one running this script.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
from linpd.petsc import read_pieces  # noqa: E402 (the installed package's reader of a per-rank result)


# The bundled scenes the driver runs whole on every rank (no per-rank geometry for their model);
# every other scene must run per rank.
WHOLE = {"blend-point-load.json", "blend-bar-crack.json", "blend-coarse-ce.json",
         "ce-point-load.json"}


def mpiexec(ranks: int, args, timeout: float, env=None) -> subprocess.CompletedProcess:
    cmd = ["mpiexec", "-n", str(ranks)]
    if os.geteuid() == 0:
        cmd += ["--allow-run-as-root"]
    cmd += ["--oversubscribe", os.environ.get("LINPD_PETSC_PYTHON", "/usr/bin/python3"), "-m", "linpd.petsc"]
    return subprocess.run(cmd + args, cwd=ROOT, capture_output=True, text=True, timeout=timeout, env=env)


def check_pieces(scene: Path, ranks: int, own: Path, dist: Path, tol: float) -> float:
    """The per-rank run's pieces against ``linpd solve``'s result: every node in exactly one
    piece, ``u`` to ``tol`` of ``max|u|`` (returned: the measured difference), the index naming
    the pieces, and the balance's totals to ``1e-8`` of the applied force."""
    a = json.loads((own / "result.json").read_text())
    b = json.loads((dist / "result.json").read_text())
    assert b["stats"]["solve"]["geometry"] == "per-rank", b["stats"]["solve"]["geometry"]
    assert b["pieces"] == [f"result-{r}.vtu" for r in range(ranks)] and len(b["stats"]["solve"]["slabs"]) == ranks
    index = (dist / "result.pvtu").read_text()
    assert all(f'Source="{p}"' in index for p in b["pieces"]), index
    x = np.asarray(a["x"], dtype=float).reshape(len(a["x"]), -1)
    ua = np.asarray(a["u"], dtype=float).reshape(len(a["x"]), -1)
    where = {tuple(np.round(p / np.max(np.abs(x)) * 1e9).astype(np.int64)): k for k, p in enumerate(x)}
    seen = np.zeros(len(x), dtype=int)
    ub = np.zeros_like(ua)
    points, arrays = read_pieces(dist)
    for p, u in zip(points[:, : x.shape[1]], arrays["u"][:, : ua.shape[1]]):
        k = where[tuple(np.round(p / np.max(np.abs(x)) * 1e9).astype(np.int64))]
        seen[k] += 1
        ub[k] = u
    assert np.all(seen == 1), f"{scene.name}: nodes in no piece or in two: {np.flatnonzero(seen != 1)[:5]}"
    if "file_node" in arrays:
        # a cloud's pieces name each node's number in the file: linpd solve's node order
        k = arrays["file_node"][:, 0].astype(np.int64)
        assert np.array_equal(np.sort(k), np.arange(len(x))), f"{scene.name}: file_node is not a permutation"
        assert np.allclose(x[k], points[:, : x.shape[1]], rtol=0, atol=1e-12 * np.max(np.abs(x))), scene.name
    assert b["nodes"] == len(x), (b["nodes"], len(x))
    rel = float(np.max(np.abs(ua - ub)) / np.max(np.abs(ua)))
    assert rel <= tol, f"{scene.name}: per-rank PETSc and linpd differ by {rel:.3e} > {tol:.0e}"
    fa, fb = np.asarray(a["balance"]["applied"], dtype=float), np.asarray(b["balance"]["applied"], dtype=float)
    # the largest force of the balance (a scene held by displacements alone has no load, and its
    # constraints' reactions cancel each other)
    scale = max([np.max(np.abs(fa))] + [np.max(np.abs(np.asarray(c["reaction"], dtype=float)))
                                        for c in a["balance"]["constraints"]])
    # the moments about the same reference point, to 1e-8 of the largest force times the body
    diagonal = float(np.sqrt(np.sum((x.max(axis=0) - x.min(axis=0)) ** 2)))
    assert np.allclose(a["balance"]["reference"], b["balance"]["reference"], rtol=0, atol=1e-12 * diagonal)
    for key in ("applied_moment", "reaction_moment"):
        diff = np.max(np.abs(np.subtract(a["balance"][key], b["balance"][key])), initial=0.0)
        assert diff <= 1e-8 * scale * diagonal, (key, a["balance"][key], b["balance"][key])
    assert len(a["balance"]["constraints"]) == len(b["balance"]["constraints"])
    for ca, cb in zip(a["balance"]["constraints"], b["balance"]["constraints"]):
        assert ca["dofs"] == cb["dofs"], (ca, cb)
        assert np.max(np.abs(np.subtract(ca["reaction"], cb["reaction"]))) <= 1e-8 * scale, (ca, cb)
    assert np.max(np.abs(fa - fb)) <= 1e-12 * scale, (fa, fb)
    ra, rb = np.asarray(a["balance"]["reaction"], dtype=float), np.asarray(b["balance"]["reaction"], dtype=float)
    assert np.max(np.abs(ra - rb)) <= 1e-8 * scale, (ra, rb)
    return rel


def check_scene(scene: Path, ranks: int, petsc, tmp: Path, binary: str) -> None:
    own, dist = tmp / scene.stem / "linpd", tmp / scene.stem / "petsc"
    p = subprocess.run([binary, "solve", str(scene), "--out", str(own), "-q"], capture_output=True, text=True)
    assert p.returncode == 0, f"linpd solve: {p.stderr}"
    parts = tmp / scene.stem / "parts"
    p = mpiexec(ranks, [str(scene), "--out", str(parts), "-ksp_rtol", "1e-12"] + petsc, timeout=600)
    assert p.returncode == 0, f"linpd.petsc failed ({p.returncode}):\n{p.stdout}\n{p.stderr}"
    geometry = json.loads((parts / "result.json").read_text())["stats"]["solve"]["geometry"]
    want = "whole" if scene.name in WHOLE else "per-rank"
    assert geometry == want, f"{scene.name}: the driver ran with {geometry} geometry, expected {want}"
    if want == "whole":
        assert "has no per-rank geometry" in p.stderr, p.stderr
        print(f"check_petsc: {scene.name}: {p.stderr.strip()}")
    else:
        rel = check_pieces(scene, ranks, own, parts, 1e-10)
        print(f"check_petsc: {scene.name} on {ranks} ranks, per-rank geometry: max|u_petsc - u_linpd| / max|u_linpd| "
              f"= {rel:.2e}; {p.stdout.strip()}")
    p = mpiexec(ranks, [str(scene), "--gather", "--out", str(dist), "-ksp_rtol", "1e-12"] + petsc, timeout=600)
    assert p.returncode == 0, f"linpd.petsc failed ({p.returncode}):\n{p.stdout}\n{p.stderr}"
    print(p.stdout.strip())
    a = json.loads((own / "result.json").read_text())
    b = json.loads((dist / "result.json").read_text())
    ua, ub = np.asarray(a["u"], dtype=float), np.asarray(b["u"], dtype=float)
    assert ua.shape == ub.shape, (ua.shape, ub.shape)
    rel = np.max(np.abs(ua - ub)) / np.max(np.abs(ua))
    s = b["stats"]["solve"]
    print(f"check_petsc: {scene.name} on {ranks} ranks: max|u_petsc - u_linpd| / max|u_linpd| = {rel:.2e} "
          f"(linpd: {a['stats']['solve']['solver']}; PETSc: {s['solver']}, {s['iterations']} iterations, "
          f"relative residual {s['rel_residual']:.1e}, symmetric: {s['symmetric']})")
    assert rel <= 1e-8, f"{scene.name}: PETSc and linpd differ by {rel:.3e} > 1e-8"
    if not any(o == "-ksp_type" for o in petsc):
        want = "petsc-cg-" if s["symmetric"] else "petsc-gmres-"
        assert s["solver"].startswith(want), f"{scene.name}: {s['solver']} for symmetric = {s['symmetric']}"
    assert s["ranks"] == ranks and len(s["peak_rss_bytes_per_rank"]) == ranks
    assert a["x"] == b["x"] and a["stats"]["bonds"] == b["stats"]["bonds"]
    assert sorted(b["run"]) == sorted(a["run"]), "result.json's run member differs in keys"


def check_memory_limit(tmp: Path, binary: str) -> None:
    """No rank builds the whole body: under ``LINPD_MEMORY_GIB`` per process, a scene whose whole
    model linpd estimates above the limit is refused by ``linpd solve`` and by the driver's
    ``--gather`` (every rank builds it whole), and solved by the driver on 2 ranks, each of whose
    windows it estimates below: a cube of 31,713 lattice nodes (0.1 GiB whole, 0.06 GiB a window
    of 17-18 of 33 planes; limit 0.08 GiB) and the same nodes as a CSV point cloud, each moved by
    up to 0.1 h (0.7 GiB whole with the ball quadrature's longer bonds, 0.45-0.5 GiB a window;
    limit 0.55 GiB)."""
    sys.path.insert(0, str(ROOT / "python" / "bench"))
    import scale_out

    for tag, doc, limit in (("cube", scale_out.scene(30, {"type": "auto"}), "0.08"),
                            ("cloud", scale_out.cloud_scene(30, {"type": "auto"}, "bond", 2, 1, tmp), "0.55")):
        scene = tmp / f"{tag}-limit.json"
        scene.write_text(json.dumps(doc))
        limited = dict(os.environ, LINPD_MEMORY_GIB=limit)
        p = subprocess.run([binary, "solve", str(scene), "--out", str(tmp / f"{tag}-limit-linpd"), "-q"],
                           capture_output=True, text=True, env=limited)
        assert p.returncode != 0 and "available (LINPD_MEMORY_GIB)" in p.stderr, p.stderr
        p = mpiexec(2, [str(scene), "--gather", "--out", str(tmp / f"{tag}-limit-gather")], timeout=300, env=limited)
        assert p.returncode != 0 and p.stderr.count("LINPD_MEMORY_GIB") == 2, p.stderr
        p = mpiexec(2, [str(scene), "--out", str(tmp / f"{tag}-limit-parts"), "-ksp_rtol", "1e-12"], timeout=300,
                    env=limited)
        assert p.returncode == 0, f"{p.stdout}\n{p.stderr}"
        own = tmp / f"{tag}-limit-linpd-free"
        p = subprocess.run([binary, "solve", str(scene), "--out", str(own), "-q"], capture_output=True, text=True)
        assert p.returncode == 0, p.stderr
        rel = check_pieces(scene, 2, own, tmp / f"{tag}-limit-parts", 1e-10)
        print(f"check_petsc: LINPD_MEMORY_GIB={limit} refuses the whole {tag} (linpd solve, --gather) and 2 ranks "
              f"solve it per rank: max|u_petsc - u_linpd| / max|u_linpd| = {rel:.2e}")


def check_petsc64(path64: str, tmp: Path, binary: str) -> None:
    """With a PETSc built with 64-bit indices (``path64``: its petsc4py's directory, e.g. Debian's
    python3-petsc4py-64-real): ``linpd export --format petsc64`` loads with its ``MatLoad`` to
    the entries of ``K.mtx`` (bit for bit: both print shortest round-trip or binary doubles), and
    the driver's per-rank solve on 2 ranks matches ``linpd solve`` as above."""
    scene = ROOT / "data" / "cantilever-3d.json"
    e64, emtx = tmp / "export64", tmp / "exportmtx"
    for fmt, out in (("petsc64", e64), ("mtx", emtx)):
        p = subprocess.run([binary, "export", str(scene), "--format", fmt, "--out", str(out), "-q"],
                           capture_output=True, text=True)
        assert p.returncode == 0, p.stderr
    site = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p and "petscdir" not in p]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(site + [path64]))
    load = (
        "import sys, numpy as np\n"
        "from petsc4py import PETSc\n"
        "A = PETSc.Mat().load(PETSc.Viewer().createBinary(sys.argv[1], 'r'))\n"
        "I, J, V = A.getValuesCSR()\n"
        "np.savez(sys.argv[2], I=I, J=J, V=V, bits=np.dtype(PETSc.IntType).itemsize * 8)\n"
    )
    py = os.environ.get("LINPD_PETSC_PYTHON", "/usr/bin/python3")
    p = subprocess.run([py, "-c", load, str(e64 / "K.petsc"), str(tmp / "k64.npz")], capture_output=True, text=True,
                       env=env)
    assert p.returncode == 0, p.stderr
    got = np.load(tmp / "k64.npz")
    assert int(got["bits"]) == 64, "not a 64-bit PETSc"
    import scipy.io
    import scipy.sparse

    want = scipy.sparse.csr_matrix(scipy.io.mmread(str(emtx / "K.mtx")))
    mine = scipy.sparse.csr_matrix((got["V"], got["J"], got["I"]), shape=want.shape)
    assert abs(mine - want).max() == 0.0, "K.petsc (64-bit) and K.mtx differ"
    print(f"check_petsc: 64-bit PETSc MatLoad of `linpd export --format petsc64` equals K.mtx ({want.nnz} entries)")
    own, parts = tmp / "c64" / "linpd", tmp / "c64" / "parts"
    p = subprocess.run([binary, "solve", str(scene), "--out", str(own), "-q"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    p = mpiexec(2, [str(scene), "--out", str(parts), "-ksp_rtol", "1e-12"], timeout=300, env=env)
    assert p.returncode == 0, f"{p.stdout}\n{p.stderr}"
    rel = check_pieces(scene, 2, own, parts, 1e-10)
    bits = json.loads((parts / "result.json").read_text())["stats"]["solve"]["petsc_int_bits"]
    assert bits == 64, bits
    print(f"check_petsc: the driver on a 64-bit PETSc, 2 ranks: max|u_petsc - u_linpd| / max|u_linpd| = {rel:.2e}")


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("scenes", nargs="+")
    args, petsc = ap.parse_known_args()
    scenes = [Path(s).resolve() for s in args.scenes]
    binary = os.environ.get("LINPD_BIN", str(ROOT / "target" / "release" / "linpd"))
    with tempfile.TemporaryDirectory() as tmp:
        for scene in scenes:
            check_scene(scene, args.ranks, petsc, Path(tmp), binary)

        # more ranks than lattice planes: the ranks that own nothing take part in every
        # collective with no rows and an empty piece
        doc = json.loads((ROOT / "data" / "lps-plate-2d.json").read_text())
        doc["name"], doc["grid"]["max"] = "thin-plate", [1.0, 0.1]
        doc["grid"]["layer"] = {"x-": 0.075, "x+": 0.075}
        thin = Path(tmp) / "thin-plate.json"
        thin.write_text(json.dumps(doc))
        own = Path(tmp) / "thin" / "linpd"
        p = subprocess.run([binary, "solve", str(thin), "--out", str(own), "-q"], capture_output=True, text=True)
        assert p.returncode == 0, p.stderr
        p = mpiexec(7, [str(thin), "--out", str(Path(tmp) / "thin" / "parts"), "-ksp_rtol", "1e-12"], timeout=300)
        assert p.returncode == 0, f"{p.stdout}\n{p.stderr}"
        rel = check_pieces(thin, 7, own, Path(tmp) / "thin" / "parts", 1e-10)
        slabs = json.loads((Path(tmp) / "thin" / "parts" / "result.json").read_text())["stats"]["solve"]["slabs"]
        empty = sum(1 for s in slabs if s["owned_planes"][0] == s["owned_planes"][1])
        assert empty == 2, slabs
        print(f"check_petsc: 5 lattice planes on 7 ranks ({empty} own nothing): max|u_petsc - u_linpd| / "
              f"max|u_linpd| = {rel:.2e}")

        check_memory_limit(Path(tmp), binary)

        if os.environ.get("LINPD_PETSC64_PATH"):
            check_petsc64(os.environ["LINPD_PETSC64_PATH"], Path(tmp), binary)

        # a bad scene: linpd's message on every rank, non-zero exit, no hang
        doc = json.loads(scenes[0].read_text())
        doc["model"]["horizon"] = -1.0
        for key, name in doc.get("nodes", {}).items():
            doc["nodes"][key] = str(scenes[0].parent.resolve() / name)
        bad = Path(tmp) / "bad.json"
        bad.write_text(json.dumps(doc))
        p = mpiexec(args.ranks, [str(bad)], timeout=120)
        assert p.returncode != 0, "a bad scene must fail"
        n_msg = p.stderr.count("model.horizon: must be > 0")
        assert n_msg == args.ranks, f"expected linpd's message from each of {args.ranks} ranks, got {n_msg}:\n{p.stderr}"
        print(f"check_petsc: a bad scene stops all {args.ranks} ranks with linpd's message")
    return 0

if __name__ == "__main__":
    sys.exit(main())
