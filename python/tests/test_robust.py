"""Issue #30: the Python entry points (``linpd.Scene``, ``write_result``, the PETSc driver) make
the checks of ``linpd solve``: a clear error naming the cause, nothing written.

The PETSc cases run ``mpiexec -n 2 $LINPD_PETSC_PYTHON -m linpd.petsc`` (default Debian's
``/usr/bin/python3`` with its petsc4py) on this interpreter's ``linpd`` package, and are skipped
when that interpreter cannot import petsc4py or ``mpiexec`` is missing.
"""

import json
import math
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import linpd

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data"
PETSC_PYTHON = os.environ.get("LINPD_PETSC_PYTHON", "/usr/bin/python3")
PETSC_PATH = os.environ.get(
    "LINPD_PETSC_PATH", "/usr/lib/petscdir/petsc3.18/x86_64-linux-gnu-real/lib/python3/dist-packages"
)


def flat_plate(force):
    """A 3D plate one node thick: its out-of-plane motion is a mechanism (zero stiffness), though
    the clamp holds every rigid motion; ``linpd solve`` refuses it."""
    return {
        "name": "flat-plate",
        "dimension": 3,
        "grid": {"min": [0.0, 0.0, 0.0], "max": [1.0, 0.5, 0.1], "spacing": 0.1, "layer": {"x-": 0.3}},
        "body": {"box": {"min": [-1.0, -1.0, -1.0], "max": [2.0, 2.0, 0.01]}},
        "model": {"type": "bond", "horizon": 0.3,
                  "micromodulus": {"kernel": "constant", "modulus": 1.0, "normalize": "discrete"}},
        "constraints": [{"region": {"box": {"min": [-1.0, -1.0, -1.0], "max": [0.0, 1.0, 1.0]}},
                         "displacement": {"value": [0.0, 0.0, 0.0]}}],
        "loads": [{"type": "resultant", "region": {"box": {"min": [1.0, -1.0, -1.0], "max": [2.0, 1.0, 1.0]}},
                   "force": force}],
        "output": {"dir": "out"},
    }


# --- item 1: the row system refuses a mechanism -------------------------------------------------

@pytest.mark.parametrize("force", [[1e-4, 0.0, 0.0], [0.0, 0.0, -1e-4]])
def test_row_system_refuses_a_mechanism(force):
    s = linpd.Scene(flat_plate(force))
    with pytest.raises(linpd.LinpdError) as e:
        s.row_info()
    msg = str(e.value)
    for needle in ["the row system", "diagonal entry at free DOF", "singular", "component 2"]:
        assert needle in msg, msg
    with pytest.raises(linpd.LinpdError):
        s.assemble_rows(0, 3)


# --- item 2: write_result refuses non-finite displacements --------------------------------------

@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_write_result_refuses_non_finite_u(tmp_path, bad):
    s = linpd.Scene(str(DATA / "bar-point-load.json"))
    n, _, _, _ = s.row_info()
    u = s.expand(np.zeros(n))
    u[3] = bad
    out = tmp_path / "out"
    with pytest.raises(linpd.LinpdError) as e:
        s.write_result(u, {"solver": "test"}, out)
    msg = str(e.value)
    assert msg.startswith("u: ") and "not finite" in msg and "u[3]" in msg, msg
    assert not out.exists(), "nothing may be written"
    assert list(tmp_path.iterdir()) == [], list(tmp_path.iterdir())
    # finite u is written
    u[3] = 0.0
    assert len(s.write_result(u, {"solver": "test"}, out)) == 3


def test_write_result_refuses_non_finite_report(tmp_path):
    s = linpd.Scene(str(DATA / "bar-point-load.json"))
    n, _, _, _ = s.row_info()
    with pytest.raises(linpd.LinpdError) as e:
        s.write_result(s.expand(np.zeros(n)), {"rel_residual": math.nan}, tmp_path / "out")
    assert "rel_residual: nan is not a number JSON can hold" in str(e.value), str(e.value)
    assert not (tmp_path / "out").exists()


# --- item 3: NaN in a Scene dict is named by its key path ---------------------------------------

@pytest.mark.parametrize(
    "edit, path",
    [
        (lambda d: d["model"].__setitem__("horizon", math.nan), "model.horizon: nan"),
        (lambda d: d["grid"]["max"].__setitem__(1, math.inf), "grid.max[1]: inf"),
        (lambda d: d["loads"][0].__setitem__("force", [float("-inf"), 0.0, 0.0]), "loads[0].force[0]: -inf"),
        (lambda d: d["model"].__setitem__("horizon", np.float64("nan")), "model.horizon: nan"),
    ],
)
def test_scene_dict_non_finite_named(edit, path):
    d = flat_plate([1e-4, 0.0, 0.0])
    edit(d)
    with pytest.raises(linpd.LinpdError) as e:
        linpd.Scene(d)
    msg = str(e.value)
    assert msg.startswith(path) and "is not a number JSON can hold" in msg, msg
    assert "line 1" not in msg and "expected value" not in msg, msg


def test_pipeline_dict_non_finite_named(tmp_path):
    doc = json.loads((DATA / "coarsen-plate-2d.pipeline.json").read_text())
    doc["scene"] = str(DATA / doc["scene"])
    key = next(k for k, v in doc["levels"][0].items() if isinstance(v, (int, float)) and not isinstance(v, bool))
    doc["levels"][0][key] = math.nan
    with pytest.raises(linpd.LinpdError) as e:
        linpd.coarsen(doc, out=tmp_path / "out")
    assert str(e.value).startswith(f"levels[0].{key}: nan is not a number JSON can hold"), str(e.value)
    assert not (tmp_path / "out").exists()


# --- the PETSc driver (items 1 and 2 through mpiexec) -------------------------------------------

def _petsc_env(tmp_path):
    """The environment in which ``PETSC_PYTHON -m linpd.petsc`` imports this ``linpd`` package
    (only it: a link in a directory of its own) beside Debian's petsc4py; None to skip."""
    if shutil.which("mpiexec") is None or not Path(PETSC_PYTHON).exists():
        return None
    site = tmp_path / "site"
    site.mkdir()
    (site / "linpd").symlink_to(Path(linpd.__file__).resolve().parent)
    env = dict(os.environ, PYTHONPATH=f"{site}:{PETSC_PATH}")
    probe = subprocess.run([PETSC_PYTHON, "-c", "import petsc4py, linpd"], env=env, capture_output=True)
    return env if probe.returncode == 0 else None


def _driver(env, args, cwd):
    cmd = ["mpiexec", "-n", "2"]
    if os.geteuid() == 0:
        cmd += ["--allow-run-as-root"]
    cmd += ["--oversubscribe", PETSC_PYTHON, "-m", "linpd.petsc"]
    return subprocess.run(cmd + args, cwd=cwd, env=env, capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("force", [[1e-4, 0.0, 0.0], [0.0, 0.0, -1e-4]])
def test_petsc_driver_refuses_a_mechanism(tmp_path, force):
    env = _petsc_env(tmp_path)
    if env is None:
        pytest.skip("no mpiexec or no petsc4py for " + PETSC_PYTHON)
    scene = tmp_path / "plate.json"
    scene.write_text(json.dumps(flat_plate(force)))
    p = _driver(env, [str(scene)], tmp_path)
    assert p.returncode == 1, f"exit {p.returncode}:\n{p.stdout}\n{p.stderr}"
    assert "the row system" in p.stderr and "component 2" in p.stderr and "singular" in p.stderr, p.stderr
    assert "reason" not in p.stderr, p.stderr
    assert not (tmp_path / "out").exists()


def test_petsc_driver_refuses_a_failed_ksp(tmp_path):
    env = _petsc_env(tmp_path)
    if env is None:
        pytest.skip("no mpiexec or no petsc4py for " + PETSC_PYTHON)
    out = tmp_path / "out"
    p = _driver(env, [str(DATA / "cantilever-3d.json"), "--out", str(out), "-ksp_max_it", "2"], tmp_path)
    assert p.returncode == 1, f"exit {p.returncode}:\n{p.stdout}\n{p.stderr}"
    assert "did not converge: reason -3" in p.stderr and "nothing written" in p.stderr, p.stderr
    assert not out.exists()
