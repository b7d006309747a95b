"""The Python package against the linpd command line (issue #16, item 1).

* ``Scene.stiffness()``, ``rhs()`` and ``dofs()`` equal the files of ``linpd export`` (read with
  scipy's Matrix Market reader) **exactly**: the same Rust function builds both, and the
  Matrix Market values are printed as the shortest decimals that read back to the same bits;
* ``Scene.assemble_rows(first, last)`` (built from the rows' own nodes, not from the assembled
  matrix) equals ``stiffness()[first:last]`` and ``linpd export``'s ``K.mtx`` for every model
  (bond, LPS, coarsened, blend): values to a sum-order rounding bound (see
  ``test_assemble_rows_equals_stiffness``); ``Scene.is_symmetric()`` is the export's symmetry;
* ``Scene.solve()`` equals ``linpd solve``'s ``result.json`` (see ``test_solve_equals_cli``);
* bad scenes raise ``LinpdError`` with linpd's message; ``coarsen`` runs a pipeline as
  ``linpd coarsen`` does.

The ``linpd`` binary is ``$LINPD_BIN`` when set (``scripts/test`` sets it), else
``cargo run --release --``.
"""

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import scipy.sparse

import linpd

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data"


def linpd_cli(*args: str) -> subprocess.CompletedProcess:
    binary = os.environ.get("LINPD_BIN")
    cmd = [binary] if binary else ["cargo", "run", "--release", "--quiet", "--"]
    return subprocess.run(cmd + list(args), cwd=ROOT, capture_output=True, text=True)


def cli_ok(*args: str) -> None:
    p = linpd_cli(*args)
    assert p.returncode == 0, f"linpd {' '.join(args)}: {p.stderr}"


def sorted_coo(m):
    """(rows, cols, values) of every stored entry, sorted by row then column."""
    c = scipy.sparse.coo_matrix(m)
    order = np.lexsort((c.col, c.row))
    return c.row[order], c.col[order], c.data[order]


# one scene per model family that exports: bond on a lattice in 1D/2D/3D, a point cloud, LPS,
# the 1D blend (unsymmetric)
EXPORTED = ["bar-point-load.json", "plate-hole-2d.json", "cantilever-3d.json", "bracket-cloud-2d.json",
            "lps-plate-2d.json", "blend-point-load.json"]


@pytest.mark.parametrize("name", EXPORTED)
def test_stiffness_rhs_dofs_equal_export(name, tmp_path):
    out = tmp_path / "export"
    cli_ok("export", str(DATA / name), "--out", str(out), "-q")
    scene = linpd.Scene(DATA / name)
    k = scene.stiffness()
    assert isinstance(k, scipy.sparse.csr_matrix)
    want = scipy.io.mmread(str(out / "K.mtx"))
    assert k.shape == want.shape
    # every stored entry, explicit zeros included, same position, same bits
    for got_part, want_part in zip(sorted_coo(k), sorted_coo(want)):
        np.testing.assert_array_equal(got_part, want_part)
    f = scipy.io.mmread(str(out / "f.mtx"))
    f = np.asarray(f.todense() if scipy.sparse.issparse(f) else f).reshape(-1)
    np.testing.assert_array_equal(scene.rhs(), f)
    dofs = np.loadtxt(out / "dofs.csv", delimiter=",", skiprows=1, dtype=np.int64).reshape(-1, 3)
    np.testing.assert_array_equal(scene.dofs(), dofs[:, 1:])
    np.testing.assert_array_equal(dofs[:, 0], np.arange(k.shape[0]))


def check_rows(scene, k, name):
    """Rows from their own nodes against the assembled matrix ``k``, over splits into 1..5
    blocks (odd sizes, so that blocks also start inside a node's rows). Every stored row entry
    is in ``k``'s pattern (which may hold more explicit zeros: bonds a defect cuts, the LPS
    lattice pattern's structural zeros); the values are sums over a node's bonds (LPS: up to
    ``2 |F|^2`` terms from the families of a node and its partners) in possibly another order,
    so they may differ by rounding, ``|F|^2 eps max|term|``, below ``1e-13 max|K|`` (measured:
    at most 7e-17 in tests/rows.rs); a wrong bond, sign or component changes an entry by
    O(max|K|). Coarsened and blend rows are copies of stored entries: the bound holds with 0."""
    k = scipy.sparse.csr_matrix(k)
    n = k.shape[0]
    scale = abs(k).max()
    for parts in [1, 2, 3, 5]:
        cuts = [0] + sorted({(n * p) // parts + (p % 2) for p in range(1, parts)}) + [n]
        for first, last in zip(cuts[:-1], cuts[1:]):
            indptr, indices, data = scene.assemble_rows(first, last)
            assert indptr[0] == 0 and len(indptr) == last - first + 1
            assert all(np.all(np.diff(indices[indptr[r]:indptr[r + 1]]) > 0) for r in range(last - first))
            got = scipy.sparse.csr_matrix((data, indices, indptr), shape=(last - first, n))
            want = k[first:last]
            # every entry handed out is stored in the assembled pattern (0/1 patterns: the
            # product keeps the common entries)
            g1, w1 = got.copy(), want.copy()
            g1.data[:] = 1.0
            w1.data[:] = 1.0
            assert g1.multiply(w1).nnz == g1.nnz, (name, first, last)
            diff = abs(got - want).max() if got.nnz + want.nnz else 0.0
            assert diff <= 1e-13 * scale, (name, first, last, diff / scale)


@pytest.mark.parametrize("name", ["bar-point-load.json", "plate-hole-2d.json", "cantilever-3d.json",
                                  "bracket-cloud-2d.json", "plate-crack-2d.json", "lps-plate-2d.json"])
def test_assemble_rows_equals_stiffness(name):
    scene = linpd.Scene(DATA / name)
    check_rows(scene, scene.stiffness(), name)


@pytest.fixture(scope="module")
def coarsened_level(tmp_path_factory):
    """Level 1 of ``data/coarsen-plate-2d.pipeline.json`` (its K is unsymmetric in its diagonal
    blocks, docs/coarsening.md) as a scene file, written once for this module (about 3 s)."""
    out = tmp_path_factory.mktemp("level")
    pipeline = json.loads((DATA / "coarsen-plate-2d.pipeline.json").read_text())
    pipeline["solve"] = False
    pipeline["levels"] = pipeline["levels"][:1]
    linpd.coarsen(pipeline, out=out / "levels", base_dir=DATA)
    scene = json.loads((DATA / "coarsen-plate-2d.json").read_text())
    scene.pop("grid")
    scene["name"] = "coarsen-plate-2d-level-1"
    scene["model"] = {"type": "coarsened", "moduli": str(out / "levels" / "level-1.mtx")}
    scene["output"] = {"dir": str(out / "out"), "plot": False}
    path = out / "level-1-scene.json"
    path.write_text(json.dumps(scene))
    return path


# LPS on a lattice, on a point cloud, with a position-aware surface correction; the 1D blend
# (unsymmetric) and with a pre-crack; pure CE
# (the coarse CE mesh, data/blend-coarse-ce.json, is in tests/rows.rs: 5M entries, slow here)
ROW_SCENES = ["lps-plate-2d.json", "bracket-cloud-lps-2d.json", "surface-bar-3d.json", "blend-point-load.json",
              "blend-bar-crack.json", "ce-point-load.json"]


@pytest.mark.parametrize("name", ROW_SCENES + ["coarsened"])
def test_assemble_rows_equals_export(name, tmp_path, coarsened_level):
    """``assemble_rows`` against ``linpd export``'s ``K.mtx`` (read by scipy) and
    ``is_symmetric()`` against ``export.json``'s symmetry, for the models whose rows are not
    bond rows; the right-hand side of ``row_info`` is ``f.mtx``."""
    path = coarsened_level if name == "coarsened" else DATA / name
    out = tmp_path / "export"
    cli_ok("export", str(path), "--out", str(out), "-q")
    scene = linpd.Scene(path)
    check_rows(scene, scipy.io.mmread(str(out / "K.mtx")), name)
    f = scipy.io.mmread(str(out / "f.mtx"))
    f = np.asarray(f.todense() if scipy.sparse.issparse(f) else f).reshape(-1)
    np.testing.assert_array_equal(scene.row_info()[3], f)
    meta = json.loads((out / "export.json").read_text())
    symmetric = scene.is_symmetric()
    assert symmetric == meta["symmetric"], (name, scene.asymmetry(), meta["asymmetry"])
    # the blended model and the level are unsymmetric, the others symmetric
    assert symmetric == (not (name.startswith("blend") or name == "coarsened")), (name, scene.asymmetry())


@pytest.mark.parametrize("name", ["bar-point-load.json", "plate-hole-2d.json", "cantilever-3d.json"])
def test_solve_equals_cli(name, tmp_path):
    """The same solve as ``linpd solve`` (same scene, solver, code): ``u`` to 1e-12 of max|u|.
    Cholesky and the parallel matvecs are deterministic per run, so the two agree to a few
    ulps; 1e-12 leaves room for a different thread count and still catches any wrong DOF."""
    out = tmp_path / "solve"
    cli_ok("solve", str(DATA / name), "--out", str(out), "-q")
    doc = json.loads((out / "result.json").read_text())
    scene = linpd.Scene(DATA / name)
    r = scene.solve()
    d = scene.dim
    u_cli = np.asarray(doc["u"], dtype=float).reshape(-1, d)
    assert r["u"].shape == (scene.n_nodes, d)
    assert np.max(np.abs(r["u"] - u_cli)) <= 1e-12 * np.max(np.abs(u_cli))
    assert r["report"]["solver"] == doc["stats"]["solve"]["solver"]
    assert r["report"]["rel_residual"] < 1e-8
    np.testing.assert_array_equal(np.asarray(doc["x"], dtype=float).reshape(-1, d), scene.positions())
    assert r["balance"] is not None and r["stats"]["bonds"] == doc["stats"]["bonds"]


def test_positions_volumes_and_dict_scene():
    text = json.loads((DATA / "plate-hole-2d.json").read_text())
    a, b = linpd.Scene(DATA / "plate-hole-2d.json"), linpd.Scene(text)
    np.testing.assert_array_equal(a.positions(), b.positions())
    np.testing.assert_array_equal(a.volumes(), b.volumes())
    assert a.positions().shape == (a.n_nodes, 2) and a.volumes().shape == (a.n_nodes,)
    assert np.all(a.volumes() > 0)


def test_bad_scenes_raise_linpd_message(tmp_path):
    doc = json.loads((DATA / "bar-point-load.json").read_text())
    doc["model"]["horizon"] = -1.0
    with pytest.raises(linpd.LinpdError, match=r"model\.horizon: must be > 0"):
        linpd.Scene(doc)
    # the CLI says the same
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc))
    p = linpd_cli("validate", str(bad))
    assert p.returncode != 0 and "model.horizon: must be > 0" in p.stderr
    with pytest.raises(linpd.LinpdError, match="no-such-scene.json"):
        linpd.Scene(tmp_path / "no-such-scene.json")
    with pytest.raises(linpd.LinpdError, match="unknown field"):
        linpd.Scene({**json.loads((DATA / "bar-point-load.json").read_text()), "colour": "red"})
    with pytest.raises(TypeError):
        linpd.Scene(42)
    # row assembly: a range outside the unknowns
    bar = linpd.Scene(DATA / "bar-point-load.json")
    n = bar.stiffness().shape[0]
    with pytest.raises(linpd.LinpdError, match="not a range"):
        bar.assemble_rows(0, n + 1)


def test_coarsen_matches_cli(tmp_path):
    pipeline = DATA / "coarsen-plate-2d.pipeline.json"
    cli_ok("coarsen", str(pipeline), "--out", str(tmp_path / "cli"), "-q")
    want = json.loads((tmp_path / "cli" / "summary.json").read_text())
    got = linpd.coarsen(pipeline, out=tmp_path / "py")
    assert Path(got["output_dir"]) == tmp_path / "py"
    assert [(l["level"], l["nodes"], l["bonds"]) for l in got["levels"]] == \
        [(l["level"], l["nodes"], l["bonds"]) for l in want["levels"]]
    assert len(got["levels"]) >= 2
    assert sorted(p.name for p in (tmp_path / "py").iterdir()) == sorted(p.name for p in (tmp_path / "cli").iterdir())
    with pytest.raises(linpd.LinpdError):
        linpd.coarsen({"name": "x"})


def _free_beam(n_across: int = 4) -> "linpd.Scene":
    """A free bond beam 1 x 0.1 x 0.1 (cell placement, no constraint), density 2."""
    h = 0.1 / n_across
    return linpd.Scene(
        {
            "name": "free-beam",
            "dimension": 3,
            "density": 2.0,
            "grid": {"min": [0, 0, 0], "max": [1, 0.1, 0.1], "spacing": h, "placement": "cell"},
            "model": {
                "type": "bond",
                "horizon": 3 * h,
                "micromodulus": {"kernel": "inverse_distance", "modulus": 1.0},
            },
        }
    )


def test_free_stiffness_mass_and_modes():
    """Issue #32: ``stiffness(free=True)`` of an unconstrained body is symmetric and annihilates
    the rigid motions (1e-12 of ``|K| |u|``: round-off of the row sums); ``mass()`` is
    ``density * V`` per DOF; ``modes()`` agrees with ARPACK's shift-invert (scipy's ``eigsh``,
    another eigensolver, on the same ``K`` and ``M``) to 1e-8 in ``omega^2`` and finds the six
    zero modes."""
    scene = _free_beam()
    k = scene.stiffness(free=True)
    n = 3 * scene.n_nodes
    assert k.shape == (n, n)
    assert abs(k - k.T).max() <= 1e-14 * abs(k).max()
    x = scene.positions()
    scale = abs(k).max()
    for a in range(3):
        t = np.zeros((scene.n_nodes, 3))
        t[:, a] = 1.0
        assert np.abs(k @ t.ravel()).max() <= 1e-12 * scale * n
    rot = np.zeros((scene.n_nodes, 3))
    rot[:, 0], rot[:, 1] = -x[:, 1], x[:, 0]
    assert np.abs(k @ rot.ravel()).max() <= 1e-12 * scale * n
    m = scene.mass()
    assert np.allclose(m, 2.0 * np.repeat(scene.volumes(), 3), rtol=0, atol=0)
    modes = scene.modes(4)
    assert len(modes["zero_modes"]) == 6
    assert modes["shapes"].shape == (4, scene.n_nodes, 3)
    assert np.all(np.abs(modes["shapes"]).max(axis=(1, 2)) == 1.0)
    import scipy.sparse.linalg

    shift = modes["shift"]
    w = scipy.sparse.linalg.eigsh(k.tocsc(), k=10, M=scipy.sparse.diags(m), sigma=-shift, which="LM")[0]
    w = np.sort(w)
    assert np.all(np.abs(w[:6]) <= 1e-6 * w[6])
    ours = np.array([mode["omega2"] for mode in modes["modes"]])
    assert np.allclose(ours, w[6:10], rtol=1e-8, atol=0), (ours, w[6:10])
    assert np.allclose(modes["frequencies"], np.sqrt(ours) / (2 * np.pi), rtol=1e-15)


def test_mass_and_modes_without_density_are_named():
    scene = linpd.Scene(DATA / "plate-tension-2d.json")
    with pytest.raises(linpd.LinpdError, match="density"):
        scene.mass()
    with pytest.raises(linpd.LinpdError, match="density"):
        scene.modes(2)
