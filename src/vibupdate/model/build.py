"""Building a parametric model: four routes to the same `AffineModel` (docs/method.md, sections 1
and 2; docs/fe-models.md):

* `from_builder` — a Python function ``params -> System | (M, K)``, differentiated by complex step;
* `from_assembly` — an `Assembly` of `vibupdate.model.expressions.LinearExpression` properties and
  lumped values, assembled directly into the affine form;
* `from_files` — nominal ``M0``, ``K0`` and per-parameter ``dM/dp``, ``dK/dp`` in Matrix Market
  (``.mtx``) or ``.npz`` files, the form exported by ANSYS, Abaqus or Nastran DMAP;
* `vibupdate.model.element_groups.affine_from_elements` — every element's matrices, each parameter
  scaling a group of elements.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from vibupdate.model.affine import (AffineModel, check_parameter_names, affine_from_assembly, affine_from_builder,
                                   check_matrices, symmetric_error)
from vibupdate.model.fe.export import existing_file
from vibupdate.model.parameters import Parameter


from_builder = affine_from_builder
from_assembly = affine_from_assembly


def load_matrix(path) -> sp.csr_matrix:
    """Read a square matrix from a Matrix Market (``.mtx``) or ``.npz`` file.

    ``.npz`` files may hold a `scipy.sparse.save_npz` matrix or a single dense array.
    """
    import scipy.io   # here: a model built in Python reads no file (scipy.io loads many readers)

    path = existing_file(path, "matrix file")
    suffix = path.suffix.lower()
    if suffix not in (".mtx", ".npz"):
        raise ValueError(f"matrix file {str(path)!r}: expected a .mtx or .npz file")
    try:
        A = sp.csr_matrix(scipy.io.mmread(str(path))) if suffix == ".mtx" else _load_npz(path)
    except (OSError, EOFError, KeyError, IndexError, TypeError, ValueError) as exc:
        raise ValueError(f"matrix file {str(path)!r} could not be read: {exc}") from None
    if np.iscomplexobj(A.data):
        raise ValueError(f"matrix file {str(path)!r} holds complex values; real matrices are expected")
    return sp.csr_matrix(A, dtype=float)


def _load_npz(path: Path) -> sp.csr_matrix:
    with np.load(path, allow_pickle=False) as data:
        keys = set(data.files)
        if {"format", "shape", "data"} <= keys:
            return sp.load_npz(path)
        if len(keys) == 1:
            return sp.csr_matrix(data[next(iter(keys))])
    raise ValueError(f"matrix file {str(path)!r}: expected one array or a scipy.sparse matrix, found {sorted(keys)}")


def from_files(M0, K0, parameters: Sequence[Parameter], *, dM: Mapping | None = None,
               dK: Mapping | None = None, dofs: Sequence[str] | None = None,
               matrix_precision: float | None = None) -> AffineModel:
    """Affine model from matrix files (or matrices) exported by an FE package.

    Parameters
    ----------
    M0, K0 : path or sparse matrix, shape (n, n)
        Nominal mass and stiffness matrices.
    parameters : sequence of Parameter
        The updating parameters; each needs a ``dM`` or a ``dK`` matrix.
    dM, dK : mapping of parameter name to path or matrix, optional
        ``dM/dp`` and ``dK/dp`` in physical units (e.g. kg per kg/m^3). A parameter needs at
        least one of the two; a missing one counts as zero.
    dofs : sequence of str, optional
        DOF names in matrix order; default ``q1 ... qn``.
    matrix_precision : float, optional
        Relative precision of the matrix entries (`AffineModel.matrix_precision`), e.g. 5e-10
        for matrices written with 10 significant digits; None: exact to double precision.

    Returns
    -------
    AffineModel
        ``M0``, ``K0`` and the normalized parameter matrices ``M_i = dM/dp p_ref`` (Eq. 13).

    Raises
    ------
    ValueError
        A file cannot be read, a matrix has the wrong shape or is not symmetric, a mapping
        names an unknown parameter, or a parameter has neither matrix.
    """
    parameters = tuple(parameters)
    check_parameter_names(parameters)
    dM, dK = dict(dM or {}), dict(dK or {})
    known = {p.name for p in parameters}
    for label, mapping in (("dM", dM), ("dK", dK)):
        unknown = sorted(set(mapping) - known)
        if unknown:
            raise ValueError(f"{label} names unknown parameters: {', '.join(unknown)}")

    def read(item):
        return sp.csr_matrix(item if sp.issparse(item) or isinstance(item, np.ndarray) else load_matrix(item),
                             dtype=float)

    M, K = read(M0), read(K0)
    names = tuple(dofs) if dofs is not None else tuple(f"q{i + 1}" for i in range(M.shape[0]))
    check_matrices(M, K, names, what="matrix files M0/K0", precision=matrix_precision)
    n = M.shape[0]
    M_par, K_par = [], []
    for p in parameters:
        if p.name not in dM and p.name not in dK:
            raise ValueError(f"parameter '{p.name}' has neither a dM nor a dK matrix")
        for label, mapping, out in (("dM", dM, M_par), ("dK", dK, K_par)):
            A = read(mapping[p.name]) if p.name in mapping else sp.csr_matrix((n, n))
            if A.shape != (n, n):
                raise ValueError(f"{label} of parameter '{p.name}' has shape {A.shape}, expected ({n}, {n}) like M0")
            if symmetric_error(A) > 1e-9:
                raise ValueError(f"{label} of parameter '{p.name}' is not symmetric")
            out.append(sp.csr_matrix(A * p.reference))
    return AffineModel(parameters, names, M, K, tuple(M_par), tuple(K_par), matrix_precision)
