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


def mpiexec(ranks: int, args, timeout: float) -> subprocess.CompletedProcess:
    cmd = ["mpiexec", "-n", str(ranks)]
    if os.geteuid() == 0:
        cmd += ["--allow-run-as-root"]
    cmd += ["--oversubscribe", os.environ.get("LINPD_PETSC_PYTHON", "/usr/bin/python3"), "-m", "linpd.petsc"]
    return subprocess.run(cmd + args, cwd=ROOT, capture_output=True, text=True, timeout=timeout)


def check_scene(scene: Path, ranks: int, petsc, tmp: Path, binary: str) -> None:
    own, dist = tmp / scene.stem / "linpd", tmp / scene.stem / "petsc"
    p = subprocess.run([binary, "solve", str(scene), "--out", str(own), "-q"], capture_output=True, text=True)
    assert p.returncode == 0, f"linpd solve: {p.stderr}"
    p = mpiexec(ranks, [str(scene), "--out", str(dist), "-ksp_rtol", "1e-12"] + petsc, timeout=600)
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

        # a bad scene: linpd's message on every rank, non-zero exit, no hang
        doc = json.loads(scenes[0].read_text())
        doc["model"]["horizon"] = -1.0
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
