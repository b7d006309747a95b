"""linpd: linear peridynamics from Python.

The numbers come from linpd's Rust crates through the same functions as the ``linpd``
command line, so a :class:`Scene` gives the CLI's results bit for bit:

* :meth:`Scene.stiffness` and :meth:`Scene.rhs` are the reduced system
  ``A_ff u_f = f_f - (A u_bar)_f`` that ``linpd export`` writes (``K.mtx``, ``f.mtx``);
* :meth:`Scene.solve` is ``linpd solve`` (the ``result.json`` document, with ``u`` as an
  array of shape ``(nodes, d)``);
* :meth:`Scene.assemble_rows` computes a contiguous block of rows of ``A_ff`` without the
  others, for every static model (bond, LPS, coarsened levels, 1D blend/CE): each MPI rank of
  the PETSc driver (``python -m linpd.petsc``) assembles only its own; :meth:`Scene.is_symmetric`
  tells whether ``A_ff`` is symmetric (the driver picks CG or GMRES by it).

Errors are :class:`LinpdError` with linpd's message (the JSON path and the reason, e.g.
``model.horizon: must be > 0, got -1e0``).
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, Optional, Tuple, Union

import numpy as np

from ._linpd import LinpdError, NativeScene, __version__
from ._linpd import coarsen as _coarsen

__all__ = ["Scene", "LinpdError", "coarsen", "__version__"]

PathLike = Union[str, "os.PathLike[str]"]


def _non_finite(obj: Any, path: str) -> Optional[Tuple[str, float]]:
    """``(key path, value)`` of the first NaN or infinite float in ``obj`` (dicts, lists and
    tuples walked in order; ``model.horizon``, ``grid.max[2]``), else ``None``."""
    if isinstance(obj, float):
        return None if np.isfinite(obj) else (path, obj)
    if isinstance(obj, np.floating):
        return None if np.isfinite(obj) else (path, float(obj))
    if isinstance(obj, dict):
        items = ((f"{path}.{k}" if path else str(k), v) for k, v in obj.items())
    elif isinstance(obj, (list, tuple)):
        items = ((f"{path}[{k}]", v) for k, v in enumerate(obj))
    else:
        return None
    for p, v in items:
        found = _non_finite(v, p)
        if found is not None:
            return found
    return None


def _to_json(obj: Any, what: str) -> str:
    """``obj`` as JSON text; a NaN or infinite float (which JSON cannot hold: ``json.dumps``
    would write ``NaN``, which linpd then refuses as text the user never wrote) is a
    :class:`LinpdError` naming its key path."""
    found = _non_finite(obj, "")
    if found is not None:
        path, value = found
        raise LinpdError(f"{path or what}: {value} is not a number JSON can hold (NaN and infinity are not "
                         f"allowed in a {what})")
    try:
        return json.dumps(obj, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise LinpdError(f"{what}: cannot be written as JSON: {e}") from None


class Scene:
    """A validated linpd scene, from a JSON file or a dict with the same keys.

    ``Scene("data/cantilever-3d.json")`` reads a file (relative file names in it start at its
    directory, as with ``linpd solve``); ``Scene({...})`` validates a dict (relative file names
    start at ``base_dir``, default the working directory). Raises :class:`LinpdError` for an
    invalid scene, with the message ``linpd validate`` prints.
    """

    def __init__(self, scene: Union[PathLike, Dict[str, Any]], base_dir: Optional[PathLike] = None):
        if isinstance(scene, dict):
            self._native = NativeScene.from_json(_to_json(scene, "scene"), os.fspath(base_dir or "."))
        elif isinstance(scene, (str, os.PathLike)):
            self._native = NativeScene.from_path(os.fspath(scene))
        else:
            raise TypeError(f"Scene takes a path or a dict, got {type(scene).__name__}")
        self._system: Optional[Tuple[Any, np.ndarray]] = None

    @property
    def name(self) -> str:
        """The scene's name."""
        return self._native.name

    @property
    def dim(self) -> int:
        """The dimension ``d`` (DOFs per node)."""
        return self._native.dim

    @property
    def n_nodes(self) -> int:
        """Number of nodes."""
        return self._native.n_nodes

    @property
    def model_type(self) -> str:
        """``model.type`` of the scene (``bond``, ``lps``, ``blend``, ``ce``, ``coarsened``)."""
        return self._native.model_type

    @property
    def output_dir(self) -> str:
        """``output.dir`` of the scene, else ``out/<name>``."""
        return self._native.output_dir

    def _reduced(self) -> Tuple[Any, np.ndarray]:
        # assembled once: stiffness() and rhs() share it
        if self._system is None:
            import scipy.sparse  # only this method needs scipy

            n, col_ptr, row_idx, values, rhs = self._native.reduced_system()
            k = scipy.sparse.csc_matrix((values, row_idx, col_ptr), shape=(n, n)).tocsr()
            self._system = (k, rhs)
        return self._system

    def stiffness(self, free: bool = False):
        """The reduced stiffness ``A_ff`` as a ``scipy.sparse.csr_matrix``: the matrix of
        ``linpd export``'s ``K.mtx`` (every stored entry, explicit zeros included), rows and
        columns numbered as :meth:`dofs`. With ``free=True``: the stiffness over every DOF
        (node-major, ``d`` per node) with no constraint applied, a free body's (singular by its
        rigid motions; what :meth:`modes` of a free-free body uses)."""
        if free:
            import scipy.sparse

            n, col_ptr, row_idx, values, _ = self._native.unconstrained_stiffness()
            return scipy.sparse.csc_matrix((values, row_idx, col_ptr), shape=(n, n)).tocsr()
        return self._reduced()[0]

    def mass(self) -> np.ndarray:
        """The lumped mass ``density * V_i`` per DOF (node-major, ``d`` per node), shape
        ``(nodes * d,)``; the scene needs a ``density``."""
        return self._native.mass()

    def modes(self, count: int = 6) -> Dict[str, Any]:
        """The ``count`` lowest elastic modes as ``linpd modes`` computes them (nothing is
        written): its ``modes.json`` document as a dict, plus ``shapes``, an array of shape
        ``(count, nodes, d)`` (``max |phi| = 1``) and ``frequencies`` (``omega / 2 pi``)."""
        doc, shapes = self._native.modes(count)
        result = json.loads(doc)
        result["shapes"] = np.asarray(shapes).reshape(len(result["modes"]), -1, self.dim)
        result["frequencies"] = np.array([m["frequency"] for m in result["modes"]])
        return result

    def rhs(self) -> np.ndarray:
        """The reduced right-hand side ``f_f - (A u_bar)_f`` (``f.mtx``), shape ``(n,)``."""
        return self._reduced()[1]

    def dofs(self) -> np.ndarray:
        """``(node, component)`` of every unknown (row of :meth:`stiffness`), shape ``(n, 2)``:
        ``dofs.csv`` of ``linpd export``."""
        return self._native.dofs()

    def positions(self) -> np.ndarray:
        """Node positions, shape ``(nodes, d)``."""
        return self._native.positions()

    def volumes(self) -> np.ndarray:
        """Node volumes ``V_i``, shape ``(nodes,)``."""
        return self._native.volumes()

    def solve(self) -> Dict[str, Any]:
        """Solves the scene as ``linpd solve`` does (nothing is written) and returns its
        ``result.json`` document as a dict, with ``u`` as an array of shape ``(nodes, d)``
        and ``report`` (the same as ``stats["solve"]``: solver, residual, timings, ...)."""
        u, doc = self._native.solve()
        result = json.loads(doc)
        result["u"] = np.asarray(u).reshape(-1, self.dim)
        result["report"] = result["stats"]["solve"]
        return result

    def assemble_rows(self, first: int, last: int) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rows ``first:last`` of ``A_ff`` as CSR arrays ``(indptr, indices, data)`` with global
        column indices (``indptr[0] == 0``), computed from those rows' nodes only: the rest of
        the matrix is never assembled. Equal to ``stiffness()[first:last]``.

        Every static model: bond (lattice or point cloud: a node's bonds), LPS (its tangent
        couples nodes two horizons apart; a row is summed from the families of its node and of
        that node's partners), coarsened levels (rows of the stored ``K``) and the 1D blend/CE
        models (rows of the stored operator). Entries that are explicit zeros in
        :meth:`stiffness` (bonds a defect cuts, the LPS lattice pattern's structural zeros) may
        be absent. The first call builds the model (bonds, constraints, right-hand side) and
        checks it as a solve would.
        """
        return self._native.assemble_rows(int(first), int(last))

    def is_symmetric(self) -> bool:
        """Whether ``A_ff`` is symmetric: :meth:`asymmetry` at most linpd's ``SYMMETRY_RTOL``
        (1e-12), the test by which ``linpd solve`` chooses between CG/Cholesky and GMRES/LU.
        False for the blended 1D model and for coarsened levels with an unsymmetric ``K``.
        Builds the row system on the first call, as :meth:`assemble_rows`."""
        return self._native.row_symmetry()[0]

    def asymmetry(self) -> float:
        """``max |A_ff - A_ff^T| / max |A_ff|`` as the model bounds it (a coarsened level
        reports that of its whole ``K``; bond and LPS models are symmetric by construction, 0)."""
        return self._native.row_symmetry()[1]

    def row_info(self) -> Tuple[int, int, np.ndarray, np.ndarray]:
        """``(n, block_size, free_dofs, rhs)`` for row-block assembly: the number of unknowns,
        ``d`` when every node has all or none of its components free (else 1), the full DOF
        ``d * node + component`` of every row, and the reduced right-hand side."""
        return self._native.row_info()

    def expand(self, u_free: np.ndarray) -> np.ndarray:
        """Displacements over all DOFs (``d * nodes``, node-major) from the unknowns' values:
        the prescribed values at constrained DOFs, ``u_free`` at the others. The nodes are the
        model's: for a blend scene with a coarse CE mesh (``ce_spacing``) the mesh's nodes."""
        return self._native.expand(np.ascontiguousarray(u_free, dtype=np.float64))

    def write_result(self, u: np.ndarray, report: Dict[str, Any], out: PathLike) -> list:
        """Writes ``u.csv``, ``result.vtu`` and ``result.json`` into ``out`` (all or none, like
        ``linpd solve``, without the plots) for displacements ``u`` over all DOFs computed
        elsewhere; ``report`` becomes ``stats["solve"]``. Returns the paths written. Non-finite
        displacements (a failed or diverged solve) are a :class:`LinpdError` and nothing is
        written."""
        u = np.ascontiguousarray(np.asarray(u, dtype=np.float64).reshape(-1))
        # a NaN displacement is refused by the native side, naming the first one
        return self._native.write_result(u, _to_json(report, "report"), os.fspath(out))


def coarsen(pipeline: Union[PathLike, Dict[str, Any]], out: Optional[PathLike] = None,
            base_dir: Optional[PathLike] = None) -> Dict[str, Any]:
    """Runs a coarsening pipeline as ``linpd coarsen`` does and returns its summary (the
    ``summary.json`` document: per level the nodes, bonds, radius, tail, timings and, with
    ``"solve": true``, the error at the shared nodes), with ``output_dir``, where the level
    files (``level-<m>.mtx``, ``level-<m>.nodes.csv``) were written (``out``, else the
    pipeline's ``output.dir``). A dict's relative paths start at ``base_dir`` (default: the
    working directory)."""
    o = None if out is None else os.fspath(out)
    if isinstance(pipeline, dict):
        d, doc = _coarsen(text=_to_json(pipeline, "pipeline"), base_dir=os.fspath(base_dir or "."), out=o)
    elif isinstance(pipeline, (str, os.PathLike)):
        d, doc = _coarsen(path=os.fspath(pipeline), out=o)
    else:
        raise TypeError(f"coarsen takes a path or a dict, got {type(pipeline).__name__}")
    summary = json.loads(doc)
    summary["output_dir"] = d
    return summary
