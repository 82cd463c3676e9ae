"""A model given element by element, its parameters scaling groups of elements (the route as the
user reads it: docs/fe-models.md, "Element groups").

    K(p) = sum_e s_e(p) K_e,      M(p) = sum_e t_e(p) M_e

with ``K_e``, ``M_e`` the element matrices at the nominal parameters and ``s_e`` 1, or ``p_i / p0_i``
for an element of the group parameter ``i`` scales, so that ``K_i = (p_ref,i / p0_i) sum_{e in
group i} K_e`` (Eqs. 13-14), formed once: every element's entries are laid out once as triplets
(row, column, value, element) and each matrix is the sum of its elements' triplets.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from vibupdate.model.affine import AffineModel, check_parameter_names, check_matrices
from vibupdate.model.parameters import Parameter


@dataclass(frozen=True)
class ElementMatrices:
    """Every element's matrices as triplets on the model's DOFs.

    Attributes
    ----------
    labels : tuple, length n_el
        Element labels (the FE code's element numbers, or names).
    dofs : tuple of str, length n
        DOF names in matrix order.
    rows, cols : ndarray of int64, shape (n_t,)
        Row and column of each triplet in ``dofs``.
    owner : ndarray of int64, shape (n_t,)
        Position in ``labels`` of the element each triplet belongs to.
    K, M : ndarray of float, shape (n_t,)
        Stiffness (N/m, N m/rad) and mass (kg, kg m^2) of each triplet; 0 where an element has
        no such matrix.
    precision : float, optional
        Relative precision of the entries as written (`AffineModel.matrix_precision`).
    source : str
        The files read, for messages.
    """

    labels: tuple
    dofs: tuple[str, ...]
    rows: np.ndarray
    cols: np.ndarray
    owner: np.ndarray
    K: np.ndarray
    M: np.ndarray
    precision: float | None = None
    source: str = "element matrices"

    @property
    def n_dofs(self) -> int:
        return len(self.dofs)

    def assemble(self, which: str, elements: np.ndarray | None = None) -> sp.csr_matrix:
        """``K`` or ``M`` (``which``) of the elements at positions ``elements`` (all when None)."""
        values = self.K if which == "K" else self.M
        keep = slice(None) if elements is None else np.isin(self.owner, elements)
        n = self.n_dofs
        A = sp.coo_matrix((values[keep], (self.rows[keep], self.cols[keep])), shape=(n, n)).tocsr()
        A.eliminate_zeros()
        return A

    def without(self, fixed: Sequence[str]) -> "ElementMatrices":
        """The elements with the DOFs ``fixed`` removed (supports the export did not apply)."""
        where = {d: k for k, d in enumerate(self.dofs)}
        missing = [d for d in fixed if d not in where]
        if missing:
            raise ValueError(f"fixed DOF {missing[0]!r} is not a DOF of the elements ({self.source})")
        if not fixed:
            return self
        dropped = np.zeros(self.n_dofs, dtype=bool)
        dropped[[where[d] for d in fixed]] = True
        position = np.cumsum(~dropped) - 1
        keep = ~(dropped[self.rows] | dropped[self.cols])
        return ElementMatrices(self.labels, tuple(d for d, out in zip(self.dofs, dropped) if not out),
                               position[self.rows[keep]], position[self.cols[keep]], self.owner[keep],
                               self.K[keep], self.M[keep], self.precision, self.source)


def element_matrices(elements: Sequence[tuple], *, dofs: Sequence[str] | None = None,
                     precision: float | None = None, source: str = "element matrices") -> ElementMatrices:
    """The triplets of elements given one by one.

    Parameters
    ----------
    elements : sequence of (label, dofs, K, M)
        Per element: its label, its DOF names (length n_e, in the order of its matrices), its
        stiffness, array shape (n_e, n_e), and its mass, same shape, or None. Matrices must be
        symmetric; a DOF name may repeat within an element (its entries add).
    dofs : sequence of str, optional
        The model's DOF order; default: the order in which the elements name them.
    precision : float, optional
        Relative precision of the entries (`ElementMatrices.precision`).
    source : str
        Where the elements come from, for messages.
    """
    labels = [e[0] for e in elements]
    if not labels:
        raise ValueError(f"{source}: no elements")
    seen = set()
    for label in labels:
        if label in seen:
            raise ValueError(f"{source}: element {label!r} is given twice")
        seen.add(label)
    order = list(dict.fromkeys(d for e in elements for d in e[1])) if dofs is None else list(dofs)
    index = {d: k for k, d in enumerate(order)}
    by_size: dict[int, list] = {}
    for position, (label, names, K, M) in enumerate(elements):
        try:
            where = [index[d] for d in names]
        except KeyError as exc:
            raise ValueError(f"{source}: element {label!r} names DOF {exc.args[0]!r}, which is not in the DOF list") \
                from None
        K = np.asarray(K, dtype=float)
        M = np.zeros_like(K) if M is None else np.asarray(M, dtype=float)
        for what, A in (("stiffness", K), ("mass", M)):
            if A.shape != (len(where), len(where)):
                raise ValueError(f"{source}: element {label!r}: {what} matrix has shape {A.shape} "
                                 f"for {len(where)} DOFs")
        by_size.setdefault(len(where), []).append((position, where, K, M))
    parts = [_triplets(batch, labels, source) for batch in by_size.values()]
    rows, cols, owner, K, M = (parts[0][k] if len(parts) == 1 else np.concatenate([p[k] for p in parts])
                               for k in range(5))
    return ElementMatrices(tuple(labels), tuple(order), rows, cols, owner, K, M, precision, source)


def _triplets(batch, labels, source: str):
    """Triplets of elements of one size: ``(position, dof indices, K, M)`` each; the matrices
    checked finite and symmetric all at once."""
    position = np.array([b[0] for b in batch], dtype=np.int64)
    index = np.array([b[1] for b in batch], dtype=np.int64)            # (n_el, n_e)
    n_el, n_e = index.shape
    stacked = {"stiffness": np.stack([b[2] for b in batch]), "mass": np.stack([b[3] for b in batch])}
    for what, A in stacked.items():
        bad = ~np.isfinite(A).all(axis=(1, 2))
        if bad.any():
            raise ValueError(f"{source}: element {labels[position[bad.argmax()]]!r}: {what} matrix has non-finite "
                             "entries")
        asymmetry = np.abs(A - A.swapaxes(1, 2)).max(axis=(1, 2), initial=0.0)
        bad = asymmetry > 1e-9 * np.abs(A).max(axis=(1, 2), initial=0.0)
        if bad.any():
            raise ValueError(f"{source}: element {labels[position[bad.argmax()]]!r}: {what} matrix is not symmetric")
    rows = np.repeat(index, n_e, axis=1).ravel()           # (element, row, column) order of the matrices
    cols = np.tile(index, (1, n_e)).ravel()
    owner = np.repeat(position, n_e * n_e)
    return rows, cols, owner, stacked["stiffness"].ravel(), stacked["mass"].ravel()


@dataclass(frozen=True)
class ElementScaling:
    """Which elements a parameter scales, and which of their matrices.

    Attributes
    ----------
    elements : tuple
        Element labels.
    matrix : str
        ``"K"`` (a modulus, a stiffness factor) or ``"M"`` (a density, a mass factor).
    """

    elements: tuple
    matrix: str = "K"


def affine_from_elements(elements: ElementMatrices, parameters: Sequence[Parameter],
                         scaling: Mapping[str, ElementScaling], *, fixed: Sequence[str] = ()) -> AffineModel:
    """Affine form of a model given element by element (module docstring).

    Parameters
    ----------
    elements : ElementMatrices
        The elements at the nominal parameters.
    parameters : sequence of Parameter, length n_x
    scaling : mapping of parameter name to ElementScaling
        The elements each parameter scales. A parameter absent here has zero matrices (its
        role comes from elsewhere, e.g. a configuration's lumped mass). An element's matrix is
        scaled by at most one parameter (a product of two would not be affine). A scaling
        parameter needs a non-zero nominal value: the element matrices are those at it.
    fixed : sequence of str
        DOF names to remove (supports the export did not apply).
    """
    parameters = tuple(parameters)
    check_parameter_names(parameters)
    names = {p.name: p for p in parameters}
    unknown = sorted(set(scaling) - set(names))
    if unknown:
        verb = "is" if len(unknown) == 1 else "are"
        raise ValueError(f"element groups name {', '.join(map(repr, unknown))}, which {verb} not a parameter")
    elements = elements.without(list(fixed))
    position = {label: k for k, label in enumerate(elements.labels)}
    claimed: dict[tuple, str] = {}
    M_par, K_par = [], []
    empty = sp.csr_matrix((elements.n_dofs, elements.n_dofs))
    for p in parameters:
        role = scaling.get(p.name)
        if role is None:
            M_par.append(empty)
            K_par.append(empty)
            continue
        if role.matrix not in ("K", "M"):
            raise ValueError(f"parameter '{p.name}' scales 'K' or 'M' of its elements, got {role.matrix!r}")
        if p.nominal == 0.0:
            raise ValueError(f"parameter '{p.name}' scales element matrices and has nominal 0: the element matrices "
                             "are those at the nominal value, so it must be non-zero")
        missing = [e for e in role.elements if e not in position]
        if missing:
            raise ValueError(f"parameter '{p.name}' names element {missing[0]!r}, which is not among the "
                             f"{len(position)} elements of {elements.source}")
        if not role.elements:
            raise ValueError(f"parameter '{p.name}' names no elements")
        for e in role.elements:
            other = claimed.setdefault((e, role.matrix), p.name)
            if other != p.name:
                raise ValueError(f"element {e!r} has its {role.matrix} scaled by both '{other}' and '{p.name}': "
                                 "a product of parameters is not affine; give each element to one parameter")
        group = elements.assemble(role.matrix, np.array([position[e] for e in role.elements]))
        scaled = sp.csr_matrix(group * (p.reference / p.nominal))
        (K_par if role.matrix == "K" else M_par).append(scaled)
        (M_par if role.matrix == "K" else K_par).append(empty)
    M0, K0 = elements.assemble("M"), elements.assemble("K")
    check_matrices(M0, K0, elements.dofs, what=f"the assembled elements of {elements.source}",
                   precision=elements.precision)
    return AffineModel(parameters, elements.dofs, M0, K0, tuple(M_par), tuple(K_par), elements.precision)
